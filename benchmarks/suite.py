"""Wall time of a record suite on 1 and on 2 workers (docs/benchmarks.md "Record suites").

    python -m benchmarks.suite [--members 4] [--end-time 8] [--repeats 3] [--folder DIR]

The suite: the example slice (cases/paper_tunnel), condition no_water only, `--members` seeded
synthetic Kanai-Tajimi records (20 s at 0.01 s, tunnelquake.motion.SyntheticModel, seeds 1, 2, ...)
scaled to the example's PGA, `--end-time` s of shaking each (8 s: about 25 s of CPU a member).
Each repeat runs `tunnelquake run <case> --workers N --no-post` from an empty results folder, the
worker counts alternating (1, 2, 1, 2, ...) so that a change of the machine's load reaches both.
Printed: the CPU model, the load average before and after, each run's wall and CPU time (the
command's and all its descendants'), the medians and their ratio.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from tunnelquake.motion import SyntheticModel
from tunnelquake.paths import ROOT


def _case(folder: Path, members: int, end_time: float) -> Path:
    rec = folder / "records"
    rec.mkdir(parents=True, exist_ok=True)
    for seed in range(1, members + 1):
        r = SyntheticModel(seed=seed).generate()
        rows = "\n".join(f"{i * r.dt:.4f} {a!r}" for i, a in enumerate(np.asarray(r.acc, float).tolist()))
        (rec / f"kt{seed}.txt").write_text(rows + "\n")
    text = (ROOT / "cases" / "paper_tunnel" / "case.yaml").read_text().split("\nvariants:")[0]
    text = text.replace("conditions: [no_water, static_water, dynamic_water]", "conditions: [no_water]")
    text = text.replace("if_missing: synthetic", "if_missing: synthetic\n  units: g")
    # the shaking cut to end_time, in the case's own time section
    text = text.replace("\ntime:\n", f"\ntime:\n  end_time: {end_time:g} s\n", 1) if "\ntime:\n" in text else \
        text + f"\ntime:\n  end_time: {end_time:g} s\n"
    text += "\nsuite:\n  records:\n    - {glob: 'records/kt*.txt', units: g}\n  scaling: pga\n"
    path = folder / "case.yaml"
    path.write_text(text)
    return path


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _load() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.suite", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--members", type=int, default=4)
    p.add_argument("--end-time", type=float, default=8.0, help="s of shaking a member")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--folder", type=Path, default=None, help="work folder (default: a temporary one)")
    args = p.parse_args(argv)
    import tempfile

    folder = args.folder or Path(tempfile.mkdtemp(prefix="tq-bench-suite-"))
    case = _case(folder, args.members, args.end_time)
    model = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
    model = next((ln.split(":", 1)[1].strip() for ln in model.splitlines() if ln.startswith("Model name")), "?")
    print(f"CPU: {model}; {len(os.sched_getaffinity(0))} cores; load average before: {_load()}", flush=True)
    print(f"case: {case} ({args.members} members, no_water, {args.end_time:g} s of shaking each)", flush=True)
    walls: dict[int, list[float]] = {n: [] for n in args.workers}
    for k in range(args.repeats):
        for n in args.workers:
            shutil.rmtree(folder / "results", ignore_errors=True)
            c0, t0 = _cpu(), time.perf_counter()
            out = subprocess.run([sys.executable, "-m", "tunnelquake", "run", str(case), "--workers", str(n),
                                  "--no-post"], capture_output=True, text=True)
            wall, cpu = time.perf_counter() - t0, _cpu() - c0
            if out.returncode != 0:
                print(out.stdout[-3000:] + out.stderr[-3000:], file=sys.stderr)
                return 1
            walls[n].append(wall)
            print(f"repeat {k + 1}: {n} worker(s): wall {wall:.1f} s, CPU {cpu:.1f} s ({cpu / args.members:.1f} s a "
                  f"member); load {_load()}", flush=True)
    med = {n: statistics.median(w) for n, w in walls.items()}
    for n, m in med.items():
        print(f"median of {args.repeats}, {n} worker(s): {m:.1f} s")
    if 1 in med:
        for n in med:
            if n != 1:
                print(f"ratio {n} workers / 1 worker: {med[n] / med[1]:.3f}")
    print(f"load average after: {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
