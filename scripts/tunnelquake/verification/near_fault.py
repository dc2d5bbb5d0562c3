"""Near-fault pulses on a case's slice, condition dynamic_water, with the case's own coupling: which
complete, against what `tunnelquake check` predicts for each (docs/stability.md "Near-fault pulses").

Two synthetic records, each a two-column file of acceleration (m/s^2) starting at T1 = 1 s:

    fling  a fling step: one cycle of sine acceleration of period T = 2 s,
           a(t) = (2 pi D / T^2) sin(2 pi (t - T1) / T); the velocity is one-sided and the ground
           keeps a permanent offset D (Abrahamson's fling model)
    pulse  a pulse without offset: v(t) = V sin(2 pi s) sin^2(pi s), s = (t - T1) / T, V = 2 pi D / T:
           the displacement u = V T [(1 - cos 2 pi s)/(4 pi) - sin^2(2 pi s)/(8 pi)] peaks at D
           (s = 1/2) and returns to zero, and the acceleration starts and ends at zero (a sampled
           jump would leave the ground a velocity)

D is the record's offset (fling) or peak displacement (pulse), in metres. The outcrop convention
halves it in the incident wave, and the free surface doubles it again: the tunnel moves by about D
(measured on the example slice: fling D = 3 m leaves the lining 2.59 m across and 1.84 m down, the
vertical 2/3 of the horizontal). Each case file is the case with its conditions cut to dynamic_water,
its record replaced (units m/s^2, no PGA scaling, so the record's own amplitude is kept; no baseline
correction, which would take the offset out), and the water model set; the coupling is the case's.

    python -m tunnelquake.verification.near_fault write cases/paper_tunnel --folder /tmp/nf
    python -m tunnelquake.verification.near_fault run --folder /tmp/nf       # one at a time, niced
    python -m tunnelquake.verification.near_fault table --folder /tmp/nf

A run is *stable* when it completes the record and its coupling energy is below 1 % of the interface
work (stiffness_map's criterion); the prediction is `scene.added_mass_diagnostic(case).stable`.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

DT = 0.01  # s, the records' step
DURATION = 12.0  # s, the records' length
T1 = 1.0  # s, the pulse's start
PERIOD = 2.0  # s, the pulse's period
OFFSETS = (0.5, 1.5, 3.0)  # m
KINDS = ("fling", "pulse")
WATERS = ("compressible", "incompressible")
ENERGY_LIMIT = 0.01  # the stability criterion on the coupling energy / interface work


def record(kind: str, d: float, dt: float = DT, duration: float = DURATION, t1: float = T1,
           period: float = PERIOD) -> tuple[np.ndarray, np.ndarray]:
    """(t, a): the fling step of offset `d` m, or the pulse of peak displacement `d` m (module doc)."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    s = (t - t1) / period
    inside = (s >= 0) & (s <= 1)
    if kind == "fling":
        a = 2 * np.pi * d / period**2 * np.sin(2 * np.pi * s)
    elif kind == "pulse":
        v = 2 * np.pi * d / period
        a = np.pi * v / period * (2 * np.cos(2 * np.pi * s) * np.sin(np.pi * s) ** 2 + np.sin(2 * np.pi * s) ** 2)
    else:
        raise ValueError(f"record kind {kind!r}: use one of {', '.join(KINDS)}")
    return t, np.where(inside, a, 0.0)


def name(kind: str, d: float, water: str) -> str:
    return f"{kind}_{d:g}_{water}"


def case_data(base: dict, record_file: Path, kind: str, d: float, water: str) -> dict:
    """The case data of one run: a deep copy of `base` with the run's keys laid over it."""
    c = copy.deepcopy(base)
    c.pop("variants", None)
    c.pop("reference", None)
    c["name"] = name(kind, d, water)
    c["conditions"] = ["dynamic_water"]
    c["water"]["model"] = water
    gm = c["ground_motion"]
    gm.update(source="file", file=str(record_file), format="two_column", units="m/s^2", duration=f"{DURATION} s",
              baseline_correction=False)
    gm.pop("pga", None)
    gm.pop("if_missing", None)
    return c


def write(case_file: Path, folder: Path, kinds=KINDS, offsets=OFFSETS, waters=WATERS,
          period: float = PERIOD) -> list[Path]:
    """The records (pulse period `period` s) and one case folder a run under `folder`; returns the
    case files."""
    base = yaml.safe_load(case_file.read_text())
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for kind in kinds:
        for d in offsets:
            t, a = record(kind, d, period=period)
            rec = folder / f"{kind}_{d:g}.txt"
            rec.write_text("".join(f"{x:.4f} {y:.10e}\n" for x, y in zip(t, a, strict=True)))
            for water in waters:
                sub = folder / name(kind, d, water)
                sub.mkdir(exist_ok=True)
                cf = sub / "case.yaml"
                cf.write_text(yaml.safe_dump(case_data(base, rec.resolve(), kind, d, water), sort_keys=False))
                out.append(cf)
    return out


def result(case_file: Path) -> dict:
    """What a run of `case_file` ended in, from its results file (and run.json, when `run` made it)."""
    import h5py

    row: dict = {"case": case_file.parent.name, "status": "no results file", "t_end": 0.0}
    meta = case_file.parent / "run.json"
    if meta.is_file():
        row.update(json.loads(meta.read_text()))
    res = case_file.parent / "results" / "results_dynamic_water.h5"
    if not res.is_file():
        return row
    try:
        f = h5py.File(res, "r")
    except OSError:  # a run still writing it holds its lock
        row["status"] = "running"
        return row
    with f:
        row["status"] = str(f.attrs.get("status", ""))
        if "monitors" in f and len(f["monitors"]):
            g = f["monitors/top_arch"] if "top_arch" in f["monitors"] else next(iter(f["monitors"].values()))
            row["t_end"] = float(g["time"][-1, 0]) if g["time"].shape[0] else 0.0
            row["final_u"] = [float(x) for x in g["u"][-1]]
        if "coupling" in f:
            c = dict(f["coupling"].attrs)
            row["passes_per_window"] = float(c["passes"]) / max(float(c["windows"]), 1.0)
            row["max_passes"] = int(c["max_passes"])
            row["unconverged_windows"] = int(c.get("unconverged_windows", 0))
            row["coupling_energy"] = float(c["coupling_energy"])
            row["interface_work_peak"] = float(c["interface_work_peak"])
            row["coupled_wall_s"] = float(c["coupled_wall_s"])
    return row


def stable(row: dict) -> bool:
    e, w = row.get("coupling_energy"), row.get("interface_work_peak")
    return (row["status"] == "completed" and e is not None and w is not None and w > 0
            and abs(e) < ENERGY_LIMIT * w)


def cases(folder: Path) -> list[Path]:
    """The case files of the runs `write` made under `folder` (sub-folders named kind_D_water)."""
    pattern = re.compile(rf"^({'|'.join(KINDS)})_[0-9.]+_({'|'.join(WATERS)})$")
    return sorted(p / "case.yaml" for p in folder.iterdir() if pattern.match(p.name) and (p / "case.yaml").is_file())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tunnelquake.verification.near_fault",
                                 description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write", help="write the records and the case folders")
    w.add_argument("case", type=Path, help="case folder or case.yaml (a slice)")
    w.add_argument("--folder", type=Path, required=True)
    w.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    w.add_argument("--offsets", type=float, nargs="+", default=list(OFFSETS), help="m")
    w.add_argument("--water", nargs="+", default=list(WATERS), choices=WATERS)
    w.add_argument("--period", type=float, default=PERIOD, help="s, the pulses' period (default %(default)s)")
    r = sub.add_parser("run", help="run every case folder not yet run, one at a time")
    r.add_argument("--folder", type=Path, required=True)
    r.add_argument("--timeout", type=float, default=3600.0, help="seconds a run at most")
    t = sub.add_parser("table", help="the markdown table of the runs")
    t.add_argument("--folder", type=Path, required=True)
    a = ap.parse_args(argv)

    if a.cmd == "write":
        case_file = a.case / "case.yaml" if a.case.is_dir() else a.case
        for cf in write(case_file, a.folder, a.kinds, a.offsets, a.water, a.period):
            print(cf)
        return 0
    if a.cmd == "run":
        for cf in cases(a.folder):
            if (cf.parent / "run.json").is_file():
                continue
            t0 = time.monotonic()
            with open(cf.parent / "run.log", "w") as log:
                try:
                    code = subprocess.run(["nice", sys.executable, "-m", "tunnelquake", "run", str(cf), "--no-post"],
                                          stdout=log, stderr=subprocess.STDOUT, timeout=a.timeout,
                                          env=dict(os.environ)).returncode
                except subprocess.TimeoutExpired:
                    code = -1
            (cf.parent / "run.json").write_text(json.dumps({"exit": code, "wall_s": round(time.monotonic() - t0, 1)}))
            print(json.dumps(result(cf)))
        return 0

    from ..case import CaseError, load_case
    from ..scene import added_mass_diagnostic

    print("| record | D (m) | water | completes | lining's final u_x / u_z (m) | passes a window (max) | "
          "E_c (/ interface work) | check predicts | agree | coupled wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for cf in cases(a.folder):
        row = result(cf)
        if row["status"] in ("no results file", "running"):
            continue
        data = yaml.safe_load(cf.read_text())
        try:
            predicted = added_mass_diagnostic(load_case(cf)).stable
        except CaseError:
            predicted = False
        kind, d, water = row["case"].split("_")
        ok = stable(row)
        if row["status"] == "completed":
            done = "yes"
        elif "coupling is unstable" in row["status"]:  # the divergence detection's stop
            done = f"**no**: divergence detection at {row['t_end']:.2f} s"
        else:
            done = f"**no**: {row['status'][:80]} (t = {row['t_end']:.2f} s)"
        u = row.get("final_u")
        ratio = (f"{row['coupling_energy']:+.2g} J ({row['coupling_energy'] / row['interface_work_peak']:+.1e})"
                 if row.get("interface_work_peak") else "–")
        ppw = f"{row['passes_per_window']:.2f} ({row['max_passes']})" if "passes_per_window" in row else "–"
        print(f"| {kind} | {d} | {data['water']['model']} | {done} | "
              f"{f'{u[0]:.2f} / {u[2]:.2f}' if u else '–'} | {ppw} | {ratio} | "
              f"{'stable' if predicted else 'unstable'} | {'yes' if ok == predicted else '**no**'} | "
              f"{row.get('coupled_wall_s', float('nan')):.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
