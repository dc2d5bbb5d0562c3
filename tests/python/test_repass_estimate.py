"""check's run-time estimate of a coupling window's re-passes (scene.repass_reach, rates.repass_factor):
tq-solid steps a window again only over what the water's force can reach within it
(Solver::planRepasses), so a re-pass costs its first pass less the element evaluations it leaves out.

References: the closed form of the model (a pass 1 - (1 - f) s of a one-rate step, f s of it the
element evaluations, a re-pass evaluating r of them) at its limits, and the estimate's coupled CPU
against the same estimate with every re-pass counted whole, on a case unlike the paper's (the
pressure tunnel: 3.5 m radius, 0.5 m lining, 60 m head) with subcycling and at one rate."""
from __future__ import annotations

import copy

import pytest

from conftest import EXAMPLE
from tunnelquake import rates as R
from tunnelquake import scene
from tunnelquake.case import load_case

PRESSURE_TUNNEL = EXAMPLE.parents[1] / "pressure_tunnel" / "case.yaml"
#: the probe box's share of its step in element evaluations, as measured on the Intel VM (0.85-0.97)
BOX_SHARE = 0.9 * R.PROBE_ELEMENT_STEPS * R.SOLID_PER_PROBE_S


def test_a_repass_costs_its_pass_less_the_evaluations_it_leaves_out():
    """repass_factor(f, r) = (w - (1 - r) f s) / w, w = 1 - (1 - f) s: 1 when the re-pass evaluates
    everything (r = 1) or the evaluations' share is not measured (s = 0); r at one rate (f = 1) when
    the evaluations are the whole step (s = 1)."""
    rates = R.MachineRates(0.3, "test", "given", eval_share=BOX_SHARE)
    s = rates.solid_eval_share
    assert s == pytest.approx(0.9)
    for f in (1.0, 0.29):
        assert rates.repass_factor(f, 1.0) == pytest.approx(1.0, rel=1e-12)
        w = 1 - (1 - f) * s
        assert rates.repass_factor(f, 0.6) == pytest.approx((w - 0.4 * f * s) / w, rel=1e-12)
    assert R.MachineRates(0.3, "test", "given").repass_factor(0.29, 0.6) == 1.0
    everything = R.MachineRates(0.3, "test", "given", eval_share=R.PROBE_ELEMENT_STEPS * R.SOLID_PER_PROBE_S)
    assert everything.repass_factor(1.0, 0.6) == pytest.approx(0.6, rel=1e-12)


@pytest.mark.parametrize("subcycling", [3, 0])
def test_the_estimate_counts_each_repass_at_its_reach(monkeypatch, subcycling):
    """The coupled condition's solid CPU: its first pass and (passes a window - 1) re-passes at
    repass_factor of the case's own reach (below 1: the outer rock is out of reach within a window of
    16 steps), against the estimate that counts them whole; the water's part unchanged."""
    case = load_case(PRESSURE_TUNNEL)
    case.data["conditions"] = ["dynamic_water"]
    case.data["time"]["subcycling"] = subcycling
    rates = R.MachineRates(0.3, "test", "given", eval_share=BOX_SHARE)
    est = scene.runtime_estimate(case, rates=rates)
    r, again = est.repass["dynamic_water"]
    assert 0.2 < r < 1 and again < 1
    f = est.subcycled["dynamic_water"][0] if subcycling else 1.0
    assert again == pytest.approx(rates.repass_factor(f, r), rel=1e-12)
    assert f"dynamic_water's windows stepped again over the water's reach: {r:.2f}" in est.line()
    monkeypatch.setattr(R.MachineRates, "repass_factor", lambda self, f, r: 1.0)  # every re-pass whole
    whole = scene.runtime_estimate(copy.deepcopy(case), rates=rates)
    per_window = scene.passes_per_window(case.data["coupling"])
    assert per_window > 1 and whole.repass["dynamic_water"] == (r, 1.0)
    from tunnelquake.case import case_geology, ground_layers
    from tunnelquake.meshing.params import element_counts, resolve

    d, c = case.data, case.data["coupling"]
    counts = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    water = per_window * est.steps / c["window"] * (rates.water_pass + counts["water"] * rates.water_cell_pass)
    first = (whole.cpu["dynamic_water"] - water) / per_window  # a window's whole pass of the solid
    assert 0 < water < whole.cpu["dynamic_water"] and first > 0
    assert est.cpu["dynamic_water"] - water == pytest.approx(first * (1 + (per_window - 1) * again), rel=1e-9)
