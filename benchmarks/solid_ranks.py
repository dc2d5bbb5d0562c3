#!/usr/bin/env python3
"""tq-solid on MPI ranks against one process (a benchmark, not a test).

usage: python -m benchmarks.solid_ranks FOLDER [--n 40] [--steps 200] [--rounds 3]
                                        [--baseline EXE] [--configs plain:2,ranks:1x2,...]

Writes an elastic box of n^3 unit hex8 (n = 40: 64,000 elements; base fixed, a ramped load on the
top, gravity) as an unstaged solid input, and runs each configuration in turn within every round:

    plain:T      tq-solid as one process with T OpenMP threads (the baseline executable, default this
                 build's tq-solid)
    ranks:RxT    mpirun -np R tq-solid --distributed with T threads a rank (tunnelquake.solid_ranks)

For each run: the stepping loop's wall time per element-step (results /timings, as tq-solid
prints it) and the CPU time (user + system) of the whole command, mpirun included; then the median
of the rounds of each configuration and its ratio to the first configuration, per round and median.
"""
from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np

from benchmarks.common import machine
from tunnelquake import paths
from tunnelquake.box_mesh import write_box_mesh, write_loaded_box_input
from tunnelquake.solid_ranks import solid_command


def write_box(folder: Path, n: int, steps: int, samples: int = 10) -> Path:
    """mesh.h5 and solid_input.h5 of the n^3 box (1 m elements, rock E 8 GPa); `steps` steps, the
    monitors sampled `samples` times over them."""
    folder.mkdir(parents=True, exist_ok=True)
    g = np.arange(n + 1, dtype=float)
    write_box_mesh(folder / "mesh.h5", g, g, g)
    E, nu, rho = 8e9, 0.27, 2700.0
    cp = np.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho)
    dt = 0.45 / cp  # half the critical step of a 1 m element (2 / omega = L / cp)
    return write_loaded_box_input(folder / "solid_input.h5", E=E, nu=nu, rho=rho, dt=dt, steps=steps,
                                  top_force=-1e6 * n * n, monitor_dt=steps * dt / samples,
                                  monitors={"top": [n / 2, n / 2, n], "middle": [n / 2, n / 2, n / 2]})


def timed(cmd: list[str]) -> tuple[subprocess.CompletedProcess, float, float]:
    """The command's result, its wall time and the CPU time (user + system) of it and its children."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"failed ({proc.returncode}): {' '.join(cmd)}\n{proc.stdout}\n{proc.stderr}")
    return proc, wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run_once(cmd: list[str], results: Path) -> dict:
    _, wall, cpu = timed(cmd)
    with h5py.File(results, "r") as f:
        us = float(f["timings"].attrs["us_per_element_step"])
    return {"us": us, "cpu_s": cpu, "wall_s": wall}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path)
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--baseline", type=Path, default=None, help="tq-solid of the plain runs (default this build's)")
    ap.add_argument("--configs", default="plain:1,ranks:1x1")
    args = ap.parse_args(argv)
    exe = paths.solid_executable()
    inp = write_box(args.folder, args.n, args.steps)
    configs = args.configs.split(",")
    runs: dict[str, list[dict]] = {c: [] for c in configs}
    for r in range(args.rounds):
        for c in configs:
            kind, _, spec = c.partition(":")
            res = args.folder / f"results_{kind}_{spec}.h5"
            if kind == "plain":
                cmd = solid_command(args.baseline or exe, inp, res, int(spec), 1)
            else:
                ranks, _, threads = spec.partition("x")
                cmd = solid_command(exe, inp, res, int(threads), int(ranks))
            out = run_once(cmd, res)
            runs[c].append(out)
            print(f"round {r + 1} {c}: {out['us']:.4f} us/element-step, CPU {out['cpu_s']:.2f} s, wall "
                  f"{out['wall_s']:.2f} s", flush=True)
    first = configs[0]
    print(f"\n{args.n ** 3} elements, {args.steps} steps, {args.rounds} rounds; {machine()}")
    for c in configs:
        us = statistics.median(x["us"] for x in runs[c])
        cpu = statistics.median(x["cpu_s"] for x in runs[c])
        ratio_us = statistics.median(a["us"] / b["us"] for a, b in zip(runs[c], runs[first], strict=True))
        ratio_cpu = statistics.median(a["cpu_s"] / b["cpu_s"] for a, b in zip(runs[c], runs[first], strict=True))
        rounds = " / ".join(f"{x['us']:.4f}" for x in runs[c])
        cpus = " / ".join(f"{x['cpu_s']:.2f}" for x in runs[c])
        ratios = " / ".join(f"{a['cpu_s'] / b['cpu_s']:.3f}" for a, b in zip(runs[c], runs[first], strict=True))
        print(f"  {c}: {us:.4f} us/element-step (rounds {rounds}), CPU {cpu:.2f} s (rounds {cpus}); / {first}: "
              f"{ratio_us:.3f} (loop wall), {ratio_cpu:.3f} (CPU; rounds {ratios})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
