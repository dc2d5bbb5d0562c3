"""The water column along a lined tunnel in rock: its pressure-wave speed with the compliance of the
lining and the rock (docs/theory.md "The water column along the tunnel"), the quarter-wave
resonances of a column with a reservoir at one end and a closed valve at the other, and the mass
oscillation of a column between a reservoir and a surge tank; and the frequencies measured from a
pressure history.

The wave speed: 1/a² = ρ (1/K + D), D = (1/A) dA/dp = 2 u(r_i)/(r_i p) the wetted section's
compliance, from a thick lining (inner radius r_i, outer r_o, plane strain, Lamé λ, G) bonded to an
infinite elastic rock (shear modulus G_r), whose cavity under the interface pressure q moves
u(r_o) = q r_o/(2 G_r)."""
from __future__ import annotations

import math

import numpy as np

from ..units import STANDARD_GRAVITY


def section_compliance(r_i: float, r_o: float, e_lining: float, nu_lining: float, g_rock: float) -> float:
    """D = (1/A) dA/dp (1/Pa) of the wetted section under a uniform internal pressure: a thick lining in
    plane strain bonded to an infinite rock of shear modulus g_rock (math.inf: rigid rock; 0: no
    rock). r_o == r_i: no lining, D = 1/G_r."""
    if r_o <= r_i:
        return 1.0 / g_rock
    g = e_lining / (2 * (1 + nu_lining))
    m = e_lining / (2 * (1 + nu_lining) * (1 - 2 * nu_lining))  # λ + G
    a2, b2 = r_i * r_i, r_o * r_o
    # the interface pressure q/p: continuity of u and σ_r at r_o with the rock's cavity stiffness 2 G_r/r_o
    if g_rock > 0:
        rock = 0.0 if math.isinf(g_rock) else (b2 - a2) / g_rock
        q_over_p = a2 * (1 / m + 1 / g) / (b2 / m + a2 / g + rock)
    else:
        q_over_p = 0.0
    # u(r_i)/p from the Lamé solution u = A r + B/r with σ_r(r_i) = −p, σ_r(r_o) = −q
    u = r_i / (b2 - a2) * ((a2 - q_over_p * b2) / (2 * m) + (1 - q_over_p) * b2 / (2 * g))
    return 2 * u / r_i


def wave_speed(bulk_modulus: float, density: float, compliance: float) -> float:
    """a = 1/sqrt(ρ (1/K + D)) (m/s); compliance 0 is the rigid tube's sqrt(K/ρ)."""
    return 1.0 / math.sqrt(density * (1.0 / bulk_modulus + compliance))


def quarter_wave_frequencies(a: float, length: float, modes: int = 2) -> list[float]:
    """f_n = (2n − 1) a/(4L) (Hz): a column with p = 0 at one end and no flow at the other."""
    return [(2 * n - 1) * a / (4 * length) for n in range(1, modes + 1)]


def surge_tank_frequencies(a: float, length: float, tunnel_area: float, tank_area: float,
                           density: float = 1000.0, gravity: float = STANDARD_GRAVITY, modes: int = 2) -> list[float]:
    """The lowest natural frequencies (Hz) of a column of length L, area A_t and wave speed a, p = 0 at
    one end and a surge tank of area A_s at the other (p = ρ g z, A_s dz/dt = Q). The tank is a
    compliance C = A_s/(ρ g) at the end: with the column's impedance Z = ρ a/A_t the frequencies solve
    tan(kL) = A_t/(ρ g ... ): cot(ωL/a) = ω C Z = ω A_s a/(g A_t). Its lowest root tends, for a stiff
    column (ωL/a ≪ 1), to the mass oscillation ω² = g A_t/(L A_s) (T = 2π sqrt(L A_s/(g A_t)))."""
    c = tank_area * a / (gravity * tunnel_area)  # s: ω c = cot(ω L / a)
    out = []
    for n in range(modes):
        lo, hi = (n * math.pi + 1e-12) * a / length, ((n + 0.5) * math.pi - 1e-12) * a / length
        f = lambda w: w * c - 1.0 / math.tan(w * length / a)  # noqa: E731  increasing on the branch
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
        out.append(0.5 * (lo + hi) / (2 * math.pi))
    del density
    return out


def mass_oscillation_period(length: float, tunnel_area: float, tank_area: float,
                            gravity: float = STANDARD_GRAVITY) -> float:
    """T = 2π sqrt(L A_s/(g A_t)) (s): the rigid column swinging against the tank's level."""
    return 2 * math.pi * math.sqrt(length * tank_area / (gravity * tunnel_area))


def measured_frequencies(t: np.ndarray, p: np.ndarray, count: int = 2) -> list[float]:
    """The frequencies (Hz) of the `count` strongest components of p(t): the strongest peak of the
    Hann-windowed spectrum (zero-padded 16×) starts a least-squares fit of a decaying sinusoid and a
    constant; the next is the strongest peak of what that fit leaves, and the fit is made again with
    both, and so on (a weak component is not lost in the side lobes of a strong one). Independent of
    any closed form. Sorted ascending."""
    from scipy.optimize import least_squares

    t = np.asarray(t, float) - float(t[0])
    p = np.asarray(p, float)
    p = p / (float(np.abs(p).max()) or 1.0)
    dt = float(np.median(np.diff(t)))
    n = 16 * len(p)
    freqs = np.fft.rfftfreq(n, dt)
    usable = freqs > 1.5 / t[-1]  # at least 1.5 periods in the record

    def model(x, k):
        out = np.full_like(t, x[0])
        for j in range(k):
            f, zeta, a, b = x[1 + 4 * j: 5 + 4 * j]
            w = 2 * np.pi * f
            out += np.exp(-zeta * w * t) * (a * np.cos(w * t) + b * np.sin(w * t))
        return out

    x = np.array([0.0])
    for k in range(1, count + 1):
        left = p - model(x, k - 1)
        spec = np.abs(np.fft.rfft((left - left.mean()) * np.hanning(len(p)), n))
        spec[~usable] = 0.0
        x = np.concatenate([x, [freqs[int(np.argmax(spec))], 0.0, 0.0, 0.0]])
        lo, hi = [-np.inf], [np.inf]
        for j in range(k):  # each frequency within 30 % of its peak, its decay a few periods at most
            lo += [0.7 * x[1 + 4 * j], -0.2, -np.inf, -np.inf]
            hi += [1.3 * x[1 + 4 * j], 0.5, np.inf, np.inf]
        x = least_squares(lambda y, k=k: model(y, k) - p, x, bounds=(lo, hi), x_scale="jac").x
    return sorted(float(x[1 + 4 * j]) for j in range(count))
