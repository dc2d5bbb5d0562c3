#!/usr/bin/env python3
"""The DRM layer's share of a step in a case with an incident wave (a benchmark, not a test).

usage: python -m benchmarks.drm_cost FOLDER [ROUNDS] [END_TIME] [CASE] [EXE,...]

Writes the solid input of CASE (default cases/axial_wave/case.yaml, condition no_water) with the
seismic stage alone (the layer acts only there) to END_TIME (default 1 s), then runs tq-solid on it
ROUNDS times (default 3, 1 thread) under `perf record -e cpu-clock -F 2000`. In each run the layer's
samples (DomainReduction's functions and its row product) are set against the rest of the run's
samples: a ratio within one run, so the machine's other load cancels. Prints each round's share and
the median, with the run's steps and CPU time. EXE,...: tq-solid executables to compare (another
build), each run in turn within every round; default the one `tunnelquake.paths` finds.
"""
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from tunnelquake import paths
from tunnelquake.case import load_case
from tunnelquake.meshing import build_tunnel_mesh
from tunnelquake.motion import from_case
from tunnelquake.prepare import write_motion
from tunnelquake.solid_input import write_solid_input

ROOT = Path(__file__).resolve().parents[1]
#: the symbols of the layer's forces (tq/boundaries/drm.hpp and its row product in drm.cpp)
LAYER = re.compile(r"DomainReduction::|\browsAvx2\b|\browsGeneric\b")


def _input(folder: Path, end_time: float, case_file: Path) -> Path:
    import yaml

    data = yaml.safe_load(case_file.read_text())
    data["time"] = dict(data.get("time") or {}, end_time=end_time)
    data["stages"] = dict(data.get("stages") or {}, sequence=["seismic"])
    gm = dict(data.get("ground_motion") or {})
    if gm.get("file"):
        gm["file"] = str((case_file.parent / gm["file"]).resolve())
    data["ground_motion"] = gm
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "case.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    case = load_case(folder / "case.yaml")
    build_tunnel_mesh(case.data["geometry"], case.data["mesh"], folder)
    motion, _ = from_case(case.data["ground_motion"], case.dir)
    write_motion(motion, folder / "motion.h5")
    return write_solid_input(case, folder / "mesh.h5", folder / "motion.h5", "no_water", folder / "solid.h5")


def _run(exe: Path, path: Path) -> tuple[float, float, int]:
    """(the layer's share of the rest of the run's samples, CPU s, steps)"""
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "perf.data"
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        run = subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", "2000", "-o", str(data), "--",
                              str(exe), str(path), "-o", str(path.with_name("results.h5")), "--threads", "1"],
                             capture_output=True, text=True, env=dict(os.environ, OMP_WAIT_POLICY="PASSIVE"),
                             check=True)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        rep = subprocess.run(["perf", "report", "-i", str(data), "--stdio", "--no-children", "--sort", "sym",
                              "--percent-limit", "0", "-q"], capture_output=True, text=True, check=True).stdout
    layer = total = 0.0
    for line in rep.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+\[.\]\s+(.*)", line)
        if m:
            total += float(m.group(1))
            if LAYER.search(m.group(2)):
                layer += float(m.group(1))
    m = re.search(r"completed (\d+) steps", run.stdout)
    if not m or total <= 0:
        raise SystemExit(run.stdout + run.stderr + rep[:2000])
    cpu = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
    return layer / (total - layer), cpu, int(m.group(1))


def main(argv: list[str]) -> int:
    folder = Path(argv[0])
    rounds = int(argv[1]) if len(argv) > 1 else 3
    end_time = float(argv[2]) if len(argv) > 2 else 1.0
    case_file = Path(argv[3]) if len(argv) > 3 else ROOT / "cases" / "axial_wave" / "case.yaml"
    exes = [Path(e) for e in argv[4].split(",")] if len(argv) > 4 else [paths.solid_executable()]
    path = _input(folder, end_time, case_file)
    shares: dict[Path, list[float]] = {e: [] for e in exes}
    for r in range(rounds):
        for exe in exes:
            share, cpu, steps = _run(exe, path)
            shares[exe].append(share)
            print(f"round {r + 1} load {os.getloadavg()[0]:.1f}, {exe}: the layer {100 * share:.2f} % of the rest "
                  f"of the run ({steps} steps, CPU {cpu:.2f} s)", flush=True)
    for exe, s in shares.items():
        print(f"{exe}: median of {rounds}: the layer {100 * statistics.median(s):.2f} % of the rest of the run "
              f"(rounds {' / '.join(f'{100 * x:.2f}' for x in s)})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
