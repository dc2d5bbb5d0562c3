"""The free field of a plane P, SV or SH wave in horizontally layered ground, and the H5DRM file
layout in which a free field is read and written for the domain reduction method.

Ground: horizontal layers (thickness, Vp, Vs, rho, damping ratio) over an elastic half-space, the
ground surface at elevation `Profile.surface` (z up, the tool's axes: x across the tunnel, y along
its axis). Damping is a complex velocity c* = c (1 + i xi) for Vp and Vs alike (the convention of
references.layer_transfer_function; the modulus is M (1 + i xi)^2, xi frequency-independent).

Wave: `PlaneWave(kind, angle, azimuth)`. `angle` is the incidence angle in the half-space from the
vertical (deg); `azimuth` the angle of the horizontal propagation direction from the tunnel's
axis y towards x (deg): e_r = (sin az, cos az, 0); 0 travels along the axis, 90 across it.
The transverse direction is e_t = e_z x e_r = (-cos az, sin az, 0). Polarisations of the incident
(up-going) wave, unit vectors in (e_r, e_z):
  P: (sin angle, cos angle)  (along the ray, up positive at vertical incidence);
  SV: (cos angle, -sin angle)  (horizontal along +e_r at vertical incidence);
  SH: along e_t.
The horizontal slowness is p = sin(angle)/c of the half-space (c = Vp for P, Vs for SV and SH),
so every point sees the same motion delayed by p (r - r0), r = e_r . (x, y).

Method: per frequency (time factor e^{i w t}), in each layer four plane waves (P and SV, down and
up, all with slowness p; two for SH); the down-going ones referenced at the layer's top and the
up-going ones at its bottom, so that no exponential grows across a layer (evanescent waves in a
layer faster than the half-space stay bounded). The free surface's two tractions, the continuity of
(u_r, u_z, sigma_rz, sigma_zz) at each interface, and the half-space's outgoing (down-going) waves
with the incident one give a square linear system (the global-matrix form of the Thomson-Haskell
propagator; Kennett 1983; Schmidt & Tango 1986). Its solution for a unit incident wave at the top
of the half-space (r = r0) is the transfer function to any depth.

Record conventions (the record is one acceleration history, the wave's defining component):
  incident: the incident wave itself (along its polarisation) at the top of the half-space;
  outcrop: the motion at the free surface of the half-space alone (no layers), component u_z for
    P, u_r for SV, u_t for SH; at vertical incidence twice the incident wave (as motion.py);
  within: the total motion at the top of the half-space inside the profile (a borehole record at
    that depth), deconvolved; refused where that motion nearly vanishes.
Refused, with the reason: SV at or past the critical angle asin(Vs/Vp) of the half-space (the
reflected P becomes evanescent and the outcrop motion is not a delayed copy of the incident
wave); an angle outside [0, 90); a record without a component the wave needs; a point above the
ground surface.

H5DRM (OpenSees' H5DRM load pattern, ShakerMaker's writer): /DRM_Data/xyz (N, 3), internal (N,),
data_location (N,) = 3 i, displacement, velocity, acceleration (3 N, nt), rows 3i..3i+2 the
point's three components; /DRM_Metadata/dt, tstart, tend, drmbox_x0 (3,), drmbox_{x,y,z}{min,max}.
The tool writes positions in its own axes (m, z up) and the motion rows (u_x, u_y, -u_z): OpenSees
flips the third row on reading, so a z-up model reads the file with no transformation. Reading
maps the file's points to the model's nodes: x_model = T ((x_file - x0) scale), every node must
match a point within a tolerance, else it is refused naming the count matched and the largest
distance (the usual symptom of a wrong unit scale).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

KINDS = ("P", "SV", "SH")
#: The padded window is lengthened until the acceleration in the middle of its padding is below this
#: share of its peak. (Not at its very end: a frequency-independent complex velocity is slightly
#: acausal, and its precursor wraps round to the end whatever the length: 5e-4 of the peak within
#: 0.3 s before a 50 ms pulse under two layers with 5 % damping.)
TAIL = 1e-4
CONVENTIONS = ("incident", "outcrop", "within")


class FreeFieldError(ValueError):
    """A wave, profile, record or file the free field cannot be computed for; the text says why
    and `fix` (when given) what to do."""

    def __init__(self, problem: str, fix: str | None = None):
        super().__init__(problem if fix is None else f"{problem}. Fix: {fix}")
        self.problem = problem
        self.fix = fix


@dataclass(frozen=True)
class Layer:
    thickness: float  # m
    vp: float  # m/s
    vs: float  # m/s
    rho: float  # kg/m^3
    damping: float = 0.0  # ratio, complex velocity c (1 + i xi)


@dataclass(frozen=True)
class HalfSpace:
    vp: float
    vs: float
    rho: float
    damping: float = 0.0


@dataclass(frozen=True)
class Profile:
    """Layers from the ground surface down, then the half-space; `surface`: the ground surface's
    elevation (m, z up)."""

    layers: tuple[Layer, ...]
    halfspace: HalfSpace
    surface: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "layers", tuple(self.layers))
        for i, m in enumerate((*self.layers, self.halfspace)):
            name = f"layer {i}" if i < len(self.layers) else "the half-space"
            if isinstance(m, Layer) and not m.thickness > 0:
                raise FreeFieldError(f"{name}: thickness {m.thickness!r} m must be positive")
            if not (m.vs > 0 and m.rho > 0 and m.vp > m.vs * math.sqrt(4 / 3)):
                raise FreeFieldError(f"{name}: Vp {m.vp!r}, Vs {m.vs!r} m/s, rho {m.rho!r}: needs Vs > 0, rho > 0 "
                                     "and Vp > 2/sqrt(3) Vs (a positive bulk modulus)")
            if not 0 <= m.damping < 0.5:
                raise FreeFieldError(f"{name}: damping ratio {m.damping!r} must lie in [0, 0.5)")

    @property
    def depth(self) -> float:
        """Depth of the top of the half-space below the surface (m)."""
        return float(sum(m.thickness for m in self.layers))

    @property
    def media(self) -> tuple:
        return (*self.layers, self.halfspace)


@dataclass(frozen=True)
class PlaneWave:
    kind: str  # P, SV or SH
    angle: float = 0.0  # deg from the vertical, in the half-space
    azimuth: float = 0.0  # deg of the horizontal propagation direction from the axis y towards x

    def __post_init__(self):
        if self.kind not in KINDS:
            raise FreeFieldError(f"wave kind {self.kind!r} is not one of {', '.join(KINDS)}")
        if not 0.0 <= self.angle < 90.0:
            raise FreeFieldError(f"incidence angle {self.angle!r} deg: must lie in [0, 90) deg from the vertical")

    def directions(self) -> tuple[np.ndarray, np.ndarray]:
        """(e_r, e_t): the horizontal propagation direction and the transverse one, in (x, y, z)."""
        s, c = _sin_cos_deg(self.azimuth)
        return np.array([s, c, 0.0]), np.array([-c, s, 0.0])

    def slowness(self, profile: Profile) -> float:
        """Horizontal slowness p (s/m); refuses SV at or past the half-space's critical angle."""
        hs = profile.halfspace
        sin_a = _sin_cos_deg(self.angle)[0]
        if self.kind == "SV":
            crit = math.degrees(math.asin(hs.vs / hs.vp))
            if self.angle >= crit:
                raise FreeFieldError(
                    f"SV wave at {self.angle:g} deg from the vertical is at or past the critical angle "
                    f"asin(Vs/Vp) = {crit:.2f} deg of the half-space (Vs {hs.vs:g}, Vp {hs.vp:g} m/s): its reflected "
                    "P wave is evanescent and the surface motion is no longer a delayed copy of the incident wave",
                    f"give an angle below {crit:.2f} deg (or a P or SH wave)")
        return sin_a / (hs.vp if self.kind == "P" else hs.vs)

    def polarisation(self) -> np.ndarray:
        """Unit polarisation of the incident wave in (x, y, z)."""
        e_r, e_t = self.directions()
        s, c = _sin_cos_deg(self.angle)
        ez = np.array([0.0, 0.0, 1.0])
        if self.kind == "P":
            return s * e_r + c * ez
        if self.kind == "SV":
            return c * e_r - s * ez
        return e_t

    def record_direction(self) -> np.ndarray:
        """The direction of the component an outcrop or within record of this wave gives: z for P,
        e_r for SV, e_t for SH."""
        e_r, e_t = self.directions()
        return {"P": np.array([0.0, 0.0, 1.0]), "SV": e_r, "SH": e_t}[self.kind]


def _sin_cos_deg(deg: float) -> tuple[float, float]:
    """sin and cos of an angle in degrees, exact at multiples of 90 degrees."""
    q, r = divmod(float(deg), 90.0)
    if r == 0.0:
        return ((0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0))[int(q) % 4]
    t = math.radians(deg)
    return math.sin(t), math.cos(t)


# ------------------------------------------------------------------------------------------------
# Frequency domain: the layered system
# ------------------------------------------------------------------------------------------------
def _vertical_slowness(c: complex, p: float) -> complex:
    """sqrt(1/c^2 - p^2) on the branch with Im <= 0 (a down-going wave e^{-i w q z} decays with
    depth z for w > 0) and Re > 0 when real."""
    q = np.sqrt(complex(1.0 / (c * c) - p * p))
    if q.imag > 0 or (q.imag == 0 and q.real < 0):
        q = -q
    return q


class _Medium:
    """One layer's or the half-space's constants for slowness p: the motion-stress vectors of its
    waves. P-SV vectors (u_r, u_d, sigma_rd, sigma_dd) / (-i w), d the depth (down); columns
    [P down, S down, P up, S up]. SH vectors (u_t, sigma_td) / (-i w); columns [down, up]."""

    def __init__(self, m, p: float):
        a = m.vp * (1 + 1j * m.damping)
        b = m.vs * (1 + 1j * m.damping)
        mu = m.rho * b * b
        lam = m.rho * a * a - 2 * mu
        qa, qb = _vertical_slowness(a, p), _vertical_slowness(b, p)
        self.qa, self.qb = qa, qb
        self.h = getattr(m, "thickness", 0.0)
        waves = [((a * p, a * qa), qa), ((-b * qb, b * p), qb), ((a * p, -a * qa), -qa), ((b * qb, b * p), -qb)]
        self.E = np.array([[ur, ud, mu * (p * ud + sd * ur), lam * (p * ur + sd * ud) + 2 * mu * sd * ud]
                           for (ur, ud), sd in waves]).T  # (4, 4)
        self.E_sh = np.array([[1.0, mu * qb], [1.0, -mu * qb]]).T  # (2, 2)

    def phases(self, w: np.ndarray, zeta: float, sh: bool) -> np.ndarray:
        """(nf, ncols): the phase of each wave at local depth zeta (down-going from the top, up-going
        from the bottom: both |.| <= 1 inside the layer)."""
        qs = (self.qb,) if sh else (self.qa, self.qb)
        down = [np.exp(-1j * w * q * zeta) for q in qs]
        up = [np.exp(-1j * w * q * (self.h - zeta)) for q in qs]
        return np.stack(down + up, axis=1)


def _solve(profile: Profile, sh: bool, kind: str, p: float, w: np.ndarray) -> tuple[list[_Medium], np.ndarray]:
    """Amplitudes (nf, n_unknowns) for a unit incident wave of `kind` at the top of the half-space."""
    media = [_Medium(m, p) for m in profile.media]
    n = len(profile.layers)
    k = 2 if sh else 4  # waves per layer
    t = 1 if sh else 2  # tractions
    nunk = k * n + t
    nf = w.size
    A = np.zeros((nf, nunk, nunk), dtype=complex)
    rhs = np.zeros((nf, nunk), dtype=complex)
    hs = media[-1]
    E_hs = hs.E_sh if sh else hs.E
    inc = E_hs[:, 1] if sh else E_hs[:, 2 if kind == "P" else 3]  # up-going column of the incident wave
    down_hs = E_hs[:, :1] if sh else E_hs[:, :2]
    if n == 0:
        A[:, :, :] = down_hs[t:, :]
        rhs[:, :] = -inc[t:]
    else:
        top = media[0]
        E0 = top.E_sh if sh else top.E
        A[:, 0:t, 0:k] = E0[t:, :][None] * top.phases(w, 0.0, sh)[:, None, :]
        for i in range(n):
            mi = media[i]
            Ei = mi.E_sh if sh else mi.E
            rows = slice(t + 2 * t * i, t + 2 * t * (i + 1))
            A[:, rows, k * i:k * (i + 1)] = Ei[None] * mi.phases(w, mi.h, sh)[:, None, :]
            if i + 1 < n:
                mj = media[i + 1]
                Ej = mj.E_sh if sh else mj.E
                A[:, rows, k * (i + 1):k * (i + 2)] = -Ej[None] * mj.phases(w, 0.0, sh)[:, None, :]
            else:
                A[:, rows, k * n:] = -down_hs[None]
                rhs[:, rows] = inc[None]
    try:
        amps = np.linalg.solve(A, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError as e:
        raise FreeFieldError(f"the layered system is singular for slowness p = {p:.6g} s/m (a layer's vertical "
                             "slowness is zero: the wave grazes along a layer)",
                             "change the angle slightly") from e
    return media, amps


def _vector_at(profile: Profile, media, amps, sh: bool, kind: str, w: np.ndarray, depth: float,
               side: str = "below") -> np.ndarray:
    """Motion-stress vector (nf, 2 or 4) at `depth` below the surface for the solved amplitudes;
    at an interface `side` picks the medium above or below it."""
    n = len(profile.layers)
    k = 2 if sh else 4
    tops = np.concatenate([[0.0], np.cumsum([m.thickness for m in profile.layers])])
    i = n
    for j in range(n):
        below_top = depth > tops[j] or (depth == tops[j] and (side == "below" or j == 0))
        above_bottom = depth < tops[j + 1] or (depth == tops[j + 1] and side == "above")
        if below_top and above_bottom:
            i = j
            break
    m = media[i]
    zeta = depth - tops[i]
    if i < n:
        E = m.E_sh if sh else m.E
        return (amps[:, k * i:k * (i + 1)] * m.phases(w, zeta, sh)) @ E.T
    E = m.E_sh if sh else m.E
    ncol = 1 if sh else 2
    q_inc = m.qb if (sh or kind != "P") else m.qa
    out = (amps[:, k * n:] * np.stack([np.exp(-1j * w * q * zeta) for q in ((m.qb,) if sh else (m.qa, m.qb))],
                                       axis=1)) @ E[:, :ncol].T
    inc = E[:, 1] if sh else E[:, 2 if kind == "P" else 3]
    return out + np.exp(1j * w * q_inc * zeta)[:, None] * inc[None]


def motion_stress(profile: Profile, wave: PlaneWave, freqs, depth: float, side: str = "below") -> np.ndarray:
    """Motion-stress vector at `depth` (m below the surface) per unit incident displacement, for
    frequencies `freqs` (Hz): P-SV (u_r, u_d, sigma_rd, sigma_dd)/(-i w), SH (u_t, sigma_td)/(-i w),
    d the depth (down), r along e_r. `side` 'above' or 'below' an interface."""
    w = 2 * np.pi * np.atleast_1d(np.asarray(freqs, dtype=float))
    sh = wave.kind == "SH"
    p = wave.slowness(profile)
    media, amps = _solve(profile, sh, wave.kind, p, w)
    return _vector_at(profile, media, amps, sh, wave.kind, w, depth, side)


def transfer(profile: Profile, wave: PlaneWave, freqs, depths) -> np.ndarray:
    """Displacement (x, y, z) per unit incident displacement, (ndepth, nf, 3), at `depths` (m below
    the surface) under the reference point r = r0, for frequencies `freqs` (Hz)."""
    w = 2 * np.pi * np.atleast_1d(np.asarray(freqs, dtype=float))
    sh = wave.kind == "SH"
    p = wave.slowness(profile)
    media, amps = _solve(profile, sh, wave.kind, p, w)
    e_r, e_t = wave.directions()
    out = np.empty((len(depths), w.size, 3), dtype=complex)
    for j, d in enumerate(depths):
        v = _vector_at(profile, media, amps, sh, wave.kind, w, float(d))
        if sh:
            out[j] = v[:, :1] * e_t[None]
        else:
            out[j] = v[:, :1] * e_r[None]
            out[j, :, 2] = -v[:, 1]
    return out


def outcrop_factor(profile: Profile, wave: PlaneWave) -> float:
    """The outcrop record's amplitude per unit incident wave: the motion of the half-space's own free
    surface (no layers) along wave.record_direction(); 2 at vertical incidence."""
    alone = Profile((), profile.halfspace, profile.surface)
    h = transfer(alone, wave, [0.0], [0.0])[0, 0] @ wave.record_direction()
    return float(h.real)


# ------------------------------------------------------------------------------------------------
# Records
# ------------------------------------------------------------------------------------------------
def record_component(record: Mapping[str, np.ndarray] | np.ndarray, wave: PlaneWave) -> np.ndarray:
    """The one history that defines `wave` from a record: an array is taken as that component
    itself; a mapping of components ('x', 'y', 'z') is projected on wave.record_direction(), and
    each component the projection needs must be there."""
    if not isinstance(record, Mapping):
        return np.asarray(record, dtype=float)
    d = wave.record_direction()
    need = [c for c, v in zip("xyz", d, strict=True) if abs(v) > 1e-12]
    missing = [c for c in need if record.get(c) is None]
    if missing:
        what = {"P": "its vertical motion (z)", "SV": f"its horizontal motion along the propagation direction "
                f"(azimuth {wave.azimuth:g} deg from the axis y)", "SH": "its horizontal motion across the "
                f"propagation direction (azimuth {wave.azimuth:g} deg from the axis y)"}[wave.kind]
        raise FreeFieldError(f"the {wave.kind} wave's record is {what}, which needs component"
                             f"{'s' if len(need) > 1 else ''} {', '.join(need)}; the record has no "
                             f"{', '.join(missing)}", f"give the {', '.join(missing)} component of the record")
    comps = [np.asarray(record[c], dtype=float) for c in need]
    n = {c.size for c in comps}
    if len(n) > 1:
        raise FreeFieldError(f"the record's components {', '.join(need)} have different lengths {sorted(n)}",
                             "put them on one clock")
    return sum(v * c for v, c in zip([d["xyz".index(c)] for c in need], comps, strict=True))


def incident_motion(record, dt: float, wave: PlaneWave, profile: Profile, convention: str) -> np.ndarray:
    """The incident wave's acceleration (along its polarisation, at the top of the half-space under
    r0) from a record of the given convention (see the module's text)."""
    if convention not in CONVENTIONS:
        raise FreeFieldError(f"record convention {convention!r} is not one of {', '.join(CONVENTIONS)}")
    acc = record_component(record, wave)
    wave.slowness(profile)  # refuses a supercritical SV before anything else
    if convention == "incident":
        return acc.copy()
    if convention == "outcrop" or not profile.layers:
        f = outcrop_factor(profile, wave)
        if abs(f) < 0.05:
            raise FreeFieldError(f"an outcrop record of this {wave.kind} wave at {wave.angle:g} deg has almost no "
                                 f"motion along its recorded component ({f:.3g} of the incident wave)",
                                 "give the record as the incident wave (convention incident)")
        return acc / f
    n = acc.size
    nfft = _fast_len(2 * n)
    freqs = np.fft.rfftfreq(nfft, dt)
    spec = _without_nyquist(np.fft.rfft(acc, nfft), nfft)
    h = transfer(profile, wave, freqs, [profile.depth])[0] @ wave.record_direction()
    band = np.abs(spec) >= 1e-3 * np.abs(spec).max() if np.any(spec) else np.ones(freqs.size, bool)
    worst = int(np.argmin(np.where(band, np.abs(h), np.inf)))
    if abs(h[worst]) < 0.05:
        raise FreeFieldError(f"a within record at the top of the half-space ({profile.depth:g} m deep) nearly vanishes "
                             f"at {freqs[worst]:.3g} Hz (|within / incident| = {abs(h[worst]):.3g}): deconvolving it "
                             "would amplify that frequency's noise", "give an outcrop or incident record, or damping "
                             "in the layers")
    return np.fft.irfft(spec / h, nfft)[:n]


def _without_nyquist(spec: np.ndarray, nfft: int) -> np.ndarray:
    """The spectrum with its Nyquist-frequency bin (even nfft) set to zero: a real signal's Nyquist
    bin is real, so the phase the layers give it would be dropped by the inverse transform and leave
    an alternating +-e over the whole window (5e-5 of the peak for a white-noise record)."""
    if nfft % 2 == 0:
        spec = spec.copy()
        spec[-1] = 0.0
    return spec


def _fast_len(n: int) -> int:
    from scipy.fft import next_fast_len

    return int(next_fast_len(int(n), real=True))


# ------------------------------------------------------------------------------------------------
# Time domain
# ------------------------------------------------------------------------------------------------
@dataclass
class FreeField:
    """Motion at `points` (N, 3) on the clock `time` (nt,): u, v, a of shape (N, nt, 3), SI units,
    in the tool's axes (x across the tunnel, y along it, z up)."""

    points: np.ndarray
    time: np.ndarray
    u: np.ndarray
    v: np.ndarray
    a: np.ndarray

    @property
    def dt(self) -> float:
        return float(self.time[1] - self.time[0])


def free_field(profile: Profile, waves: Sequence[tuple[PlaneWave, np.ndarray]], dt: float, points,
               times=None, origin: Sequence[float] | None = None, chunk: int = 256) -> FreeField:
    """The free field at `points` (N, 3; x, y, z with z the elevation) of the plane waves `waves`,
    each (wave, incident acceleration at the top of the half-space sampled every dt from t = 0).

    `origin` (x0, y0): where the incident waves' time zero is (t = 0 is when each reaches the top
    of the half-space there); None: for each wave, the point it reaches first (so that no point
    moves before t = 0). `times`: the output clock (default: the records' k dt); between samples the
    motion is interpolated linearly. Velocity and displacement are integrated from rest on the
    padded clock, before the first arrival (trapezoidal velocity, linear acceleration within a
    step: motion.integrate)."""
    from .motion import integrate

    pts = np.atleast_2d(np.asarray(points, dtype=float))
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise FreeFieldError(f"points must be an (N, 3) array of x, y, z; got shape {pts.shape}")
    depth = profile.surface - pts[:, 2]
    if depth.min() < -1e-9 * max(1.0, abs(profile.surface)):
        k = int(np.argmin(depth))
        raise FreeFieldError(f"point {k} at z = {pts[k, 2]:g} m lies above the ground surface at z = "
                             f"{profile.surface:g} m", "give points in the ground (z <= the surface)")
    depth = np.maximum(depth, 0.0)
    if not waves:
        raise FreeFieldError("no wave given")
    n = max(np.asarray(a).size for _, a in waves)
    t_out = np.arange(n) * dt if times is None else np.asarray(times, dtype=float)
    out = {k: np.zeros((pts.shape[0], t_out.size, 3)) for k in ("u", "v", "a")}
    cs_min = min(m.vs for m in profile.media)
    for wave, inc in waves:
        inc = np.asarray(inc, dtype=float)
        p = wave.slowness(profile)
        e_r, _ = wave.directions()
        r = pts @ e_r
        r0 = r.min() if origin is None else float(np.dot(e_r[:2], np.asarray(origin, dtype=float)[:2]))
        delay = p * (r - r0)
        below = max(0.0, depth.max() - profile.depth)
        q_hs = 1.0 / (profile.halfspace.vp if wave.kind == "P" else profile.halfspace.vs)
        lead = max(0.0, -delay.min(), -t_out.min()) + below * q_hs + 8 * dt
        n_pre = int(math.ceil(lead / dt))
        travel = sum(m.thickness / m.vs for m in profile.layers) + depth.max() / cs_min
        span = max(t_out.max(), inc.size * dt) + delay.max() + travel
        n_tail = int(math.ceil(20 * travel / dt)) + 16
        # lengthen the window until the reverberation left in the middle of its padding (which would
        # wrap round onto the start) is negligible, judged at the shallowest point on the record's
        # content below half the Nyquist frequency
        k = [int(np.argmin(depth))]
        for _ in range(6):
            nfft = _fast_len(n_pre + int(math.ceil(span / dt)) + n_tail)
            probe = _Spectra(profile, wave, inc, dt, n_pre, nfft, depth[k], smooth=True).field([0], delay[k])
            tail = np.abs(probe[:, :, nfft - 3 * n_tail // 4:nfft - n_tail // 4]).max()
            if tail <= TAIL * max(np.abs(probe).max(), 1e-300):
                break
            n_tail *= 2
        else:
            raise FreeFieldError(f"the layers still ring at {tail / np.abs(probe).max():.2g} of the peak "
                                 f"{n_tail * dt:g} s after the record: the free field cannot be computed on a "
                                 "finite window", "give the layers some damping")
        spectra = _Spectra(profile, wave, inc, dt, n_pre, nfft, depth)
        grid = (np.arange(nfft) - n_pre) * dt
        for lo in range(0, pts.shape[0], chunk):
            idx = np.arange(lo, min(lo + chunk, pts.shape[0]))
            a_c = spectra.field(idx, delay[idx])  # (m, 3, nfft)
            v_c, u_c = integrate(a_c, dt)
            for key, arr in (("u", u_c), ("v", v_c), ("a", a_c)):
                if times is None:
                    out[key][idx] += arr[:, :, n_pre:n_pre + t_out.size].transpose(0, 2, 1)
                else:
                    for i in range(idx.size):
                        for c in range(3):
                            out[key][idx[i], :, c] += np.interp(t_out, grid, arr[i, c])
    return FreeField(points=pts, time=t_out, u=out["u"], v=out["v"], a=out["a"])


class _Spectra:
    """One wave's incident spectrum on the padded clock t = (k - n_pre) dt and its transfer
    functions to the points' depths. `smooth`: the record's content below half the Nyquist
    frequency only (a cosine taper), for judging the window's length (content near the Nyquist
    frequency, whose phase the sampled clock cannot carry, leaves a slowly decaying alternating
    tail of its own)."""

    def __init__(self, profile, wave, inc, dt, n_pre, nfft, depth, smooth=False):
        x = np.zeros(nfft)
        x[n_pre:n_pre + inc.size] = inc
        spec = _without_nyquist(np.fft.rfft(x), nfft)
        freqs = np.fft.rfftfreq(nfft, dt)
        if smooth:
            f_half = 0.25 / dt
            spec = spec * np.where(freqs < f_half, 0.5 * (1 + np.cos(np.pi * freqs / f_half)), 0.0)
        self.nfft, self.spec, self.w = nfft, spec, 2 * np.pi * freqs
        uniq, self.inv = np.unique(np.round(depth, 9), return_inverse=True)
        self.H = transfer(profile, wave, freqs, uniq)  # (ndepth, nf, 3)

    def field(self, idx, delay) -> np.ndarray:
        """Acceleration (len(idx), 3, nfft) at the points idx (indices into the depths given) with
        their horizontal delays."""
        shift = np.exp(-1j * self.w[None, :] * np.asarray(delay)[:, None]) * self.spec[None]  # (m, nf)
        H = self.H[self.inv[np.asarray(idx)]]  # (m, nf, 3)
        return np.fft.irfft(H.transpose(0, 2, 1) * shift[:, None, :], self.nfft, axis=2)


def vertical_waves(record: Mapping[str, np.ndarray], components: Sequence[str] = ("x", "y", "z")) \
        -> list[tuple[PlaneWave, np.ndarray]]:
    """Vertically incident waves from a three-component record (already the incident motion):
    x and y each an S wave polarised along that axis, z a P wave. Every component of `components`
    must be in the record."""
    missing = [c for c in components if record.get(c) is None]
    if missing:
        raise FreeFieldError(f"the motion asks for components {', '.join(components)}; the record has no "
                             f"{', '.join(missing)}", f"give the {', '.join(missing)} component, or leave "
                             f"{', '.join(missing)} out of the components asked for")
    waves = {"x": PlaneWave("SV", 0.0, 90.0), "y": PlaneWave("SV", 0.0, 0.0), "z": PlaneWave("P", 0.0, 0.0)}
    return [(waves[c], np.asarray(record[c], dtype=float)) for c in components]


# ------------------------------------------------------------------------------------------------
# H5DRM
# ------------------------------------------------------------------------------------------------
#: The stored rows' map to the model's (u_x, u_y, u_z) when the file is read: OpenSees' H5DRM reads
#: row 0 into DOF 1, row 1 into DOF 2 and minus row 2 into DOF 3.
OPENSEES_ROWS = np.diag([1.0, 1.0, -1.0])


def write_h5drm(path, field: FreeField, internal, x0: Sequence[float] = (0.0, 0.0, 0.0)) -> Path:
    """Write `field` in the H5DRM layout: positions (m, the tool's axes) plus x0, motion rows
    (u_x, u_y, -u_z). `internal` (N,) bool: True for the DRM layer's inner nodes (Bielak's b
    nodes), False for its outer ones (e). The file is put in place whole or not at all."""
    from .files import atomic_h5

    internal = np.asarray(internal, dtype=bool)
    n = field.points.shape[0]
    if internal.shape != (n,):
        raise FreeFieldError(f"internal has shape {internal.shape}; expected ({n},), one flag per point")
    t = field.time
    if t.size < 2 or np.max(np.abs(np.diff(t) - (t[1] - t[0]))) > 1e-9 * abs(t[1] - t[0]):
        raise FreeFieldError("the free field's clock must be uniform with at least two samples")
    x0 = np.asarray(x0, dtype=float)
    xyz = field.points + x0[None]
    path = Path(path)
    with atomic_h5(path, needed=3 * field.u.nbytes) as f:
        g = f.create_group("DRM_Data")
        g["xyz"] = xyz
        g["internal"] = internal
        g["data_location"] = np.arange(n, dtype=np.int32) * 3
        for name, arr in (("displacement", field.u), ("velocity", field.v), ("acceleration", field.a)):
            rows = arr @ OPENSEES_ROWS  # (N, nt, 3): the third row positive down
            g.create_dataset(name, data=np.transpose(rows, (0, 2, 1)).reshape(3 * n, t.size),
                             chunks=(3, t.size))
        md = f.create_group("DRM_Metadata")
        md["dt"] = float(t[1] - t[0])
        md["tstart"] = float(t[0])
        md["tend"] = float(t[-1])
        md["drmbox_x0"] = x0
        for k, axis in enumerate("xyz"):
            md[f"drmbox_{axis}min"] = float(xyz[:, k].min())
            md[f"drmbox_{axis}max"] = float(xyz[:, k].max())
        md["program_used"] = "TunnelQuake freefield"
        md["frame"] = "x across the tunnel, y along its axis, z up (m); motion rows u_x, u_y, -u_z"
    return path


def match_points(nodes: np.ndarray, points: np.ndarray, tolerance: float, what: str = "file") -> np.ndarray:
    """For each node (M, 3) the index of its nearest point (N, 3); refuses unless every node has
    one within `tolerance` (m) and no two nodes share one."""
    from scipy.spatial import cKDTree

    nodes = np.asarray(nodes, dtype=float)
    points = np.asarray(points, dtype=float)
    dist, idx = cKDTree(points).query(nodes)
    ok = dist <= tolerance
    if not ok.all():
        k = int(np.argmax(dist))
        span_n = np.ptp(nodes, axis=0).max()
        span_p = np.ptp(points, axis=0).max()
        hint = ""
        if span_n > 0 and span_p > 0:
            ratio = span_n / span_p
            if not 0.5 < ratio < 2.0:
                hint = (f"; the {what}'s points span {span_p:.6g} and the nodes {span_n:.6g}: a length scale of "
                        f"about {ratio:.4g} is missing (a unit error?)")
        raise FreeFieldError(
            f"{int(ok.sum())} of {nodes.shape[0]} DRM layer nodes match a {what} point within {tolerance:g} m; the "
            f"largest distance from a node to its nearest {what} point is {dist[k]:.6g} m (node {k} at "
            f"{tuple(round(float(v), 6) for v in nodes[k])}){hint}",
            "give the file's length scale and origin (a case: incident_wave.h5drm crd_scale, transformation, "
            "x0), or a file computed at the model's nodes (every layer node, the end caps' round the tunnel "
            "included)")
    uniq, counts = np.unique(idx, return_counts=True)
    if (counts > 1).any():
        j = int(uniq[np.argmax(counts)])
        raise FreeFieldError(f"{int(counts.max())} DRM layer nodes match the same {what} point {j} within "
                             f"{tolerance:g} m", "give a smaller tolerance, or a file with a point per node")
    return idx


def h5drm_layout(path) -> dict:
    """What a file in the H5DRM layout holds, checked without reading its motion: {"xyz" (N, 3),
    "internal" (N,) bool or None, "location" (N,) first row of each point, "samples", "dt", "tstart",
    "x0" (drmbox_x0, or zeros)}. Refuses, naming the dataset: a file that is not HDF5, a missing
    dataset, shapes that do not fit N points (xyz (N, 3); internal and data_location (N,);
    displacement, velocity, acceleration (3 N, nt) alike), rows outside the motion arrays, fewer
    than two samples, a step that is not positive and finite, a tend that the samples do not reach."""
    import h5py

    path = Path(path)
    if not path.is_file():
        raise FreeFieldError(f"{path}: file not found")
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise FreeFieldError(f"{path}: not an HDF5 file ({e})") from e
    with f:
        for name in ("DRM_Data/xyz", "DRM_Data/displacement", "DRM_Data/acceleration", "DRM_Metadata/dt",
                     "DRM_Metadata/tstart"):
            if name not in f:
                raise FreeFieldError(f"{path}: no dataset /{name}: not a file in the H5DRM layout",
                                     "give a file with /DRM_Data/xyz, displacement, acceleration and "
                                     "/DRM_Metadata/dt, tstart")
        xyz = np.asarray(f["DRM_Data/xyz"][...], dtype=float)
        if xyz.ndim != 2 or xyz.shape[1] != 3 or xyz.shape[0] == 0:
            raise FreeFieldError(f"{path}: /DRM_Data/xyz has shape {xyz.shape}; needs (N, 3), one row a point")
        npt = xyz.shape[0]
        out = {"xyz": xyz, "internal": None, "location": np.arange(npt) * 3}
        for name, key in (("internal", "internal"), ("data_location", "location")):
            if f"DRM_Data/{name}" in f:
                v = np.asarray(f[f"DRM_Data/{name}"][...]).ravel()
                if v.shape != (npt,):
                    raise FreeFieldError(f"{path}: /DRM_Data/{name} has {v.size} entries for {npt} points",
                                         "give one entry a point of /DRM_Data/xyz")
                out[key] = v.astype(bool) if name == "internal" else v.astype(np.int64)
        shape = f["DRM_Data/displacement"].shape
        if len(shape) != 2 or shape[0] != 3 * npt:
            raise FreeFieldError(f"{path}: /DRM_Data/displacement has shape {shape}; {npt} points need "
                                 f"({3 * npt}, nt): three rows a point, one column a sample")
        for name in ("velocity", "acceleration"):
            if f"DRM_Data/{name}" in f and f[f"DRM_Data/{name}"].shape != shape:
                raise FreeFieldError(f"{path}: /DRM_Data/{name} has shape {f[f'DRM_Data/{name}'].shape}, "
                                     f"/DRM_Data/displacement {shape}", "give every motion array the same shape")
        loc = out["location"]
        if loc.min() < 0 or loc.max() + 3 > shape[0]:
            raise FreeFieldError(f"{path}: /DRM_Data/data_location points outside the motion's {shape[0]} rows")
        nt = shape[1]
        dt = float(f["DRM_Metadata/dt"][()])
        tstart = float(f["DRM_Metadata/tstart"][()])
        if nt < 2:
            raise FreeFieldError(f"{path}: the motion has {nt} sample(s); the free field needs at least two")
        if not (math.isfinite(dt) and dt > 0) or not math.isfinite(tstart):
            raise FreeFieldError(f"{path}: /DRM_Metadata/dt is {dt:g} s and tstart {tstart:g} s; the step must be "
                                 "positive and both finite")
        if "DRM_Metadata/tend" in f:
            tend = float(f["DRM_Metadata/tend"][()])
            if abs(tend - (tstart + (nt - 1) * dt)) > 0.5 * dt and abs(tend - (tstart + nt * dt)) > 0.5 * dt:
                raise FreeFieldError(f"{path}: tstart {tstart:g} s, dt {dt:g} s and {nt} samples end at "
                                     f"{tstart + (nt - 1) * dt:g} s, but tend is {tend:g} s",
                                     "give the file's true dt (the motion's columns are its samples)")
        out.update(samples=nt, dt=dt, tstart=tstart,
                   x0=(np.asarray(f["DRM_Metadata/drmbox_x0"][...], dtype=float).ravel()
                       if "DRM_Metadata/drmbox_x0" in f else np.zeros(3)))
    return out


def read_h5drm(path, nodes, internal=None, scale: float = 1.0, x0: Sequence[float] | None = None,
               transform=None, rows=None, motion_scale: float = 1.0, tolerance: float = 1e-3,
               origin: Sequence[float] = (0.0, 0.0, 0.0)) -> FreeField:
    """The free field at the model's DRM layer `nodes` (M, 3; m, the tool's axes) from a file in the
    H5DRM layout (checked first: h5drm_layout). File points map to the model as x = transform ((xyz
    - x0) scale) + origin (x0 None: the file's drmbox_x0; transform None: identity); the motion rows
    map as u = rows @ row (rows None:
    OPENSEES_ROWS, OpenSees' reading) times `motion_scale` (to m). Every node must match a file point
    within `tolerance` (m). `internal` (M,) bool, when given, must agree with the file's flags."""
    import h5py

    path = Path(path)
    lay = h5drm_layout(path)
    xyz, flags, loc = lay["xyz"], lay["internal"], lay["location"]
    dt, tstart, nt = lay["dt"], lay["tstart"], lay["samples"]
    origin_file = lay["x0"] if x0 is None else np.asarray(x0, dtype=float)
    T = np.eye(3) if transform is None else np.asarray(transform, dtype=float)
    R = OPENSEES_ROWS if rows is None else np.asarray(rows, dtype=float)
    pts = ((xyz - origin_file[None]) * scale) @ T.T + np.asarray(origin, dtype=float)[None]
    idx = match_points(nodes, pts, tolerance)
    if internal is not None and flags is not None:
        bad = np.flatnonzero(np.asarray(internal, dtype=bool) != flags[idx])
        if bad.size:
            raise FreeFieldError(f"{path}: {bad.size} of {len(idx)} DRM layer nodes are inner nodes in the model "
                                 f"and outer ones in the file or the reverse (first: node {int(bad[0])})",
                                 "give the file of this DRM layer, or the file's internal flags")
    with h5py.File(path, "r") as f:
        data = {}
        for name in ("displacement", "velocity", "acceleration"):
            key = f"DRM_Data/{name}"
            if key not in f:
                continue
            ds = f[key]
            rows_at = (loc[idx][:, None] + np.arange(3)[None]).ravel()
            sel = np.sort(rows_at)
            block = ds[sel, :] if sel.size else np.zeros((0, nt))
            back = np.empty_like(block)
            back[np.searchsorted(sel, rows_at)] = block
            per = back.reshape(len(idx), 3, nt).transpose(0, 2, 1)  # (M, nt, 3) rows
            data[name] = per @ R.T * motion_scale
    time = tstart + np.arange(nt) * dt
    if "velocity" not in data:
        data["velocity"] = np.gradient(data["displacement"], dt, axis=1)
    return FreeField(points=np.asarray(nodes, dtype=float), time=time, u=data["displacement"], v=data["velocity"],
                     a=data["acceleration"])
