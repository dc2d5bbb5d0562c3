"""python -m benchmarks.peaks_compare REF_RESULTS NEW_RESULTS [--conditions c1,c2] [--limit 1e-3]:
every monitored peak of each condition of NEW against REF, and the coupling's figures.

For each condition found in both folders (results_<condition>.h5): every peak value of every
monitor (post.peaks: |u_x|, |u_y|, |u_z|, max σ3, most compressive σ1, damage, peak hydrodynamic
pressure; not the times of the peaks) and the ring's largest |N|, |M|, |V| and diameter change,
each as a relative difference; the worst of them; the coupling energy as a share of the largest
interface work, the passes a window and the CPU seconds of the shaking (tq-solid's solid_cpu_s +
coupler_cpu_s + OpenFOAM's last ExecutionTime). Exit status 1 when a peak differs by more than
`--limit` (relative) or a coupling energy exceeds it."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from .cost_error import ring_peaks, water_cpu


def condition_figures(folder: Path, cond: str) -> dict:
    """The peaks (flattened `monitor/key` and `ring/key`) and coupling figures of one condition."""
    import h5py

    from tunnelquake.post import peaks, read_condition

    res = folder / f"results_{cond}.h5"
    r = read_condition(res, cond)
    vals: dict[str, float] = {}
    for m, pk in peaks(r).items():
        for k, v in pk.items():
            if not k.startswith("t_") and not k.endswith("_time"):
                vals[f"{m}/{k}"] = float(v)
    for k, v in ring_peaks(res).items():
        vals[f"ring/{k}"] = v
    out: dict = {"peaks": vals, "complete": bool(r.complete), "t_end": float(r.t_end)}
    with h5py.File(res, "r") as f:
        if "coupling" in f:
            c = dict(f["coupling"].attrs)
            work = float(c.get("interface_work_peak", math.nan))
            out["energy_share"] = abs(float(c["coupling_energy"])) / work if work else math.nan
            out["passes_per_window"] = float(c["passes"]) / float(c["windows"])
            w = water_cpu(folder / cond / "fluid.log")
            out["cpu_s"] = float(c["solid_cpu_s"]) + float(c.get("coupler_cpu_s", 0.0)) + (w or 0.0)
            out["water_cpu_s"] = w
    return out


def relative(new: float, ref: float) -> float:
    if math.isnan(ref) and math.isnan(new):
        return 0.0
    if new == ref:
        return 0.0
    return abs(new - ref) / abs(ref) if ref else math.inf


def compare(ref: dict, new: dict) -> dict:
    """Each peak's relative difference (keys of both) and the worst."""
    diffs = {k: relative(new["peaks"][k], v) for k, v in ref["peaks"].items() if k in new["peaks"]}
    worst = max(diffs, key=diffs.get) if diffs else None
    return {"diffs": diffs, "worst": worst, "worst_value": diffs[worst] if worst else math.nan}


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("ref", type=Path)
    p.add_argument("new", type=Path)
    p.add_argument("--conditions", default="no_water,static_water,dynamic_water")
    p.add_argument("--limit", type=float, default=1e-3)
    args = p.parse_args(argv)
    bad = False
    for cond in args.conditions.split(","):
        if not ((args.ref / f"results_{cond}.h5").is_file() and (args.new / f"results_{cond}.h5").is_file()):
            print(f"{cond}: not in both folders")
            continue
        a, b = condition_figures(args.ref, cond), condition_figures(args.new, cond)
        c = compare(a, b)
        print(f"{cond}: {len(c['diffs'])} peaks; worst {100 * c['worst_value']:.4f} % ({c['worst']}); "
              f"completed {a['complete']} / {b['complete']}")
        for k in sorted(c["diffs"], key=c["diffs"].get, reverse=True)[:5]:
            print(f"    {k}: {a['peaks'][k]:.6g} -> {b['peaks'][k]:.6g} ({100 * c['diffs'][k]:+.4f} %)")
        for key in ("energy_share", "passes_per_window", "cpu_s", "water_cpu_s"):
            if key in a or key in b:
                print(f"    {key}: {a.get(key)} -> {b.get(key)}")
        bad |= not c["worst_value"] <= args.limit or not b["complete"]
        bad |= b.get("energy_share", 0.0) > args.limit
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
