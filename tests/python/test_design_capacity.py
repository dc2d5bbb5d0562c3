"""The capacity check of a lining section (EN 1992-1-1) against hand-computed sections.

Units in the comments: MPa, MN/m, MNm/m, m; the code works in SI. N > 0 compression, M > 0
compresses the top face (module docstring of tunnelquake.design.capacity).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from tunnelquake.design import capacity as cap

MPA = 1e6


# ------------------------------------------------------------------------------------------------
# Material values: EN 1992-1-1 Table 3.1 (printed to 2 significant digits: tolerance half a digit)
# ------------------------------------------------------------------------------------------------
def test_concrete_values_match_table_3_1():
    c30 = cap.Concrete(30 * MPA)
    assert c30.fctm_value / MPA == pytest.approx(2.9, abs=0.05)  # 0.30 * 30^(2/3) = 2.8965
    assert c30.fctk_005 / MPA == pytest.approx(2.0, abs=0.05)  # 0.7 * 2.8965 = 2.0276
    assert (c30.eps_c2, c30.eps_cu2, c30.n) == (2.0e-3, 3.5e-3, 2.0)
    c60 = cap.Concrete(60 * MPA)
    assert c60.fctm_value / MPA == pytest.approx(4.4, abs=0.05)  # 2.12 ln(1 + 68/10) = 4.354
    c70 = cap.Concrete(70 * MPA)
    assert c70.eps_c2 * 1e3 == pytest.approx(2.4, abs=0.05)  # 2.0 + 0.085 * 20^0.53 = 2.416
    assert c70.eps_cu2 * 1e3 == pytest.approx(2.7, abs=0.05)  # 2.6 + 35 * 0.2^4 = 2.656
    assert c70.n == pytest.approx(1.44, abs=0.005)  # 1.4 + 23.4 * 0.2^4 = 1.4374
    assert cap.Concrete(30 * MPA, fctm=1.27 * MPA).fctm_value == 1.27 * MPA  # a given value wins


# ------------------------------------------------------------------------------------------------
# Plain section at its cracking moment
# ------------------------------------------------------------------------------------------------
# b = 1 m, h = 0.5 m, C30/37: fctm = 0.30 * 30^(2/3) = 2.896468 MPa.
# A = 0.5 m², W = b h²/6 = 0.25/6 = 0.0416667 m³.
# N = 1 MN/m compression: N/A = 2 MPa.
# M_cr = W (fctm + N/A) = 0.0416667 * (2.896468 + 2) = 0.2040195 MNm/m.
# At 0.99 M_cr: σt = 0.99 * 4.896468 − 2 = 2.847503 MPa, u = 2.847503 / 2.896468 = 0.983095.
# At 1.01 M_cr: σt = 1.01 * 4.896468 − 2 = 2.945433 MPa, u = 1.016905.
H = 0.5
FCTM_C30 = 0.30 * 30 ** (2 / 3) * MPA


def test_plain_section_cracks_exactly_at_its_cracking_moment():
    N = 1.0e6
    M_cr = 0.25 / 6 * (FCTM_C30 + 2 * MPA)
    assert M_cr == pytest.approx(0.2040195e6, rel=1e-6)  # the hand value above
    assert float(cap.cracking_moment(N, H, FCTM_C30)) == pytest.approx(M_cr, rel=1e-14)
    at = cap.cracking_check(N, M_cr, H, FCTM_C30)
    assert float(at.utilisation) == pytest.approx(1.0, abs=1e-12)
    assert float(at.sigma_t) == pytest.approx(FCTM_C30, rel=1e-12)
    below = cap.cracking_check(N, 0.99 * M_cr, H, FCTM_C30)
    above = cap.cracking_check(N, 1.01 * M_cr, H, FCTM_C30)
    assert float(below.utilisation) == pytest.approx(0.983095, abs=2e-6) and not bool(below.cracked)
    assert float(above.utilisation) == pytest.approx(1.016905, abs=2e-6) and bool(above.cracked)
    # either face: a hogging moment of the same size is the same check
    assert float(cap.cracking_check(N, -M_cr, H, FCTM_C30).utilisation) == pytest.approx(1.0, abs=1e-12)


def test_cracking_under_axial_tension():
    # N = −0.5 MN/m (tension): N/A = −1 MPa; M_cr = W (2.896468 − 1) = 0.0790195 MNm/m.
    # Pure tension cracks when −N/A > fctm, i.e. |N| > 1.448234 MN/m.
    assert float(cap.cracking_moment(-0.5e6, H, FCTM_C30)) == pytest.approx(0.0790195e6, rel=1e-6)
    u = cap.cracking_check([-1.44e6, -1.46e6], 0.0, H, FCTM_C30)
    assert list(u.cracked) == [False, True]
    np.testing.assert_allclose(u.utilisation, [1.44 / 1.448234, 1.46 / 1.448234], rtol=1e-6)


def test_plain_concrete_uls_eq_12_2():
    # fcd,pl = 0.8 * 30 / 1.5 = 16 MPa. N = 2 MN/m, M = 0.2 MNm/m: e = 0.1 m,
    # N_Rd = 16 * 1 * 0.5 * (1 − 2 * 0.1 / 0.5) = 8 * 0.6 = 4.8 MN/m, u = 2 / 4.8 = 0.416667.
    r = cap.plain_resistance([2e6, 2e6, -1e5, 0.0], [0.2e6, 0.5e6, 0.0, 0.0], H, 16 * MPA)
    assert r.N_Rd[0] == pytest.approx(4.8e6, rel=1e-12)
    assert r.utilisation[0] == pytest.approx(2 / 4.8, rel=1e-12)
    assert r.utilisation[1] == math.inf  # e = 0.25 m = h/2: no resistance left
    assert r.utilisation[2] == math.inf  # plain concrete carries no net tension (§12)
    assert r.utilisation[3] == 0.0


# ------------------------------------------------------------------------------------------------
# Reinforced section: three points of its M–N diagram by hand
# ------------------------------------------------------------------------------------------------
# b = 1 m, h = 0.5 m, axis distance 0.05 m both faces (d = 0.45 m), As = 3000 mm²/m each face.
# C30/37, γc = 1.5, αcc = 1.0: fcd = 20 MPa; εc2 = 2.0 ‰, εcu2 = 3.5 ‰, n = 2.
# B500, γs = 1.15: fyd = 434.7826 MPa; Es = 200 GPa: εyd = 2.173913 ‰.
# As fyd = 0.003 * 434.7826 = 1.304348 MN/m.
#
# Parabola–rectangle block of depth x with εcu2 at the face (the parabola over xc = (εc2/εcu2) x
# = 4x/7 from the neutral axis):
#   force / (fcd b)       = ∫0^xc (1 − (1 − y/xc)²) dy + (x − xc) = x − xc/3 = (17/21) x
#   moment about the NA   = xc² (2/3 − 1/4) + (x² − xc²)/2 = x²/2 − xc²/12 = (139/294) x²
#   centroid from the face: β x, β = 1 − (139/294)/(17/21) = 99/238 = 0.415966
#
# 1) Pure compression, uniform εc2 = 2 ‰: steel σ = 200000 * 0.002 = 400 MPa < fyd.
#    N_Rd0 = 20 * 1 * 0.5 + 2 * 0.003 * 400 = 10 + 2.4 = 12.4 MN/m; M = 0 (symmetric).
# 2) Balanced: εcu2 at the top, εyd at the bottom steel:
#    x_b = εcu2 / (εcu2 + εyd) d = 3.5 / 5.673913 * 0.45 = 0.2775862 m;
#    top steel ε = 3.5 ‰ * (0.2775862 − 0.05) / 0.2775862 = 2.869565 ‰ > εyd: σ = +fyd.
#    Fc = (17/21) * 20 * 0.2775862 = 4.494253 MN/m; the two steels cancel: N_b = 4.494253 MN/m.
#    M_b = Fc (h/2 − β x_b) + 2 As fyd (h/2 − 0.05)
#        = 4.494253 * (0.25 − 0.415966 * 0.2775862) + 2 * 1.304348 * 0.2
#        = 4.494253 * 0.1345335 + 0.5217391 = 0.6046274 + 0.5217391 = 1.126367 MNm/m.
# 3) Pure bending (N = 0): bottom steel yields, top steel elastic, σs2 = 700 (x − 0.05)/x MPa:
#    (17/21) * 20 x + 0.003 * 700 (x − 0.05)/x − 1.304348 = 0
#    → 16.190476 x² + (2.1 − 1.304348) x − 0.105 = 0 → 16.190476 x² + 0.795652 x − 0.105 = 0
#    → x = (−0.795652 + √(0.633062 + 6.8)) / 32.380952 = (−0.795652 + 2.726364) / 32.380952
#        = 0.0596249 m (> 0.05: the top steel is compressed, 113.0 MPa < fyd, as assumed;
#          bottom steel ε = 3.5 ‰ * (0.45 − 0.0596249) / 0.0596249 = 22.9 ‰ > εyd, as assumed).
#    Fc = 16.190476 * 0.0596249 = 0.965356 MN/m, lever to mid-depth 0.25 − 0.415966 * 0.0596249 = 0.225198;
#    M_Rd = Fc (0.25 − β x) + As σs2 * 0.2 + As fyd * 0.2
#         = 0.965356 * 0.225198 + 0.003 * 112.997 * 0.2 + 0.2608696
#         = 0.2173963 + 0.0677984 + 0.2608696 = 0.546064 MNm/m.
FCD = 20 * MPA
FYD = 500 * MPA / 1.15
AS = 3.0e-3
BETA = 99 / 238


@pytest.fixture
def section():
    return cap.RCSection(h=0.5, concrete=cap.Concrete(30 * MPA), steel=cap.Reinforcement(fyk=500 * MPA, Es=200e9),
                         As_top=AS, As_bottom=AS, d_top=0.05, d_bottom=0.05)


def test_pure_compression_by_hand(section):
    N0, M0 = section.pure_compression()
    assert N0 == pytest.approx(12.4e6, rel=1e-12)
    assert M0 == pytest.approx(0.0, abs=1e-6)
    Nd, _ = section.diagram(721)
    assert Nd.max() == pytest.approx(12.4e6, rel=1e-12)  # the diagram's top is N_Rd0
    assert Nd.min() == pytest.approx(-2 * AS * FYD, rel=1e-9)  # and its bottom both steels at fyd


def test_balanced_point_by_hand(section):
    x = 3.5 / (3.5 + FYD / 200e9 * 1e3) * 0.45
    assert x == pytest.approx(0.2775862, rel=1e-6)
    Fc = 17 / 21 * FCD * x
    Mb = Fc * (0.25 - BETA * x) + 2 * AS * FYD * 0.2
    assert (Fc, Mb) == (pytest.approx(4.494253e6, rel=1e-6), pytest.approx(1.126367e6, rel=1e-6))
    N, M = section.balanced_point()
    assert N == pytest.approx(Fc, rel=1e-12)
    assert M == pytest.approx(Mb, rel=1e-12)
    assert float(section.utilisation_radial(N, M)) == pytest.approx(1.0, abs=1e-9)  # on the curve


def test_pure_bending_by_hand(section):
    a, b, c = 17 / 21 * FCD, AS * 200e9 * 3.5e-3 - AS * FYD, -AS * 200e9 * 3.5e-3 * 0.05
    x = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert x == pytest.approx(0.0596249, rel=1e-6)
    sigma_s2 = 200e9 * 3.5e-3 * (x - 0.05) / x
    assert 0 < sigma_s2 < FYD  # the regime assumed by hand
    M_Rd = a * x * (0.25 - BETA * x) + AS * sigma_s2 * 0.2 + AS * FYD * 0.2
    assert M_Rd == pytest.approx(0.546064e6, rel=1e-6)
    M_plus, M_minus = section.moment_resistance(0.0)
    assert float(M_plus) == pytest.approx(M_Rd, rel=1e-9)
    assert float(M_minus) == pytest.approx(-M_Rd, rel=1e-9)  # symmetric steel
    assert float(section.utilisation_radial(0.0, M_Rd)) == pytest.approx(1.0, abs=1e-9)


def test_pure_bending_rectangular_block_by_hand():
    # λ = 0.8, η = 1: Fc = 0.8 * 20 * x = 16 x MN/m at 0.4 x from the top; otherwise as above:
    # 16 x² + 0.795652 x − 0.105 = 0 → x = (−0.795652 + √(0.633062 + 6.72)) / 32 = 0.0598750 m;
    # M = 16 x (0.25 − 0.4 x) + As σs2 * 0.2 + As fyd * 0.2 = 0.546695 MNm/m.
    sec = cap.RCSection(0.5, cap.Concrete(30 * MPA), cap.Reinforcement(), As_top=AS, As_bottom=AS,
                        stress_block="rectangular")
    a, b, c = 0.8 * FCD, AS * 700e6 - AS * FYD, -AS * 700e6 * 0.05
    x = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert x == pytest.approx(0.0598750, rel=1e-6)
    M = a * x * (0.25 - 0.4 * x) + AS * 700e6 * (x - 0.05) / x * 0.2 + AS * FYD * 0.2
    assert M == pytest.approx(0.546695e6, rel=1e-6)
    assert float(sec.moment_resistance(0.0)[0]) == pytest.approx(M, rel=1e-9)
    assert sec.pure_compression()[0] == pytest.approx(12.4e6, rel=1e-12)  # η fcd b h + 2 As 400 MPa


def test_a_section_in_tension_with_a_small_eccentricity_by_hand():
    """A lining in hoop tension with a little bending (the pressure tunnel's demand): both bars at
    f_yd and a thin parabola-rectangle block on the compressed face, nothing else (EN 1992-1-1
    §6.1(2): the concrete's tensile strength ignored). A section unlike the examples': h 0.35 m,
    C40/50 (f_cd 26.667 MPa), ø20 @ 150 mm inner (2094 mm²/m, the bottom), ø12 @ 150 mm outer (754
    mm²/m, the top), both at 45 mm; demand N = −900 kN/m (tension), M = +100 kNm/m (inner face
    stretched: the top compressed).
    By hand, the block x deep (k = 17/21 f_cd = 21.587302 MN/m², its centroid β x = 99/238 x from the
    top), the bars' tension T = (2094 + 754) mm² × 434.7826 MPa = 1.238261 MN/m and their moment
    about mid-depth M_s = 434.7826 × (2094 − 754) × 1e-6 × 0.13 = 0.0757391 MNm/m:
      N_R = k x − T, M_R = k x (h/2 − β x) + M_s, on the demand's ray M_R N = M N_R:
      −N k β x² + (N k h/2 − M k) x + (N M_s + M T) = 0
      → 8.081633 x² − 5.558730 x + 0.055661 = 0 (MN, m) → x = 0.0101634 m,
    inside the range where the top bar still yields in tension (x ≤ 45 mm × 3.5/(3.5 + 2.173913)
    = 27.76 mm); N_R = −1.018860 MN/m, M_R = 0.1132067 MNm/m; u = N/N_R = 0.883340. The bars alone
    (no block) would give N/T = 0.727 at M = 0 and cannot carry this M with both at f_yd."""
    sec = cap.RCSection(0.35, cap.Concrete(40 * MPA), cap.Reinforcement(), As_top=754e-6, As_bottom=2094e-6,
                        d_top=0.045, d_bottom=0.045)
    k, beta, fyd = 17 / 21 * 40 * MPA / 1.5, 99 / 238, 500 * MPA / 1.15
    T, Ms = (2094e-6 + 754e-6) * fyd, fyd * (2094e-6 - 754e-6) * (0.175 - 0.045)
    assert (T, Ms) == (pytest.approx(1.238261e6, rel=1e-6), pytest.approx(0.0757391e6, rel=1e-6))
    N, M = -0.9e6, 0.1e6
    a, b, c = -N * k * beta, N * k * 0.175 - M * k, N * Ms + M * T
    x = (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert x == pytest.approx(0.0101634, rel=1e-5)
    assert 0 < x < 0.045 * 3.5e-3 / (3.5e-3 + fyd / 200e9)  # the regime assumed by hand
    NR, MR = k * x - T, k * x * (0.175 - beta * x) + Ms
    assert (NR, MR) == (pytest.approx(-1.018860e6, rel=1e-6), pytest.approx(0.1132067e6, rel=1e-6))
    assert N / NR == pytest.approx(0.883340, rel=1e-6)
    assert float(sec.utilisation_radial(N, M)) == pytest.approx(N / NR, rel=1e-9)
    assert float(sec.utilisation_radial(NR, MR)) == pytest.approx(1.0, abs=1e-9)  # the point is on the curve


def test_utilisation_radial_and_at_constant_N(section):
    Nb, Mb = section.balanced_point()
    # radial: a point halfway to the curve along its ray is used at 0.5 (by definition, but through
    # the search along the curve); the same ray scaled by 1.3 is at 1.3
    np.testing.assert_allclose(section.utilisation_radial([Nb / 2, 1.3 * Nb], [Mb / 2, 1.3 * Mb]), [0.5, 1.3],
                               rtol=1e-9)
    # at constant N: M over M_Rd(N) at the same N
    assert float(section.utilisation_constant_N(Nb, 0.5 * Mb)) == pytest.approx(0.5, rel=1e-9)
    assert float(section.utilisation_constant_N(Nb, -0.25 * Mb)) == pytest.approx(0.25, rel=1e-9)
    assert float(section.utilisation_constant_N(13e6, 0.0)) == math.inf  # beyond N_Rd0
    # a pure-bending pair: the two measures coincide (the ray is the line N = 0)
    M_Rd = float(section.moment_resistance(0.0)[0])
    assert float(section.utilisation_radial(0.0, 0.7 * M_Rd)) == pytest.approx(0.7, rel=1e-9)
    assert float(section.utilisation_constant_N(0.0, 0.7 * M_Rd)) == pytest.approx(0.7, rel=1e-9)


def test_unsymmetric_steel_and_strain_limit_points_lie_on_the_curve():
    # every sampled point of the curve has utilisation 1 by both measures (the curve is closed and
    # star-shaped about the origin); a steel strain limit shrinks the tension side only
    sec = cap.RCSection(0.5, cap.Concrete(30 * MPA), cap.Reinforcement(eps_ud=0.0225), As_top=3e-3, As_bottom=1e-3,
                        d_top=0.06, d_bottom=0.04)
    N, M = sec.diagram(181)
    np.testing.assert_allclose(sec.utilisation_radial(N[1:-1], M[1:-1]), 1.0, rtol=1e-9)
    np.testing.assert_allclose(sec.utilisation_constant_N(N[1:-1], M[1:-1]), 1.0, rtol=1e-8)
    Nt, _ = sec.pure_tension()
    assert Nt == pytest.approx(-(3e-3 + 1e-3) * FYD, rel=1e-9)  # uniform −εud: both steels at fyd


# ------------------------------------------------------------------------------------------------
# The case's design block
# ------------------------------------------------------------------------------------------------
def test_design_block_keys_units_and_errors():
    p = cap.DesignParameters.from_mapping({
        "code": "EN1992-1-1", "gamma_c": 1.5, "gamma_s": 1.15, "concrete": {"fck": "30 MPa"},
        "reinforcement": {"fyk": "500 MPa", "Es": "200 GPa", "As_inner": "3000 mm^2/m", "As_outer": "3000 mm^2/m",
                          "axis_distance": "50 mm"}})
    assert p.reinforced and p.As_inner == pytest.approx(3e-3) and p.axis_distance == pytest.approx(0.05)
    out = p.check(0.0, 0.3e6, 0.5)
    M_Rd = 0.546064e6  # the hand value above (same section)
    assert float(out["reinforced"]) == pytest.approx(0.3e6 / M_Rd, rel=1e-5)
    assert float(out["cracking"].utilisation) == pytest.approx(0.3 / (0.25 / 6) / 2.896468, rel=1e-6)
    plain = cap.DesignParameters.from_mapping({"concrete": {"fck": 30e6}, "cracking_strength": "fctk_005"})
    assert not plain.reinforced and "reinforced" not in plain.check(1e6, 1e5, 0.5)
    assert plain.fct(0.5) == pytest.approx(0.7 * FCTM_C30)
    for bad, key in (({"concrete": {"fck": "30 MPa", "fcm": 38e6}}, "design.concrete.fcm"),
                     ({"concrete": {"fck": "30 m"}}, "design.concrete.fck"),
                     ({"concrete": {"fck": 30e6}, "gamma": 1.5}, "design.gamma"),
                     ({"concrete": {"fck": 30e6}, "stress_block": "bilinear"}, "design.stress_block"),
                     ({"gamma_c": 1.5}, "design.concrete")):
        with pytest.raises(ValueError, match=key.replace(".", r"\.")):
            cap.DesignParameters.from_mapping(bad)
