"""The designer's summary (design/lining.py) on stored ring forces: the extremes and their places
and times, the capacity utilisations against hand values, the convex-hull shortcut of the
reinforced check against every pair, and the design block's errors naming the key."""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from tunnelquake.design import lining
from tunnelquake.design.capacity import Concrete, DesignParameters, Reinforcement, cracking_check

H, R_IN = 0.5, 3.0  # lining thickness and inner radius, m


def _results(path, N, M, V, dD, t, free_body=None):
    """A results.h5 holding one ring with the given histories [T, S] (and diameters [T, D]); with
    `free_body` ({"N": ..., "M": ..., "V": ...}) also its free-body forces (float64, as tq-solid writes them)."""
    S, D = N.shape[1], dD.shape[1]
    with h5py.File(path, "w") as f:
        g = f.create_group("ring_forces/0")
        for k, v in dict(y_min=0.0, y_max=1.0, centre_x=0.0, centre_z=0.0, r_inner=R_IN, r_outer=R_IN + H,
                         r_mid=R_IN + H / 2, closed=1).items():
            g.attrs[k] = v
        g["angle"] = np.linspace(0, 2 * np.pi, S, endpoint=False)
        g["diameter_angle"] = np.linspace(0, np.pi, D, endpoint=False)
        g["time"] = t[:, None]
        for name, a in (("N", N), ("M", M), ("V", V), ("diameter_change", dD)):
            g[name] = a.astype(np.float32)
        for name, a in (free_body or {}).items():
            g[f"free_body/{name}"] = a
    return path


def _histories(T=200, S=16, D=8, seed=3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2, T)
    th = np.linspace(0, 2 * np.pi, S, endpoint=False)
    N = -2e6 + 4e5 * np.sin(4 * t)[:, None] * np.cos(2 * th)[None, :] + 1e4 * rng.standard_normal((T, S))
    M = 1.2e5 * np.sin(4 * t)[:, None] * np.sin(2 * th)[None, :] + 1e3 * rng.standard_normal((T, S))
    V = 5e4 * np.cos(4 * t)[:, None] * np.cos(2 * th)[None, :]
    dD = 1e-3 * np.sin(4 * t)[:, None] * np.cos(2 * np.linspace(0, np.pi, D, endpoint=False))[None, :]
    return t, N, M, V, dD


def test_extremes_and_cracking_utilisation_are_found_where_and_when_they_occur(tmp_path):
    t, N, M, V, dD = _histories()
    path = _results(tmp_path / "r.h5", N, M, V, dD, t)
    p = DesignParameters(concrete=Concrete(fck=30e6, fctm=2.9e6))
    c = lining.condition_design(path, "no_water", {}, p)
    N32, M32 = N.astype(np.float32).astype(float), M.astype(np.float32).astype(float)
    i, j = np.unravel_index(np.argmax(M32), M32.shape)
    hi, lo = c.extremes["M"]
    assert hi.value == pytest.approx(M32[i, j]) and hi.time == pytest.approx(t[i]) and hi.angle == pytest.approx(float(lining.crown_angle(np.radians(j * 22.5))))
    assert lo.value == pytest.approx(M32.min())
    assert c.increments["N"] == pytest.approx(np.max(np.abs(N32 - N32[0])))
    # cracking: sigma_t = 6|M|/h^2 - N_c/h with N_c = -N (compression positive), by hand at the worst pair
    sig = 6 * np.abs(M32) / H**2 - (-N32) / H
    k = np.unravel_index(np.argmax(sig), sig.shape)
    assert c.utilisation["cracking"].value == pytest.approx(sig[k] / 2.9e6, rel=1e-9)
    assert c.utilisation["cracking"].time == pytest.approx(t[k[0]])
    assert cracking_check(-N32[k], M32[k], H, 2.9e6).utilisation == pytest.approx(sig[k] / 2.9e6)


def test_the_reinforced_check_on_the_hull_equals_the_check_of_every_pair(tmp_path):
    """The radial utilisation is the gauge of the convex M-N domain, convex in (N, M): its largest
    value over a history is at a vertex of the pairs' convex hull."""
    t, N, M, V, dD = _histories(T=120, S=12)
    path = _results(tmp_path / "r.h5", N, 6 * M, V, dD, t)
    p = DesignParameters(concrete=Concrete(fck=30e6), reinforcement=Reinforcement(), As_inner=2e-3,
                         As_outer=2e-3, axis_distance=0.05)
    c = lining.condition_design(path, "no_water", {}, p)
    Nc = -N.astype(np.float32).astype(float)
    Mc = (6 * M).astype(np.float32).astype(float)
    every = p.section(H).utilisation_radial(Nc.ravel(), Mc.ravel())
    assert c.utilisation["reinforced M–N (radial)"].value == pytest.approx(float(np.max(every)), rel=1e-9)


def test_the_design_block_errors_name_the_key(tmp_path):
    from conftest import EXAMPLE
    from tunnelquake.case import CaseError, load_case

    text = EXAMPLE.read_text().replace("file: ../../../shared", f"file: {EXAMPLE.parents[3] / 'shared'}")
    for block, key, words in (
            ("design:\n  gamma_c: 1.5\n", "design.concrete.fck", "is required with a design block"),
            ("design:\n  concrete: {fck: 200 MPa}\n", "design", "covers 0 < fck <= 90 MPa"),
            ("design:\n  concrete: {fck: 30 MPa}\n  utilisation: sideways\n", "design.utilisation", "use one of")):
        (tmp_path / "case.yaml").write_text(text.replace("\nstages:", f"\n{block}\nstages:", 1))
        with pytest.raises(CaseError) as e:
            load_case(tmp_path / "case.yaml")
        assert key in str(e.value) and words in str(e.value), str(e.value)
    (tmp_path / "case.yaml").write_text(text.replace(
        "\nstages:", "\ndesign:\n  concrete: {fck: 30 MPa}\n  reinforcement: {As_inner: 1500 mm2/m, As_outer: 1500 mm2/m}\n"
        "\nstages:", 1))
    case = load_case(tmp_path / "case.yaml")
    p, said = lining.design_parameters(case)
    assert p.reinforced and p.concrete.fck == 30e6 and said == "the case's design block"


def test_without_a_design_block_the_linings_own_strengths_are_used():
    class Case:
        data = {"materials": {"lining": {"compressive_strength": 25e6, "tensile_strength": 1.8e6}}, "design": {}}

    p, said = lining.design_parameters(Case())
    assert p.concrete.fck == 25e6 and p.concrete.fctm_value == 1.8e6 and not p.reinforced
    assert "compressive strength 25 MPa as fck" in said and "tensile strength 1.8 MPa as fctm" in said
    assert math.isclose(p.gamma_c, 1.5)


def test_the_difference_between_design_and_free_body_forces_is_reported_from_the_file(tmp_path):
    """The free-body forces are read back as written (float64); the largest |design - free-body| of
    N, M, V over the sections and samples equals the hand value from the file's data, and the report
    gives N and V as % of max|N| and M in kN m/m and % of max|M|. A file without them: free_body
    None, no such sentence."""
    from tunnelquake.ring_forces import read_ring_forces

    t, N, M, V, dD = _histories()
    rng = np.random.default_rng(5)
    fb = {"N": N + 3e3 * rng.standard_normal(N.shape), "M": 0.9 * M, "V": V - 2e3 * np.cos(t)[:, None]}
    path = _results(tmp_path / "r.h5", N, M, V, dD, t, free_body=fb)
    (ring,) = read_ring_forces(path)
    for q, a in fb.items():
        np.testing.assert_array_equal(getattr(ring.free_body, q), a)
    p = DesignParameters(concrete=Concrete(fck=30e6, fctm=2.9e6))
    c = lining.condition_design(path, "no_water", {}, p)
    design = {q: a.astype(np.float32).astype(float) for q, a in (("N", N), ("M", M), ("V", V))}
    d = {q: float(np.max(np.abs(design[q] - a))) for q, a in fb.items()}
    nmax, mmax = np.max(np.abs(design["N"])), np.max(np.abs(design["M"]))
    for q in ("N", "M", "V"):
        assert c.free_body_difference[q] == pytest.approx(d[q], rel=1e-12)
    (line,) = [x for x in lining.LiningDesign([c], p, "test").report_lines() if x.startswith("Equilibrium:")]
    assert f"{100 * d['N'] / nmax:.2g} % (N) and {100 * d['V'] / nmax:.2g} % (V) of max|N|" in line, line
    assert f"{d['M'] / 1e3:.3g} kN m/m in M ({100 * d['M'] / mmax:.2g} % of max|M|)" in line, line
    assert "docs/theory.md §7" in line

    path = _results(tmp_path / "old.h5", N, M, V, dD, t)
    assert read_ring_forces(path)[0].free_body is None
    c = lining.condition_design(path, "no_water", {}, p)
    assert not any(x.startswith("Equilibrium:") for x in lining.LiningDesign([c], p, "test").report_lines())


def test_the_interface_note_counts_broken_bonds_and_warns_of_the_step_sensitivity_only_then(monkeypatch):
    """interface_note on a last snapshot with 3 of 8 bonds broken: the count and time, and the warning
    that peaks after pairs let go depend on the step (docs/solid_solver.md "Subcycling": a step 1 %
    shorter moved such peaks by 20-42 %); with none broken, the count alone."""
    from types import SimpleNamespace

    from tunnelquake import post as P

    failed = {"value": np.array([0, 1, 1, 0, 0, 1, 0, 0])}
    monkeypatch.setattr(P, "read_snapshot", lambda res, t: {"time": 2.5, "interface": {"failed": failed["value"]}})
    res = SimpleNamespace(interface=object(), snapshots=[(0, 2.5)])
    note = lining.interface_note(res)
    assert note.startswith("rock–lining interface: the bond of 3 of 8 pairs broken by t = 2.500 s")
    assert "a step 1 % shorter can move them by tens of per cent" in note
    failed["value"] = np.zeros(8)
    assert lining.interface_note(res) == "rock–lining interface: the bond of 0 of 8 pairs broken by t = 2.500 s"
