#!/usr/bin/env python3
"""Cost of the reinforced-concrete lining in the analysis (a benchmark, not a test).

usage: python -m benchmarks.rc_lining_cost FOLDER [ROUNDS] [END_TIME] [CASE]

Writes one slice (CASE, default cases/pressure_tunnel/case.yaml, condition no_water) twice: as the
case gives its lining, and with `materials.lining.model: reinforced_concrete` (the bars of its
design block), and runs tq-solid on each in turn (alternating within every round, 1 thread), the
whole staged run to END_TIME (default 0.3 s). It prints each run's CPU time (the process's user +
system time: a shared machine's waiting is left out), its steps, the CPU time per element-step and
the ratios reinforced / as given, then the medians.
"""
import os
import re
import resource
import statistics
import subprocess
import sys
from pathlib import Path

from tunnelquake import paths
from tunnelquake.case import load_case
from tunnelquake.meshing import build_tunnel_mesh
from tunnelquake.motion import from_case
from tunnelquake.prepare import write_motion
from tunnelquake.solid_input import write_solid_input

ROOT = Path(__file__).resolve().parents[1]


def _inputs(folder: Path, end_time: float, case_file: Path) -> dict:
    import yaml

    base = yaml.safe_load(case_file.read_text())
    out = {}
    for name in ("as_given", "reinforced"):
        d = folder / name
        d.mkdir(parents=True, exist_ok=True)
        data = dict(base)
        data["time"] = dict(base.get("time") or {}, end_time=end_time)
        if name == "reinforced":
            data["materials"] = dict(base["materials"], lining=dict(base["materials"]["lining"],
                                                                    model="reinforced_concrete"))
        gm = dict(data.get("ground_motion") or {})
        for part in (gm, gm.get("second_horizontal"), gm.get("vertical")):  # records: absolute paths
            if isinstance(part, dict) and part.get("file"):
                part["file"] = str((case_file.parent / part["file"]).resolve())
        data["ground_motion"] = gm
        data.pop("suite", None)
        (d / "case.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
        case = load_case(d / "case.yaml")
        build_tunnel_mesh(case.data["geometry"], case.data["mesh"], d)
        motion, _ = from_case(case.data["ground_motion"], case.dir)
        write_motion(motion, d / "motion.h5")
        out[name] = write_solid_input(case, d / "mesh.h5", d / "motion.h5", "no_water", d / "solid.h5")
    return out


def _run(exe: Path, path: Path) -> tuple[float, int, float]:
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    run = subprocess.run([str(exe), str(path), "-o", str(path.with_name("results.h5")), "--threads", "1"], capture_output=True, text=True,
                         env=dict(os.environ, OMP_WAIT_POLICY="PASSIVE"), check=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
    m = re.search(r"completed (\d+) steps in .*? \(([\d.e+-]+) µs per element-step", run.stdout)
    if not m:
        raise SystemExit(run.stdout + run.stderr)
    return cpu, int(m.group(1)), float(m.group(2))


def main(argv: list[str]) -> int:
    folder = Path(argv[0])
    rounds = int(argv[1]) if len(argv) > 1 else 5
    end_time = float(argv[2]) if len(argv) > 2 else 0.3
    case_file = Path(argv[3]) if len(argv) > 3 else ROOT / "cases" / "pressure_tunnel" / "case.yaml"
    exe = paths.solid_executable()
    files = _inputs(folder, end_time, case_file)
    cpu_step = {k: [] for k in files}
    cpu_total = {k: [] for k in files}
    for r in range(rounds):
        row = []
        for name, path in files.items():
            cpu, steps, wall_us = _run(exe, path)
            cpu_step[name].append(cpu / steps)
            cpu_total[name].append(cpu)
            row.append(f"{name} cpu {cpu:.2f} s, {steps} steps, wall {wall_us:.3f} µs/element-step")
        print(f"round {r + 1} load {os.getloadavg()[0]:.1f}: " + "; ".join(row) +
              f"; ratio per step {cpu_step['reinforced'][-1] / cpu_step['as_given'][-1]:.3f}, "
              f"run {cpu_total['reinforced'][-1] / cpu_total['as_given'][-1]:.3f}", flush=True)
    med = {k: statistics.median(v) for k, v in cpu_step.items()}
    tot = {k: statistics.median(v) for k, v in cpu_total.items()}
    print(f"medians: CPU per step as given {med['as_given'] * 1e3:.3f} ms, reinforced {med['reinforced'] * 1e3:.3f} ms, "
          f"ratio {med['reinforced'] / med['as_given']:.3f}; run {tot['as_given']:.2f} s / {tot['reinforced']:.2f} s, "
          f"ratio {tot['reinforced'] / tot['as_given']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
