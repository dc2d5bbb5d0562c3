"""Capacity of a lining section per metre of tunnel: cracking, plain concrete and the M–N
interaction of a reinforced rectangular section, to EN 1992-1-1:2004 (Eurocode 2).

Section and signs
-----------------
A rectangular section of width ``b`` (1 m: forces per metre of tunnel) and thickness ``h``.
- **N > 0 is compression** (the lining's thrust), in N/m.
- **M > 0 compresses the top face and stretches the bottom face**, in N·m/m, taken about the
  section's mid-depth. On a lining: top = outer face (extrados), bottom = inner face (intrados),
  so M > 0 opens the inner face. Reinforcement areas are per metre (m²/m): ``As_top``,
  ``As_bottom`` at ``d_top``, ``d_bottom`` from their faces (axis distance: cover + bar radius).
- Strains are positive in shortening (compression) inside this module.

What is checked (EN 1992-1-1)
-----------------------------
- Cracking (elastic, uncracked section): σt = |M|/W − N/A with A = b h, W = b h²/6; the section
  cracks when σt > fct. Cracking moment M_cr = W (fct + N/A); utilisation σt / fct (1 at M_cr).
  fct is ``fctm`` (Table 3.1: 0.30 fck^(2/3) up to C50/60, 2.12 ln(1 + fcm/10) above,
  fcm = fck + 8 MPa) unless another strength is chosen (``cracking_strength``): ``fctk_005``
  (0.7 fctm), ``fctm_fl`` (§3.1.8: max(1.6 − h/1 m, 1) fctm) or ``fctd_pl``
  (§12.3.1: α_ct,pl fctk,0.05 / γc).
- Plain concrete at the ULS, §12.6.1 eq. (12.2): N_Rd = η fcd,pl b h (1 − 2e/h), e = |M|/N,
  fcd,pl = α_cc,pl fck/γc; utilisation N / N_Rd (a ray from the origin: e is held). No resistance
  to net tension nor for e ≥ h/2 (utilisation ∞). The eccentricity is the given one: any
  imperfection or second-order eccentricity (§12.6.5) belongs in M.
- Reinforced concrete, §6.1: plane sections, no concrete tensile strength, concrete
  parabola–rectangle (§3.1.7(1), eq. 3.17, fcd = α_cc fck/γc, εc2, εcu2, n of Table 3.1) or the
  rectangular block (§3.1.7(3): η fcd over λx), steel elastic–perfectly plastic (§3.2.7(2)b,
  fyd = fyk/γs, Es) with an optional strain limit εud. Ultimate strain profiles (Fig. 6.1):
  pivot A (tension steel at εud, when a limit is given), B (εcu2 at the compressed face) and C
  (εc2 at (1 − εc2/εcu2) h from the compressed face when the whole section is compressed). Bar
  areas are not deducted from the concrete. The rectangular block uses the same strain limits
  (εc2, εcu2) for the ultimate profiles.
  Utilisation of (N, M): radial from the origin by default, u = |(N, M)| / |(N_R, M_R)| with
  (N_R, M_R) the diagram's point on the same ray; or at constant N, u = M / M_Rd(N).

Case keys (`design:`; SI numbers or "<number> <unit>" strings, see ``DesignParameters.from_mapping``)
---------------------------------------------------------------------------------------------------
::

    design:
      code: EN1992-1-1            # the only one implemented
      gamma_c: 1.5                # §2.4.2.4, persistent/transient (accidental: 1.2)
      gamma_s: 1.15               # (accidental: 1.0)
      alpha_cc: 1.0               # §3.1.6(1) recommended value (some national annexes 0.85)
      alpha_cc_plain: 0.8         # §12.3.1
      alpha_ct_plain: 0.8         # §12.3.1
      stress_block: parabola_rectangle   # or rectangular
      cracking_strength: fctm     # fctm | fctk_005 | fctm_fl | fctd_pl
      utilisation: radial         # or constant_N
      concrete:
        fck: 30 MPa
        fctm: 2.9 MPa             # optional: overrides Table 3.1
      reinforcement:              # omit for a plain lining
        fyk: 500 MPa
        Es: 200 GPa
        eps_ud: null              # null: horizontal branch, no strain limit (§3.2.7(2)b)
        As_inner: 3000 mm^2/m     # the bottom face here (M > 0 stretches it)
        As_outer: 3000 mm^2/m     # the top face
        axis_distance: 0.05 m     # face to bar centroid, both faces
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from .. import units as U

MPA = 1e6

# Gauss–Legendre rule for the concrete integrals: exact for the parabola (degree ≤ 3 integrands);
# for fck > 50 MPa (non-integer n) the error is far below the material scatter.
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(12)


# ------------------------------------------------------------------------------------------------
# Materials (EN 1992-1-1 Table 3.1, §3.2.7)
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Concrete:
    """Concrete by its characteristic cylinder strength fck (Pa); Table 3.1 gives the rest."""

    fck: float
    fctm: float | None = None  # Pa; None: from fck (Table 3.1)

    def __post_init__(self):
        if not 0 < self.fck <= 90 * MPA:
            raise ValueError(f"concrete.fck = {self.fck}: EN 1992-1-1 covers 0 < fck <= 90 MPa (Pa expected)")
        if self.fctm is not None and not self.fctm > 0:
            raise ValueError(f"concrete.fctm = {self.fctm}: must be positive (Pa)")

    @property
    def _fck_mpa(self) -> float:
        return self.fck / MPA

    @property
    def fcm(self) -> float:
        return self.fck + 8 * MPA

    @property
    def fctm_value(self) -> float:
        if self.fctm is not None:
            return self.fctm
        if self._fck_mpa <= 50:
            return 0.30 * self._fck_mpa ** (2 / 3) * MPA
        return 2.12 * math.log(1 + self.fcm / MPA / 10) * MPA

    @property
    def fctk_005(self) -> float:
        return 0.7 * self.fctm_value

    def fctm_fl(self, h: float) -> float:
        """Mean flexural tensile strength (§3.1.8 eq. 3.23), h in m."""
        return max(1.6 - h, 1.0) * self.fctm_value

    @property
    def eps_c2(self) -> float:
        f = self._fck_mpa
        return 2.0e-3 if f <= 50 else (2.0 + 0.085 * (f - 50) ** 0.53) * 1e-3

    @property
    def eps_cu2(self) -> float:
        f = self._fck_mpa
        return 3.5e-3 if f <= 50 else (2.6 + 35 * ((90 - f) / 100) ** 4) * 1e-3

    @property
    def n(self) -> float:
        f = self._fck_mpa
        return 2.0 if f <= 50 else 1.4 + 23.4 * ((90 - f) / 100) ** 4

    @property
    def lam(self) -> float:
        """λ of the rectangular block (§3.1.7(3))."""
        f = self._fck_mpa
        return 0.8 if f <= 50 else 0.8 - (f - 50) / 400

    @property
    def eta(self) -> float:
        """η of the rectangular block and of eq. (12.2)."""
        f = self._fck_mpa
        return 1.0 if f <= 50 else 1.0 - (f - 50) / 200


@dataclass(frozen=True)
class Reinforcement:
    """Reinforcing steel: fyk and Es in Pa; eps_ud None = horizontal top branch without a strain
    limit (§3.2.7(2)b); a number limits the steel strain (recommended 0.9 εuk, Annex C)."""

    fyk: float = 500 * MPA
    Es: float = 200e9
    eps_ud: float | None = None

    def __post_init__(self):
        if not (self.fyk > 0 and self.Es > 0):
            raise ValueError(f"reinforcement: fyk = {self.fyk}, Es = {self.Es}: both must be positive (Pa)")
        if self.eps_ud is not None and not self.eps_ud > 0:
            raise ValueError(f"reinforcement.eps_ud = {self.eps_ud}: must be positive, or null for no limit")


# ------------------------------------------------------------------------------------------------
# Plain section: cracking and EN 1992-1-1 §12.6.1
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CrackingCheck:
    sigma_t: np.ndarray  # largest fibre tension of the uncracked section, Pa (tension > 0)
    fct: float  # tensile strength used, Pa
    M_cr: np.ndarray  # cracking moment at the given N, N·m/m (≤ 0: N alone cracks it)
    utilisation: np.ndarray  # sigma_t / fct
    cracked: np.ndarray  # sigma_t > fct


def cracking_moment(N, h: float, fct: float, b: float = 1.0):
    """M_cr = W (fct + N/A), W = b h²/6, A = b h; N > 0 compression."""
    return b * h * h / 6 * (fct + np.asarray(N, float) / (b * h))


def cracking_check(N, M, h: float, fct: float, b: float = 1.0) -> CrackingCheck:
    """Cracking of the uncracked elastic section under (N, M): σt = |M|/W − N/A against fct.
    Arrays broadcast (every section and sample at once)."""
    N, M = np.asarray(N, float), np.asarray(M, float)
    A, W = b * h, b * h * h / 6
    sigma_t = np.abs(M) / W - N / A
    u = sigma_t / fct
    return CrackingCheck(sigma_t, fct, cracking_moment(N, h, fct, b), u, u > 1.0)


@dataclass(frozen=True)
class PlainCheck:
    e: np.ndarray  # eccentricity |M|/N, m (∞ for N ≤ 0)
    N_Rd: np.ndarray  # eq. (12.2), N/m (0 when e ≥ h/2 or N ≤ 0)
    utilisation: np.ndarray  # N / N_Rd (∞ without resistance; 0 at N = M = 0)


def plain_resistance(N, M, h: float, fcd_pl: float, eta: float = 1.0, b: float = 1.0) -> PlainCheck:
    """EN 1992-1-1 §12.6.1 eq. (12.2): N_Rd = η fcd,pl b h (1 − 2e/h), e = |M|/N."""
    N, M = np.broadcast_arrays(np.asarray(N, float), np.asarray(M, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(N > 0, np.abs(M) / np.where(N > 0, N, 1.0), np.inf)
        N_Rd = np.where(e < h / 2, eta * fcd_pl * b * h * (1 - 2 * e / h), 0.0)
        u = np.where(N_Rd > 0, N / np.where(N_Rd > 0, N_Rd, 1.0), np.inf)
    u = np.where((N == 0) & (M == 0), 0.0, u)
    return PlainCheck(e, N_Rd, u)


# ------------------------------------------------------------------------------------------------
# Reinforced rectangular section: M–N interaction (EN 1992-1-1 §6.1)
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RCSection:
    """A reinforced rectangular section with its design strengths (Pa) and geometry (m, m²/m)."""

    h: float
    concrete: Concrete
    steel: Reinforcement
    As_top: float = 0.0
    As_bottom: float = 0.0
    d_top: float = 0.05
    d_bottom: float = 0.05
    b: float = 1.0
    gamma_c: float = 1.5
    gamma_s: float = 1.15
    alpha_cc: float = 1.0
    stress_block: str = "parabola_rectangle"

    def __post_init__(self):
        if not (self.h > 0 and self.b > 0):
            raise ValueError(f"section: h = {self.h}, b = {self.b}: both must be positive (m)")
        if not (0 <= self.d_top < self.h and 0 <= self.d_bottom < self.h):
            raise ValueError(f"section: bar axis distances {self.d_top}, {self.d_bottom} must lie in [0, h = {self.h})")
        if self.As_top < 0 or self.As_bottom < 0 or self.As_top + self.As_bottom <= 0:
            raise ValueError(f"section: As_top = {self.As_top}, As_bottom = {self.As_bottom}: "
                             "a reinforced section needs steel (plain concrete: plain_resistance)")
        if self.stress_block not in ("parabola_rectangle", "rectangular"):
            raise ValueError(f"stress_block = {self.stress_block!r}: parabola_rectangle or rectangular")

    # design strengths
    @property
    def fcd(self) -> float:
        return self.alpha_cc * self.concrete.fck / self.gamma_c

    @property
    def fyd(self) -> float:
        return self.steel.fyk / self.gamma_s

    @property
    def eps_yd(self) -> float:
        return self.fyd / self.steel.Es

    def mirrored(self) -> RCSection:
        """The same section turned over (top ↔ bottom)."""
        return RCSection(self.h, self.concrete, self.steel, self.As_bottom, self.As_top, self.d_bottom,
                         self.d_top, self.b, self.gamma_c, self.gamma_s, self.alpha_cc, self.stress_block)

    # --------------------------------------------------------------------------------------------
    def _concrete_stress(self, eps, eps_top, eps_bot, y):
        """Concrete stress (Pa, compression > 0) at depth y for strain eps of the profile."""
        c = self.concrete
        if self.stress_block == "parabola_rectangle":
            e = np.clip(eps, 0.0, None)
            par = 1.0 - (1.0 - np.minimum(e, c.eps_c2) / c.eps_c2) ** c.n
            return self.fcd * par
        # rectangular block: η fcd over λ x from the more compressed face
        top_is_compressed = eps_top >= eps_bot
        e_face = np.where(top_is_compressed, eps_top, eps_bot)
        e_other = np.where(top_is_compressed, eps_bot, eps_top)
        depth = np.where(top_is_compressed, y, self.h - y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(e_face > e_other, e_face / (e_face - e_other) * self.h, np.inf)
        inside = (e_face > 0) & (depth <= c.lam * x)
        return np.where(inside, c.eta * self.fcd, 0.0)

    def _breakpoints(self, eps_top, eps_bot):
        """Depths where the concrete law changes (strain 0 and εc2; the block's edge)."""
        h, c = self.h, self.concrete
        de = eps_bot - eps_top
        safe = np.where(de == 0, 1.0, de)
        pts = []
        levels = (0.0, c.eps_c2) if self.stress_block == "parabola_rectangle" else (0.0,)
        for lev in levels:
            pts.append(np.where(de == 0, 0.0, (lev - eps_top) / safe * h))
        if self.stress_block == "rectangular":
            top_is_compressed = eps_top >= eps_bot
            x = np.where(de == 0, np.inf, np.where(top_is_compressed, eps_top, eps_bot) / np.abs(safe) * h)
            edge = c.lam * x
            pts.append(np.where(top_is_compressed, edge, h - edge))
        return [np.clip(np.nan_to_num(p, nan=0.0, posinf=h, neginf=0.0), 0.0, h) for p in pts]

    def section_forces(self, eps_top, eps_bot):
        """(N, M) per metre for a plane strain profile given by the fibre strains at the top and
        bottom faces (shortening > 0). Arrays broadcast; M about mid-depth, M > 0 compresses the top."""
        eps_top, eps_bot = np.broadcast_arrays(np.asarray(eps_top, float), np.asarray(eps_bot, float))
        h, b = self.h, self.b
        bps = np.stack([np.zeros_like(eps_top), *self._breakpoints(eps_top, eps_bot), np.full_like(eps_top, h)],
                       axis=-1)
        bps = np.sort(bps, axis=-1)
        a, c = bps[..., :-1], bps[..., 1:]  # pieces
        mid, half = (a + c) / 2, (c - a) / 2
        y = mid[..., None] + half[..., None] * _GAUSS_X  # (..., pieces, gauss)
        w = half[..., None] * _GAUSS_W
        et, eb = eps_top[..., None, None], eps_bot[..., None, None]
        eps = et + (eb - et) * y / h
        sig = self._concrete_stress(eps, et, eb, y)
        Nc = b * np.sum(sig * w, axis=(-1, -2))
        Mc = b * np.sum(sig * (h / 2 - y) * w, axis=(-1, -2))
        Ns = np.zeros_like(Nc)
        Ms = np.zeros_like(Nc)
        for As, ys in ((self.As_top, self.d_top), (self.As_bottom, h - self.d_bottom)):
            es = eps_top + (eps_bot - eps_top) * ys / h
            ss = np.clip(self.steel.Es * es, -self.fyd, self.fyd)
            Ns = Ns + As * ss
            Ms = Ms + As * ss * (h / 2 - ys)
        return Nc + Ns, Mc + Ms

    # --------------------------------------------------------------------------------------------
    def _profile_top(self, x):
        """Ultimate profile (eps_top, eps_bot) with the top compressed, neutral axis at depth x
        (x ≤ 0 or x ≥ h: no neutral axis in the section; x = ±∞ allowed through large values)."""
        c, h = self.concrete, self.h
        d = h - self.d_bottom
        x = np.asarray(x, float)
        eps_ud = self.steel.eps_ud
        # pivot C: εc2 at y_C = (1 − εc2/εcu2) h
        yC = (1 - c.eps_c2 / c.eps_cu2) * h
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = np.maximum(x, h)
            et_C = c.eps_c2 * xc / (xc - yC)
            eb_C = c.eps_c2 * (xc - h) / (xc - yC)
            xb = np.where((x > 0) & (x <= h), x, h)
            et_B = np.full_like(x, c.eps_cu2)
            eb_B = c.eps_cu2 * (xb - h) / xb
            et, eb = np.where(x > h, et_C, et_B), np.where(x > h, eb_C, eb_B)
            if eps_ud is not None:
                x_AB = c.eps_cu2 * d / (c.eps_cu2 + eps_ud)
                xa = np.minimum(x, x_AB)
                et_A = eps_ud * xa / (d - xa)
                eb_A = eps_ud * (xa - h) / (d - xa)
                et, eb = np.where(x <= x_AB, et_A, et), np.where(x <= x_AB, eb_A, eb)
        return et, eb

    def _x_of_s(self, s):
        """Neutral-axis depth for the branch parameter s ∈ (0, 1): tension end → compression end."""
        s = np.clip(np.asarray(s, float), 1e-13, 1 - 1e-13)
        if self.steel.eps_ud is None:
            return self.h * np.tan(np.pi * s / 2)
        # with a steel strain limit, x ≤ 0 (pivot A, the whole section stretched) takes s < 0.1
        s0 = 0.1
        neg = -self.h * np.tan(np.pi / 2 * (s0 - np.minimum(s, s0)) / s0)
        pos = self.h * np.tan(np.pi / 2 * (np.maximum(s, s0) - s0) / (1 - s0))
        return np.where(s < s0, neg, pos)

    def curve(self, s):
        """The closed M–N resistance curve, s ∈ [0, 2]: s = 0 pure tension, 0 < s < 1 the branch with
        the top compressed (M ≥ 0 for symmetric steel), s = 1 pure compression, 1 < s < 2 the bottom
        compressed. Returns (N_R, M_R)."""
        s = np.asarray(s, float)
        st = np.where(s <= 1, s, 2 - s)
        et, eb = self._profile_top(self._x_of_s(st))
        mt, mb = self.mirrored()._profile_top(self._x_of_s(st))
        et, eb = np.where(s <= 1, et, mb), np.where(s <= 1, eb, mt)
        return self.section_forces(et, eb)

    def diagram(self, n: int = 721):
        """Points (N_R, M_R) around the closed interaction curve (n points; first = last)."""
        return self.curve(np.linspace(0.0, 2.0, n))

    def pure_compression(self) -> tuple[float, float]:
        """N_Rd0: uniform shortening εc2 (pivot C at infinite depth)."""
        e = self.concrete.eps_c2
        N, M = self.section_forces(e, e)
        return float(N), float(M)

    def pure_tension(self) -> tuple[float, float]:
        N, M = self.curve(0.0)
        return float(N), float(M)

    def balanced_point(self) -> tuple[float, float]:
        """Top face at εcu2 while the bottom steel reaches its yield strain εyd (M > 0 side)."""
        c = self.concrete
        d = self.h - self.d_bottom
        x = c.eps_cu2 / (c.eps_cu2 + self.eps_yd) * d
        N, M = self.section_forces(c.eps_cu2, c.eps_cu2 * (x - self.h) / x)
        return float(N), float(M)

    # --------------------------------------------------------------------------------------------
    def _scales(self):
        N0, _ = self.pure_compression()
        return N0, N0 * self.h

    def _angle(self, N, M):
        Ns, Ms = self._scales()
        return np.arctan2(np.asarray(M) / Ms, np.asarray(N) / Ns)

    def utilisation_radial(self, N, M, iterations: int = 45):
        """u = |(N, M)| / |(N_R, M_R)| with (N_R, M_R) on the curve along the same ray from the
        origin (the curve encloses the origin: it has tension resistance). Arrays broadcast."""
        N, M = np.broadcast_arrays(np.asarray(N, float), np.asarray(M, float))
        shape = N.shape
        N, M = N.ravel(), M.ravel()
        grid = np.linspace(0.0, 2.0, 801)
        phi = np.unwrap(self._angle(*self.curve(grid)))  # decreasing by 2π around the curve
        if np.any(np.diff(phi) > 1e-12):
            raise ValueError("the interaction curve is not star-shaped about the origin; use constant_N")
        psi = self._angle(N, M)
        psi = psi + 2 * np.pi * np.floor((phi[0] - psi) / (2 * np.pi))  # into (phi[-1], phi[0]]
        k = np.clip(np.searchsorted(-phi, -psi, side="left"), 1, len(grid) - 1)
        lo, hi = grid[k - 1], grid[k]
        ref = phi[k - 1]
        for _ in range(iterations):
            mid = (lo + hi) / 2
            a = self._angle(*self.curve(mid))
            a = a + 2 * np.pi * np.round((ref - a) / (2 * np.pi))
            above = a >= psi  # the curve has not yet turned past the ray
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
        NR, MR = self.curve((lo + hi) / 2)
        Ns, Ms = self._scales()
        num = np.hypot(N / Ns, M / Ms)
        den = np.hypot(NR / Ns, MR / Ms)
        return (num / den).reshape(shape)

    def moment_resistance(self, N, iterations: int = 50):
        """(M_hi, M_lo): the largest and smallest moment of the curve at axial force N (NaN where the
        line N = const misses the curve). With unsymmetric steel both may have one sign near the
        tips (the curve's N_max is then not at M = 0)."""
        N = np.asarray(N, float)
        shape = N.shape
        N = N.ravel()
        grid = np.linspace(0.0, 2.0, 801)
        Ng, Mg = self.curve(grid)
        da, db = Ng[None, :-1] - N[:, None], Ng[None, 1:] - N[:, None]
        cross = (da * db <= 0) & (da != db)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(cross, da / (da - db), 0.0)
        Mlin = np.where(cross, Mg[:-1] + t * (Mg[1:] - Mg[:-1]), np.nan)
        found = cross.any(axis=1)
        out = []
        for pick in (np.nanargmax, np.nanargmin):
            k = np.zeros(len(N), dtype=int)
            if found.any():
                k[found] = pick(Mlin[found], axis=1)
            lo, hi = grid[k], grid[k + 1]
            rising = Ng[k + 1] >= Ng[k]
            for _ in range(iterations):
                mid = (lo + hi) / 2
                Nm, _ = self.curve(mid)
                go_up = (Nm < N) == rising
                lo, hi = np.where(go_up, mid, lo), np.where(go_up, hi, mid)
            _, MR = self.curve((lo + hi) / 2)
            out.append(np.where(found, MR, np.nan).reshape(shape))
        return out[0], out[1]

    def utilisation_constant_N(self, N, M):
        """u = M / M_hi(N) for M ≥ 0, M / M_lo(N) for M < 0; ∞ when N is outside the curve's range.
        Where (N, 0) itself lies outside the curve (unsymmetric steel near the tips): ∞ outside
        [M_lo, M_hi] and the radial utilisation inside."""
        N, M = np.broadcast_arrays(np.asarray(N, float), np.asarray(M, float))
        Mhi, Mlo = self.moment_resistance(N)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.where(M >= 0, M / Mhi, M / Mlo)
        tip = (M == 0) & (np.where(M >= 0, Mhi, Mlo) == 0)  # N at a tip of the curve
        u = np.where(tip, 1.0, np.where(np.isnan(u), np.inf, u))
        odd = (Mlo > 0) | (Mhi < 0)
        if np.any(odd):
            tol = 1e-9 * abs(self.pure_compression()[0]) * self.h  # a point on the curve is inside
            inside = (M >= Mlo - tol) & (M <= Mhi + tol)
            u = np.where(odd & ~inside, np.inf, u)
            sel = odd & inside
            if np.any(sel):
                u = np.array(u, float)
                u[sel] = self.utilisation_radial(N[sel], M[sel])
        return u


# ------------------------------------------------------------------------------------------------
# The case's `design:` block
# ------------------------------------------------------------------------------------------------
_CHOICES = {
    "code": ("EN1992-1-1", "EN1992"),
    "stress_block": ("parabola_rectangle", "rectangular"),
    "cracking_strength": ("fctm", "fctk_005", "fctm_fl", "fctd_pl"),
    "utilisation": ("radial", "constant_N"),
}

@dataclass(frozen=True)
class DesignParameters:
    """Partial factors, material values and choices of the capacity check (keys in the module
    docstring). Defaults: EN 1992-1-1 recommended values, persistent and transient situations."""

    concrete: Concrete
    reinforcement: Reinforcement | None = None
    As_inner: float = 0.0  # m²/m, bottom face (M > 0 stretches it)
    As_outer: float = 0.0  # m²/m, top face
    axis_distance: float = 0.05  # m, face to bar centroid
    code: str = "EN1992-1-1"
    gamma_c: float = 1.5
    gamma_s: float = 1.15
    alpha_cc: float = 1.0
    alpha_cc_plain: float = 0.8
    alpha_ct_plain: float = 0.8
    stress_block: str = "parabola_rectangle"
    cracking_strength: str = "fctm"
    utilisation: str = "radial"
    def __post_init__(self):
        for key, allowed in _CHOICES.items():
            if getattr(self, key) not in allowed:
                raise ValueError(f"design.{key} = {getattr(self, key)!r}: one of {', '.join(allowed)}")
        for key in ("gamma_c", "gamma_s", "alpha_cc", "alpha_cc_plain", "alpha_ct_plain"):
            if not getattr(self, key) > 0:
                raise ValueError(f"design.{key} = {getattr(self, key)}: must be positive")

    @property
    def reinforced(self) -> bool:
        return self.reinforcement is not None and (self.As_inner + self.As_outer) > 0

    def fct(self, h: float) -> float:
        c = self.concrete
        return {"fctm": c.fctm_value, "fctk_005": c.fctk_005, "fctm_fl": c.fctm_fl(h),
                "fctd_pl": self.alpha_ct_plain * c.fctk_005 / self.gamma_c}[self.cracking_strength]

    def fcd_pl(self) -> float:
        return self.alpha_cc_plain * self.concrete.fck / self.gamma_c

    def section(self, h: float) -> RCSection:
        if not self.reinforced:
            raise ValueError("design.reinforcement: no reinforcement given (As_inner + As_outer = 0)")
        return RCSection(h, self.concrete, self.reinforcement, As_top=self.As_outer, As_bottom=self.As_inner,
                         d_top=self.axis_distance, d_bottom=self.axis_distance, gamma_c=self.gamma_c,
                         gamma_s=self.gamma_s, alpha_cc=self.alpha_cc, stress_block=self.stress_block)

    def concrete_checks(self, N, M, h: float) -> dict:
        """The checks of the concrete section alone: 'cracking' and 'plain' (EN 1992-1-1 §12)."""
        return {"cracking": cracking_check(N, M, h, self.fct(h)),
                "plain": plain_resistance(N, M, h, self.fcd_pl(), eta=self.concrete.eta)}

    def check(self, N, M, h: float) -> dict:
        """Every check for (N, M) pairs (arrays broadcast) of a lining of thickness h:
        'cracking' (CrackingCheck), 'plain' (PlainCheck, EN 1992-1-1 §12) and, when reinforced,
        'reinforced' (utilisation against the M–N curve by the chosen method)."""
        out = self.concrete_checks(N, M, h)
        if self.reinforced:
            sec = self.section(h)
            out["reinforced"] = (sec.utilisation_radial(N, M) if self.utilisation == "radial"
                                 else sec.utilisation_constant_N(N, M))
        return out

    # --------------------------------------------------------------------------------------------
    @classmethod
    def from_mapping(cls, raw: Mapping, path: str = "design") -> DesignParameters:
        """Build from the case's `design:` mapping. Unknown keys are errors naming the key; a value is
        a number (SI) or '<number> <unit>'."""

        def take(m: Mapping, allowed: dict, where: str) -> dict:
            unknown = sorted(set(m) - set(allowed))
            if unknown:
                raise ValueError(f"{where}.{unknown[0]}: unknown key (known: {', '.join(sorted(allowed))})")
            out = {}
            for k, dim in allowed.items():
                if k not in m or m[k] is None or dim == "map":
                    continue
                if dim == "str":
                    out[k] = str(m[k])
                    continue
                try:
                    out[k] = U.parse_quantity(m[k], dim).value
                except U.UnitError as exc:
                    raise ValueError(f"{where}.{k} = {m[k]!r}: {exc}") from None
            return out

        top = take(raw, {"code": "str", "gamma_c": U.DIMENSIONLESS, "gamma_s": U.DIMENSIONLESS,
                         "alpha_cc": U.DIMENSIONLESS, "alpha_cc_plain": U.DIMENSIONLESS,
                         "alpha_ct_plain": U.DIMENSIONLESS, "stress_block": "str", "cracking_strength": "str",
                         "utilisation": "str", "concrete": "map", "reinforcement": "map",
                         "crack_width_limit": U.LENGTH, "seismic_situation": "map"}, path)
        if "concrete" not in raw or not isinstance(raw["concrete"], Mapping):
            raise ValueError(f"{path}.concrete: required, a mapping with at least fck")
        conc = take(raw["concrete"], {"fck": U.PRESSURE, "fctm": U.PRESSURE}, f"{path}.concrete")
        if "fck" not in conc:
            raise ValueError(f"{path}.concrete.fck: required (e.g. '30 MPa')")
        kwargs = dict(top, concrete=Concrete(**conc))
        if raw.get("reinforcement") is not None:
            r = take(raw["reinforcement"], {"fyk": U.PRESSURE, "Es": U.PRESSURE, "eps_ud": U.DIMENSIONLESS,
                                            "As_inner": U.LENGTH, "As_outer": U.LENGTH,
                                            "As_inner_axial": U.LENGTH, "As_outer_axial": U.LENGTH,
                                            "axis_distance": U.LENGTH, "bar_diameter": U.LENGTH},
                     f"{path}.reinforcement")
            r.pop("bar_diameter", None)  # the crack width's (design.lining.crack_settings)
            for k in ("As_inner_axial", "As_outer_axial"):  # the analysis' axial bars: not in a hoop section
                r.pop(k, None)
            geo = {k: r.pop(k) for k in ("As_inner", "As_outer", "axis_distance") if k in r}
            kwargs.update(geo, reinforcement=Reinforcement(**r))
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in kwargs.items() if k in names})


def design_mapping(d: dict) -> dict | None:
    """The case's `design:` block as the capacity check reads it (DesignParameters.from_mapping),
    or None when it gives no concrete strength (the lining's are used)."""
    des = d.get("design") or {}
    if not (des.get("concrete") or {}).get("fck"):
        return None
    out = {k: v for k, v in des.items() if k not in ("concrete", "reinforcement")}
    out["concrete"] = {k: v for k, v in des["concrete"].items() if v is not None}
    reinf = {k: v for k, v in (des.get("reinforcement") or {}).items() if v is not None}
    if reinf.get("As_inner", 0) + reinf.get("As_outer", 0) > 0:
        out["reinforcement"] = reinf
    return out
