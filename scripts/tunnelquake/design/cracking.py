"""Crack width of a reinforced lining section per metre of tunnel, EN 1992-1-1:2004 §7.3.4.

The steel strain comes from the cracked section (concrete linear in compression with modulus E_c,
no tension; steel linear, E_s) under a given N, M: the analysis itself has no reinforcement, so
the steel's strain is the one the section would have under the run's forces.

Signs as in `design.capacity`: N > 0 compression, M > 0 compresses the top face (the lining's
outer face) and stretches the bottom face (its inner face); strains positive in shortening.
The steel area is not deducted from the concrete in compression.

Per face in tension (§7.3.4):
    w_k = s_r,max (ε_sm − ε_cm)                                                   (7.8)
    ε_sm − ε_cm = max[(σ_s − k_t f_ct,eff / ρ_p,eff (1 + α_e ρ_p,eff)) / E_s, 0.6 σ_s / E_s]   (7.9)
    s_r,max = k3 c + k1 k2 k4 φ / ρ_p,eff                                          (7.11)
            = 1.3 (h − x) where the bars are spaced wider than 5 (c + φ/2)         (7.14)
with ρ_p,eff = A_s / (b h_c,eff), h_c,eff = min(2.5 (h − d), (h − x)/3, h/2) (§7.3.2(3), Fig. 7.1;
without a compression zone min(2.5 (h − d), h/2)), α_e = E_s / E_c, f_ct,eff = f_ctm (§7.3.2(2)),
k1 = 0.8 (high-bond bars), k2 = 0.5 in bending, (ε1 + ε2) / (2 ε1) in eccentric tension and 1.0 in
pure tension (7.13: ε1, ε2 the greater and lesser tensile strain at the section's faces), k3 = 3.4,
k4 = 0.425 (the recommended values), c the cover of the bars (axis distance − φ/2), and
k_t = 0.6 for short-term and 0.4 for long-term loading. A section whose uncracked tensile stress
|M|/W − N/A stays at or below f_ct,eff has no crack: w_k = 0 there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

K1, K3, K4 = 0.8, 3.4, 0.425
#: k_t of (7.9): short-term and long-term loading
KT_SHORT, KT_LONG = 0.6, 0.4


@dataclass(frozen=True)
class CrackSection:
    """A rectangular section b x h with bars of diameter `phi` at axis distance `a_top`, `a_bottom`
    from their faces (areas per metre As_top, As_bottom), concrete E_c and f_ct,eff, steel E_s."""

    h: float
    As_top: float
    As_bottom: float
    a_top: float
    a_bottom: float
    phi: float
    Ec: float
    Es: float
    fct_eff: float
    b: float = 1.0

    # ---------------------------------------------------------------------------------------
    def _bars(self):
        return ((self.As_top, self.a_top), (self.As_bottom, self.h - self.a_bottom))

    def forces(self, eps_top, eps_bot):
        """(N, M) of the strain plane (shortening positive) on the cracked section."""
        h, b, Ec = self.h, self.b, self.Ec
        et, eb = np.broadcast_arrays(np.asarray(eps_top, float), np.asarray(eps_bot, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            y0 = np.where(et != eb, et / (et - eb) * h, np.inf)  # where the strain is zero
        # the compressed part [lo, hi] of [0, h]
        top_c, bot_c = et > 0, eb > 0
        lo = np.where(top_c, 0.0, np.where(bot_c, np.clip(y0, 0, h), h))
        hi = np.where(top_c, np.where(bot_c, h, np.clip(y0, 0, h)), h)

        def eps(y):
            return et + (eb - et) * y / h

        fa, fc = eps(lo), eps(hi)
        L = hi - lo
        n_c = Ec * b * L * (fa + fc) / 2
        first = Ec * b * L / 6 * (fa * (2 * lo + hi) + fc * (lo + 2 * hi))  # ∫ σ y dy
        m_c = n_c * h / 2 - first
        N, M = n_c, m_c
        for As, ys in self._bars():
            s = self.Es * eps(ys)
            N = N + As * s
            M = M + As * s * (h / 2 - ys)
        return N, M

    def strains(self, N, M, grid: int = 721, iterations: int = 60):
        """The strain plane (ε_top, ε_bot) carrying (N, M) on the cracked section (arrays
        broadcast): the direction of the plane by bisection on the angle of its forces (monotone:
        the section's forces are the gradient of a strictly convex energy with steel at both
        faces), its size by the forces' homogeneity."""
        N, M = np.broadcast_arrays(np.asarray(N, float), np.asarray(M, float))
        shape = N.shape
        N, M = N.ravel(), M.ravel()
        Ns, Ms = self.Ec * self.b * self.h, self.Ec * self.b * self.h**2 / 6

        def angle(phi):
            n, m = self.forces(np.cos(phi), np.sin(phi))
            return np.arctan2(m / Ms, n / Ns)

        phis = np.linspace(-np.pi, np.pi, grid)
        psi = np.unwrap(angle(phis))
        if np.any(np.diff(psi) * np.sign(psi[-1] - psi[0]) < 0):
            raise ValueError("the cracked section's force map is not monotone (steel at one face only?)")
        rising = psi[-1] > psi[0]
        target = np.arctan2(M / Ms, N / Ns)
        base = psi[0] if rising else psi[-1]
        target = target + 2 * np.pi * np.ceil((base - target) / (2 * np.pi))
        target = np.where(target >= base + 2 * np.pi, target - 2 * np.pi, target)
        order = psi if rising else psi[::-1]
        ph = phis if rising else phis[::-1]
        k = np.clip(np.searchsorted(order, target), 1, grid - 1)
        lo, hi = ph[k - 1], ph[k]
        ref = order[k - 1]
        for _ in range(iterations):
            mid = (lo + hi) / 2
            a = angle(mid)
            a = a + 2 * np.pi * np.round((ref - a) / (2 * np.pi))
            below = a < target
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        phi = (lo + hi) / 2
        n1, m1 = self.forces(np.cos(phi), np.sin(phi))
        lam = np.hypot(N / Ns, M / Ms) / np.hypot(n1 / Ns, m1 / Ms)
        return (lam * np.cos(phi)).reshape(shape), (lam * np.sin(phi)).reshape(shape)

    # ---------------------------------------------------------------------------------------
    def crack_width(self, N, M, kt: float, cracked=None) -> dict:
        """§7.3.4 at both faces for (N, M) pairs. `cracked` (bool, broadcast with N, M; optional):
        where the section has cracked already (the analysis' own crack pattern), it is taken as
        cracked whatever its uncracked stress. Returns arrays (broadcast shape): 'w_bottom',
        'w_top' (m; 0 where the face's bars are not stretched or the section is uncracked),
        'eps_s_bottom', 'eps_s_top' (the bars' stretch, tension positive), 'sigma_s_bottom',
        'sigma_s_top' (Pa), 'x' (depth of the compression zone from its face, m)."""
        N, M = np.broadcast_arrays(np.asarray(N, float), np.asarray(M, float))
        h, b = self.h, self.b
        et, eb = self.strains(N, M)
        sigma_unc = np.abs(M) / (b * h * h / 6) - N / (b * h)  # the uncracked section's tension
        cracked = sigma_unc > self.fct_eff if cracked is None else (sigma_unc > self.fct_eff) | np.asarray(cracked, bool)
        out = {}
        alpha_e = self.Es / self.Ec
        for face, As, a, e_face, e_other in (("bottom", self.As_bottom, self.a_bottom, eb, et),
                                             ("top", self.As_top, self.a_top, et, eb)):
            d = h - a  # the bars' depth from the compressed (other) face
            ys = d  # measured from the other face
            stretch = -(e_other + (e_face - e_other) * ys / h)  # tension positive
            sig = self.Es * stretch
            comp = e_other > 0  # a compression zone at the other face
            with np.errstate(divide="ignore", invalid="ignore"):
                x = np.where(comp, np.clip(e_other / (e_other - e_face) * h, 0, h), 0.0)
            hc = np.where(comp, np.minimum(np.minimum(2.5 * (h - d), (h - x) / 3), h / 2),
                          min(2.5 * (h - d), h / 2))
            with np.errstate(divide="ignore", invalid="ignore"):  # h_c,eff = 0: compressed through, no crack
                rho = As / (b * np.maximum(hc, 1e-12 * h))
                diff = np.maximum((sig - kt * self.fct_eff / rho * (1 + alpha_e * rho)) / self.Es,
                                  0.6 * sig / self.Es)
            # k2: bending (a compression zone) 0.5; tension (7.13) (ε1 + ε2) / (2 ε1) at the faces
            e1 = np.maximum(-e_face, -e_other)
            e2 = np.minimum(-e_face, -e_other)
            with np.errstate(divide="ignore", invalid="ignore"):
                k2 = np.where(comp, 0.5, np.where(e1 > 0, (e1 + e2) / (2 * e1), 1.0))
            c = a - self.phi / 2
            spacing = math.pi * self.phi**2 / 4 / As if As > 0 else math.inf
            if spacing > 5 * (c + self.phi / 2):
                sr = 1.3 * (h - x)
            else:
                sr = K3 * c + K1 * k2 * K4 * self.phi / rho
            w = np.where(cracked & (stretch > 0) & (As > 0), sr * diff, 0.0)
            out[f"w_{face}"] = w
            out[f"eps_s_{face}"] = stretch
            out[f"sigma_s_{face}"] = sig
            out[f"x_{face}"] = np.where(comp, x, 0.0)
        return out
