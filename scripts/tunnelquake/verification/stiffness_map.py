"""Water stiffness x density ratio x scheme on a case's slice, condition dynamic_water: which
combinations the coupled chain runs through, against what `tunnelquake check` predicts for each
(docs/stability.md "Water stiffness").

Each run is the case file with its conditions cut to dynamic_water, its record cut to `--duration`
seconds, and these keys laid over it:

    water.model / water.bulk_modulus   the stiffness (K in GPa, or incompressible)
    water.density                      the density ratio to the lining
    coupling.scheme / volume_law       implicit with the volume law in the solid (the default),
                                       implicit with the whole pressure exchanged and the linear
                                       ramp (volume_law water, window_force_weight 0.5: the former
                                       computation), explicit with the volume law in the solid

A run is *stable* when `tunnelquake run` completes the requested duration (no energy-guard stop,
no divergence stop, no solver failure) and its coupling energy is below 1 % of the interface work;
the prediction is `scene.added_mass_diagnostic(case).stable`. Every case file written and every log
stays in the work folder.

    python -m tunnelquake.verification.stiffness_map run cases/paper_tunnel --folder /tmp/smap \\
        --out /tmp/smap/map.jsonl
    python -m tunnelquake.verification.stiffness_map table /tmp/smap/map.jsonl

The case's record path may be relative to the case folder: it is made absolute in the copies.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import h5py
import yaml

STIFFNESSES = ("2.2 GPa", "22 GPa", "220 GPa", "2200 GPa", "incompressible")
DENSITIES = (1000.0, 2500.0)  # kg/m^3: water/lining density ratio 0.4 and 1 for the example's lining
SCHEMES = (("implicit", "solid"), ("implicit", "water"), ("explicit", "solid"))
ENERGY_LIMIT = 0.01  # the stability criterion on the coupling energy / interface work


def variant(base: dict, case_dir: Path, stiffness: str, density: float, scheme: str, law: str,
            duration: float) -> dict:
    """The case data of one run of the map (a deep copy of `base` with the map's keys laid over it)."""
    d = json.loads(json.dumps(base))
    d["conditions"] = ["dynamic_water"]
    d.pop("variants", None)
    gm = d["ground_motion"]
    gm["duration"] = f"{duration} s"
    if gm.get("file"):
        gm["file"] = str((case_dir / gm["file"]).resolve())
    w = d["water"]
    if stiffness == "incompressible":
        w["model"] = "incompressible"
    else:
        w["model"] = "compressible"
        w["bulk_modulus"] = stiffness
    w["density"] = f"{density} kg/m^3"
    c = d["coupling"]
    c["scheme"] = scheme
    c["volume_law"] = law
    if law == "water":  # the whole pressure exchanged, with the linear ramp: the former computation
        c["window_force_weight"] = 0.5
    if scheme != "implicit":  # the explicit scheme: one-step windows, no iterations to start or reuse
        for k in ("window", "reuse", "predictor", "tolerance", "window_force_weight"):
            c.pop(k, None)
        c["window"] = 1
    return d


def run_one(case_file: Path, timeout: float) -> dict:
    """`tunnelquake run` of one map case; what it ended in, from its results file."""
    t0 = time.monotonic()
    try:
        proc = subprocess.run([sys.executable, "-m", "tunnelquake", "run", str(case_file)], capture_output=True,
                              text=True, timeout=timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        code = -1
    wall = time.monotonic() - t0
    (case_file.parent / "run.log").write_text(proc.stdout + proc.stderr if code != -1 else "timeout\n")
    res = case_file.parent / "results" / "results_dynamic_water.h5"
    out = {"exit": code, "wall_s": round(wall, 1), "status": "no results file", "t_end": 0.0}
    if res.is_file():
        with h5py.File(res, "r") as f:
            out["status"] = str(f.attrs.get("status", ""))
            c = dict(f["coupling"].attrs) if "coupling" in f else {}
            if "monitors" in f and len(f["monitors"]):
                g = next(iter(f["monitors"].values()))
                out["t_end"] = float(g["time"][-1, 0]) if g["time"].shape[0] else 0.0
                peaks = {m: float(abs(f[f"monitors/{m}/water_pressure"][:, 1]).max())
                         for m in f["monitors"] if "water_pressure" in f[f"monitors/{m}"]}
                out["peak_pressure"] = peaks
            if c:
                out["passes_per_window"] = float(c["passes"]) / max(float(c["windows"]), 1.0)
                out["coupling_energy"] = float(c["coupling_energy"])
                out["interface_work_peak"] = float(c["interface_work_peak"])
    return out


def stable(row: dict) -> bool:
    e, w = row.get("coupling_energy"), row.get("interface_work_peak")
    return (row["exit"] == 0 and row["status"] == "completed" and e is not None and w is not None and w > 0
            and e < ENERGY_LIMIT * w)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tunnelquake.verification.stiffness_map",
                                 description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run the map")
    r.add_argument("case", type=Path, help="case folder or case.yaml (a slice)")
    r.add_argument("--folder", type=Path, required=True, help="work folder (one sub-folder a run)")
    r.add_argument("--out", type=Path, required=True, help="JSON lines, one a run (appended)")
    r.add_argument("--duration", type=float, default=5.0, help="seconds of the record (default 5)")
    r.add_argument("--stiffness", nargs="+", default=list(STIFFNESSES))
    r.add_argument("--density", type=float, nargs="+", default=list(DENSITIES))
    r.add_argument("--schemes", nargs="+", default=[f"{s}:{law}" for s, law in SCHEMES],
                   help="scheme:volume_law pairs (default: %(default)s)")
    r.add_argument("--timeout", type=float, default=1800.0, help="seconds a run at most")
    t = sub.add_parser("table", help="the markdown table of a map")
    t.add_argument("jsonl", type=Path)
    a = ap.parse_args(argv)

    if a.cmd == "table":
        from ..case import CaseError, load_case
        from ..scene import added_mass_diagnostic
        print("| K | ρw/ρl | scheme | volume law | check predicts | run | ends at (s) | E_c / interface work | "
              "passes/window | agree |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for line in a.jsonl.read_text().splitlines():
            row = json.loads(line)
            cf = Path(row.get("case_file", ""))
            if cf.is_file():  # the prediction of today's check for the run's own case file
                try:
                    row["predicted"] = added_mass_diagnostic(load_case(cf)).stable
                except CaseError:
                    row["predicted"] = False
            ok = stable(row)
            ratio = (f"{row['coupling_energy'] / row['interface_work_peak']:+.2e}"
                     if row.get("interface_work_peak") else "–")
            ppw = f"{row['passes_per_window']:.2f}" if "passes_per_window" in row else "–"
            run = "stable" if ok else f"**unstable**: {row['status'][:90]}"
            print(f"| {row['stiffness']} | {row['density_ratio']:.2f} | {row['scheme']} | {row['volume_law']} | "
                  f"{'stable' if row['predicted'] else 'unstable'} | {run} | {row['t_end']:.3f} | {ratio} | {ppw} | "
                  f"{'yes' if ok == row['predicted'] else '**no**'} |")
        return 0

    from ..case import load_case
    from ..scene import added_mass_diagnostic

    case_file = a.case / "case.yaml" if a.case.is_dir() else a.case
    base = yaml.safe_load(case_file.read_text())
    lining_density = load_case(case_file).data["materials"]["lining"]["density"]
    a.folder.mkdir(parents=True, exist_ok=True)
    for scheme_law in a.schemes:
        scheme, law = scheme_law.split(":")
        for rho in a.density:
            for k in a.stiffness:
                name = f"{scheme}-{law}-rho{rho:g}-{k.replace(' ', '')}"
                folder = a.folder / name
                folder.mkdir(parents=True, exist_ok=True)
                cf = folder / "case.yaml"
                cf.write_text(yaml.safe_dump(variant(base, case_file.parent, k, rho, scheme, law, a.duration),
                                             sort_keys=False))
                try:
                    predicted = added_mass_diagnostic(load_case(cf)).stable
                    row = run_one(cf, a.timeout)
                except Exception as e:  # the case check refused the combination: part of the map
                    predicted, row = False, {"exit": 1, "wall_s": 0.0, "status": f"refused by check: {e}",
                                             "t_end": 0.0}
                row.update(name=name, case_file=str(cf.resolve()), stiffness=k, density_ratio=rho / lining_density, scheme=scheme,
                           volume_law=law, predicted=predicted, duration=a.duration)
                with a.out.open("a") as f:
                    f.write(json.dumps(row) + "\n")
                print(f"{name}: predicted {'stable' if predicted else 'unstable'}, run "
                      f"{'stable' if stable(row) else 'unstable'} ({row['status'][:80]}, {row['wall_s']} s)",
                      flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
