"""time.subcycling per condition: one level for every condition, or a mapping of conditions to
levels (a condition left out steps single-rate). Each condition's tq-solid input carries its own
level, its results fingerprint only its own, and a subcycled condition's answer stays within the
bar the product sets for subcycling (0.1 % of single-rate on every monitored peak) on a case with
nothing in it that turns on events (elastic, bonded, under water pressure). Bad levels and condition
names are refused by `tunnelquake check`, naming the key and the fix.

The case: a slice 1.5 m thick of an 8 m tunnel with a 0.35 m lining in an 80 m square of soft elastic
rock, bonded, 40 m of head, the seeded synthetic motion."""
from __future__ import annotations

import h5py
import numpy as np
import pytest
from case_texts import synthetic_motion, tunnel

from conftest import mesh_and_motion, run_solid, solid_with
from tunnelquake import fingerprint
from tunnelquake.case import CaseError, load_case, subcycling_levels
from tunnelquake.solid_input import write_solid_input

#: the bar the product holds a subcycled run to against single-rate (docs/solid_solver.md "Subcycling")
BAR = 1e-3


def _text(subcycling: str | None, damping: str = "") -> str:
    time = f"time: {{end_time: 0.6 s, subcycling: {subcycling}}}\n" if subcycling else "time: {end_time: 0.6 s}\n"
    return tunnel("per_condition", [-40.0, 40.0], [0.0, 2.0], [-40.0, 40.0], centre_x=0.0, centre_z=0.0,
                  radius="4.0 m", lining="0.35 m", mode="slice", slice_thickness="1.5 m", max_element_size="6 m",
                  lining_elements_around=24, lining_elements_through=2, near_field_half_width=10.0,
                  near_field_radial_divisions=4) + """\
materials:
  rock: {model: elastic, youngs_modulus: 6 GPa, poisson_ratio: 0.3, density: 2400 kg/m^3}
  lining: {model: elastic, youngs_modulus: 30 GPa, poisson_ratio: 0.2, density: 2500 kg/m^3}
interface: {model: bonded}
in_situ: {kx: 0.7, ky: 1.0}
water: {head: 40 m}
""" + synthetic_motion("1.5 m/s^2", 0.5, 1.0) + time + damping + """stages:
  sequence: [in_situ, excavation, lining, hydrostatic, seismic]
conditions: [no_water, static_water]
output:
  history_interval: 0.001 s
  monitors:
    crown: [0.0, 1.0, 4.2]
    springline: [4.2, 1.0, 0.0]
"""


def _case(tmp_path, subcycling: str | None, name: str = "case.yaml", damping: str = ""):
    p = tmp_path / name
    p.write_text(_text(subcycling, damping))
    return load_case(p)


def _solver_level(inp) -> int:
    with h5py.File(inp, "r") as f:
        return int(f["solver"].attrs.get("subcycling_levels", 0))


def test_a_mapping_sets_each_conditions_level_and_only_its_fingerprint(tmp_path):
    """{static_water: 2}: static_water's input steps at 2 levels, no_water's single-rate; no_water's
    fingerprint is that of the case without subcycling, static_water's that of `subcycling: 2` for
    all (so results of a condition whose level did not change are not made stale)."""
    mapped = _case(tmp_path, "{static_water: 2}", "mapped.yaml")
    single = _case(tmp_path, None, "single.yaml")
    every = _case(tmp_path, "2", "every.yaml")
    assert [subcycling_levels(mapped.data, c) for c in ("no_water", "static_water", "dynamic_water")] == [0, 2, 0]
    assert [subcycling_levels(every.data, c) for c in ("no_water", "static_water")] == [2, 2]
    mesh_and_motion(mapped, tmp_path)
    levels = {}
    for cond in ("no_water", "static_water"):
        for tag, case in (("mapped", mapped), ("every", every)):
            inp = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", cond,
                                    tmp_path / f"{tag}_{cond}.h5")
            levels[tag, cond] = _solver_level(inp)
    assert levels == {("mapped", "no_water"): 0, ("mapped", "static_water"): 2,
                      ("every", "no_water"): 2, ("every", "static_water"): 2}

    def digest(case, cond):
        return fingerprint.condition_inputs(case, cond)["digest"]

    assert digest(mapped, "no_water") == digest(single, "no_water")
    assert digest(mapped, "static_water") == digest(every, "static_water")
    assert digest(mapped, "static_water") != digest(single, "static_water")


@pytest.mark.skipif(solid_with() is None, reason="tq-solid not built (set TQ_BUILD_DIR)")
def test_the_subcycled_condition_is_within_the_bar_of_single_rate(tmp_path):
    """static_water stepped by the mapping's level 2 against single-rate, 0.6 s of shaking: the rock
    takes coarser steps (results' /subcycling: levels 2, under 0.7 of the element evaluations) and
    every monitored peak (|u_x|, |u_z|, the lining's max sigma3 and most compressive sigma1) is within
    0.1 % of single-rate; no_water of the same case runs single-rate (no /subcycling). About 10 s."""
    from tunnelquake.post import peaks, read_condition

    exe = solid_with()
    mapped = _case(tmp_path, "{static_water: 2}", "mapped.yaml")
    single = _case(tmp_path, None, "single.yaml")
    mesh_and_motion(mapped, tmp_path)
    res = {}
    for tag, case, cond in (("sub", mapped, "static_water"), ("one", single, "static_water"),
                            ("nw", mapped, "no_water")):
        inp = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", cond, tmp_path / f"{tag}_in.h5")
        res[tag] = tmp_path / f"{tag}.h5"
        run_solid(exe, inp, res[tag], timeout=300)
    with h5py.File(res["sub"], "r") as f:
        sc = dict(f["subcycling"].attrs)
    assert sc["levels"] == 2 and sc["elements_level_1"] + sc["elements_level_2"] > 0 and sc["cost_fraction"] < 0.7
    for tag in ("one", "nw"):
        with h5py.File(res[tag], "r") as f:
            assert "subcycling" not in f
    a = peaks(read_condition(res["sub"], "static_water"))
    b = peaks(read_condition(res["one"], "static_water"))
    compared = 0
    for m in ("crown", "springline"):
        for key in ("max_ux", "max_uz", "max_tension", "min_sigma1"):
            ref, got = b[m][key], a[m][key]
            assert abs(ref) > 0 and np.isfinite(got)
            assert abs(got - ref) <= BAR * abs(ref), (m, key, got, ref)
            compared += 1
    assert compared == 8


@pytest.mark.parametrize("value, path, words", [
    ("{static_watr: 2}", "time.subcycling.static_watr", "did you mean 'static_water'?"),
    ("{static_water: 9}", "time.subcycling.static_water", "give a value in [0, 8]"),
    ("{static_water: 1.5}", "time.subcycling.static_water", "must be a whole number"),
    ("[2, 3]", "time.subcycling", "or a mapping of conditions to levels, e.g. {static_water: 3"),
])
def test_bad_levels_and_names_are_refused_with_the_key_and_the_fix(tmp_path, value, path, words):
    with pytest.raises(CaseError) as e:
        _case(tmp_path, value)
    text = str(e.value)
    assert f"{path} = " in text and words in text, text


def test_a_viscous_damping_is_refused_only_where_a_condition_that_runs_subcycles(tmp_path):
    """Rayleigh's stiffness term cannot be subcycled: refused when a condition that runs is
    subcycled (the message names it), accepted when only a condition not run is."""
    rayleigh = "damping: {model: rayleigh, ratio: 0.05, frequencies: [1.5 Hz, 10 Hz]}\n"
    with pytest.raises(CaseError) as e:
        _case(tmp_path, "{static_water: 2}", damping=rayleigh)
    assert "time.subcycling = {'static_water': 2}" in str(e.value)
    assert "(it subcycles static_water)" in str(e.value) and "time.subcycling: 0" in str(e.value)
    case = _case(tmp_path, "{dynamic_water: 2}", damping=rayleigh)
    assert [subcycling_levels(case.data, c) for c in case.data["conditions"]] == [0, 0]
