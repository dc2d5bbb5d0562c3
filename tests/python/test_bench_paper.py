"""`tunnelquake bench --paper`: the arithmetic of the error table and the Pareto front.

The benchmark's figures are not tests (docs/benchmarks.md, "The paper case's shortcuts"); what is
tested here, with hand-made numbers whose answers are worked out by hand in the comments, is the
error of each monitored peak against the reference, the worst over monitors and quantities, the
Pareto front and the runs that dominate a point, and the case variant the bench writes.
"""
from __future__ import annotations

import math

import pytest
import yaml

from benchmarks.common import update_docs
from benchmarks.paper import (
    BEGIN,
    END,
    Variant,
    analyse,
    dominators,
    error_table,
    pareto_front,
    peak_error,
    set_key,
    write_variant,
)
from conftest import EXAMPLE
from tunnelquake.case import load_case


def _peaks(p, ux, uz, s, d):
    return {"hydrodynamic_pressure_peak": p, "max_ux": ux, "max_uz": uz, "max_tension": s, "max_damage": d}


REF = {"top_arch": _peaks(0.20e6, 0.020, 0.015, 1.25e6, 0.10),
       "haunch": _peaks(0.16e6, 0.021, 0.016, 1.30e6, 0.00)}


def test_peak_error_relative_absolute_and_missing():
    assert peak_error(0.22, 0.20, "relative") == pytest.approx(0.10, rel=1e-12)  # |0.22 - 0.2| / 0.2
    assert peak_error(0.18, 0.20, "relative") == pytest.approx(0.10, rel=1e-12)  # magnitude, both signs
    assert peak_error(0.13, 0.10, "absolute") == pytest.approx(0.03, rel=1e-12)
    assert peak_error(0.0, 0.0, "relative") == 0.0
    assert peak_error(1.0, 0.0, "relative") == math.inf
    assert math.isnan(peak_error(None, 1.0, "relative"))
    assert math.isnan(peak_error(math.nan, 1.0, "relative"))


def test_error_table_takes_the_worst_monitor_and_the_worst_quantity():
    run = {"top_arch": _peaks(0.21e6, 0.0202, 0.015, 1.00e6, 0.13),   # p +5 %, ux +1 %, s -20 %, D +30 %
           "haunch": _peaks(0.24e6, 0.0210, 0.0168, 1.30e6, 0.00)}    # p +50 %, uz +5 %
    e = error_table(run, REF)
    assert e["pressure"]["monitors"]["top_arch"] == pytest.approx(0.05, rel=1e-9)
    assert e["pressure"]["worst"] == pytest.approx(0.50, rel=1e-9)
    assert e["u_x"]["worst"] == pytest.approx(0.01, rel=1e-9)
    assert e["u_z"]["worst"] == pytest.approx(0.05, rel=1e-9)
    assert e["stress"]["worst"] == pytest.approx(0.20, rel=1e-9)
    assert e["damage"]["worst"] == pytest.approx(0.30, rel=1e-9)  # haunch: D = 0 in both, error 0
    assert e["worst"] == pytest.approx(0.50, rel=1e-9)
    # A solid-only run has no pressure: that quantity is nan and does not enter the worst.
    dry = {m: {k: v for k, v in pk.items() if k != "hydrodynamic_pressure_peak"} for m, pk in run.items()}
    ref_dry = {m: {k: v for k, v in pk.items() if k != "hydrodynamic_pressure_peak"} for m, pk in REF.items()}
    e = error_table(dry, ref_dry)
    assert math.isnan(e["pressure"]["worst"])
    assert e["worst"] == pytest.approx(0.30, rel=1e-9)


def test_pareto_front_and_dominators():
    # (wall s, error): A cheap and bad, B dominated by C (slower and worse), C, D the reference
    # (slowest, error 0), E dominated by A (same time, worse), F unusable (nan error: stopped).
    pts = [(10.0, 0.30), (50.0, 0.10), (40.0, 0.05), (100.0, 0.0), (10.0, 0.40), (5.0, math.nan)]
    assert pareto_front(pts) == [0, 2, 3]  # by time: A, C, D
    assert dominators(pts, 1) == [2]
    assert dominators(pts, 4) == [0]
    assert dominators(pts, 2) == []
    # Two identical points do not dominate each other: both on the front.
    assert pareto_front([(1.0, 0.1), (1.0, 0.1)]) == [0, 1]


def _run(name, cond, wall, pk, completed=True):
    return {"name": name, "what": name, "condition": cond, "overrides": {}, "cost_only": False, "wall_s": wall,
            "completed": completed, "status": "completed" if completed else "stopped", "peaks": pk,
            "dt": 6.3e-5, "elements": 1464, "load": [1.0, 1.0]}


def test_analyse_ratios_against_the_median_default_and_where_the_default_sits():
    scale = {m: {k: v * 1.1 for k, v in pk.items()} for m, pk in REF.items()}  # every peak +10 %
    runs = [_run("default", "dynamic_water", 100.0, REF),
            _run("reference", "dynamic_water", 300.0, REF),
            _run("fast", "dynamic_water", 50.0, scale),          # 2x faster, 10 % error: on the front
            _run("slow", "dynamic_water", 200.0, scale),         # dominated by the default
            _run("broken", "dynamic_water", 5.0, scale, completed=False),  # stopped: no errors
            _run("default (again)", "dynamic_water", 120.0, REF)]
    a = analyse(runs)["dynamic_water"]
    assert a["default_wall"] == pytest.approx(110.0)  # median of 100 and 120
    ratios = {row["run"]["name"]: row["ratio"] for row in a["rows"]}
    assert ratios["fast"] == pytest.approx(50.0 / 110.0)
    assert "errors" not in next(row for row in a["rows"] if row["run"]["name"] == "broken")
    f = a["fronts"]["worst"]
    # default: 0 error vs reference (same peaks) at 110 s: it dominates "slow" and the reference
    assert f["front"] == ["fast", "default"]
    assert f["default_on_front"] is True
    # a default worse than a cheaper run is reported as dominated, with the run that dominates it
    runs[0]["peaks"] = runs[-1]["peaks"] = {m: {k: v * 1.2 for k, v in pk.items()} for m, pk in REF.items()}
    f = analyse(runs)["dynamic_water"]["fronts"]["worst"]
    assert f["default_on_front"] is False
    assert f["default_dominated_by"] == ["fast"]


def test_the_variant_written_is_the_default_case_with_one_key_changed(tmp_path, example_text):
    base = yaml.safe_load(example_text)
    v = Variant("contact off", "interface.model: bonded", "static_water", {"interface.model": "bonded"})
    d = write_variant(v, base, EXAMPLE.parent, tmp_path, 3.0)
    case = load_case(d / "case.yaml")  # a valid case
    assert case.data["interface"]["model"] == "bonded"
    assert case.data["conditions"] == ["static_water"]
    assert case.data["ground_motion"]["duration"] == pytest.approx(3.0)
    ref = load_case(EXAMPLE).data
    for sect in ("materials", "water", "coupling", "mesh", "damping"):
        assert case.data[sect] == ref[sect]
    nested = {}
    set_key(nested, "materials.rock.model", "elastic")
    assert nested == {"materials": {"rock": {"model": "elastic"}}}


def test_update_docs_touches_only_the_paper_section():
    doc = f"# Benchmarks\n\n<!-- bench:solid -->\nsolid\n<!-- /bench:solid -->\n\n{BEGIN}\nold\n{END}\ntail\n"
    out = update_docs(doc, f"{BEGIN}\nnew\n{END}", BEGIN, END)
    assert "solid\n" in out and "new" in out and "old" not in out and out.endswith("tail\n")
