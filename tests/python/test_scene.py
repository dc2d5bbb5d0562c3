"""What each condition runs, and when a slice is equivalent to the 3D model (ARCHITECTURE.md §6)."""
from __future__ import annotations

import pytest

from conftest import EXAMPLE
from tunnelquake.case import load_case
from tunnelquake.scene import assess_slice, plan


def _case(write_case, **edits):
    text = EXAMPLE.read_text()
    for old, new in edits.values():
        assert old in text
        text = text.replace(old, new, 1)
    return load_case(write_case(text))


def test_conditions_run_only_what_they_need(write_case):
    case = _case(write_case)
    assert dict(plan(case)) == {"no_water": ("solid",), "static_water": ("solid",),
                                "dynamic_water": ("solid", "fluid")}


def test_example_slice_is_valid(write_case):
    assert assess_slice(_case(write_case)).valid


def test_slice_with_incompressible_dynamic_water_is_valid_with_the_volume_law_in_the_solid(write_case):
    # the solid holds the enclosed volume (coupling.volume_law: solid, the default; `water` is refused
    # by the case check, tests/python/test_case_file.py)
    case = _case(write_case, m=("  model: compressible\n", "  model: incompressible\n"))
    assert case.data["coupling"]["volume_law"] == "solid"
    assert assess_slice(case).valid


def test_3d_case_is_offered_the_slice(write_case):
    """A 3D case whose water cannot leave through the ends is offered the slice; with open ends the
    advice says the slice is the closed-ends model (measured on the paper case: 4x the mid-length
    hydrodynamic pressure of the open-ended 80 m tunnel; docs/benchmarks.md "Slice against 3D")."""
    case = _case(write_case, m=("  mode: slice ", "  mode: 3d "), e=("  ends: open\n", "  ends: closed\n"))
    a = assess_slice(case)
    assert a.valid and "mesh.mode: slice" in a.advice[0]
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d ")))
    assert a.valid and "water.ends: closed" in a.advice[0] and "4x lower" in a.advice[0]
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d "),
                           c=("conditions: [no_water, static_water, dynamic_water]", "conditions: [no_water]")))
    assert "mesh.mode: slice" in a.advice[0]  # no moving water: the ends do not matter


def test_3d_case_is_offered_subcycling(write_case):
    """A 3D case with a condition stepping everything at the lining's step is offered subcycling for
    it (paper mesh: 0.29 of the element evaluations; docs/solid_solver.md "Subcycling"); one whose
    conditions all have it, and the slice, are not."""
    one = ("  subcycling: {static_water: 3, dynamic_water: 3}\n", "  subcycling: 0\n")
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d "), s=one))
    assert any("time.subcycling: 3" in x and "no_water, static_water, dynamic_water" in x for x in a.advice)
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d ")))  # the example's: no_water single-rate
    assert any("time.subcycling: 3" in x and "(here single-rate: no_water)" in x for x in a.advice)
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d "), s=(one[0], "  subcycling: 3\n")))
    assert not any("subcycling" in x for x in a.advice)
    assert not any("subcycling" in x for x in assess_slice(_case(write_case)).advice)


def test_3d_water_is_offered_the_robust_window_settings(write_case):
    """A 3D case with dynamic water in implicit windows of several steps is offered tolerance 1e-4, and the
    window force weight 0.75 (the default there) when it asks for less (docs/coupler.md "Window force
    weight", "Energy guard": the paper case in 3D ran into a period-two mode with the linear ramp and into
    energy-creating drift at 1e-3); the slice (validated at 1e-3) is not."""
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d ")))
    assert not any("window_force_weight" in x for x in a.advice)  # the default is 0.75
    assert any("coupling.tolerance: 1e-4" in x for x in a.advice)
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d "),
                           w=("  reuse: 16\n", "  reuse: 16\n  window_force_weight: 0.5\n")))
    assert any("window_force_weight: 0.75" in x for x in a.advice)
    a = assess_slice(_case(write_case, m=("  mode: slice ", "  mode: 3d "), t=("  tolerance: 1e-3\n", "  tolerance: 1e-4\n"),
                           w=("  reuse: 16\n", "  reuse: 16\n  window_force_weight: 0.75\n")))
    assert not any("window_force_weight" in x or "coupling.tolerance" in x for x in a.advice)
    a = assess_slice(_case(write_case))
    assert not any("window_force_weight" in x or "coupling.tolerance" in x for x in a.advice)


def test_added_mass_diagnostic_matches_the_hand_estimates(write_case):
    """ARCHITECTURE.md §5: m_G = 2500 x 0.25 / 2 = 312.5 kg/m^2; water adds rho_w R / n = 4500 (n = 1)
    and 2250 (n = 2) kg/m^2: ratios 14.4 and 7.2 > 1, so a staggered scheme (explicit, paper)
    diverges (measured: docs/stability.md), compressible or not; compressible water
    (c = sqrt(2.2e9 / 1000) = 1483 m/s) with the solid step 0.9 x 0.25 m / c_p(lining) also gives the
    impedance ratio rho_w c dt_c / m_G ~ 0.30 per solid step of the window dt_c (the example's windows
    of 16 steps: 4.8), the step 0.9 L / c_p with L the innermost lining hexahedra's volume / largest face
    as tq-solid takes it (0.25 m x cos(pi/48) x (4.5 + 4.75) / (2 x 4.75): chords of 48 around). The
    implicit scheme (the example's) is stable."""
    import math

    from tunnelquake.scene import added_mass_diagnostic

    case = _case(write_case)
    am = added_mass_diagnostic(case)
    assert am.interface_mass == pytest.approx(312.5, rel=1e-12)
    cp = math.sqrt(28e9 * 0.83 / (1.17 * 0.66 * 2500))
    k = case.data["coupling"]["window"]
    assert k == 16
    length = 0.25 * math.cos(math.pi / 48) * (4.5 + 4.75) / (2 * 4.75)
    assert am.ratios["impedance"] == pytest.approx(1000 * math.sqrt(2.2e6) * k * 0.9 * length / cp / 312.5,
                                                   rel=1e-12)
    assert am.ratios["mode 1"] == pytest.approx(1000 * 4.5 / 312.5, rel=1e-12)
    assert am.ratios["mode 2"] == pytest.approx(1000 * 4.5 / 2 / 312.5, rel=1e-12)
    assert 0.25 < am.ratios["impedance"] / k < 0.4
    assert am.stable and "implicit" in am.message  # the example
    for model in ("compressible", "incompressible"):
        paper = added_mass_diagnostic(_case(write_case, m=("  model: compressible\n", f"  model: {model}\n"),
                                            s=("  scheme: implicit\n", "  scheme: paper\n"),
                                            w=("  window: 16\n", "  window: 1\n"), r=("  reuse: 16\n", ""),
                                            p=("  predictor: damped\n", "  predictor: auto\n")))
        # the water's translation (mode 1) is carried by the solid: the exchange keeps mode 2's 7.2
        assert not paper.stable and "diverge" in paper.message and "added-mass ratio 7.2" in paper.message
        former = added_mass_diagnostic(_case(write_case, s=("  scheme: implicit\n", "  scheme: paper\n"),
                                             w=("  window: 16\n", "  window: 1\n"), r=("  reuse: 16\n", ""),
                                             p=("  predictor: damped\n", "  predictor: auto\n"),
                                             t=("  tolerance: 1e-3\n", "  tolerance: 1e-3\n  water_translation: water\n")))
        assert not former.stable and "added-mass ratio 14.4" in former.message


def test_added_mass_diagnostic_takes_the_solid_step_the_run_takes(write_case):
    """The impedance ratio rho_w c dt_c / m_G is of the window's time dt_c = window x the solid's step
    as tq-solid takes it: time.dt where the case gives it (here a third of the lining's stable step: a
    third of the ratio), and where the mesh's hexahedra set a shorter critical step than the lining's
    (`frequencies`, region -> 2 c_p / L, as check reads them from the case's mesh), 0.9 x 2 / w_max."""
    import math

    from tunnelquake.scene import added_mass_diagnostic

    cp = math.sqrt(28e9 * 0.83 / (1.17 * 0.66 * 2500))
    length = 0.25 * math.cos(math.pi / 48) * (4.5 + 4.75) / (2 * 4.75)
    z = 1000 * math.sqrt(2.2e6) * 16 / 312.5  # rho_w c k / m_G
    assert added_mass_diagnostic(_case(write_case)).ratios["impedance"] == pytest.approx(z * 0.9 * length / cp,
                                                                                          rel=1e-12)
    dt = 0.9 * length / cp / 3
    given = _case(write_case, t=("  subcycling: {static_water: 3, dynamic_water: 3}\n",
                                 f"  subcycling: {{static_water: 3, dynamic_water: 3}}\n  dt: {dt!r}\n"))
    assert given.data["time"]["dt"] == dt
    assert added_mass_diagnostic(given).ratios["impedance"] == pytest.approx(z * dt, rel=1e-12)
    w_rock = 2 * 4000.0 / 0.05  # a rock element 0.05 m across at c_p 4 km/s: shorter than the lining's step
    frequencies = {"lining": 2 * cp / length, "rock": w_rock}
    assert added_mass_diagnostic(_case(write_case), frequencies).ratios["impedance"] == pytest.approx(
        z * 0.9 * 2 / w_rock, rel=1e-12)


def test_incompressible_water_with_long_windows_is_warned(write_case):
    """Measured on the paper case in 3D with open ends and the whole pressure exchanged
    (`volume_law: water`; docs/stability.md "The paper case in 3D with incompressible water"): at
    added-mass ratio 14.4 incompressible water with windows of 16 steps diverged (the divergence
    detection stopped it at 0.053 s) and one-step windows needed 12.4 passes a step, so check warns
    for windows of several steps and says what to expect for one-step windows. With the volume law of
    open ends in the solid (the default) the same case ran the whole record with windows of 16 steps
    (docs/stability.md "Open ends in 3D"), and check says it is stable."""
    from tunnelquake.scene import added_mass_diagnostic

    edits = dict(m=("  mode: slice ", "  mode: 3d "), w=("  model: compressible\n", "  model: incompressible\n"),
                 v=("  tolerance: 1e-3\n", "  tolerance: 1e-3\n  volume_law: water\n"))
    am = added_mass_diagnostic(_case(write_case, **edits))
    assert not am.stable and "windows of several steps diverged" in am.message and "14.4" in am.message
    am = added_mass_diagnostic(_case(write_case, k=("  window: 16\n", "  window: 1\n"), **edits))
    assert am.stable and "expect many passes" in am.message
    del edits["v"]
    am = added_mass_diagnostic(_case(write_case, **edits))
    assert am.stable and "per plane of wet nodes" in am.message, am.message
    assert added_mass_diagnostic(_case(write_case)).stable  # the example: compressible water


def test_check_predicts_the_volumetric_stiffness_limit_of_the_exchange(write_case):
    """The enclosed water's stiffness 2K/R per wall area against the wet nodes' 312.5 kg/m^2, exchanged
    once a window of dt_c = 16 x 0.9 x L / c_p(lining) (L = 0.243 m, the innermost lining hexahedra's
    volume / largest face), is stable while omega_v dt_c < 2 (an explicit
    spring with the window's step). Measured on the example slice with coupling.volume_law: water
    (docs/stability.md "Water stiffness"): K = 2.2 GPa (1.84) ran the whole record, 22 GPa (5.8) was
    stopped by the energy guard, 220 GPa diverged. With the volume law in the solid (the default) the
    stiffness is not exchanged: stable for any K."""
    import math

    from tunnelquake.scene import added_mass_diagnostic

    cp = math.sqrt(28e9 * 0.83 / (1.17 * 0.66 * 2500))
    dt_c = 16 * 0.9 * 0.25 * math.cos(math.pi / 48) * (4.5 + 4.75) / (2 * 4.75) / cp
    water = ("  scheme: implicit\n", "  scheme: implicit\n  volume_law: water\n")
    for k_gpa, stable in ((2.2, True), (22, False), (220, False)):
        am = added_mass_diagnostic(_case(write_case, w=water,
                                         k=("bulk_modulus: 2.2 GPa", f"bulk_modulus: {k_gpa} GPa")))
        assert am.ratios["volume stiffness"] == pytest.approx(math.sqrt(2 * k_gpa * 1e9 / (4.5 * 312.5)) * dt_c,
                                                              rel=1e-12)
        assert am.stable is stable, am.message
        if not stable:
            assert "volume_law: solid" in am.message
        solid = added_mass_diagnostic(_case(write_case, k=("bulk_modulus: 2.2 GPa", f"bulk_modulus: {k_gpa} GPa")))
        assert solid.stable and "volume stiffness" not in solid.ratios and "in the solid" in solid.message
    inc = added_mass_diagnostic(_case(write_case, m=("  model: compressible\n", "  model: incompressible\n")))
    assert inc.stable and "incompressible, any bulk modulus" in inc.message


def test_check_predicts_the_period_two_mode_of_ramped_windows(write_case):
    """Implicit windows of 16 steps with the ramped force (window force weight 0.5) let a mode of period
    two windows grow on a large exchanged added mass: measured on the example slice with the whole
    pressure exchanged (docs/stability.md "Water stiffness"), water of 1000 kg/m^3 (mode 1: 14.4 times the
    wet nodes' mass) ran, water as dense as the lining (36) stopped at 4.4 s. With the default weight 0.75
    the same densities ran (the volume law and translation in the solid)."""
    from tunnelquake.scene import PERIOD_TWO_RATIO, added_mass_diagnostic

    ramp = ("  scheme: implicit\n", "  scheme: implicit\n  volume_law: water\n  window_force_weight: 0.5\n")
    dense = ("  density: 1000 kg/m^3\n", "  density: 2500 kg/m^3\n")
    light = added_mass_diagnostic(_case(write_case, s=ramp))
    assert light.ratios["mode 1"] == pytest.approx(14.4) and light.ratios["mode 1"] < PERIOD_TWO_RATIO
    assert light.stable
    heavy = added_mass_diagnostic(_case(write_case, s=ramp, d=dense))
    assert heavy.ratios["mode 1"] == pytest.approx(36.0) and not heavy.stable
    assert "period two" in heavy.message and "window_force_weight: 0.75" in heavy.message
    assert added_mass_diagnostic(_case(write_case, d=dense)).stable  # defaults: weight 0.75, laws in the solid


def test_incompressible_water_with_open_ends_is_predicted_stable_with_its_volume_in_the_solid(write_case):
    """`tunnelquake check` predicts incompressible and compressible water, open or closed ends, stable
    in implicit windows of several steps when tq-solid carries the water's volume (the default): the
    paper case in 3D ran the whole record with each of the four (docs/stability.md "Open ends in 3D":
    open ends and incompressible water, OpenFOAM solving the remainder in compressible water: 1.77
    passes a window, E_c -0.58 J of 39.6 kJ; pimpleFoam solving it stopped at 8.46 s).
    Exchanging the whole pressure of incompressible water in windows of several steps is predicted
    unstable (docs/stability.md "The paper case in 3D with incompressible water"). A tunnel unlike the
    paper's: 5.0 m excavated radius, 0.6 m lining."""
    from tunnelquake.scene import added_mass_diagnostic

    other = dict(r=("  excavated_radius: 5.25 m\n", "  excavated_radius: 5.0 m\n"),
                 t=("  lining_thickness: 0.75 m\n", "  lining_thickness: 0.6 m\n"),
                 m=("  mode: slice ", "  mode: 3d "))
    incompressible = dict(other, w=("  model: compressible\n", "  model: incompressible\n"))
    closed = dict(e=("  ends: open\n", "  ends: closed\n"))
    for edits in (incompressible, dict(incompressible, **closed), other, dict(other, **closed)):
        am = added_mass_diagnostic(_case(write_case, **edits))
        assert am.stable and "in the solid" in am.message, am.message
    am = added_mass_diagnostic(_case(write_case, **incompressible, v=("  reuse: 16\n", "  reuse: 16\n  volume_law: water\n")))
    assert not am.stable and "water.model: compressible" in am.message, am.message
