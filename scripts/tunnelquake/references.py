"""Closed-form references used by the verification cases and the benchmarks.

Each function states its source. Sign conventions are given per function; SI units throughout.
The formulas follow ../shared/design/VERIFICATION.md.
"""
from __future__ import annotations

import math

import numpy as np


# ------------------------------------------------------------------------------------------------
# Waves in a uniform half-space (vertical incidence) and a layer on rock
# ------------------------------------------------------------------------------------------------
def free_field_1d(u0, z: float, t: np.ndarray, H: float, c: float) -> np.ndarray:
    """Displacement at height z above the base of a uniform layer of thickness H with a free top,
    for an incident (up-going) displacement u0(t) at the base and no reflection back down:
    u(z, t) = u0(t − z/c) + u0(t − (2H − z)/c)  (d'Alembert; VERIFICATION.md)."""
    return u0(t - z / c) + u0(t - (2 * H - z) / c)


def layer_transfer_function(f: np.ndarray, H: float, cs: float, xi: float, rho_s: float,
                            rho_r: float, cr: float) -> np.ndarray:
    """Surface / outcrop amplitude ratio of a damped layer on elastic rock (Kramer 1996, §7.2):
    F2(ω) = 1 / [cos(k* H) + i α* sin(k* H)], k* = ω / cs*, cs* = cs (1 + i ξ),
    α* = ρs cs* / (ρr cr)."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    cs_star = cs * (1 + 1j * xi)
    k = w / cs_star
    alpha = rho_s * cs_star / (rho_r * cr)
    return 1.0 / (np.cos(k * H) + 1j * alpha * np.sin(k * H))


def rayleigh_coefficients(xi: float, f1: float, f2: float) -> tuple[float, float]:
    """Mass and stiffness factors (α, β) giving damping ratio ξ at f1 and f2 (Hz)."""
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    return 2 * xi * w1 * w2 / (w1 + w2), 2 * xi / (w1 + w2)


def stable_step(L_min: float, cp: float, xi_max: float = 0.0) -> float:
    """Δt ≤ (2/ω_max)(√(1+ξ²) − ξ) with ω_max = 2 cp / L_min (lumped-mass hex8)."""
    w = 2 * cp / L_min
    return 2 / w * (math.sqrt(1 + xi_max**2) - xi_max)


# ------------------------------------------------------------------------------------------------
# Static stresses around the tunnel (plane strain; compression positive in Kirsch's convention)
# ------------------------------------------------------------------------------------------------
def kirsch(p: float, k: float, a: float, r, theta):
    """Stresses around a circular hole of radius a in an infinite plate, far field σv = p,
    σh = k p, compression positive, θ measured from the horizontal (Brady & Brown, ch. 7).
    Returns (σrr, σθθ, τrθ)."""
    r, theta = np.asarray(r, float), np.asarray(theta, float)
    q = (a / r) ** 2
    c2, s2 = np.cos(2 * theta), np.sin(2 * theta)
    srr = p / 2 * ((1 + k) * (1 - q) - (1 - k) * (1 - 4 * q + 3 * q * q) * c2)
    stt = p / 2 * ((1 + k) * (1 + q) + (1 - k) * (1 + 3 * q * q) * c2)
    srt = p / 2 * (1 - k) * (1 + 2 * q - 3 * q * q) * s2
    return srr, stt, srt


def kirsch_pressurised(p: float, k: float, a: float, p_i: float, r, theta):
    """Kirsch's field with a pressure p_i on the hole's wall (an unlined pressure tunnel; Lamé's
    term added: σrr += p_i a²/r², σθθ −= p_i a²/r²), compression positive, θ from the horizontal.
    Returns (σrr, σθθ, τrθ)."""
    srr, stt, srt = kirsch(p, k, a, r, theta)
    q = p_i * (a / np.asarray(r, float)) ** 2
    return srr + q, stt - q, srt


def kirsch_jacking_ratio_at_wall(p: float, k: float, p_i: float, theta) -> np.ndarray:
    """The compressive normal stress on a radial plane at the wall of the pressurised hole, the hoop
    stress σθθ = p[(1+k) + 2(1−k) cos 2θ] − p_i, over the internal pressure p_i (the axial stress
    assumed larger); with k < 1 smallest at the crown and invert, (p(3k − 1) − p_i) / p_i, with
    k > 1 at the springlines, (p(3 − k) − p_i) / p_i."""
    return (kirsch_wall_hoop(p, k, theta) - p_i) / p_i


def kirsch_wall_hoop(p: float, k: float, theta) -> np.ndarray:
    """σθθ at the wall: p[(1+k) + 2(1−k) cos 2θ] — sidewall (θ=0) p(3−k), crown (θ=π/2) p(3k−1)."""
    return p * ((1 + k) + 2 * (1 - k) * np.cos(2 * np.asarray(theta, float)))


def lined_tunnel_internal_pressure(p_i: float, a: float, b: float, E_l: float, nu_l: float,
                                   E_m: float, nu_m: float) -> dict:
    """A lining a ≤ r ≤ b bonded in infinite rock under internal pressure p_i (plane strain).
    Returns the contact pressure p_c (compression positive) and the inner/outer hoop stresses of the
    lining (tension positive). VERIFICATION.md; G_m → 0 gives Lamé's thick cylinder."""
    G_l, G_m = E_l / (2 * (1 + nu_l)), E_m / (2 * (1 + nu_m))
    den = G_l * (b * b - a * a) + G_m * ((1 - 2 * nu_l) * b * b + a * a)
    pc = p_i * 2 * G_m * (1 - nu_l) * a * a / den
    hoop_in = p_i * (G_l * (a * a + b * b) + G_m * ((1 - 2 * nu_l) * b * b - a * a)) / den
    hoop_out = p_i * 2 * a * a * (G_l - G_m * nu_l) / den
    return {"contact_pressure": pc, "hoop_inner": hoop_in, "hoop_outer": hoop_out}


def lame_thick_cylinder(p_i: float, p_o: float, a: float, b: float, r):
    """Lamé: radial and hoop stress (tension positive) in a thick cylinder, internal p_i,
    external p_o (pressures positive)."""
    r = np.asarray(r, float)
    A = (p_i * a * a - p_o * b * b) / (b * b - a * a)
    B = (p_i - p_o) * a * a * b * b / (b * b - a * a)
    return A - B / r**2, A + B / r**2


# ------------------------------------------------------------------------------------------------
# Rings
# ------------------------------------------------------------------------------------------------
def ring_diametral_deflection(P: float, R: float, E: float, nu: float, h: float, width: float = 1.0,
                              plane_strain: bool = True) -> float:
    """Shortening of the loaded diameter of a thin ring under a diametral pair of line loads P
    (per width `width`): ΔD = 0.149 P R³ / (E' I), I = width h³/12, E' = E/(1−ν²) in plane strain
    (Roark; VERIFICATION.md). 0.149 = π/4 − 2/π."""
    Ep = E / (1 - nu * nu) if plane_strain else E
    inertia = width * h**3 / 12
    return (math.pi / 4 - 2 / math.pi) * P * R**3 / (Ep * inertia)


def ring_ovaling_frequency(n: int, E: float, nu: float, rho_s: float, h: float, R: float,
                           rho_f: float = 0.0, fluid_radius: float | None = None) -> float:
    """Natural frequency (Hz) of mode n of a thin ring (plane strain), empty or filled with
    incompressible fluid of density ρf (added pressure −(ρf R/n) ẅ):
    ω² = D n²(n²−1)² / (R⁴ [m (n²+1) + ρf R n]), D = E h³ / (12 (1−ν²)), m = ρs h.

    fluid_radius: radius a of the water (the lining's inner face) when it is not the mid radius R.
    The water's kinetic energy for a wall motion W cos nθ at r = a is ½ ρf π a² Ẇ²/n per unit
    length, so ρf R n becomes ρf n a²/R (the same energy argument; the thin-ring formula takes
    a = R, which is O(h/R) off: 3 % in frequency for h/R = 0.1 with water)."""
    D = E * h**3 / (12 * (1 - nu * nu))
    m = rho_s * h
    a = R if fluid_radius is None else fluid_radius
    w2 = D * n * n * (n * n - 1) ** 2 / (R**4 * (m * (n * n + 1) + rho_f * n * a * a / R))
    return math.sqrt(w2) / (2 * math.pi)


# ------------------------------------------------------------------------------------------------
# Water
# ------------------------------------------------------------------------------------------------
def rigid_pipe_pressure(rho: float, a: float, R: float, theta) -> np.ndarray:
    """Hydrodynamic wall pressure in a full rigid pipe under lateral acceleration a:
    p(θ) = −ρ a R cos θ, θ from the direction of a. Valid below the first transverse acoustic mode
    f = 1.8412 c / (2πR)."""
    return -rho * a * R * np.cos(np.asarray(theta, float))


def volume_change_pressure(K: float, dV_over_V: float) -> float:
    """Weakly compressible water in a closed container: p = −K ΔV/V."""
    return -K * dV_over_V


def added_mass_ratio(rho_f: float, R: float, n: int, rho_s: float, h_node: float) -> float:
    """Fluid added mass ρf R/n per unit wall area over the interface node's lumped mass per area
    (ρs h_node): the ratio that governs staggered-coupling stability (Causin et al. 2005)."""
    return rho_f * R / n / (rho_s * h_node)


def open_pipe_contraction(rho: float, R: float, L: float, w: float, w_dot: float, y, r=None):
    """Incompressible water in a pipe with open ends whose wall moves radially, uniformly along
    the axis: 1D (plug-flow) solution (tests/verification/fluid_open_contraction).

    Pipe 0 ≤ y ≤ L, radius R, radial wall velocity w(t) (> 0 outwards) and its rate ẇ; both
    ends open at p = 0 (hydrodynamic pressure); inviscid; the radius change itself is neglected
    (u_r ≪ R, error O(u_r/R)).

    Continuity of the section A = πR²: ∂(A u)/∂y = −∂A/∂t = −2πR w, so ∂u/∂y = −2w/R, and by
    symmetry u(L/2) = 0:  u(y) = −s (y − L/2),  s = 2w/R.
    Momentum (1D Euler): ∂u/∂t + u ∂u/∂y = −(1/ρ) ∂p/∂y, with ∂u/∂t = −ṡ (y − L/2) and
    u ∂u/∂y = s² (y − L/2):  ∂p/∂y = ρ (ṡ − s²)(y − L/2), and with p(0) = p(L) = 0
        p(y) = −(ρ/2) (ṡ − s²) y (L − y),   ṡ = 2ẇ/R.
    Contraction (w < 0) accelerating inwards (ẇ < 0) raises the pressure, most at mid-length:
    p(L/2) = −ρ (ṡ − s²) L²/8.  Outflow through each end (out of the pipe):
        Q = A |u(0)| = −π R L w.

    Radial variation (r given): the 3D potential flow φ = −s (y − L/2)²/2 + s r²/4 is an exact
    incompressible flow with wall velocity w whose axial velocity is the 1D one; its unsteady
    Bernoulli pressure adds ρ (ṡ/4 + s²/8)(R²/2 − r²) to the 1D (section-mean) pressure, so at
    the wall (r = R) p_w = p(y) − ρ (ṡ/4 + s²/8) R²/2.  Relative to the mid-length pressure this
    is O(2R²/L²) (0.6 % for the paper's L/R = 17.8); the open-end condition p = 0 on a whole end
    section adds local end effects over about R.

    Returns (p [Pa] at y (section mean, or at radius r), u [m/s] at y, Q [m³/s] per end).
    """
    y = np.asarray(y, float)
    s = 2.0 * w / R
    s_dot = 2.0 * w_dot / R
    p = -0.5 * rho * (s_dot - s * s) * y * (L - y)
    if r is not None:
        p = p + rho * (s_dot / 4.0 + s * s / 8.0) * (R * R / 2.0 - np.asarray(r, float) ** 2)
    u = -s * (y - L / 2.0)
    Q = -math.pi * R * L * w
    return p, u, Q


def _bessel_ratio(n: int, x: np.ndarray) -> np.ndarray:
    """I_n(x) / (x I_n'(x)) with I_n' = (I_{n−1} + I_{n+1})/2 (exponentially scaled Bessel functions)."""
    from scipy.special import ive

    return ive(n, x) / (x * 0.5 * (ive(n - 1, x) + ive(n + 1, x)))


def open_tube_added_mass(n: int, a: float, L: float, y: float | None = None, terms: int = 20000) -> float:
    """Added mass per wall area, over its 2D value ρf a/n, of incompressible inviscid water in a
    tube of radius a and length L with open ends (p = 0 at y = 0 and L) whose wall moves radially
    as W cos nθ, uniformly along the axis (n ≥ 1).

    Potential flow (Laplace in the cylinder; ∂φ/∂r = Ẇ cos nθ at r = a, φ = 0 at the ends):
    1 = Σ_{k odd} c_k sin(κ_k y), c_k = 4/(kπ), κ_k = kπ/L, and each term is
    φ_k ∝ I_n(κ_k r) cos nθ sin(κ_k y), so the wall pressure is p = −ρf (a/n) Ẅ cos nθ m(y) with
        m(y) = Σ_{k odd} c_k g_n(κ_k a) sin(κ_k y),   g_n(x) = n I_n(x) / (x I_n'(x))  (→ 1 as x → 0).
    y given: the local value m(y) (m(L/2) → 1 for L ≫ a: the 2D ring's added mass at mid-length).
    y None: the value for a uniform mode shape (Rayleigh, the water's kinetic energy over the 2D
    one): m̄ = Σ_{k odd} (c_k²/2) g_n(κ_k a) (→ 1 for L ≫ a, since Σ_{k odd} 8/(kπ)² = 1)."""
    if n < 1:
        raise ValueError(f"n = {n}: the added mass of an open tube is defined here for n >= 1 (n = 0: open_tube_mu_max)")
    k = np.arange(1, 2 * terms, 2, dtype=float)
    c = 4.0 / (k * np.pi)
    g = n * _bessel_ratio(n, k * np.pi * a / L)
    if y is None:
        return float(np.sum(0.5 * c * c * g))
    return float(np.sum(c * g * np.sin(k * np.pi * y / L)))


def open_tube_mu_max(a: float, L: float) -> float:
    """Largest eigenvalue μ_max (m) of the added-mass operator of water in a tube of radius a and
    length L with open ends: wall pressure −ρf μ Ẅ for a wall motion that is an eigenmode
    cos nθ sin(κ y), κ = kπ/L, with μ = a I_n(κa) / (κa I_n'(κa)).  For n ≥ 1, μ ≤ a/n; the
    breathing mode n = 0 pushes the water out of the ends, μ = a I_0(x)/(x I_1(x)) ≥ 2a/x², largest
    at k = 1 (x = πa/L): μ_max ≈ 2L²/(π² a) for L ≫ a (the 1D plug flow of open_pipe_contraction).
    The closed circle (no reference pressure) has μ_max = a (n = 1) instead."""
    from scipy.special import ive

    x = math.pi * a / L
    return float(a * ive(0, x) / (x * ive(1, x)))


# ------------------------------------------------------------------------------------------------
# Plane waves at a free surface and through layers
# ------------------------------------------------------------------------------------------------
def free_surface_reflection_p(alpha: float, beta: float, angle_deg: float) -> tuple[float, float]:
    """Reflection coefficients (PP, PS) of a P wave of unit displacement amplitude incident at
    `angle_deg` from the vertical on the free surface of an elastic half-space (Aki & Richards 2002,
    eq. 5.32). With p = sin i / α, ξ = cos i / α, η = cos j / β, X = 1/β² − 2p² (= η² − p²) and the
    Rayleigh denominator D = X² + 4p²ξη:  PP = (4p²ξη − X²)/D,  PS = −4αpξX/(βD).
    Polarisations in (horizontal along the propagation, up): incident P (sin i, cos i), reflected
    P (sin i, −cos i), reflected S (−cos j, −sin j)."""
    p = math.sin(math.radians(angle_deg)) / alpha
    xi = math.sqrt(1 / alpha**2 - p * p)
    eta = math.sqrt(1 / beta**2 - p * p)
    X = 1 / beta**2 - 2 * p * p
    D = X * X + 4 * p * p * xi * eta
    return (4 * p * p * xi * eta - X * X) / D, -4 * alpha * p * xi * X / (beta * D)


def free_surface_p(alpha: float, beta: float, angle_deg: float) -> tuple[float, float]:
    """Surface displacement (horizontal along the propagation direction, vertical up) of an elastic
    half-space for an incident P wave of unit displacement amplitude at `angle_deg` from the
    vertical: the incident wave plus the two of free_surface_reflection_p,
        u_r = sin i (1 + PP) − cos j PS = 4 α p ξ η / (β² D),
        u_z = cos i (1 − PP) − sin j PS = 2 α ξ X / (β² D)   (2 at vertical incidence)."""
    p = math.sin(math.radians(angle_deg)) / alpha
    xi = math.sqrt(1 / alpha**2 - p * p)
    eta = math.sqrt(1 / beta**2 - p * p)
    X = 1 / beta**2 - 2 * p * p
    D = X * X + 4 * p * p * xi * eta
    return 4 * alpha * p * xi * eta / (beta**2 * D), 2 * alpha * xi * X / (beta**2 * D)


def free_surface_sv(alpha: float, beta: float, angle_deg: float) -> tuple[float, float]:
    """Surface displacement (horizontal along the propagation direction, vertical up) of an elastic
    half-space for an incident SV wave of unit amplitude at `angle_deg` from the vertical below the
    critical angle asin(β/α) (polarised (cos j, −sin j) in (r, up): along +r at vertical incidence).

    With p = sin j / β and ξ, η, X, D as in free_surface_p: SS = (4p²ξη − X²)/D and
    SP = 4βpηX/(αD) (Aki & Richards 2002, eq. 5.32, in these polarisations), so
        u_r = β η (1 − SS) + α p SP = 2 η X / (β D)      (2 at vertical incidence),
        u_z = −(β p (1 + SS) + α ξ SP) = −4 p ξ η / (β D)."""
    p = math.sin(math.radians(angle_deg)) / beta
    if p >= 1 / alpha:
        raise ValueError(f"SV at {angle_deg} deg is past the critical angle {math.degrees(math.asin(beta / alpha))} deg")
    xi = math.sqrt(1 / alpha**2 - p * p)
    eta = math.sqrt(1 / beta**2 - p * p)
    X = 1 / beta**2 - 2 * p * p
    D = X * X + 4 * p * p * xi * eta
    return 2 * eta * X / (beta * D), -4 * p * xi * eta / (beta * D)


def sh_layers_transfer_function(f: np.ndarray, layers: list[tuple[float, float, float, float]],
                                rock: tuple[float, float]) -> np.ndarray:
    """Surface / incident displacement of vertically incident SH waves through horizontal layers on
    an elastic half-space (Kramer 1996, §7.2.1.3; Roesset 1977): layers (thickness, cs, ρ, ξ) from
    the surface down, rock (cs, ρ) undamped. u = A_m e^{i(ωt + k_m z)} + B_m e^{i(ωt − k_m z)} in
    layer m (z its local depth), A_1 = B_1, and across the interface under layer m
        A_{m+1} = ½ A_m (1 + α_m) e^{i k_m h_m} + ½ B_m (1 − α_m) e^{−i k_m h_m},
        B_{m+1} = ½ A_m (1 − α_m) e^{i k_m h_m} + ½ B_m (1 + α_m) e^{−i k_m h_m},
    α_m = ρ_m cs*_m / (ρ_{m+1} cs*_{m+1}), cs* = cs (1 + iξ), k* = ω / cs*. Returns
    2 A_1 / A_rock (the incident wave is A_rock: an outcrop record is 2 A_rock)."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    media = [(h, cs * (1 + 1j * xi), rho) for h, cs, rho, xi in layers] + [(0.0, complex(rock[0]), rock[1])]
    A = np.ones_like(w, dtype=complex)
    B = np.ones_like(w, dtype=complex)
    for (h, c, rho), (_, c2, rho2) in zip(media[:-1], media[1:], strict=True):
        k = w / c
        a = rho * c / (rho2 * c2)
        e = np.exp(1j * k * h)
        A, B = 0.5 * A * (1 + a) * e + 0.5 * B * (1 - a) / e, 0.5 * A * (1 - a) * e + 0.5 * B * (1 + a) / e
    return 2.0 / A
