#!/usr/bin/env python3
"""Compare tq-solid-bench binaries by CPU time per element-step (a benchmark, not a test).

usage: python -m benchmarks.cpu_compare ROUNDS N STEPS THREADS BENCH1 BENCH2 ...   (EXTRA="--damping" adds options)

For each binary in turn (alternating within every round) it runs `BENCH --n N --steps STEPS
--repeat 1 --threads THREADS` and the same with `--steps 0`, and divides the CPU-time difference
(set-up and warm-up cancel) by STEPS x N^3. CPU time leaves out the time the process waits for a
core, so on a shared, overloaded machine it resolves differences that wall-clock medians do not.
Prints each round's figures and ratios to the first binary, then the medians.
"""
import os
import resource
import statistics
import subprocess
import sys

rounds, n, steps, threads = map(int, sys.argv[1:5])
bins = sys.argv[5:]
env = dict(os.environ, OMP_WAIT_POLICY='PASSIVE')


def cpu(b, s):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([b, '--n', str(n), '--steps', str(s), '--repeat', '1', '--threads', str(threads)] + os.environ.get('EXTRA', '').split(), env=env,
                   stdout=subprocess.DEVNULL, check=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)


res = {b: [] for b in bins}
for r in range(rounds):
    row = []
    for b in bins:
        t = cpu(b, steps) - cpu(b, 0)
        res[b].append(1e6 * t / (steps * n ** 3))
        row.append(f'{os.path.basename(b)}={res[b][-1]:.4f}')
    print(f'round {r+1} load {os.getloadavg()[0]:.1f}: ' + ' '.join(row) + '  ratios vs first: ' +
          ' '.join(f'{res[bins[0]][-1]/res[b][-1]:.3f}' for b in bins[1:]), flush=True)
print('medians: ' + ' '.join(f'{os.path.basename(b)}={statistics.median(v):.4f}' for b, v in res.items()))
