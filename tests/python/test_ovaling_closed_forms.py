"""The closed-form ovaling methods (Wang 1993, Penzien 2000) against exact elasticity.

No published worked example was at hand, so each formula is checked where it is exact:
- Wang's full slip is the exact solution of an inextensible thin ring with a smooth interface in an
  elastic plane under far-field pure shear (Einstein & Schwartz 1979), for any flexibility F: the
  ground's side is solved here with Kolosov–Muskhelishvili potentials and the ring with its own
  equilibrium and bending, independently of the module's formulas;
- rigid lining (F → 0): the rigid circular inclusion, smooth and bonded;
- no lining (F → ∞): the unlined hole, ΔD/D = 2(1 − ν) γ;
- Penzien's full slip equals Wang's (Hashash, Park & Yao 2005 state it; here it is an identity).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from tunnelquake.design import ovaling as ov


# ------------------------------------------------------------------------------------------------
# Exact plane elasticity outside a circle r = a under far-field pure shear (plane strain).
# Far field σxx = τ, σyy = −τ (a shear τ on planes at 45°, engineering strain γ = τ/G):
#   φ(z) = β a²/z,  ψ(z) = −τ z + δ a⁴/z³  (n = 2 terms; β, δ real by symmetry)
#   σrr + σθθ = 4 Re φ',  σθθ − σrr + 2i σrθ = 2 e^{2iθ} (z̄ φ'' + ψ'),
#   2G (u_r + i u_θ) = e^{−iθ} (κ φ − z conj(φ') − conj(ψ)),  κ = 3 − 4ν.
# On r = a these give σrr = 2(τ − β) cos 2θ, σrθ = −(τ + 2β − 3δ) sin 2θ,
#   2G u_r = a [(κ + 1) β + τ − δ] cos 2θ,  2G u_θ = a [−κβ − τ + β − δ] sin 2θ.
# ------------------------------------------------------------------------------------------------
def km_on_circle(beta, delta, tau, G, nu, a, theta):
    """(σrr, σrθ, u_r, u_θ) at r = a from the potentials above, evaluated numerically."""
    kappa = 3 - 4 * nu
    z = a * np.exp(1j * theta)
    phi = beta * a**2 / z
    dphi = -beta * a**2 / z**2
    ddphi = 2 * beta * a**2 / z**3
    psi = -tau * z + delta * a**4 / z**3
    dpsi = -tau - 3 * delta * a**4 / z**4
    s_sum = 4 * np.real(dphi)
    s_dif = 2 * np.exp(2j * theta) * (np.conj(z) * ddphi + dpsi)
    srr = (s_sum - np.real(s_dif)) / 2
    srt = np.imag(s_dif) / 2
    u = np.exp(-1j * theta) * (kappa * phi - z * np.conj(dphi) - np.conj(psi)) / (2 * G)
    return srr, srt, np.real(u), np.imag(u)


def ring_thrust_amplitude(q_r0, q_t0, r):
    """Thin ring, n = 2 loads q_r = q_r0 cos 2θ (outward), q_θ = q_t0 sin 2θ: equilibrium
    N' + V + q_θ r = 0 and V' − N + q_r r = 0 with N = N0 cos 2θ, V = V0 sin 2θ give
    V0 = 2 N0 − q_t0 r and N0 = r (2 q_t0 − q_r0) / 3."""
    return r * (2 * q_t0 - q_r0) / 3


THETA = np.linspace(0.0, np.pi, 7)
G_M, NU_CASES = 1.0e9, (0.0, 0.2, 0.3, 0.45)


def ground(nu):
    return 2 * G_M * (1 + nu), nu  # E_m, ν_m


@pytest.mark.parametrize("nu", NU_CASES)
def test_wang_full_slip_is_the_exact_thin_ring_with_a_smooth_interface(nu):
    # Inextensible thin ring, radial load q0 cos 2θ: w = q0 r⁴ / (9 EI') (the ring's n = 2 bending,
    # EI' = E_l I / (1 − ν_l²)). The ground with σrθ = 0 and σrr = q0 cos 2θ on r = a:
    # β = τ − q0/2, δ = (2β + τ)/3 (checked below); u_r(ground) = w fixes q0, linearly.
    E_m, nu_m = ground(nu)
    a, t, nu_l, gamma = 3.25, 0.5, 0.2, 1e-3
    tau = G_M * gamma
    for E_l in (30e9, 3e9, 0.3e9):  # F from about 0.2 to 20
        EI = E_l * t**3 / 12 / (1 - nu_l**2)

        def mismatch(q0, EI=EI):
            beta = tau - q0 / 2
            delta = (2 * beta + tau) / 3
            srr, srt, ur, _ = km_on_circle(beta, delta, tau, G_M, nu, a, THETA)
            np.testing.assert_allclose(srt, 0, atol=1e-9 * tau)  # smooth interface
            np.testing.assert_allclose(srr, q0 * np.cos(2 * THETA), atol=1e-9 * tau)
            return ur[0] - q0 * a**4 / (9 * EI)

        m0, m1 = mismatch(0.0), mismatch(tau)
        q0 = -m0 * tau / (m1 - m0)  # the mismatch is affine in q0
        T_exact = abs(ring_thrust_amplitude(q0, 0.0, a))
        w_exact = q0 * a**4 / (9 * EI)
        w = ov.wang_full_slip(gamma, E_m, nu_m, E_l, nu_l, t, a)
        assert w.thrust == pytest.approx(T_exact, rel=1e-12)
        assert w.moment == pytest.approx(a * T_exact, rel=1e-12)  # M0 = r V0 / 2 = r N0 (q_θ = 0)
        assert w.diameter_change == pytest.approx(2 * w_exact, rel=1e-12)


@pytest.mark.parametrize("nu", NU_CASES)
def test_rigid_lining_is_the_rigid_inclusion(nu):
    E_m, nu_m = ground(nu)
    a, gamma = 3.0, 1e-3
    tau = G_M * gamma
    kappa = 3 - 4 * nu
    # smooth rigid inclusion: u_r = 0 and σrθ = 0 → β = −2τ/(3κ + 1), δ = (2β + τ)/3
    beta = -2 * tau / (3 * kappa + 1)
    srr, srt, ur, _ = km_on_circle(beta, (2 * beta + tau) / 3, tau, G_M, nu, a, THETA)
    np.testing.assert_allclose(ur, 0, atol=1e-12 * a * gamma)
    np.testing.assert_allclose(srt, 0, atol=1e-9 * tau)
    T_smooth = abs(ring_thrust_amplitude(srr[0], 0.0, a))
    stiff = ov.wang_full_slip(gamma, E_m, nu_m, 1e24, 0.2, 0.5, a)  # F ≈ 1e-12
    assert stiff.thrust == pytest.approx(T_smooth, rel=1e-9)
    assert ov.penzien(gamma, E_m, nu_m, 1e24, 0.2, 0.5, a, slip="full").thrust == pytest.approx(T_smooth, rel=1e-9)
    assert stiff.diameter_change == pytest.approx(0.0, abs=1e-9 * a * gamma)
    # bonded rigid inclusion: u = 0 → β = δ = −τ/κ; σrr = τ(1 + 1/κ) cos 2θ, σrθ = −τ(1 + 1/κ) sin 2θ
    b_ = -tau / kappa
    srr, srt, ur, ut = km_on_circle(b_, b_, tau, G_M, nu, a, THETA)
    np.testing.assert_allclose(np.hypot(ur, ut), 0, atol=1e-12 * a * gamma)
    np.testing.assert_allclose(srr, tau * (1 + 1 / kappa) * np.cos(2 * THETA), atol=1e-9 * tau)
    T_bonded = abs(ring_thrust_amplitude(srr[0], -tau * (1 + 1 / kappa), a))
    assert T_bonded == pytest.approx(tau * a * (1 + 1 / kappa), rel=1e-12)
    # Wang's no-slip K2 at F = C = 0 (a lining rigid in bending and in compression) is the bonded
    # rigid inclusion's 1 + 1/κ exactly: 1 + 2/(6 − 8ν)
    K2_exact = 1 + 1 / kappa
    assert ov.wang_k2(0.0, 0.0, nu) == pytest.approx(K2_exact, rel=1e-12)
    assert ov.wang_k2(0.0, 0.0, 0.5) == pytest.approx(2.0, rel=1e-15)  # κ = 1


@pytest.mark.parametrize("nu", NU_CASES)
def test_no_lining_is_the_unlined_hole(nu):
    # traction-free hole: σrr = σrθ = 0 → β = δ = τ; u_r = a (κ + 1) τ cos 2θ / (2G),
    # ΔD/D = (κ + 1) γ / 2 = 2 (1 − ν) γ
    E_m, nu_m = ground(nu)
    a, gamma = 3.0, 1e-3
    tau = G_M * gamma
    srr, srt, ur, _ = km_on_circle(tau, tau, tau, G_M, nu, a, THETA)
    np.testing.assert_allclose(np.hypot(srr, srt), 0, atol=1e-9 * tau)
    dD_over_D = 2 * ur[0] / (2 * a)
    assert dD_over_D == pytest.approx(2 * (1 - nu) * gamma, rel=1e-12)
    assert ov.free_field_diameter_change(gamma, 2 * a, nu, perforated=True) == pytest.approx(2 * ur[0], rel=1e-12)
    soft = dict(E_m=E_m, nu_m=nu_m, E_l=E_m * 1e-12, nu_l=0.2, t=0.3, r=a)  # F ≈ 1e13
    for o in (ov.wang_full_slip(gamma, **soft), ov.penzien(gamma, **soft, slip="full"),
              ov.penzien(gamma, **soft, slip="none")):
        assert o.diameter_change / (2 * a) == pytest.approx(dD_over_D, rel=1e-9), o.method
        assert o.thrust < 1e-9 * tau * a and o.moment < 1e-9 * tau * a * a, o.method
    assert ov.wang_no_slip(gamma, **soft).thrust < 1e-9 * tau * a  # K2 → 0 with the lining's stiffness


@pytest.mark.parametrize("nu", NU_CASES)
def test_penzien_full_slip_equals_wang_full_slip(nu):
    # α = 12 EI'(5 − 6ν)/(d³ G) = (5 − 6ν)/(2F) with F = G r³/(3 EI'), so R = 4(1 − ν)/(α + 1)
    # = (2/3) K1 F and Δ = R γ d/2 = (K1 F γ/3) d; T = 12 EI' Δ/d³ = K1 G r γ/3 = Wang's T.
    E_m, nu_m = ground(nu)
    for E_l in (300e9, 30e9, 3e9, 0.3e9):
        args = (1e-3, E_m, nu_m, E_l, 0.2, 0.4, 3.5)
        w, p = ov.wang_full_slip(*args), ov.penzien(*args, slip="full")
        for k in ("thrust", "moment", "shear", "diameter_change"):
            assert getattr(p, k) == pytest.approx(getattr(w, k), rel=1e-12), k
        F = ov.flexibility_ratio(*args[1:])
        assert p.ratio == pytest.approx(2 / 3 * w.ratio * F, rel=1e-12)


def test_penzien_no_slip_and_its_known_thrust_deficit():
    # Penzien's no slip: Tⁿ = 24 EI' Δⁿ/d³ = 2 Mⁿ/r = Vⁿ; bonding restrains the ring (Rⁿ < R for ν < 0.5,
    # αⁿ/α = 2(3 − 4ν)/(5 − 6ν) > 1). Its thrust ignores the interface shear and is far below Wang's
    # no-slip thrust K2 τ r: "an order of magnitude" (Hashash, Park & Yao 2005) for flexible linings.
    args = (1e-3, 2e9, 0.3, 30e9, 0.2, 0.5, 3.25)  # F = 27.0, C = 0.80
    assert ov.flexibility_ratio(*args[1:]) == pytest.approx(27.04, rel=1e-12)
    assert ov.compressibility_ratio(*args[1:]) == pytest.approx(0.80, rel=1e-12)
    pn, pf, wn = ov.penzien(*args, slip="none"), ov.penzien(*args, slip="full"), ov.wang_no_slip(*args)
    assert pn.thrust == pytest.approx(2 * pn.moment / 3.25, rel=1e-12) == pn.shear
    assert pn.ratio < pf.ratio
    assert pn.thrust / wn.thrust < 0.15  # 0.092 here
    # Wang no slip at F = 27.04, C = 0.8, ν = 0.3: K2 = 1 + (27.04 * (0.4 − 0.32) − 0.5 * 0.16 * 0.8 + 2)
    # / (27.04 * (2.4 + 0.32) + 0.8 * (2.5 − 2.4 + 0.54) + 6 − 2.4) = 1 + 4.0992 / 77.6608 = 1.052783
    assert wn.ratio == pytest.approx(1 + 4.0992 / 77.6608, rel=1e-12)


def test_distribution_around_the_ring():
    # n = 2 pattern: thrust and moment peak at 45° to the springline, the shear at the springline
    # and crown, and V = −(1/r) dM/dθ (the ring's moment equilibrium, sign of Penzien's V).
    o = ov.penzien(1e-3, 2e9, 0.3, 30e9, 0.2, 0.5, 3.25, slip="none")
    T, M, V = o.around_ring(np.array([-math.pi / 4, 0.0, math.pi / 4]))
    assert abs(T[0]) == pytest.approx(o.thrust) and abs(M[0]) == pytest.approx(o.moment)
    assert abs(V[1]) == pytest.approx(o.shear) and abs(T[1]) < 1e-9 * o.thrust
    th = np.linspace(0, 2 * np.pi, 37)
    h = 1e-6
    dM = (o.around_ring(th + h)[1] - o.around_ring(th - h)[1]) / (2 * h)
    np.testing.assert_allclose(o.around_ring(th)[2], -dM / 3.25, atol=1e-6 * o.shear)


def test_free_field_inputs():
    # γ_max = V_s/C_s (Wang 1993): 0.3 m/s in ground with C_s = 600 m/s → 5e-4;
    # non-perforated ΔD = γ D/2 = 5e-4 * 7 / 2 = 1.75 mm.
    g = ov.free_field_shear_strain(0.3, 600.0)
    assert g == pytest.approx(5e-4)
    assert ov.free_field_diameter_change(g, 7.0, 0.3) == pytest.approx(1.75e-3)
    with pytest.raises(ValueError, match="nu_m"):
        ov.wang_full_slip(1e-3, 1e9, 0.5, 30e9, 0.2, 0.5, 3.0)
