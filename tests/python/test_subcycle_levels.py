"""The subcycling levels `check` computes from a mesh (subcycle_levels, scene.subcycled_levels)
against those tq-solid sets up and reports (its results' /subcycling: elements_level_L, nodes_level_L,
cost_fraction), and what a subcycled condition then costs in the run-time estimate
(rates.MachineRates.subcycled_factor).

References: tq-solid's own counts, exactly (the same rule on the same mesh: integers, and the
cost fraction a sum of powers of 2 over the elements, to round-off), on meshes unlike each other: a
bonded slice (the interface's tied pairs share a level); a 3D tunnel with the dynamic contact (its
pairs at the finest level; its rock block renumbered before it is cut into chunks), and the same
tunnel with its ends plugged (where the blocks' order by estimated level decides the chunks); the
element-evaluation probe's box (one region, layers of two sizes). The estimate's subcycled CPU
against the one-rate CPU of the same case: the closed form 1 - (1 - f) s."""
from __future__ import annotations

import h5py
import pytest
from case_texts import synthetic_motion, tunnel

from conftest import mesh_and_motion, run_solid, solid_with
from tunnelquake import rates as R
from tunnelquake.case import load_case
from tunnelquake.scene import runtime_estimate, subcycled_levels
from tunnelquake.solid_input import write_solid_input
from tunnelquake.subcycle_levels import PROBE_ROCK, mesh_levels, write_probe_box


def _section(name: str, mode: str, y_range, interface: str, **mesh) -> str:
    """An 8 m tunnel with a 0.35 m lining in an 80 m square of soft elastic rock."""
    keys = dict(max_element_size="6 m", lining_elements_around=24, lining_elements_through=2,
                near_field_half_width=10.0, near_field_radial_divisions=4) | mesh
    return tunnel(name, [-40.0, 40.0], y_range, [-40.0, 40.0], centre_x=0.0, centre_z=0.0, radius="4.0 m",
                  lining="0.35 m", mode=mode, **keys) + f"""\
materials:
  rock: {{model: elastic, youngs_modulus: 6 GPa, poisson_ratio: 0.3, density: 2400 kg/m^3}}
  lining: {{model: elastic, youngs_modulus: 30 GPa, poisson_ratio: 0.2, density: 2500 kg/m^3}}
interface: {{model: {interface}}}
in_situ: {{kx: 0.7, ky: 1.0}}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + f"""stages:
  sequence: [in_situ, excavation, lining, seismic]
output:
  monitors:
    crown: [0.0, {0.5 * (y_range[0] + y_range[1])}, 4.2]
"""


def _slice() -> str:
    """The section as a bonded slice 1.5 m thick."""
    return _section("levels_slice", "slice", [0.0, 2.0], "bonded", slice_thickness="1.5 m")


def _3d_text() -> str:
    """The section as a 3D tunnel 14 m long (7 axial elements) with the dynamic contact: 2,212 rock
    elements, a block renumbered breadth first before it is cut into chunks."""
    return _section("levels_3d", "3d", [0.0, 14.0], "dynamic_contact", elements_along_axis=7)


def _plugged_text() -> str:
    """The 3D tunnel 14 m long in 9 axial elements, its ends plugged with rock 2 elements deep: the
    plugs' elements touch the tunnel's faces, so the breadth-first fronts from them mix levels."""
    return _section("levels_plugged", "3d", [0.0, 14.0], "dynamic_contact", elements_along_axis=9,
                    tunnel_end_plugs=2)


def _case(tmp_path, text: str, levels: int, name: str = "case.yaml"):
    p = tmp_path / name
    p.write_text(text + f"time: {{end_time: 0.004 s, subcycling: {levels}}}\nconditions: [no_water]\n")
    return load_case(p)


def _reported(results) -> dict:
    with h5py.File(results, "r") as f:
        return {k: float(v) for k, v in f["subcycling"].attrs.items()}


def _assert_same(computed, reported: dict) -> None:
    top = int(reported["levels"])
    assert len(computed.elements) == len(computed.nodes) == top + 1
    for level in range(top + 1):
        assert computed.elements[level] == reported[f"elements_level_{level}"], (level, computed, reported)
        assert computed.nodes[level] == reported[f"nodes_level_{level}"], (level, computed, reported)
    assert computed.cost_fraction == pytest.approx(reported["cost_fraction"], rel=1e-12)


@pytest.mark.skipif(solid_with() is None, reason="tq-solid not built (set TQ_BUILD_DIR)")
@pytest.mark.parametrize("text, levels", [(_slice, 3), (_3d_text, 2), (_plugged_text, 3)],
                         ids=["bonded_slice", "contact_3d", "plugged_3d"])
def test_the_levels_are_tq_solids_own(tmp_path, text, levels):
    """The counts by level and the cost fraction scene.subcycled_levels computes for the case (from a
    mesh it makes itself) equal those tq-solid reports when it runs the case's mesh: the grading,
    the interface's constraint and the chunks reproduced."""
    case = _case(tmp_path, text(), levels)
    mesh_and_motion(case, tmp_path)
    inp = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", "no_water", tmp_path / "in.h5")
    run_solid(solid_with(), inp, tmp_path / "out.h5", timeout=600)
    reported = _reported(tmp_path / "out.h5")
    assert int(reported["levels"]) == levels and 0 < reported["cost_fraction"] < 1  # a mesh of several levels
    _assert_same(subcycled_levels(case)["no_water"], reported)


def test_a_chunk_steps_at_its_own_elements_level(tmp_path, monkeypatch):
    """The blocks' elements in order of their estimated level (tq-solid's setOrderLevels; its counts
    equal these on the same mesh, test_the_levels_are_tq_solids_own's plugged_3d): a chunk of 64 is
    evaluated at its finest element's level, so an element evaluated finer than its own nodes' finest
    level sits only in the chunk that straddles a level's end, fewer than 64 a level and block. The
    breadth-first order alone (the estimate taken out) leaves hundreds so on this mesh and costs more."""
    from tunnelquake import subcycle_levels as SL

    case = _case(tmp_path, _plugged_text(), 3)

    def excess(lv) -> int:  # the most elements evaluated at level L or finer that own a coarser one
        return max(sum(lv.elements[:k + 1]) - sum(lv.own[:k + 1]) for k in range(len(lv.elements)))

    by_level = subcycled_levels(case)["no_water"]
    monkeypatch.setattr(SL, "order_levels", lambda *a, **k: None)
    fronts = subcycled_levels(case)["no_water"]
    assert by_level.own == fronts.own and sum(by_level.elements) == sum(fronts.elements)
    assert 0 <= excess(by_level) < 2 * SL.CHUNK  # two blocks: the rock and the lining
    assert excess(fronts) > 2 * SL.CHUNK
    assert by_level.cost_fraction < 0.9 * fronts.cost_fraction


@pytest.mark.skipif(solid_with() is None, reason="tq-solid not built (set TQ_BUILD_DIR)")
def test_the_probe_box_levels_are_tq_solids_own(tmp_path):
    """The element-evaluation probe's box (one elastic region, a thin layer under thick ones, base
    fixed): the levels computed from its mesh at its given step equal tq-solid's."""
    inp = write_probe_box(tmp_path, 4, R.EVAL_PROBE_LEVELS)
    run_solid(solid_with(), inp, tmp_path / "out.h5", timeout=120)
    with h5py.File(inp, "r") as f:
        dt, safety = float(f["solver"].attrs["dt"]), float(f["solver"].attrs["safety"])
    rock = dict(zip(("youngs_modulus", "poisson_ratio", "density"), PROBE_ROCK, strict=True))
    computed = mesh_levels(tmp_path / "mesh.h5", {"rock": rock}, R.EVAL_PROBE_LEVELS, safety, dt)
    _assert_same(computed, _reported(tmp_path / "out.h5"))


def test_a_subcycled_condition_costs_the_evaluations_it_leaves_out(tmp_path):
    """runtime_estimate: a subcycled condition's solid CPU is the same condition's one-rate CPU times
    1 - (1 - f) s, f its levels' cost fraction and s the element evaluations' share of the case's
    element-step (the probe box's share over the box's element-step against the case's); without a
    measured share (0) it counts at one rate."""
    text = _slice()
    one = _case(tmp_path, text, 0, "one.yaml")
    sub = _case(tmp_path, text, 3, "sub.yaml")
    box = 0.84
    rates = R.MachineRates(0.3, "test", "given", eval_share=box)
    f = subcycled_levels(sub)["no_water"].cost_fraction
    assert 0 < f < 1
    s = box / (R.PROBE_ELEMENT_STEPS * R.SOLID_PER_PROBE_S)
    a, b = runtime_estimate(one, rates=rates), runtime_estimate(sub, rates=rates)
    assert b.cpu["no_water"] == pytest.approx(a.cpu["no_water"] * (1 - (1 - f) * s), rel=1e-12)
    assert b.subcycled["no_water"] == pytest.approx((f, 1 - (1 - f) * s), rel=1e-12)
    unmeasured = runtime_estimate(sub, rates=R.MachineRates(0.3, "test", "given"))
    assert unmeasured.cpu["no_water"] == pytest.approx(a.cpu["no_water"], rel=1e-12)


def test_a_case_check_does_not_mesh_counts_at_one_rate_and_says_so(tmp_path, monkeypatch):
    """A case of more hexahedra than check meshes itself (scene.CHECK_MESH_MAX_ELEMENTS, lowered here
    below the slice's) and without a current mesh: its subcycled condition counted at one rate, and
    the estimate's basis says why and how to have it counted (`tunnelquake mesh`)."""
    from tunnelquake import scene

    monkeypatch.setattr(scene, "CHECK_MESH_MAX_ELEMENTS", 10)
    rates = R.MachineRates(0.3, "test", "given", eval_share=0.84)
    one = runtime_estimate(_case(tmp_path, _slice(), 0, "one.yaml"), rates=rates)
    sub = runtime_estimate(_case(tmp_path, _slice(), 3, "sub.yaml"), rates=rates)
    assert sub.cpu["no_water"] == pytest.approx(one.cpu["no_water"], rel=1e-12) and not sub.subcycled
    assert "counted at one rate" in sub.basis and "`tunnelquake mesh`" in sub.basis
