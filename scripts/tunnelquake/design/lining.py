"""What a designer reads first, per condition: the lining's section forces around the ring with their
envelopes, the ovaling, the section's capacity over the whole run, and the closed-form ovaling
methods for the run's free-field shear strain.

The forces come from tq-solid at every monitor sample (`tunnelquake.ring_forces`: N tension
positive, M positive with tension at the inner face). The capacity check (`design.capacity`) takes
N positive in compression and M positive stretching the bottom face; the lining's inner face is the
bottom, so it gets (−N, M).

Capacity over a history: the cracking and plain-concrete checks are evaluated at every section and
sample. The reinforced section's radial utilisation (the gauge of the convex M–N domain) is a
convex function of (N, M), so its largest value over all pairs is reached at a vertex of their
convex hull: it is evaluated there only. The constant-N utilisation is evaluated on the hull
vertices and the largest |M| of each of 64 bins of N.

The closed forms (Wang 1993, Penzien 2000: `design.ovaling`) give the racking of a circular lining
under vertically propagating shear waves alone; they are compared with the run's dynamic increments
(the forces less their value at the start of the shaking), which also hold the vertical motion's
and, in condition 3, the water's share.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import ovaling as ov
from .angles import crown_angle
from .capacity import Concrete, DesignParameters, design_mapping

#: bins of N for the constant-N utilisation's candidates (besides the hull vertices)
N_BINS = 64


def design_parameters(case) -> tuple[DesignParameters | None, str]:
    """The case's `design:` block, or, without one, the lining material's strengths taken as the
    characteristic values (fck = compressive_strength, fctm = tensile_strength) with EN 1992-1-1's
    recommended factors; and a sentence saying which. Without either there is nothing to check the
    forces against: (None, the reason), and the capacity checks are skipped."""
    raw = design_mapping(case.data)
    if raw is not None:
        return DesignParameters.from_mapping(raw), "the case's design block"
    lin = case.data["materials"]["lining"]
    fck, fct = lin.get("compressive_strength"), lin.get("tensile_strength")
    if not fck:
        return None, ("capacity checks skipped: no design block and no materials.lining.compressive_strength to "
                      "take as fck (add design: {concrete: {fck: 30 MPa}} to check the section)")
    p = DesignParameters(concrete=Concrete(fck=float(fck), fctm=float(fct) if fct else None))
    said = f"no design block: the lining's compressive strength {fck / 1e6:.3g} MPa as fck"
    said += f" and its tensile strength {fct / 1e6:.3g} MPa as fctm" if fct else ", fctm from fck (Table 3.1)"
    return p, said


@dataclass(frozen=True)
class Combination:
    """The seismic design situation (EN 1990 eq. 6.12b): E_d = γ_G E_G + ψ2 E_W + γ_I ΔE_seismic, the
    static state split into the lining's own and the ground's load G (the no-water condition's state
    at the seismic start) and the water's W (the wet condition's minus it), ΔE the run's change from
    its state at the seismic start. Without the no-water condition the whole static state takes γ_G."""

    gamma_G: float = 1.0
    psi2_water: float = 1.0
    gamma_I: float = 1.0

    @classmethod
    def from_case(cls, d: dict) -> Combination:
        raw = ((d.get("design") or {}).get("seismic_situation")) or {}
        return cls(**{k: float(v) for k, v in raw.items() if v is not None})

    def words(self) -> str:
        return (f"E_d = γ_G E_G + ψ2 E_W + γ_I ΔE with γ_G {self.gamma_G:g}, ψ2 {self.psi2_water:g} (the water), "
                f"γ_I {self.gamma_I:g} (keys design.seismic_situation.gamma_G, psi2_water, gamma_I; EN 1990 "
                "eq. 6.12b, EN 1998-1 §4.2.5)")

    def apply(self, now: np.ndarray, static: np.ndarray, dry: np.ndarray | None) -> np.ndarray:
        """The design value of a history [T, S] whose state at the seismic start is `static` [S];
        `dry` [S]: the same quantity's static state without water (None: the whole static state is G)."""
        G = static if dry is None else dry
        W = np.zeros_like(static) if dry is None else static - dry
        return self.gamma_G * G + self.psi2_water * W + self.gamma_I * (now - static)


@dataclass
class Extreme:
    value: float
    angle: float  # deg from the crown towards +x (crown_angle)
    time: float
    where: str = ""  # more of the place, e.g. the face


@dataclass
class CrackSettings:
    """What the crack width needs beyond the capacity's parameters: the bars' diameter, the
    concrete's modulus (the analysis' lining E), and the limit (None: widths without a verdict)."""

    bar_diameter: float
    Ec: float
    limit: float | None = None


@dataclass
class ConditionDesign:
    condition: str
    ring_index: int
    thickness: float
    radius: float  # mid-surface radius, m
    extremes: dict[str, tuple[Extreme, Extreme]]  # quantity -> (max, min)
    ovaling: tuple[Extreme, Extreme] | None  # largest elongation, largest shortening (m)
    utilisation: dict[str, Extreme]  # check -> the largest utilisation, where and when
    increments: dict[str, float] = field(default_factory=dict)  # max |N - N0|, |M - M0|, |V - V0|
    # The largest |design - free-body| of N, M, V over the sections and samples, and max |N|, max |M|
    # of the design forces (their scales); empty when the file has no free-body forces.
    free_body_difference: dict[str, float] = field(default_factory=dict)
    # the state at the seismic start: quantity -> (max, min) over the sections (time: the first sample)
    static: dict[str, tuple[Extreme, Extreme]] = field(default_factory=dict)
    # the seismic design situation's forces: quantity -> (max, min); and how the static part was split
    combined: dict[str, tuple[Extreme, Extreme]] = field(default_factory=dict)
    split: str = ""
    # crack width (m): 'static' (k_t long-term) and 'seismic' (k_t short-term) -> the largest
    crack: dict[str, Extreme] = field(default_factory=dict)
    crack_limit: float | None = None
    skipped: list[str] = field(default_factory=list)  # checks not made, each with why
    # per section (angles from the crown, deg): the design forces' envelopes {q: (max [S], min [S])}
    # and the static state {q: [S]}; the demand pairs (N compression +, M) for the M–N diagram
    angles: np.ndarray | None = None
    envelope: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    static_forces: dict[str, np.ndarray] = field(default_factory=dict)
    demand: tuple[np.ndarray, np.ndarray] | None = None
    # the ring's diameters: direction from the crown (deg) [D], the times [T] and each one's change
    # relative to the seismic start [T, D] (m), for the deformed lining
    diameter: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    # the analysis' own crack pattern (a reinforced_concrete lining): the largest damage D at the
    # snapshots, its angle, the first snapshot time with a crack, and how many sections have cracked
    analysis_crack: Extreme | None = None

    def governing_time(self) -> float | None:
        """The time of the largest finite utilisation (the summary's governing check), else of the
        largest diameter change; None with neither."""
        finite = [e for e in self.utilisation.values() if math.isfinite(e.value)]
        if finite:
            return max(finite, key=lambda e: e.value).time
        if self.diameter is not None:
            i = int(np.unravel_index(int(np.argmax(np.abs(self.diameter[2]))), self.diameter[2].shape)[0])
            return float(self.diameter[1][i])
        return None


def _pick_ring(rings, monitors: dict):
    if len(rings) == 1:
        return rings[0]
    ys = [p[1] for p in (monitors or {}).values() if p is not None]
    y = float(np.mean(ys)) if ys else 0.5 * (rings[0].y_min + rings[-1].y_max)
    return min(rings, key=lambda r: abs(0.5 * (r.y_min + r.y_max) - y))


def _extreme(values: np.ndarray, angle: np.ndarray, time: np.ndarray, largest: bool) -> Extreme:
    k = int(np.argmax(values) if largest else np.argmin(values))
    i, j = np.unravel_index(k, values.shape)
    return Extreme(float(values[i, j]), float(crown_angle(angle[j])), float(time[i]))


def _hull_candidates(N: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Indices of the (N, M) pairs where a convex function of them can be largest, plus the largest
    |M| per bin of N."""
    pts = np.c_[N, M]
    idx = set()
    scale = np.ptp(pts, axis=0)
    if pts.shape[0] >= 3 and np.all(scale > 0):
        from scipy.spatial import ConvexHull

        idx.update(ConvexHull(pts / scale).vertices.tolist())
    else:
        idx.update(range(pts.shape[0]))
    edges = np.linspace(N.min(), N.max(), N_BINS + 1)
    which = np.clip(np.searchsorted(edges, N, side="right") - 1, 0, N_BINS - 1)
    absM = np.abs(M)
    for b in np.unique(which):
        members = np.flatnonzero(which == b)
        idx.add(int(members[np.argmax(absM[members])]))
    return np.array(sorted(idx))


def static_state(path: Path, monitors: dict):
    """The ring's N, M, V [S] at the seismic start (the first sample), or None."""
    from ..ring_forces import read_ring_forces

    rings = [r for r in read_ring_forces(path) if r.time.size > 0 and r.N.size > 0]
    if not rings:
        return None
    r = _pick_ring(rings, monitors)
    return {q: getattr(r, q)[0].astype(float) for q in ("N", "M", "V")}


def analysis_cracks(path: Path, condition: str, ring) -> tuple[np.ndarray, np.ndarray] | None:
    """The analysis' own crack pattern at the sections of `ring`: the field snapshots' times [K] and,
    per snapshot, the largest damage D (a reinforced_concrete lining's concrete cracked in tension;
    D never decreases) of the middle section's lining elements whose centre lies nearest each
    section's angle [K, S]. None without snapshots that hold the lining's damage."""
    import h5py

    from ..post import damage_section, read_condition

    res = read_condition(path, condition)
    if res.mesh is None or not res.snapshots:
        return None
    times, rows = [], []
    c, conn = res.mesh["coordinates"], res.mesh["connectivity"]
    with h5py.File(path, "r") as f:  # the damage alone of each snapshot
        damage = {key: f[f"snapshots/{key}/damage"][...] for key, _ in res.snapshots
                  if f"snapshots/{key}/damage" in f}
    for key, t in res.snapshots:
        if key not in damage:
            return None
        _, d, sel = damage_section(res, {"damage": damage[key]})
        if d.size == 0:
            return None
        ctr = c[conn[sel]].mean(axis=1)
        th = np.arctan2(ctr[:, 2] - ring.centre[1], ctr[:, 0] - ring.centre[0])  # as the sections' angles
        j = np.argmin(np.abs((th[:, None] - ring.angle[None, :] + np.pi) % (2 * np.pi) - np.pi), axis=1)
        per = np.zeros(ring.angle.size)
        np.maximum.at(per, j, np.asarray(d, float))
        times.append(t)
        rows.append(per)
    return np.asarray(times), np.asarray(rows)


def cracked_at(cracks: tuple[np.ndarray, np.ndarray], time: np.ndarray) -> np.ndarray:
    """[T, S]: whether each section had cracked in the analysis by each sample time, as the latest
    field snapshot at or before it records (a crack between two snapshots counts from the later)."""
    times, D = cracks
    k = np.searchsorted(times, np.asarray(time, float) + 1e-9 * max(1.0, float(np.max(times))), side="right") - 1
    out = np.zeros((np.size(time), D.shape[1]), bool)
    ok = k >= 0
    out[ok] = D[k[ok]] > 0
    return out


def _crack_extreme(sec, Nc, Mc, kt, angle, time, cracked=None) -> Extreme:
    from .cracking import CrackSection  # noqa: F401 - sec is one

    w = sec.crack_width(Nc, Mc, kt, cracked)
    both = np.stack([w["w_bottom"], w["w_top"]])
    f, i, j = np.unravel_index(int(np.argmax(both)), both.shape)
    if not both[f, i, j] > 0:  # why there is none
        return Extreme(0.0, 0.0, 0.0, "no stretched bars at a cracked section" if cracked is not None and
                       np.any(cracked) else "uncracked: σ_t ≤ f_ctm")
    return Extreme(float(both[f, i, j]), float(crown_angle(angle[j])), float(time[i]),
                   "inner face" if f == 0 else "outer face")


def condition_design(path: Path, condition: str, monitors: dict, params: DesignParameters | None,
                     combination: Combination | None = None, dry: dict | None = None,
                     crack: CrackSettings | None = None, skipped: str = "",
                     bars_in_analysis: bool = False) -> ConditionDesign | None:
    """The designer's quantities of one condition's ring forces. `params` None: forces only (the
    checks skipped, `skipped` says why). `dry`: the no-water condition's static state (static_state)
    to split the static state into G and water for the combination. `bars_in_analysis`: the lining
    is reinforced_concrete, so its crack pattern (analysis_cracks) says where it has cracked: there the
    cracking check reports the crack and the crack width takes the section as cracked."""
    from ..ring_forces import read_ring_forces

    rings = [r for r in read_ring_forces(path) if r.time.size > 0 and r.N.size > 0]
    if not rings:
        return None
    r = _pick_ring(rings, monitors)
    h = r.r_outer - r.r_inner
    ext = {q: (_extreme(getattr(r, q), r.angle, r.time, True), _extreme(getattr(r, q), r.angle, r.time, False))
           for q in ("N", "M", "V")}
    ovl = None
    if r.diameter_change.size:
        ovl = (_extreme(r.diameter_change, r.diameter_angle, r.time, True),
               _extreme(r.diameter_change, r.diameter_angle, r.time, False))
    static = {q: (_extreme(getattr(r, q)[:1], r.angle, r.time[:1], True),
                  _extreme(getattr(r, q)[:1], r.angle, r.time[:1], False)) for q in ("N", "M", "V")}
    combination = combination or Combination()
    use_dry = dry is not None and condition != "no_water" and all(dry[q].shape == getattr(r, q)[0].shape
                                                                  for q in ("N", "M", "V"))
    des = {q: combination.apply(getattr(r, q).astype(float), getattr(r, q)[0].astype(float),
                                dry[q] if use_dry else None) for q in ("N", "M", "V")}
    split = ("G from the no-water condition's state at the seismic start, the water's part the rest" if use_dry
             else "the whole static state taken as G" if condition != "no_water" else "no water: the static state is G")
    comb = {q: (_extreme(des[q], r.angle, r.time, True), _extreme(des[q], r.angle, r.time, False))
            for q in ("N", "M", "V")}
    inc = {q: float(np.max(np.abs(getattr(r, q) - getattr(r, q)[0]))) for q in ("N", "M", "V")}
    out = ConditionDesign(condition, r.index, h, r.r_mid, ext, ovl, {}, inc, free_body_difference(r),
                          static=static, combined=comb, split=split, angles=crown_angle(r.angle),
                          envelope={q: (des[q].max(axis=0), des[q].min(axis=0)) for q in ("N", "M", "V")},
                          static_forces={q: des[q][0] for q in ("N", "M", "V")})
    cand = _hull_candidates(-des["N"].ravel(), des["M"].ravel())
    out.demand = (-des["N"].ravel()[cand], des["M"].ravel()[cand])
    if r.diameter_change.size:
        out.diameter = (crown_angle(r.diameter_angle), r.time, r.diameter_change)
    if params is None:
        out.skipped.append(skipped)
        return out
    Nc, Mc = -des["N"], des["M"]  # the capacity check's signs: compression positive, the inner face at the bottom
    util = {}
    if params.reinforced:
        flatN, flatM = Nc.ravel(), Mc.ravel()
        cand = _hull_candidates(flatN, flatM)
        sec = params.section(h)
        u = (sec.utilisation_radial(flatN[cand], flatM[cand]) if params.utilisation == "radial"
             else sec.utilisation_constant_N(flatN[cand], flatM[cand]))
        k = int(cand[int(np.argmax(u))])
        i, j = np.unravel_index(k, Nc.shape)
        util[f"reinforced M–N ({params.utilisation})"] = Extreme(float(np.max(u)), float(crown_angle(r.angle[j])),
                                                                float(r.time[i]))
        checks = params.concrete_checks(Nc, Mc, h)
        util["cracking"] = _extreme(checks["cracking"].utilisation, r.angle, r.time, True)
        cracks = analysis_cracks(path, condition, r) if bars_in_analysis else None
        mask = None
        if cracks is not None and float(np.max(cracks[1])) > 0:
            k, j = np.unravel_index(int(np.argmax(cracks[1])), cracks[1].shape)
            first = int(np.argmax(np.any(cracks[1] > 0, axis=1)))
            out.analysis_crack = Extreme(float(cracks[1][k, j]), float(crown_angle(r.angle[j])), float(cracks[0][first]),
                                         f"{int(np.count_nonzero(cracks[1][-1] > 0))} of {r.angle.size} sections")
            mask = cracked_at(cracks, r.time)
        if crack is None:
            out.skipped.append("crack width skipped: no design.reinforcement.bar_diameter")
        else:
            from .cracking import KT_LONG, KT_SHORT, CrackSection

            rf = params.reinforcement
            cs = CrackSection(h, params.As_outer, params.As_inner, params.axis_distance, params.axis_distance,
                              crack.bar_diameter, crack.Ec, rf.Es, params.concrete.fctm_value)
            s0 = {q: des[q][:1] for q in ("N", "M")}
            try:
                out.crack["static (k_t 0.4, long-term)"] = _crack_extreme(cs, -s0["N"], s0["M"], KT_LONG, r.angle,
                                                                          r.time[:1],
                                                                          None if mask is None else mask[:1])
                out.crack["seismic situation (k_t 0.6, short-term)"] = _crack_extreme(cs, Nc, Mc, KT_SHORT, r.angle,
                                                                                      r.time, mask)
            except ValueError as e:  # a section the cracked analysis cannot take: said, the rest kept
                out.crack.clear()
                out.skipped.append(f"crack width not computed: {e}")
            out.crack_limit = crack.limit
    else:
        checks = params.concrete_checks(Nc, Mc, h)
        util["cracking"] = _extreme(checks["cracking"].utilisation, r.angle, r.time, True)
        plain = np.where(np.isfinite(checks["plain"].utilisation), checks["plain"].utilisation, np.inf)
        e = _extreme(plain, r.angle, r.time, True)
        if not math.isfinite(e.value):  # where the section has none left: say the force that takes it away
            out_of = ~np.isfinite(plain)
            worst = np.where(out_of, -Nc, -np.inf)  # the largest net tension among them
            e = _extreme(worst, r.angle, r.time, True)
            e = Extreme(math.inf, e.angle, e.time, f"N = {e.value / 1e3:+.3g} kN/m (tension +)" if e.value > 0 else
                        "the eccentricity |M/N| reaches h/2")
        util["plain concrete (EN 1992-1-1 §12.6.1)"] = e
    out.utilisation = util
    return out


def free_body_difference(ring) -> dict[str, float]:
    """The largest |design - free-body| of N, M and V over the ring's sections and samples (keys N, M, V)
    with the design forces' max |N| and max |M| (keys max|N|, max|M|); empty without free-body forces.
    M is NaN with one element through the thickness."""
    fb = ring.free_body
    if fb is None or fb.N.shape != ring.N.shape or ring.N.size == 0:
        return {}
    out = {q: float(np.max(np.abs(getattr(ring, q) - getattr(fb, q)))) for q in ("N", "M", "V")}
    out["max|N|"], out["max|M|"] = float(np.max(np.abs(ring.N))), float(np.max(np.abs(ring.M)))
    return out


def free_field_shear_strain(case, motion_file: Path) -> tuple[float, float, float]:
    """γ_max = PGV / c_s of the rock (Wang 1993: vertically propagating shear waves), PGV the outcrop
    record's peak velocity (twice the incident wave's; at depth the free field is at most that).
    Returns (γ_max, PGV, c_s)."""
    import h5py

    rock = case.data["materials"]["rock"]
    G = rock["youngs_modulus"] / (2 * (1 + rock["poisson_ratio"]))
    cs = math.sqrt(G / rock["density"])
    with h5py.File(motion_file, "r") as f:
        dt = float(f.attrs["dt"])
        ax = np.asarray(f["incident_ax"][...], float)
    from ..motion import integrate

    pgv = 2.0 * float(np.max(np.abs(integrate(ax, dt)[0])))
    return pgv / cs, pgv, cs


def condition_jacking(res, case, reach: float | None = None) -> dict:
    """Hydraulic jacking of one wet condition from its field snapshots: 'static' (the snapshot at
    the seismic start, within two samples of it) and 'seismic' (the smallest over the later
    snapshots), each a JackingResult or a sentence saying why there is none."""
    from .. import post as P
    from .jacking import jacking

    d = case.data
    g = d["geometry"]
    w = d["water"]
    reach = g["excavated_radius"] if reach is None else reach
    out: dict = {}
    if res.mesh is None or not res.snapshots:
        return {"static": "no field snapshot in the results", "seismic": "no field snapshot in the results"}
    regions = res.mesh.get("regions") or []
    region = res.mesh.get("region")
    conn, xyz = res.mesh["connectivity"], res.mesh["coordinates"]
    cent = xyz[conn].mean(axis=1)
    rock = np.ones(conn.shape[0], bool) if region is None else region != (regions.index("lining") if "lining" in
                                                                           regions else -1)
    if d["mesh"]["mode"] != "slice":
        y0 = P._section_y(res)
        dist = np.abs(cent[:, 1] - y0)
        rock &= dist <= dist[rock].min() + 1e-6 * max(1.0, float(np.ptp(xyz[:, 1])))
    t0 = min((float(mo.time[0]) for mo in res.monitors.values() if mo.time.size), default=0.0)
    dt = float(d["output"]["history_interval"])
    args = ((g["tunnel_centre_x"], g["tunnel_centre_z"]), g["excavated_radius"], reach, w["head"], w["density"],
            d["in_situ"]["gravity"])
    worst = None
    for key, t in res.snapshots:
        snap = P.read_snapshot(res, key)
        if "stress" not in snap:
            continue
        j = jacking(cent[rock], snap["stress"][rock], *args, time=t)
        if j is None:
            continue
        if t <= t0 + 2 * dt and "static" not in out:
            out["static"] = j
        elif worst is None or j.ratio < worst.ratio:
            worst = j
    out.setdefault("static", "no field snapshot at the seismic start (output.snapshot_times without 0 s)")
    out["seismic"] = worst if worst is not None else "no field snapshot in the shaking"
    return out


def interface_note(res) -> str:
    """How many rock–lining pairs have a broken bond at the last snapshot, in words ('' without
    interface pairs or snapshots)."""
    from .. import post as P

    if res.interface is None or not res.snapshots:
        return ""
    snap = P.read_snapshot(res, res.snapshots[-1][0])
    failed = (snap.get("interface") or {}).get("failed")
    if failed is None or not np.size(failed):
        return ""
    n, k = int(np.size(failed)), int(np.count_nonzero(failed))
    return (f"rock–lining interface: the bond of {k} of {n} pairs broken by t = {snap['time']:.3f} s"
            + (" (the lining and the rock no longer act as one there: figure fig10). The peaks after the "
               "first pair lets go depend on the step in which each pair fails: a step 1 % shorter can move "
               "them by tens of per cent (docs/solid_solver.md, \"Subcycling\"), so read them as one "
               "realisation, not to three digits" if k else ""))


def _verdict(u: float) -> str:
    return "passes" if u <= 1 else "**fails**"


@dataclass
class LiningDesign:
    """The designer's summary of the runs; `report_lines()` gives its markdown, `summary_lines()` the
    table per condition a designer reads first."""

    conditions: list[ConditionDesign]
    params: DesignParameters | None
    source: str
    closed_forms: list[ov.Ovaling] = field(default_factory=list)
    gamma: tuple[float, float, float] | None = None
    missing: list[str] = field(default_factory=list)
    combination: Combination = field(default_factory=Combination)
    jacking: dict[str, dict] = field(default_factory=dict)  # condition -> condition_jacking
    jacking_reach: float | None = None
    notes: dict[str, list[str]] = field(default_factory=dict)  # condition -> what else the designer must know
    bars_in_analysis: bool = False  # the lining is `reinforced_concrete`: its forces come from the bars too

    ANGLES = ("Angles: degrees about the tunnel axis from the crown (0°) towards +x (springline +x 90°, "
              "invert 180°, springline −x −90°), for the monitors, the section forces and the checks alike.")

    def _rows(self, c: ConditionDesign) -> list[tuple[str, str, str, str, str, str]]:
        """(check, value, where, when, verdict, note) rows of one condition."""
        rows = []
        for name, e in c.utilisation.items():
            if name == "cracking" and c.analysis_crack is not None:
                a = c.analysis_crack
                verdict = (f"cracked in the analysis (damage up to {a.value:.2g} at {a.angle + 0.0:.0f}°, {a.where}, "
                           f"from t = {a.time:.3f} s)")
            elif name == "cracking":
                verdict = "cracks (serviceability)" if e.value > 1 else "uncracked"
            else:
                verdict = _verdict(e.value)
            val = (f"no resistance left: {e.where}" if not math.isfinite(e.value) else f"{e.value:.3g}")
            rows.append((name, val, f"{e.angle:.0f}°", f"{e.time:.3f}", verdict, ""))
        for name, e in c.crack.items():
            lim = c.crack_limit
            if e.value == 0:
                rows.append((f"crack width, {name}", f"0 ({e.where})", "", "", "passes", ""))
                continue
            verdict = (_verdict(e.value / lim) if lim else "no limit given (design.crack_width_limit)")
            rows.append((f"crack width, {name}", f"{e.value * 1e3:.3g} mm" + (f" ({e.value / lim:.3g} of "
                         f"{lim * 1e3:.3g} mm)" if lim else ""), f"{e.angle:.0f}°, {e.where}", f"{e.time:.3f}",
                         verdict, ""))
        for when, j in (self.jacking.get(c.condition) or {}).items():
            if isinstance(j, str):
                rows.append((f"hydraulic jacking, {when}", "—", "", "", "not checked: " + j, ""))
                continue
            rows.append((f"hydraulic jacking, {when}: σ_min / p_w", f"{j.ratio:.3g} ({j.sigma_min / 1e6:.3g} / "
                         f"{j.p_w / 1e6:.3g} MPa)", f"{j.angle:.0f}°, {j.distance:.2f} m into the rock",
                         f"{j.time:.3f}", "passes" if j.ratio >= 1 else "**fails**", ""))
        return rows

    def summary_lines(self) -> list[str]:
        """Per condition: the governing check (the largest utilisation that has a verdict), then
        every check with where, when and its verdict."""
        out = ["## Design summary", "", self.ANGLES, ""]
        said = set()
        if self.params is None:
            out += [f"- {self.source}", ""]
            said.add(self.source)
        for c in self.conditions:
            rows = self._rows(c)
            ranked = []
            for name, e in c.utilisation.items():
                if name != "cracking":
                    ranked.append((e.value, name, e))
            for name, e in c.crack.items():
                if c.crack_limit:
                    ranked.append((e.value / c.crack_limit, f"crack width, {name}", e))
            for when, j in (self.jacking.get(c.condition) or {}).items():
                if not isinstance(j, str):
                    ranked.append((1.0 / j.ratio if j.ratio > 0 else math.inf, f"hydraulic jacking, {when}", j))
            s0 = c.static
            out += [f"### {c.condition}", "",
                    f"Static state at the seismic start (tension positive): N₀ {s0['N'][1].value / 1e3:.4g} kN/m at "
                    f"{s0['N'][1].angle:.0f}° to {s0['N'][0].value / 1e3:.4g} kN/m at {s0['N'][0].angle:.0f}°, "
                    f"M₀ {s0['M'][1].value / 1e3:.4g} kN m/m at {s0['M'][1].angle:.0f}° to "
                    f"{s0['M'][0].value / 1e3:.4g} kN m/m at {s0['M'][0].angle:.0f}°.", ""]
            if ranked:
                u, name, e = max(ranked, key=lambda x: x[0])
                verdict = _verdict(u)
                own = (f" (σ_min / p_w {e.ratio:.3g})" if hasattr(e, "ratio") else
                       f" ({e.value * 1e3:.3g} mm)" if name.startswith("crack") else "")
                out += [f"Governing: **{name}**, utilisation {u:.3g}{own} at {e.angle:.0f}°, t = {e.time:.3f} s: "
                        f"{verdict}.", ""]
            if rows:
                out += ["| check | value | where | time (s) | verdict |", "|---|---:|---|---:|---|"]
                out += [f"| {a} | {b} | {w} | {t} | {v} |" for a, b, w, t, v, _ in rows] + [""]
            out += [f"- {x}" for x in c.skipped if x and x not in said]
            out += [f"- {x}" for x in self.notes.get(c.condition, [])]
            note = self._ultimate_beside_uncracked(c)
            out += [f"- {note}"] if note else []
            out += [""] if out[-1] != "" else []
        return out

    @staticmethod
    def _ultimate_beside_uncracked(c: ConditionDesign) -> str:
        """Why a failing reinforced M–N row and an 'uncracked' cracking row are no contradiction."""
        mn = next((e for k, e in c.utilisation.items() if k.startswith("reinforced M–N")), None)
        cr = c.utilisation.get("cracking")
        if mn is None or cr is None or not mn.value > 1 or cr.value > 1 or c.analysis_crack is not None:
            return ""
        return (f"The reinforced M–N check fails ({mn.value:.3g} at {mn.angle:.0f}°, t = {mn.time:.3f} s) where the "
                f"cracking check finds the section uncracked ({cr.value:.3g}): two limit states, not a contradiction. "
                "The M–N resistance is the ultimate one, without the concrete's tensile strength (EN 1992-1-1 "
                "§6.1(2)) and with the bars at f_yk/γ_s; the cracking check sets the section's tension against "
                "f_ctm. Should the lining crack (a lower tensile strength, shrinkage, a joint), the bars alone "
                "cannot carry this demand: more reinforcement is needed.")

    def inputs_lines(self) -> list[str]:
        """The design inputs that shaped the answer."""
        p = self.params
        out = ["Design inputs: " + (f"capacity to {p.code} ({self.source}; γc {p.gamma_c:g}, γs {p.gamma_s:g}, "
                                    f"fck {p.concrete.fck / 1e6:.3g} MPa, fctm {p.concrete.fctm_value / 1e6:.3g} MPa"
                                    if p is not None else "no capacity check (the design summary says why")]
        if p is not None and p.reinforced:
            r = p.reinforcement
            out[0] += (f", As inner {p.As_inner * 1e6:.4g} mm²/m, As outer {p.As_outer * 1e6:.4g} mm²/m, axis distance "
                       f"{p.axis_distance * 1e3:.3g} mm, fyk {r.fyk / 1e6:.3g} MPa, Es {r.Es / 1e9:.3g} GPa")
        elif p is not None:
            out[0] += ", plain concrete"
        out[0] += ("); combination: " + self.combination.words() + ".")
        if p is not None and p.reinforced and self.bars_in_analysis:
            out[0] += (" The reinforcement is in the analysis too (lining model reinforced_concrete: bars smeared in "
                       "the lining's elements, concrete cracking with tension stiffening), so N, M, V come from the "
                       "cracked reinforced section; the crack widths from the cracked section under them.")
        elif p is not None and p.reinforced:
            out[0] += (" The reinforcement is in the check only, not in the analysis: the forces come from a lining "
                       "without bars, and the steel strains (crack widths) from the cracked section under them.")
        return out + [""]

    def report_lines(self) -> list[str]:
        out = [f"Section forces per metre of tunnel, integrated through the lining's thickness at each of the "
               f"ring's sections at every monitor sample (tq-solid); N tension positive, M positive with tension at "
               f"the inner face. {self.ANGLES}", ""]
        out += self.inputs_lines()
        for c in self.conditions:
            out += [f"**{c.condition}** (ring {c.ring_index}, thickness {c.thickness:.3g} m, mid radius "
                    f"{c.radius:.3g} m)", "",
                    "| quantity | max | at | time (s) | min | at | time (s) | largest change in the shaking |",
                    "|---|---:|---:|---:|---:|---:|---:|---:|"]
            for q, unit, scale in (("N", "kN/m", 1e-3), ("M", "kN m/m", 1e-3), ("V", "kN/m", 1e-3)):
                hi, lo = c.extremes[q]
                out.append(f"| {q} ({unit}) | {hi.value * scale:.4g} | {hi.angle:.0f}° | {hi.time:.3f} | "
                           f"{lo.value * scale:.4g} | {lo.angle:.0f}° | {lo.time:.3f} | {c.increments[q] * scale:.4g} |")
            if c.ovaling is not None:
                hi, lo = c.ovaling
                out.append(f"| diameter change (mm) | {hi.value * 1e3:.4g} | {hi.angle:.0f}° | {hi.time:.3f} | "
                           f"{lo.value * 1e3:.4g} | {lo.angle:.0f}° | {lo.time:.3f} | |")
            out += ["", f"Static state (at the seismic start) and the seismic design situation ({c.split}):", "",
                    "| quantity | static max | at | static min | at | design max | at | time (s) | design min | at "
                    "| time (s) |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
            for q, unit in (("N", "kN/m"), ("M", "kN m/m"), ("V", "kN/m")):
                (shi, slo), (dhi, dlo) = c.static[q], c.combined[q]
                out.append(f"| {q} ({unit}) | {shi.value / 1e3:.4g} | {shi.angle:.0f}° | {slo.value / 1e3:.4g} | "
                           f"{slo.angle:.0f}° | {dhi.value / 1e3:.4g} | {dhi.angle:.0f}° | {dhi.time:.3f} | "
                           f"{dlo.value / 1e3:.4g} | {dlo.angle:.0f}° | {dlo.time:.3f} |")
            rows = self._rows(c)
            if rows:
                out += ["", "| check | value | where | time (s) | verdict |", "|---|---:|---|---:|---|"]
                out += [f"| {a} | {b} | {w} | {t} | {v} |" for a, b, w, t, v, _ in rows]
            out += [""] + [f"- {x}" for x in c.skipped if x and x != self.source]
            out += [""] if out[-1] != "" else []
            d = c.free_body_difference
            if d and d["max|N|"] > 0:
                m = (f"{d['M'] / 1e3:.3g} kN m/m in M ({100 * d['M'] / d['max|M|']:.2g} % of max|M|)"
                     if math.isfinite(d["M"]) and d["max|M|"] > 0 else "M not compared (no moments)")
                out += [f"Equilibrium: over the run these design forces (stress resultants) differ from the ring's "
                        f"free-body forces, which balance its loads to round-off, by at most "
                        f"{100 * d['N'] / d['max|N|']:.2g} % (N) and {100 * d['V'] / d['max|N|']:.2g} % (V) of "
                        f"max|N| and {m}: the mesh's O(Δθ²) (in M mostly the radial-stress couple) and, in the "
                        "shaking, the one time step between them (docs/theory.md §7).", ""]
        if any(self.jacking.values()):
            out += [f"Hydraulic jacking: every rock element within {self.jacking_reach:.3g} m of the excavated wall; "
                    "σ_min the smallest compressive principal stress, p_w the water's static pressure at the element's "
                    "elevation, ρ_w g (head − (z − z_axis)); the field snapshots give the stresses (the first at the "
                    "seismic start: the static state).", ""]
        if self.gamma is not None and self.closed_forms:
            g, pgv, cs = self.gamma
            out += [f"Closed-form ovaling for the free-field shear strain γ_max = PGV / c_s = {pgv:.3g} / {cs:.4g} = "
                    f"{g:.3g} (outcrop peak velocity, rock shear-wave speed): the racking by vertically propagating "
                    "shear waves alone, against the largest changes of the run's forces in the shaking above.", "",
                    "| method | thrust (kN/m) | moment (kN m/m) | shear (kN/m) | diameter change (mm) |",
                    "|---|---:|---:|---:|---:|"]
            for o in self.closed_forms:
                out.append(f"| {o.method} | {o.thrust / 1e3:.4g} | {o.moment / 1e3:.4g} | {o.shear / 1e3:.4g} | "
                           f"{o.diameter_change * 1e3:.4g} |")
            out.append("")
        for m in self.missing:
            out += [f"- {m}", ""]
        return out


def crack_settings(case) -> CrackSettings | None:
    """The crack width's settings, None without design.reinforcement.bar_diameter."""
    des = case.data.get("design") or {}
    phi = (des.get("reinforcement") or {}).get("bar_diameter")
    if not phi:
        return None
    return CrackSettings(float(phi), float(case.data["materials"]["lining"]["youngs_modulus"]),
                         des.get("crack_width_limit"))


def _bars_in_analysis(case) -> bool:
    """Whether the analysis itself carries the bars (the lining's model is reinforced_concrete)."""
    return case.data["materials"]["lining"].get("model") == "reinforced_concrete"


def _condition_design(case, res, dry: dict | None):
    """condition_design of one condition's results `res` with the case's design settings."""
    params, source = design_parameters(case)
    return condition_design(Path(res.path), res.condition, case.data["output"].get("monitors") or {}, params,
                            Combination.from_case(case.data), dry, crack_settings(case),
                            skipped=source if params is None else "", bars_in_analysis=_bars_in_analysis(case))


def _jacks(case, res) -> bool:
    """Whether the hydraulic jacking check applies to `res`: a wet condition of a case with a head."""
    return res.condition != "no_water" and case.data["water"]["head"] > 0


def condition_parts(case, res, dry: dict | None) -> dict:
    """What lining_design computes of one condition alone, from its results (`res`) and the no-water
    condition's static state `dry` (static_state; None without it): its condition_design ("design")
    and, for a wet condition of a case with a head, its condition_jacking ("jacking")."""
    parts = {"design": _condition_design(case, res, dry)}
    if _jacks(case, res):
        parts["jacking"] = condition_jacking(res, case, case.data["geometry"]["excavated_radius"])
    return parts


def _same_state(a: dict | None, b: dict | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.keys() == b.keys() and all(np.array_equal(a[q], b[q]) for q in a)


def lining_design(case, results, known: dict | None = None) -> LiningDesign | None:
    """The designer's summary of the conditions whose results carry ring forces; None when none does.
    A case without strengths gets the forces without the checks, and one line saying why. `known`:
    {condition: (dry, condition_parts(case, res, dry))} computed earlier from the same results files
    (post_early.py); each is used where its `dry` is the static state used here (no_water's always),
    else computed again."""
    params, source = design_parameters(case)
    monitors = case.data["output"].get("monitors") or {}
    dry = next((static_state(Path(r.path), monitors) for r in results if r.condition == "no_water"), None)
    # no_water's own design does not use the dry state (condition_design)
    known = {c: parts for c, (state, parts) in (known or {}).items() if c == "no_water" or _same_state(state, dry)}
    done, missing = [], []
    for res in results:
        c = known[res.condition]["design"] if res.condition in known else _condition_design(case, res, dry)
        if c is None:
            from ..ring_forces import ring_forces_note

            missing.append(f"{res.condition}: no lining section forces ({ring_forces_note(res.path)})")
        else:
            done.append(c)
    if not done:
        return None
    design = LiningDesign(done, params, source, missing=missing, combination=Combination.from_case(case.data),
                          bars_in_analysis=_bars_in_analysis(case))
    design.jacking_reach = case.data["geometry"]["excavated_radius"]
    for res in results:
        if _jacks(case, res):
            design.jacking[res.condition] = (known[res.condition]["jacking"] if res.condition in known else
                                             condition_jacking(res, case, design.jacking_reach))
        note = interface_note(res) if hasattr(res, "interface") else ""
        if note:
            design.notes.setdefault(res.condition, []).append(note)
    motion = case.output_dir / "motion.h5"
    if motion.is_file():
        d = case.data
        rock, lin = d["materials"]["rock"], d["materials"]["lining"]
        design.gamma = free_field_shear_strain(case, motion)
        c0 = done[0]
        design.closed_forms = ov.all_methods(design.gamma[0], rock["youngs_modulus"], rock["poisson_ratio"],
                                             lin["youngs_modulus"], lin["poisson_ratio"], c0.thickness, c0.radius)
    return design
