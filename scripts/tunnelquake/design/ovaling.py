"""Closed-form ovaling of a circular lining under a free-field shear strain γ_max (quasi-static,
plane strain, elastic ground and lining, thin-ring lining): Wang (1993) full slip and no slip, and
Penzien (2000) full slip and no slip.

Sources
-------
- J.-N. Wang (1993), *Seismic Design of Tunnels: A Simple State-of-the-Art Design Approach*,
  Parsons Brinckerhoff Monograph 7, §4 (after Einstein & Schwartz 1979); also Hashash, Hook,
  Schmidt & Yao (2001), Tunn. Undergr. Space Technol. 16:247, and FHWA-NHI-10-034 (2009) §13.5.
- J. Penzien (2000), "Seismically induced racking of tunnel linings", Earthq. Eng. Struct. Dyn.
  29:683–691; compared with Wang by Hashash, Park & Yao (2005), Tunn. Undergr. Space Technol.
  20:435 (identical in full slip; Penzien's no-slip thrust far below Wang's and the finite
  elements', which agree with Wang).

Symbols (SI; per metre of tunnel)
---------------------------------
E_m, ν_m ground; E_l, ν_l lining; t lining thickness; r lining radius (Wang's "radius of the
tunnel": use the mid-surface radius of the ring), d = 2r; I = t³/12 (m⁴/m); G_m = E_m/(2(1+ν_m));
τ_max = G_m γ_max.

- flexibility ratio      F = E_m (1 − ν_l²) r³ / (6 E_l I (1 + ν_m))
- compressibility ratio  C = E_m (1 − ν_l²) r / (E_l t (1 + ν_m)(1 − 2ν_m))
- Wang, full slip: K1 = 12 (1 − ν_m) / (2F + 5 − 6ν_m)
      T_max = K1 E_m r γ_max / (6 (1 + ν_m)),  M_max = r T_max,  ΔD/D = ± K1 F γ_max / 3
- Wang, no slip: T_max = K2 τ_max r,
      K2 = 1 + {F[(1 − 2ν_m) − (1 − 2ν_m) C] − ½(1 − 2ν_m)² C + 2}
               / {F[(3 − 2ν_m) + (1 − 2ν_m) C] + C[5/2 − 8ν_m + 6ν_m²] + 6 − 8ν_m};
      the moment and ΔD of full slip (Wang's recommendation: conservative).
- Penzien: Δ_ff = γ_max d / 2 (the free-field change of a diameter at 45°),
      full slip: R = 4(1 − ν_m)/(α + 1), α = 12 E_l I (5 − 6ν_m) / (d³ G_m (1 − ν_l²)),
                 T = 12 E_l I Δ / (d³ (1 − ν_l²)), M = 6 E_l I Δ / (d² (1 − ν_l²)),
                 V = 24 E_l I Δ / (d³ (1 − ν_l²)), Δ = R Δ_ff;
      no slip:   Rⁿ = 4(1 − ν_m)/(αⁿ + 1), αⁿ = 24 E_l I (3 − 4ν_m) / (d³ G_m (1 − ν_l²)),
                 Tⁿ = 24 E_l I Δⁿ / (d³ (1 − ν_l²)), Mⁿ and Vⁿ as in full slip with Δⁿ.
- Shear for Wang (not given there): thin-ring equilibrium of the n = 2 mode, V_max = 2 M_max / r.

Every method returns amplitudes (``Ovaling``); around the ring they vary as cos 2(θ + π/4)
(thrust, moment) and sin 2(θ + π/4) (shear), θ from the springline, the sign following the sense
of the shear strain (Penzien 2000). Free-field diameter change: non-perforated ground
ΔD/D = ± γ_max / 2; perforated (unlined hole) ΔD/D = ± 2 (1 − ν_m) γ_max.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Ovaling:
    """Amplitudes of the seismic ovaling of the lining, per metre of tunnel."""

    method: str
    thrust: float  # N/m
    moment: float  # N·m/m
    shear: float  # N/m
    diameter_change: float  # m (ΔD of the diameter at 45° to the shear)
    ratio: float  # K1, K2 (Wang) or R, Rⁿ (Penzien)

    def around_ring(self, theta):
        """(T, M, V) at angles θ (rad, from the springline) for a positive shear strain."""
        theta = np.asarray(theta, float)
        c, s = np.cos(2 * (theta + math.pi / 4)), np.sin(2 * (theta + math.pi / 4))
        return -self.thrust * c, -self.moment * c, -self.shear * s


def _check(E_m, nu_m, E_l, nu_l, t, r):
    if not (E_m > 0 and E_l > 0 and t > 0 and r > 0):
        raise ValueError(f"E_m = {E_m}, E_l = {E_l}, t = {t}, r = {r}: all must be positive")
    if not (-1 < nu_m < 0.5 and -1 < nu_l < 0.5):
        raise ValueError(f"nu_m = {nu_m}, nu_l = {nu_l}: Poisson's ratios must lie in (-1, 0.5)")


def flexibility_ratio(E_m: float, nu_m: float, E_l: float, nu_l: float, t: float, r: float) -> float:
    """F = E_m (1 − ν_l²) r³ / (6 E_l I (1 + ν_m)), I = t³/12 per metre (Wang 1993)."""
    _check(E_m, nu_m, E_l, nu_l, t, r)
    return E_m * (1 - nu_l**2) * r**3 / (6 * E_l * t**3 / 12 * (1 + nu_m))


def compressibility_ratio(E_m: float, nu_m: float, E_l: float, nu_l: float, t: float, r: float) -> float:
    """C = E_m (1 − ν_l²) r / (E_l t (1 + ν_m)(1 − 2ν_m)) (Wang 1993)."""
    _check(E_m, nu_m, E_l, nu_l, t, r)
    return E_m * (1 - nu_l**2) * r / (E_l * t * (1 + nu_m) * (1 - 2 * nu_m))


def wang_k1(F: float, nu_m: float) -> float:
    """Full-slip response coefficient K1 = 12(1 − ν_m)/(2F + 5 − 6ν_m)."""
    return 12 * (1 - nu_m) / (2 * F + 5 - 6 * nu_m)


def wang_k2(F: float, C: float, nu_m: float) -> float:
    """No-slip thrust coefficient K2 (Wang 1993; as printed in Hashash et al. 2001)."""
    a = 1 - 2 * nu_m
    num = F * (a - a * C) - 0.5 * a * a * C + 2
    den = F * ((3 - 2 * nu_m) + a * C) + C * (2.5 - 8 * nu_m + 6 * nu_m**2) + 6 - 8 * nu_m
    return 1 + num / den


def free_field_shear_strain(v_peak: float, c_s: float) -> float:
    """γ_max = V_s / C_s: peak particle velocity of vertically propagating shear waves over the
    ground's shear-wave speed (Wang 1993 §4; an upper bound near the surface)."""
    return v_peak / c_s


def free_field_diameter_change(gamma_max: float, D: float, nu_m: float, perforated: bool = False) -> float:
    """ΔD of a circle of diameter D in the free field: γ_max D / 2 (non-perforated ground) or
    2 (1 − ν_m) γ_max D (a hole without lining)."""
    return (2 * (1 - nu_m) if perforated else 0.5) * gamma_max * D


def wang_full_slip(gamma_max: float, E_m: float, nu_m: float, E_l: float, nu_l: float, t: float,
                   r: float) -> Ovaling:
    F = flexibility_ratio(E_m, nu_m, E_l, nu_l, t, r)
    K1 = wang_k1(F, nu_m)
    T = K1 * E_m * r * gamma_max / (6 * (1 + nu_m))
    M = r * T
    return Ovaling("Wang 1993, full slip", T, M, 2 * M / r, K1 * F * gamma_max / 3 * 2 * r, K1)


def wang_no_slip(gamma_max: float, E_m: float, nu_m: float, E_l: float, nu_l: float, t: float,
                 r: float) -> Ovaling:
    """Thrust from K2; the moment, shear and ΔD of full slip (Wang's conservative recommendation)."""
    F = flexibility_ratio(E_m, nu_m, E_l, nu_l, t, r)
    C = compressibility_ratio(E_m, nu_m, E_l, nu_l, t, r)
    K2 = wang_k2(F, C, nu_m)
    tau = E_m / (2 * (1 + nu_m)) * gamma_max
    fs = wang_full_slip(gamma_max, E_m, nu_m, E_l, nu_l, t, r)
    return Ovaling("Wang 1993, no slip", K2 * tau * r, fs.moment, fs.shear, fs.diameter_change, K2)


def penzien(gamma_max: float, E_m: float, nu_m: float, E_l: float, nu_l: float, t: float, r: float,
            slip: str = "full") -> Ovaling:
    """Penzien (2000): slip = 'full' or 'none'."""
    _check(E_m, nu_m, E_l, nu_l, t, r)
    if slip not in ("full", "none"):
        raise ValueError(f"slip = {slip!r}: 'full' or 'none'")
    d = 2 * r
    G_m = E_m / (2 * (1 + nu_m))
    EI = E_l * t**3 / 12 / (1 - nu_l**2)  # plane-strain bending stiffness per metre
    if slip == "full":
        alpha = 12 * EI * (5 - 6 * nu_m) / (d**3 * G_m)
    else:
        alpha = 24 * EI * (3 - 4 * nu_m) / (d**3 * G_m)
    R = 4 * (1 - nu_m) / (alpha + 1)
    delta = R * gamma_max * d / 2
    T = (12 if slip == "full" else 24) * EI * delta / d**3
    M = 6 * EI * delta / d**2
    V = 24 * EI * delta / d**3
    name = "Penzien 2000, full slip" if slip == "full" else "Penzien 2000, no slip"
    return Ovaling(name, T, M, V, delta, R)


def all_methods(gamma_max: float, E_m: float, nu_m: float, E_l: float, nu_l: float, t: float,
                r: float) -> list[Ovaling]:
    """The four closed forms for one case, in the order the report lists them."""
    args = (gamma_max, E_m, nu_m, E_l, nu_l, t, r)
    return [wang_full_slip(*args), wang_no_slip(*args), penzien(*args, slip="full"), penzien(*args, slip="none")]
