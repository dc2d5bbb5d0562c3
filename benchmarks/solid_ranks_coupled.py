#!/usr/bin/env python3
"""A case's coupled condition (dynamic_water, OpenFOAM's water) on MPI ranks against one process
(a measurement, not a test).

usage: python -m benchmarks.solid_ranks_coupled FOLDER [--case cases/paper_tunnel] [--variant 3d]
                                                [--end 2.0] [--ranks 1,2,3,4,8] [--compare-only]

Writes the case file into FOLDER/r<N>/ for each rank count N (its motion file made absolute,
`time.end_time` cut to END seconds, conditions [dynamic_water], results in FOLDER/r<N>/results),
runs `tunnelquake run CASE [--variant V] --no-post --ranks N` for each N in turn (N = 1 is the
plain run), and compares every numeric dataset of the dynamic_water results file (all but
/timings) with the first rank count's: the datasets equal bitwise, and the largest difference
relative to each dataset's largest magnitude over the others (benchmarks.solid_ranks_cases'
comparison). A rank count whose run has not finished (no completed results file) is left out, so
`--compare-only` reports the runs done so far.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import yaml

from benchmarks.common import machine
from benchmarks.solid_ranks_cases import _compare

ROOT = Path(__file__).resolve().parents[1]


def _write_case(src: Path, variant: str | None, end: float, folder: Path) -> Path:
    data = yaml.safe_load(src.read_text())
    gm = data["ground_motion"]
    for g in (gm, gm.get("vertical") or {}, gm.get("second_horizontal") or {}):
        if "file" in g:
            g["file"] = str((src.parent / g["file"]).resolve())
    if variant:
        v = data["variants"][variant]
        data["variants"] = {variant: v}
        v["time"] = {**(v.get("time") or {}), "end_time": f"{end} s"}
        v["conditions"] = ["dynamic_water"]
    else:
        data.pop("variants", None)
        data["time"] = {**(data.get("time") or {}), "end_time": f"{end} s"}
        data["conditions"] = ["dynamic_water"]
    data["output"]["directory"] = str(folder / "results")
    folder.mkdir(parents=True, exist_ok=True)
    case = folder / "case.yaml"
    case.write_text(yaml.safe_dump(data, sort_keys=False))
    return case


def _results(folder: Path) -> Path | None:
    """The dynamic_water results file of a completed run in folder (results*/results_dynamic_water.h5),
    or None."""
    for p in sorted(folder.glob("results*/results_dynamic_water.h5")):
        with h5py.File(p, "r") as f:
            if f.attrs.get("status") == "completed":
                return p
    return None


def _datasets(res: Path) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    with h5py.File(res, "r") as f:
        def take(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu" and not name.startswith("timings"):
                out["/" + name] = np.asarray(obj[()], dtype=np.float32 if obj.dtype == np.float32 else float)

        f.visititems(take)
    return out


def compare(folder: Path, ranks: list[int]) -> None:
    ref_n = ranks[0]
    ref_file = _results(folder / f"r{ref_n}")
    if ref_file is None:
        print(f"{ref_n} rank(s): no completed run in {folder / f'r{ref_n}'}")
        return
    ref = _datasets(ref_file)
    for n in ranks[1:]:
        got_file = _results(folder / f"r{n}")
        if got_file is None:
            print(f"{n} rank(s): not run (no completed results file)")
            continue
        c = _compare(ref, _datasets(got_file))
        others = sorted(set(ref) - set(c["bitwise"]))
        worst = max((c["worst"], c["acc"]), key=lambda x: x[0])
        print(f"{n} rank(s) against {ref_n}: {len(c['bitwise'])} of {len(ref)} datasets bitwise; the others "
              f"({', '.join(others) or 'none'}): largest relative difference {worst[0]:.3g} ({worst[1]}); "
              f"single precision {c['f32_ulps'][0]:.3g} ulp; envelope peak times differing {c['peak_times'][0]} "
              f"of {c['peak_times'][1]}", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path)
    ap.add_argument("--case", type=Path, default=ROOT / "cases" / "paper_tunnel")
    ap.add_argument("--variant", default="3d")
    ap.add_argument("--end", type=float, default=2.0, help="seconds of shaking")
    ap.add_argument("--ranks", default="1,2,3,4,8")
    ap.add_argument("--compare-only", action="store_true")
    args = ap.parse_args(argv)
    folder = args.folder.resolve()
    ranks = [int(x) for x in args.ranks.split(",")]
    if not args.compare_only:
        src = args.case if args.case.suffix else args.case / "case.yaml"
        for n in ranks:
            case = _write_case(src.resolve(), args.variant or None, args.end, folder / f"r{n}")
            cmd = [sys.executable, "-m", "tunnelquake", "run", str(case), "--no-post", "--ranks", str(n)]
            if args.variant:
                cmd += ["--variant", args.variant]
            t0 = time.perf_counter()
            with (folder / f"r{n}" / "run.log").open("w") as log:
                rc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, env=dict(os.environ)).returncode
            print(f"{n} rank(s): rc {rc}, {time.perf_counter() - t0:.0f} s wall", flush=True)
            if rc != 0:
                return rc
    compare(folder, ranks)
    print(machine())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
