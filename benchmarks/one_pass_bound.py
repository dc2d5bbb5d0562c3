"""The coupled condition's cost at one water pass a window, the bound of any coupling scheme, against
the case's own settings (a measurement, not a test: the one-pass run's answer is not scored).

usage: python -m benchmarks.one_pass_bound OUT [--case CASE.yaml] [--variant 3d] [--end 0.35]
                                           [--rounds 8] [--record-coupled S --record-outside S]

Writes two copies of the case (the variant laid over it, `time.end_time` cut to END s, conditions
[dynamic_water], results in OUT/<name>/results): `own`, as written, and `one`, whose
`coupling.tolerance` is 1e9 and `coupling.energy_limit` 0, so that every window is accepted at its
first pass (the implicit scheme with an extrapolating predictor, linear or damped, tests pass 0 alone;
docs/coupler.md "Convergence test"; a run that took more passes than windows stops the benchmark).
Each round runs `tunnelquake run CASE --no-post` for both, in an order that turns each round (the
OpenMP wait the product's own, as benchmarks.allrun_time runs it), and reads the results' `/coupling`
attributes (coupled wall, tq-solid's step, passes, windows). Printed: each run's figures, each round's one-pass coupled wall over the own run's, the
median ratio; with --record-coupled (a record's coupled wall, s) and --record-outside (its seconds
outside the coupling: mesh, motion, static stages), the record's time at that ratio. The case needs
the implicit scheme (the condition's water passes are what the bound removes).
"""
from __future__ import annotations

import copy
import json
import statistics
import sys
from pathlib import Path

import h5py

from .allrun_time import case_with_conditions, cut_case_parser, parse_cut_case, run_no_post, write_case
from .common import machine

ORDER = ("own", "one")


def cases(src: Path, variant: str | None, end: float, out: Path) -> dict[str, Path]:
    """OUT/own/case.yaml and OUT/one/case.yaml (dynamic_water only, cut to `end` s)."""
    base = case_with_conditions(src, ["dynamic_water"])
    one = copy.deepcopy(base)
    c = one.setdefault("coupling", {})
    if variant and isinstance((one.get("variants") or {}).get(variant), dict):
        c = one["variants"][variant].setdefault("coupling", {})
    c["tolerance"] = 1e9
    c["energy_limit"] = 0
    return {"own": write_case(base, src.parent, out / "own", variant, end),
            "one": write_case(one, src.parent, out / "one", variant, end)}


def run(case: Path) -> dict:
    """`tunnelquake run CASE --no-post` from an empty results folder; the /coupling attributes."""
    wall = run_no_post(case)
    with h5py.File(case.parent / "results" / "results_dynamic_water.h5", "r") as f:
        a = f["coupling"].attrs
        got = {k: float(a[k]) for k in ("coupled_wall_s", "solid_s", "exchange_wait_s", "exchange_work_s", "passes",
                                        "windows")}
    got["run_wall_s"] = wall
    return got


def main(argv: list[str]) -> int:
    ap = cut_case_parser("python -m benchmarks.one_pass_bound", __doc__, 0.35, 8)
    ap.add_argument("--record-coupled", type=float, default=None, help="a whole record's coupled wall, s")
    ap.add_argument("--record-outside", type=float, default=0.0, help="that record's seconds outside the coupling")
    a = parse_cut_case(ap, argv)
    paths = cases(a.case.resolve(), a.variant or None, a.end, a.out.resolve())
    print(f"{machine()}; {a.case} ({a.variant or 'as written'}), first {a.end:g} s, {a.rounds} rounds", flush=True)
    rows, ratios = [], []
    for r in range(a.rounds):
        got = {}
        for name in ORDER if r % 2 == 0 else ORDER[::-1]:
            got[name] = run(paths[name])
            g = got[name]
            print(f"round {r + 1} {name}: coupled {g['coupled_wall_s']:.2f} s, tq-solid's step {g['solid_s']:.2f} s, "
                  f"{g['passes']:.0f} passes in {g['windows']:.0f} windows", flush=True)
        if got["one"]["passes"] != got["one"]["windows"]:
            raise SystemExit(f"{paths['one']}: {got['one']['passes']:.0f} passes in {got['one']['windows']:.0f} "
                             "windows: the first pass was not tested (use coupling.predictor linear or damped)")
        ratio = got["one"]["coupled_wall_s"] / got["own"]["coupled_wall_s"]
        ratios.append(ratio)
        rows.append({"round": r + 1, **{f"{n}_{k}": v for n in ORDER for k, v in got[n].items()}, "ratio": ratio})
        print(f"round {r + 1}: one pass a window / own settings, coupled wall {ratio:.3f}", flush=True)
    med = statistics.median(ratios)
    print(f"median ratio {med:.3f} ({min(ratios):.3f}-{max(ratios):.3f}) over {a.rounds} rounds")
    summary = {"machine": machine(), "case": str(a.case), "variant": a.variant, "end_s": a.end, "rows": rows,
               "median_ratio": med}
    if a.record_coupled:
        est = [a.record_coupled * x + a.record_outside for x in (med, min(ratios), max(ratios))]
        summary["record_at_one_pass_s"] = est
        print(f"the record at one pass a window: about {est[0]:.0f} s ({est[1]:.0f}-{est[2]:.0f} over the rounds)")
    (a.out / "one_pass_bound.json").write_text(json.dumps(summary, indent=1))
    print(f"written {a.out / 'one_pass_bound.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
