#!/usr/bin/env python3
"""The free field's computation as a share of a run with an incident wave (a benchmark, not a test).

usage: python -m benchmarks.drm_free_field_share FOLDER [ROUNDS] [END_TIME] [CASE]

Per round: writes the solid input of CASE (default cases/axial_wave/case.yaml, condition no_water)
with the seismic stage alone to END_TIME (default: the case's own, its record's length), timing the free field
at the DRM layer's nodes (`drm_input.write_drm_group`: the layer found, the wave through the layers,
`/drm` written) in this process's CPU time; then runs tq-solid on that input (1 thread) and takes its
CPU time. Prints the free field's CPU over the input writing's and tq-solid's together, each round
and the median. The run counted here leaves out the static stages, meshing and post, so the share
of a whole `tunnelquake run` is smaller than the one printed.
"""
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import tunnelquake.solid_input as solid_input
from benchmarks.drm_cost import ROOT, _input
from tunnelquake import paths
from tunnelquake.case import load_case
from tunnelquake.motion import from_case


def _round(folder: Path, end_time: float, case_file: Path) -> tuple[float, float, float]:
    """(free field CPU s, input writing CPU s, tq-solid CPU s)"""
    spent = {"free_field": 0.0}
    timed = solid_input.write_drm_group

    def write_drm_group(*args, **kwargs):
        t0 = time.process_time()
        try:
            return timed(*args, **kwargs)
        finally:
            spent["free_field"] += time.process_time() - t0

    solid_input.write_drm_group = write_drm_group
    try:
        t0 = time.process_time()
        path = _input(folder, end_time, case_file)
        writing = time.process_time() - t0
    finally:
        solid_input.write_drm_group = timed
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([str(paths.solid_executable()), str(path), "-o", str(path.with_name("results.h5")),
                    "--threads", "1"], capture_output=True, text=True, check=True,
                   env=dict(os.environ, OMP_WAIT_POLICY="PASSIVE"))
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    solver = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
    if spent["free_field"] <= 0.0:
        raise SystemExit(f"{case_file}: no free field was computed (the case has no plane incident wave)")
    return spent["free_field"], writing, solver


def _record_length(case_file: Path) -> float:
    """The case's end time: its own `time.end_time`, else its record's length."""
    case = load_case(case_file)
    if case.data["time"]["end_time"]:
        return float(case.data["time"]["end_time"])
    motion, _ = from_case(case.data["ground_motion"], case.dir)
    return float(motion.dt * (motion.ax.size - 1))


def main(argv: list[str]) -> int:
    folder = Path(argv[0])
    rounds = int(argv[1]) if len(argv) > 1 else 3
    case_file = Path(argv[3]) if len(argv) > 3 else ROOT / "cases" / "axial_wave" / "case.yaml"
    end_time = float(argv[2]) if len(argv) > 2 else _record_length(case_file)
    shares = []
    for r in range(rounds):
        ff, writing, solver = _round(folder / f"round{r + 1}", end_time, case_file)
        shares.append(ff / (writing + solver))
        print(f"round {r + 1} load {os.getloadavg()[0]:.1f}: free field {ff:.2f} CPU s, input writing {writing:.2f} s, "
              f"tq-solid {solver:.2f} s: {100 * shares[-1]:.2f} % of the run", flush=True)
    print(f"median of {rounds}: the free field {100 * statistics.median(shares):.2f} % of the run "
          f"(rounds {' / '.join(f'{100 * s:.2f}' for s in shares)}); end time {end_time:g} s, {case_file}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
