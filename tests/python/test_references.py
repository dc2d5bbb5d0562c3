"""The closed-form references themselves, checked against their published numbers and limits."""
from __future__ import annotations

import numpy as np
import pytest

from tunnelquake import references as ref


def test_ring_ovaling_example_from_verification_md():
    # VERIFICATION.md: E 30 GPa, nu 0.2, rho 2500, h 0.3 m, R 3 m: 14.53 Hz empty, 9.01 Hz water-filled
    args = dict(n=2, E=30e9, nu=0.2, rho_s=2500.0, h=0.3, R=3.0)
    assert ref.ring_ovaling_frequency(**args) == pytest.approx(14.53, abs=0.01)
    assert ref.ring_ovaling_frequency(**args, rho_f=1000.0) == pytest.approx(9.01, abs=0.01)
    # ratio 1/sqrt(1 + 2 rho_f R / (5 rho_s h)) for n = 2
    ratio = ref.ring_ovaling_frequency(**args, rho_f=1000.0) / ref.ring_ovaling_frequency(**args)
    assert ratio == pytest.approx(1 / np.sqrt(1 + 2 * 1000 * 3 / (5 * 2500 * 0.3)), rel=1e-12)


def test_ring_deflection_coefficient():
    # 0.149 in VERIFICATION.md is pi/4 - 2/pi = 0.14878
    d = ref.ring_diametral_deflection(P=1.0, R=1.0, E=12.0, nu=0.0, h=1.0)
    assert d == pytest.approx(0.149, abs=5e-4)


def test_kirsch_wall_and_far_field():
    p, k, a = 10e6, 0.5, 5.25
    th = np.linspace(0, np.pi, 13)
    srr, stt, srt = ref.kirsch(p, k, a, a, th)
    np.testing.assert_allclose(srr, 0, atol=1e-6 * p)  # traction-free wall
    np.testing.assert_allclose(srt, 0, atol=1e-6 * p)
    np.testing.assert_allclose(stt, ref.kirsch_wall_hoop(p, k, th), rtol=1e-12)
    assert ref.kirsch_wall_hoop(p, k, 0.0) == pytest.approx(p * (3 - k))  # sidewall
    assert ref.kirsch_wall_hoop(p, k, np.pi / 2) == pytest.approx(p * (3 * k - 1))  # crown
    srr, stt, _ = ref.kirsch(p, k, a, 1e6 * a, 0.0)  # far away on the horizontal: sigma_rr = k p
    assert srr == pytest.approx(k * p, rel=1e-9) and stt == pytest.approx(p, rel=1e-9)


def test_lined_tunnel_reduces_to_lame_without_rock():
    a, b, p = 4.5, 5.25, 1.2e6
    r = ref.lined_tunnel_internal_pressure(p, a, b, E_l=28e9, nu_l=0.17, E_m=1e-9, nu_m=0.27)
    s_rr, s_tt = ref.lame_thick_cylinder(p, 0.0, a, b, np.array([a, b]))
    assert r["contact_pressure"] == pytest.approx(0.0, abs=1e-9 * p)
    assert r["hoop_inner"] == pytest.approx(s_tt[0], rel=1e-9)
    assert r["hoop_outer"] == pytest.approx(s_tt[1], rel=1e-9)
    assert s_rr[0] == pytest.approx(-p) and s_rr[1] == pytest.approx(0.0, abs=1e-6)


def test_lined_tunnel_rigid_rock_takes_the_pressure():
    # rock far stiffer than the lining: the contact pressure tends to p_i and the lining barely strains
    r = ref.lined_tunnel_internal_pressure(1.0, 4.5, 5.25, E_l=28e9, nu_l=0.17, E_m=28e15, nu_m=0.27)
    assert r["contact_pressure"] == pytest.approx(2 * (1 - 0.17) * 4.5**2 / ((1 - 2 * 0.17) * 5.25**2 + 4.5**2),
                                                  rel=1e-4)


def test_transfer_function_limits():
    f = np.linspace(0.1, 20, 400)
    # matched impedance, no damping: the layer is part of a half-space, surface = outcrop
    F = ref.layer_transfer_function(f, H=100, cs=500, xi=0.0, rho_s=2000, rho_r=2000, cr=500)
    np.testing.assert_allclose(np.abs(F), 1.0, rtol=1e-12)
    # stiffer rock: undamped first resonance at cs/4H with amplitude 1/alpha
    F = ref.layer_transfer_function(np.array([500 / 400]), H=100, cs=500, xi=0.0, rho_s=2000, rho_r=2500, cr=1500)
    assert abs(F[0]) == pytest.approx(1 / (2000 * 500 / (2500 * 1500)), rel=1e-9)


def test_free_field_surface_doubles_incident():
    H, c = 50.0, 500.0
    t = np.linspace(0, 1, 1001)

    def u0(tt):
        return np.exp(-(((tt - 0.2) / 0.02) ** 2))

    np.testing.assert_allclose(ref.free_field_1d(u0, H, t, H, c), 2 * u0(t - H / c), rtol=1e-12)


def test_rayleigh_gives_the_ratio_at_both_frequencies():
    a, b = ref.rayleigh_coefficients(0.05, 1.5, 10.0)
    for f in (1.5, 10.0):
        w = 2 * np.pi * f
        assert a / (2 * w) + b * w / 2 == pytest.approx(0.05, rel=1e-12)


@pytest.mark.parametrize("vp_vs", [1.7, 2.5])
def test_free_surface_reflection_of_p_conserves_energy(vp_vs):
    # energy flux normal to the surface: PP^2 + PS^2 (beta cos j) / (alpha cos i) = 1 (Aki & Richards 5.2.4)
    alpha, beta = 1000.0 * vp_vs, 1000.0
    for angle in (0.0, 10.0, 35.0, 60.0, 85.0):
        pp, ps = ref.free_surface_reflection_p(alpha, beta, angle)
        ci = np.cos(np.radians(angle))
        cj = np.sqrt(1 - (np.sin(np.radians(angle)) * beta / alpha) ** 2)
        assert pp**2 + ps**2 * beta * cj / (alpha * ci) == pytest.approx(1.0, rel=1e-12)
    assert ref.free_surface_reflection_p(alpha, beta, 0.0) == pytest.approx((-1.0, 0.0))
    assert ref.free_surface_p(alpha, beta, 0.0) == pytest.approx((0.0, 2.0))
    assert ref.free_surface_sv(alpha, beta, 0.0) == pytest.approx((2.0, 0.0))
