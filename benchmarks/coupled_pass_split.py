"""The coupled solid's passes against the same solid alone (a measurement, not a test): what a
coupling window costs tq-solid in its first pass, in each pass stepped again, and at the window's end,
against the same window's steps of `static_water` (the same mesh, levels, materials and step, its
water a static pressure), alternated.

usage: python -m benchmarks.coupled_pass_split OUT [--case CASE.yaml] [--variant 3d] [--end 1.0]
                                               [--rounds 3]

Writes two copies of the case (the variant laid over it, `time.end_time` cut to END s, results in
OUT/<name>/results): `coupled` with conditions [dynamic_water] (the case's implicit scheme and windows)
and `alone` with [static_water]. Each round runs `tunnelquake run CASE --no-post` for both, in an order
that turns each round, with benchmarks.allrun_time's environment. Read: the coupled results'
`/coupling` attributes `solid_first_passes_s` (from each window's plan to its first exchange),
`solid_repasses_s` (from a refused exchange to the next, the restore included), `solid_s`, passes and
windows, and its `/timings steps`; the alone results' `/timings wall_s` (the shaking's wall) and
`steps` (its shaking's wall holds its results' samples, which the coupled run books at each window's
end). Printed per round, in ms: the alone solid per window of the coupled run's steps, the coupled
first pass per window, a re-pass, the window's end (solid_s less both, per window), and the ratios
first pass / alone and re-pass / first pass; their medians over the rounds. The figures go to
OUT/coupled_pass_split.json.
"""
from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

import h5py

from .allrun_time import case_with_conditions, cut_case_parser, parse_cut_case, run_no_post, write_case
from .common import machine

ORDER = ("coupled", "alone")
CONDITION = {"coupled": "dynamic_water", "alone": "static_water"}


def cases(src: Path, variant: str | None, end: float, out: Path) -> dict[str, Path]:
    """OUT/coupled/case.yaml (dynamic_water) and OUT/alone/case.yaml (static_water), cut to `end` s."""
    return {name: write_case(case_with_conditions(src, [CONDITION[name]]), src.parent, out / name, variant, end)
            for name in ORDER}


def figures(case: Path, name: str) -> dict:
    """The run's attributes this benchmark reads (see the module's doc)."""
    with h5py.File(case.parent / "results" / f"results_{CONDITION[name]}.h5", "r") as f:
        t = f["timings"].attrs
        got = {"steps": float(t["steps"]), "shaking_wall_s": float(t["wall_s"])}
        if name == "coupled":
            a = f["coupling"].attrs
            for k in ("solid_s", "solid_first_passes_s", "solid_repasses_s", "passes", "windows", "coupled_wall_s"):
                got[k] = float(a[k])
    return got


def split(c: dict, alone: dict) -> dict:
    """The round's figures in ms: alone a window, the coupled first pass, a re-pass, a window's end."""
    w, re = c["windows"], c["passes"] - c["windows"]
    steps_per_window = c["steps"] / w
    out = {"alone_ms": 1e3 * alone["shaking_wall_s"] / alone["steps"] * steps_per_window,
           "first_ms": 1e3 * c["solid_first_passes_s"] / w,
           "repass_ms": 1e3 * c["solid_repasses_s"] / re if re > 0 else float("nan"),
           "end_ms": 1e3 * (c["solid_s"] - c["solid_first_passes_s"] - c["solid_repasses_s"]) / w,
           "passes_per_window": c["passes"] / w}
    out["first_over_alone"] = out["first_ms"] / out["alone_ms"]
    out["repass_over_first"] = out["repass_ms"] / out["first_ms"]
    return out


def main(argv: list[str]) -> int:
    a = parse_cut_case(cut_case_parser("python -m benchmarks.coupled_pass_split", __doc__, 1.0, 3), argv)
    paths = cases(a.case.resolve(), a.variant or None, a.end, a.out.resolve())
    print(f"{machine()}; {a.case} ({a.variant or 'as written'}), first {a.end:g} s, {a.rounds} rounds", flush=True)
    rows = []
    for r in range(a.rounds):
        got = {}
        for name in ORDER if r % 2 == 0 else ORDER[::-1]:
            run_no_post(paths[name])
            got[name] = figures(paths[name], name)
        s = split(got["coupled"], got["alone"])
        rows.append({"round": r + 1, **{f"{n}_{k}": v for n in ORDER for k, v in got[n].items()}, **s})
        print(f"round {r + 1}: alone {s['alone_ms']:.2f} ms a window; coupled first pass {s['first_ms']:.2f} "
              f"({s['first_over_alone']:.3f}x), re-pass {s['repass_ms']:.2f} ({s['repass_over_first']:.3f}x the "
              f"first), window's end {s['end_ms']:.2f} ms; {s['passes_per_window']:.3f} passes a window", flush=True)
    med = {k: statistics.median(row[k] for row in rows) for k in ("alone_ms", "first_ms", "repass_ms", "end_ms",
                                                                  "first_over_alone", "repass_over_first")}
    print("medians: " + ", ".join(f"{k} {v:.3f}" for k, v in med.items()))
    summary = {"machine": machine(), "case": str(a.case), "variant": a.variant, "end_s": a.end, "rows": rows,
               "medians": med}
    (a.out / "coupled_pass_split.json").write_text(json.dumps(summary, indent=1))
    print(f"written {a.out / 'coupled_pass_split.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
