"""The design checks beyond the capacity: a case without strengths still gets its report, the crack
width of EN 1992-1-1 §7.3.4 against hand calculations, hydraulic jacking against Kirsch's field
with an internal pressure, and the seismic design situation's combination of the static state and
the seismic increment."""
from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from case_texts import record_motion, small_slice
from test_design_lining import H, _histories, _results

from tunnelquake import references as ref
from tunnelquake.design import lining
from tunnelquake.design.capacity import Concrete, DesignParameters, Reinforcement
from tunnelquake.design.cracking import CrackSection
from tunnelquake.design.jacking import jacking


def _stub_case(tmp_path, lining_material: dict, design: dict | None = None, head: float = 0.0):
    data = {"materials": {"lining": dict(lining_material, youngs_modulus=33e9, poisson_ratio=0.2),
                          "rock": {"youngs_modulus": 20e9, "poisson_ratio": 0.25, "density": 2650.0}},
            "design": design or {}, "output": {"monitors": {}}, "water": {"head": head},
            "geometry": {"excavated_radius": 3.5}}
    return SimpleNamespace(data=data, output_dir=tmp_path)


# ------------------------------------------------------------------------------------------------
# A case the checks cannot be made for
# ------------------------------------------------------------------------------------------------
def test_an_elastic_lining_without_strengths_gets_its_forces_and_one_line_why(tmp_path):
    """The usual first analysis: an elastic lining with no compressive strength and no design block.
    The design summary has the forces and the static state, and says in one line that the capacity
    checks are skipped and why, instead of raising (which made `post` fail a completed run)."""
    t, N, M, V, dD = _histories()
    path = _results(tmp_path / "results_no_water.h5", N, M, V, dD, t)
    case = _stub_case(tmp_path, {"model": "elastic"})
    design = lining.lining_design(case, [SimpleNamespace(path=path, condition="no_water")])
    assert design is not None and design.params is None
    (c,) = design.conditions
    assert c.utilisation == {} and len(c.skipped) == 1
    assert c.skipped[0].startswith("capacity checks skipped: no design block and no "
                                   "materials.lining.compressive_strength")
    text = "\n".join(design.summary_lines() + design.report_lines())
    assert "capacity checks skipped" in text and "fails" not in text and "passes" not in text
    N32 = N.astype(np.float32).astype(float)
    assert c.static["N"][1].value == pytest.approx(N32[0].min(), rel=1e-12)  # N0 at the seismic start


# ------------------------------------------------------------------------------------------------
# Crack width, EN 1992-1-1 §7.3.4
# ------------------------------------------------------------------------------------------------
#: a 0.5 m C30/37 section with 12 mm bars at 100 mm on both faces, 56 mm to their axes
SEC = dict(h=0.5, As_top=1.131e-3, As_bottom=1.131e-3, a_top=0.056, a_bottom=0.056, phi=0.012, Ec=33e9, Es=200e9,
           fct_eff=2.9e6)


def test_crack_width_in_bending_is_the_hand_calculation():
    """M = 150 kN m/m, N = 0, long-term (k_t 0.4). By hand: α_e = 200/33; the cracked neutral axis
    from b x²/2 + α_e A_s' (x − d') = α_e A_s (d − x); I_cr; σ_s = α_e M (d − x) / I_cr;
    h_c,eff = min(2.5 (h − d), (h − x)/3, h/2); ρ = A_s / h_c,eff; (7.9), (7.11) with k1 0.8, k2 0.5,
    k3 3.4, k4 0.425, c = 56 − 6 = 50 mm; spacing 100 mm <= 5 (c + φ/2) = 280 mm."""
    h, As, a, phi, Es, Ec, fct = 0.5, 1.131e-3, 0.056, 0.012, 200e9, 33e9, 2.9e6
    d, dp, M = h - a, a, 150e3
    ae = Es / Ec
    # x^2/2 + 2 ae As x - ae As (d + d') = 0
    x = -2 * ae * As + math.sqrt((2 * ae * As) ** 2 + 2 * ae * As * (d + dp))
    Icr = x**3 / 3 + ae * As * (x - dp) ** 2 + ae * As * (d - x) ** 2
    sigma_s = ae * M * (d - x) / Icr
    hc = min(2.5 * (h - d), (h - x) / 3, h / 2)
    rho = As / hc
    eps = max((sigma_s - 0.4 * fct / rho * (1 + ae * rho)) / Es, 0.6 * sigma_s / Es)
    sr = 3.4 * (a - phi / 2) + 0.8 * 0.5 * 0.425 * phi / rho
    w_hand = sr * eps
    out = CrackSection(**SEC).crack_width(0.0, M, 0.4)
    assert float(out["x_bottom"]) == pytest.approx(x, rel=1e-9)
    assert float(out["sigma_s_bottom"]) == pytest.approx(sigma_s, rel=1e-9)
    assert float(out["w_bottom"]) == pytest.approx(w_hand, rel=1e-9)
    assert float(out["w_top"]) == 0.0  # the outer face's bars are compressed
    assert 0.3e-3 < w_hand < 0.5e-3  # the hand value itself: 0.40 mm


def test_crack_width_in_pure_tension_is_the_hand_calculation():
    """N = −1000 kN/m (tension), M = 0, short-term (k_t 0.6), an early-age f_ct,eff = 1.5 MPa
    (§7.3.2(2)), so that N / A = 2 MPa cracks the section: both faces' bars stretch alike,
    σ_s = N / (2 A_s); no compression zone: h_c,eff = min(2.5 a, h/2), k2 = 1 (7.13 with ε1 = ε2).
    Below f_ct,eff (N = −700 kN/m: 1.4 MPa) the section is uncracked: no width."""
    h, As, a, phi, Es, Ec, fct = 0.5, 1.131e-3, 0.056, 0.012, 200e9, 33e9, 1.5e6
    sigma_s = 1000e3 / (2 * As)
    hc = min(2.5 * a, h / 2)
    rho = As / hc
    ae = Es / Ec
    eps = max((sigma_s - 0.6 * fct / rho * (1 + ae * rho)) / Es, 0.6 * sigma_s / Es)
    w_hand = (3.4 * (a - phi / 2) + 0.8 * 1.0 * 0.425 * phi / rho) * eps
    sec = CrackSection(**dict(SEC, fct_eff=fct))
    out = sec.crack_width(-1000e3, 0.0, 0.6)
    for face in ("bottom", "top"):
        assert float(out[f"sigma_s_{face}"]) == pytest.approx(sigma_s, rel=1e-9)
        assert float(out[f"w_{face}"]) == pytest.approx(w_hand, rel=1e-9)
    assert float(sec.crack_width(-700e3, 0.0, 0.6)["w_bottom"]) == 0.0


def test_an_uncracked_section_has_no_crack_width():
    """N = 2 MN/m compression with M = 100 kN m/m: |M|/W − N/A = 2.4 − 4 < 0 < f_ct: no crack."""
    out = CrackSection(**SEC).crack_width(2e6, 100e3, 0.6)
    assert float(out["w_bottom"]) == 0.0 and float(out["w_top"]) == 0.0


# ------------------------------------------------------------------------------------------------
# Hydraulic jacking against Kirsch's field
# ------------------------------------------------------------------------------------------------
def _kirsch_cloud(p, k, a, p_i, radii, angles, zc=0.0):
    """Points around the hole (x, y, z; θ from +x towards +z) and their stresses [E, 6] in
    tq-solid's order and sign (tension positive): Kirsch's polar stresses turned to x-z, the axial
    stress a large compression (2p) so that the in-plane stresses govern."""
    R, T = np.meshgrid(radii, angles, indexing="ij")
    R, T = R.ravel(), T.ravel()
    srr, stt, srt = ref.kirsch_pressurised(p, k, a, p_i, R, T)
    c, s = np.cos(T), np.sin(T)
    sxx = srr * c * c + stt * s * s - 2 * srt * s * c
    szz = srr * s * s + stt * c * c + 2 * srt * s * c
    sxz = (srr - stt) * s * c + srt * (c * c - s * s)
    stress = -np.c_[sxx, np.full_like(R, 2 * p), szz, np.zeros_like(R), np.zeros_like(R), sxz]
    return np.c_[R * c, np.zeros_like(R), zc + R * s], stress, (R, T, srr, stt, srt)


@pytest.mark.parametrize("k, p_i", [(0.5, 3e6), (0.6, 6e6), (1.4, 4e6)])
def test_jacking_ratio_is_kirschs(k, p_i):
    """An unlined opening of radius 3 m under a far-field σv = 10 MPa, σh = k σv, and an internal
    pressure p_i: the normal stress on a radial plane is Kirsch's hoop stress with Lamé's term,
    σθθ(r, θ) (references.kirsch_pressurised; the axial stress, 2 σv here, is larger). The checker
    on the field sampled on 20 rings out to 2a and every 5° finds the smallest σθθ / p_i of the
    closed form over the annulus a ≤ r ≤ 2a (on a grid 10x finer) within 1 %, where the closed form
    has it. For k < 1 that is the wall at the crown and invert, (p(3k − 1) − p_i) / p_i; for k = 1.4
    the springline at r = 2a (the hoop stress falls from p(3 − k) − p_i at the wall towards σv).
    The uniform p_i is the checker's ρ_w g (head − Δz) with a head of 1e9 m (Δz/head ≤ 6e-9)."""
    p, a, head, g = 10e6, 3.0, 1e9, 9.81
    radii, angles = np.linspace(a, 2 * a, 20), np.radians(np.arange(0.0, 360.0, 5.0))
    xyz, stress, _ = _kirsch_cloud(p, k, a, p_i, radii, angles)
    j = jacking(xyz, stress, (0.0, 0.0), a, 1.5 * a, head, p_i / (g * head), g)
    R, T = np.meshgrid(np.linspace(a, 2 * a, 200), np.radians(np.arange(0.0, 360.0, 0.5)), indexing="ij")
    _, stt, _ = ref.kirsch_pressurised(p, k, a, p_i, R, T)
    m = int(np.argmin(stt))
    assert j.ratio == pytest.approx(float(stt.ravel()[m] / p_i), rel=1e-2)
    assert j.distance == pytest.approx(float(R.ravel()[m]) - a, abs=0.02 * a)
    assert j.elements == radii.size * angles.size
    if k < 1:  # the wall at the crown or invert, the closed form at the wall
        assert j.ratio == pytest.approx((p * (3 * k - 1) - p_i) / p_i, rel=1e-7)
        assert float(ref.kirsch_jacking_ratio_at_wall(p, k, p_i, np.pi / 2)) == pytest.approx(j.ratio, rel=1e-7)
        assert min(abs(j.angle), abs(abs(j.angle) - 180.0)) < 1e-6 and j.distance < 1e-9
    else:  # a springline, at the reach's end
        assert abs(abs(j.angle) - 90.0) < 1e-6


def test_jacking_off_the_wall_is_the_polar_closed_form_at_every_point():
    """Away from the wall (first ring at 1.05 a) the checker's smallest ratio equals the closed
    form's hoop stress σθθ (the normal stress on a radial plane; the axial 2p is larger) over p_i,
    smallest over the same points: the turn to x-z and back to the hoop direction to round-off."""
    p, k, a, p_i, head, g = 10e6, 0.5, 3.0, 3e6, 1e9, 9.81
    xyz, stress, (R, T, srr, stt, srt) = _kirsch_cloud(p, k, a, p_i, np.linspace(1.05 * a, 2 * a, 12),
                                                     np.radians(np.arange(2.5, 360.0, 5.0)))
    j = jacking(xyz, stress, (0.0, 0.0), a, a, head, p_i / (g * head), g)
    assert j.ratio == pytest.approx(float(stt.min() / p_i), rel=1e-7)
    assert j.distance == pytest.approx(0.05 * a, rel=1e-9)


# ------------------------------------------------------------------------------------------------
# The seismic design situation
# ------------------------------------------------------------------------------------------------
def test_the_seismic_situation_combines_the_static_parts_and_the_increment_with_the_case_factors(tmp_path):
    """E_d = γ_G E_G + ψ2 E_W + γ_I (E − E0): G the no-water condition's state at the seismic
    start, W the wet condition's static state less it. With γ_G 1.35, ψ2 0.8, γ_I 1.2 on stored
    histories, the design extremes are the hand formula's, at the same section and time; with all
    factors 1 the design forces are the run's."""
    t, N, M, V, dD = _histories()
    dry_N = N - 5e5  # the no-water condition: 500 kN/m less compression... its own static state
    dry = _results(tmp_path / "dry.h5", dry_N, 0.5 * M, V, dD, t)
    wet = _results(tmp_path / "wet.h5", N, M, V, dD, t)
    params = DesignParameters(concrete=Concrete(fck=30e6), reinforcement=Reinforcement(), As_inner=1.131e-3,
                              As_outer=1.131e-3, axis_distance=0.056)
    comb = lining.Combination(gamma_G=1.35, psi2_water=0.8, gamma_I=1.2)
    G = lining.static_state(dry, {})
    c = lining.condition_design(wet, "static_water", {}, params, comb, G)
    f32 = {q: a.astype(np.float32).astype(float) for q, a in (("N", N), ("M", M), ("dN", dry_N), ("dM", 0.5 * M))}
    for q, d in (("N", "dN"), ("M", "dM")):
        E, E0, EG = f32[q], f32[q][0], f32[d][0]
        hand = 1.35 * EG + 0.8 * (E0 - EG) + 1.2 * (E - E0)
        hi, lo = c.combined[q]
        assert hi.value == pytest.approx(hand.max(), rel=1e-9) and lo.value == pytest.approx(hand.min(), rel=1e-9)
        i, j = np.unravel_index(np.argmax(hand), hand.shape)
        assert hi.time == pytest.approx(t[i]) and hi.angle == pytest.approx(float(lining.crown_angle(j * np.pi / 8)))
    assert "G from the no-water condition" in c.split
    words = comb.words()
    assert "γ_G 1.35" in words and "design.seismic_situation" in words
    plain = lining.condition_design(wet, "static_water", {}, params, lining.Combination(), G)
    assert plain.combined["N"][0].value == pytest.approx(f32["N"].max(), rel=1e-12)


def test_angles_are_from_the_crown_towards_plus_x():
    """tq-solid's sections from +x towards +z become the monitors' convention: crown 0°, +x 90°,
    invert 180°, −x −90°."""
    got = lining.crown_angle(np.radians([90.0, 0.0, -90.0, 180.0, 135.0]))
    np.testing.assert_allclose(got, [0.0, 90.0, 180.0, -90.0, -45.0], atol=1e-12)


def test_the_pressure_tunnel_case_asks_for_every_check():
    """The example unlike the paper's states bars, crack limit and the combination's factors."""
    from conftest import ROOT
    from tunnelquake.case import load_case

    case = load_case(Path(ROOT) / "cases" / "pressure_tunnel" / "case.yaml")
    p, _ = lining.design_parameters(case)
    assert p.reinforced and p.As_inner == pytest.approx(1.131e-3)
    cs = lining.crack_settings(case)
    assert cs.bar_diameter == pytest.approx(0.012) and cs.limit == pytest.approx(0.05e-3)
    assert lining.Combination.from_case(case.data) == lining.Combination(1.0, 1.0, 1.0)
    assert H == 0.5


# ------------------------------------------------------------------------------------------------
# The usual first analysis, run and posted
# ------------------------------------------------------------------------------------------------
FIRST = small_slice("first_analysis") + """water: {head: 40 m}
""" + record_motion("record.txt", units="g", pga="0.2 g", vertical_ratio=0, duration="1.0 s") + """time: {end_time: 0.1 s}
conditions: [static_water]
output:
  monitors:
    crown: [0.0, 0.5, 2.8]
"""


def test_a_first_analysis_without_strengths_runs_to_its_report(tmp_path, capsys):
    """An elastic lining with no strengths and no design block, run through `tunnelquake run`: the
    run exits 0 with its report, whose design summary comes first, says once why the capacity
    checks are skipped, and still gives the static N0 and the hydraulic jacking from the snapshots
    (the static one at the seismic start). About 12 s."""
    from tunnelquake.cli import main

    t = np.arange(0.0, 1.0 + 1e-9, 0.01)
    a = 0.2 * np.sin(2 * np.pi * 3 * t) * np.exp(-(((t - 0.4) / 0.2) ** 2))
    (tmp_path / "record.txt").write_text("# time (s)  acceleration (g)\n"
                                         + "".join(f"{x:.3f} {y:.6e}\n" for x, y in zip(t, a, strict=True)))
    (tmp_path / "case.yaml").write_text(FIRST)
    assert main(["run", str(tmp_path / "case.yaml")]) == 0
    out = capsys.readouterr().out
    assert out.count("capacity checks skipped") == 1, out
    report = (tmp_path / "results" / "report.md").read_text()
    assert report.index("## Design summary") < report.index("## Input motion")
    summary = report[report.index("## Design summary"):report.index("## Input motion")]
    assert summary.count("capacity checks skipped") == 1 and "fails" not in summary
    assert "Static state at the seismic start (tension positive): N₀" in summary
    assert "| hydraulic jacking, static: σ_min / p_w |" in summary
    assert "| hydraulic jacking, seismic: σ_min / p_w |" in summary


def test_plain_concrete_without_resistance_names_the_force_that_takes_it(tmp_path):
    """A plain lining whose thrust is compressive everywhere but at one section and sample, where it
    carries 0.2 kN/m of tension: §12.6.1 leaves no resistance there, and the row says so with the
    force, the place and the time, not a bare 'no resistance'."""
    t, N, M, V, dD = _histories()
    N = np.full_like(N, -1e6)
    N[37, 5] = 200.0  # 0.2 kN/m tension
    M = np.zeros_like(M)
    path = _results(tmp_path / "r.h5", N, M, V, dD, t)
    p = DesignParameters(concrete=Concrete(fck=30e6, fctm=2.9e6))
    c = lining.condition_design(path, "no_water", {}, p)
    e = c.utilisation["plain concrete (EN 1992-1-1 §12.6.1)"]
    assert math.isinf(e.value) and e.where == "N = +0.2 kN/m (tension +)"
    assert e.time == pytest.approx(t[37]) and e.angle == pytest.approx(float(lining.crown_angle(5 * np.pi / 8)))
    (row,) = [x for x in lining.LiningDesign([c], p, "test").report_lines() if x.startswith("| plain concrete")]
    assert "no resistance left: N = +0.2 kN/m (tension +)" in row and "**fails**" in row


def test_envelopes_and_demand_points_of_the_figures_are_the_design_forces(tmp_path):
    """What the figures draw: per section the largest and smallest design force over the run and
    the static state (the first sample), and the demand pairs (N compression +, M) on the hull of
    every pair (the reinforced utilisation's largest value is among them); both figures are drawn."""
    from tunnelquake.design import figures as F

    t, N, M, V, dD = _histories()
    path = _results(tmp_path / "r.h5", N, M, V, dD, t)
    p = DesignParameters(concrete=Concrete(fck=30e6), reinforcement=Reinforcement(), As_inner=1.131e-3,
                         As_outer=1.131e-3, axis_distance=0.056)
    c = lining.condition_design(path, "no_water", {}, p)
    f32 = {q: a.astype(np.float32).astype(float) for q, a in (("N", N), ("M", M), ("V", V))}
    for q in ("N", "M", "V"):
        np.testing.assert_array_equal(c.envelope[q][0], f32[q].max(axis=0))
        np.testing.assert_array_equal(c.envelope[q][1], f32[q].min(axis=0))
        np.testing.assert_array_equal(c.static_forces[q], f32[q][0])
    sec = p.section(H)
    every = sec.utilisation_radial(-f32["N"].ravel(), f32["M"].ravel())
    assert float(np.max(sec.utilisation_radial(*c.demand))) == pytest.approx(float(every.max()), rel=1e-9)
    assert F.fig_envelopes([c], tmp_path / "env.png").stat().st_size > 20_000
    assert F.fig_mn([c], sec, tmp_path / "mn.png").stat().st_size > 20_000
    assert F.ring_scale([np.array([-2.0, 1.0])], 3.0) == pytest.approx(0.45 * 3.0 / 2.0)


def test_the_deformed_lining_is_drawn_at_the_governing_time_at_the_scale_its_title_states(tmp_path, monkeypatch):
    """fig_deformed: at the sample nearest the governing time each diameter's change Δd is drawn
    half at each of its ends, radially off the mid-line R, at one scale k = 0.15 R / max|Δd/2|
    that the title states; the angle from the crown towards +x (x = r sin φ, z = r cos φ)."""
    from tunnelquake.design import figures as F

    R, phi, times = 3.25, np.array([0.0, 45.0, 90.0, 135.0]), np.array([0.0, 1.0, 2.0])
    dd = np.array([[0.0, 0.0, 0.0, 0.0], [2e-3, -1e-3, -2e-3, 0.5e-3], [4e-3, 0.0, -4e-3, 0.0]])
    cond = SimpleNamespace(condition="no_water", radius=R, diameter=(phi, times, dd), governing_time=lambda: 1.1)
    drawn = {}
    monkeypatch.setattr(F, "_save", lambda fig, out: drawn.setdefault("fig", fig))
    assert F.fig_deformed([cond], tmp_path / "deformed.png") == tmp_path / "deformed.png"
    ax = drawn["fig"].axes[0]
    k = 0.15 * R / 1e-3  # the sample at t = 1 s, nearest 1.1 s: largest |Δd/2| 1 mm
    assert f"displacements × {k:.3g}" in ax.get_title()
    x, z = ax.lines[1].get_data()
    r, th = np.hypot(x, z), np.degrees(np.arctan2(x, z))
    for p, d in zip(phi, dd[1], strict=True):
        for end in (p, p + 180.0):
            j = int(np.argmin(np.abs((th - end + 180.0) % 360.0 - 180.0)))
            assert r[j] == pytest.approx(R + k * d / 2, rel=1e-12), (p, end)


def test_a_failing_ultimate_check_beside_an_uncracked_section_is_explained(tmp_path):
    """A lining in hoop tension of 1,000 kN/m: above what ø16 @ 200 mm on both faces carry at f_yd
    (2 × 1005 mm²/m × 500/1.15 MPa = 874 kN/m: the reinforced M–N check fails) and below the plain
    section's cracking force f_ctm t (2.9 MPa × 0.5 m = 1,450 kN/m: uncracked). The summary keeps
    both rows and says in one line why they are no contradiction; a demand the bars carry gets no
    such line."""
    t, N, M, V, dD = _histories()
    p = DesignParameters(concrete=Concrete(fck=30e6, fctm=2.9e6), reinforcement=Reinforcement(), As_inner=1.005e-3,
                         As_outer=1.005e-3)
    for n, fails in ((1.0e6, True), (0.6e6, False)):
        path = _results(tmp_path / f"r{n:g}.h5", np.full_like(N, n), np.zeros_like(M), V, dD, t)
        c = lining.condition_design(path, "static_water", {}, p)
        mn, cr = c.utilisation["reinforced M–N (radial)"], c.utilisation["cracking"]
        assert (mn.value > 1) == fails and cr.value < 1
        text = "\n".join(lining.LiningDesign([c], p, "test").summary_lines())
        assert ("two limit states, not a contradiction" in text) == fails, text


def test_a_section_cracked_in_the_analysis_is_reported_cracked_with_its_cracked_sections_width(tmp_path, monkeypatch):
    """A reinforced_concrete lining whose concrete the analysis has cracked while its N stays below
    f_ctm t (the bars carry it: 1,000 kN/m of hoop tension, 0.69 of 2.9 MPa × 0.5 m): the cracking row
    reports the analysis' crack (its largest damage, how many sections, from which snapshot), no line
    calls the cracked section uncracked, and the short-term crack width at the cracked sections, from the
    first sample at or after the snapshot that shows them cracked, is §7.3.4's for a section in pure
    tension (σ_s = N / 2A_s at both faces, h_c,eff = min(2.5 a, h/2), k2 = 1), by hand to 1e-9; the
    long-term width of the static state, before the crack, is 0. With the bars in the check only the
    same forces give 'uncracked' and no width (the forces alone)."""
    t, N, M, V, dD = _histories()
    S = N.shape[1]
    n, As, a, phi, Es, Ec, fct, kt = 1.0e6, 1.005e-3, 0.05, 0.016, 200e9, 33e9, 2.9e6, 0.6
    p = DesignParameters(concrete=Concrete(fck=30e6, fctm=fct), reinforcement=Reinforcement(), As_inner=As,
                         As_outer=As, axis_distance=a)
    path = _results(tmp_path / "r.h5", np.full_like(N, n), np.zeros_like(M), V, dD, t)
    D = np.zeros((2, S))
    D[1, 3:6] = [0.4, 0.6, 0.5]  # sections 3-5 cracked at the snapshot at 1 s
    monkeypatch.setattr(lining, "analysis_cracks", lambda path, condition, ring: (np.array([0.0, 1.0]), D))
    crack = lining.CrackSettings(phi, Ec, 0.3e-3)
    c = lining.condition_design(path, "static_water", {}, p, crack=crack, bars_in_analysis=True)
    text = "\n".join(lining.LiningDesign([c], p, "test").summary_lines())
    row = next(x for x in text.splitlines() if x.startswith("| cracking |"))
    assert "cracked in the analysis (damage up to 0.6" in row and "3 of 16 sections, from t = 1.000 s" in row, row
    assert "uncracked" not in row and "two limit states" not in text, text
    sigma_s, hc = n / (2 * As), min(2.5 * a, H / 2)
    rho = As / hc
    eps = max((sigma_s - kt * fct / rho * (1 + Es / Ec * rho)) / Es, 0.6 * sigma_s / Es)
    w = (3.4 * (a - phi / 2) + 0.8 * 1.0 * 0.425 * phi / rho) * eps
    seismic, static = c.crack["seismic situation (k_t 0.6, short-term)"], c.crack["static (k_t 0.4, long-term)"]
    assert seismic.value == pytest.approx(w, rel=1e-9)
    assert seismic.time == float(t[np.searchsorted(t, 1.0)])
    assert static.value == 0.0
    plain = lining.condition_design(path, "static_water", {}, p, crack=crack)
    assert plain.analysis_crack is None and plain.crack["seismic situation (k_t 0.6, short-term)"].value == 0.0
    assert "| cracking | 0.69 |" in "\n".join(lining.LiningDesign([plain], p, "test").summary_lines())


def test_the_analysis_crack_pattern_is_read_per_section_from_the_snapshots(tmp_path):
    """analysis_cracks: the lining elements' damage at each field snapshot, the largest per section
    of the ring (the element nearest each section's angle, the sections' angles from +x towards +z
    about the ring's centre); cracked_at: a section counts as cracked from the first snapshot that
    shows its crack. A ring of 16 elements around, damage at the element 11.25° from the crown
    towards +x only, growing from the snapshot at 1 s: the section there, and no other, from 2 s."""
    from test_post import _write_results

    a0 = math.radians(11.25)
    path = _write_results(tmp_path / "results_no_water.h5", t_end=3.0, snaps=(1.0, 2.0, 3.0),
                          damage_of=lambda a, r, ts: np.where(np.abs(a - a0) < 1e-6, 0.2 * (ts - 1.0), 0.0))
    ring = SimpleNamespace(centre=(0.0, 0.0), angle=math.pi / 2 - np.radians(11.25 + 22.5 * np.arange(16)))
    times, D = lining.analysis_cracks(path, "no_water", ring)
    np.testing.assert_array_equal(times, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(D[:, 0], [0.0, 0.2, 0.4], rtol=1e-12)
    assert not D[:, 1:].any()
    cracked = lining.cracked_at((times, D), np.array([0.5, 1.5, 2.0, 2.5]))
    np.testing.assert_array_equal(cracked[:, 0], [False, False, True, True])
    assert not cracked[:, 1:].any()
