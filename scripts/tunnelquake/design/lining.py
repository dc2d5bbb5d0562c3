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
from .capacity import Concrete, DesignParameters, design_mapping

#: bins of N for the constant-N utilisation's candidates (besides the hull vertices)
N_BINS = 64


def design_parameters(case) -> tuple[DesignParameters, str]:
    """The case's `design:` block, or, without one, the lining material's strengths taken as the
    characteristic values (fck = compressive_strength, fctm = tensile_strength) with EN 1992-1-1's
    recommended factors; and a sentence saying which."""
    raw = design_mapping(case.data)
    if raw is not None:
        return DesignParameters.from_mapping(raw), "the case's design block"
    lin = case.data["materials"]["lining"]
    fck, fct = lin.get("compressive_strength"), lin.get("tensile_strength")
    if not fck:
        raise ValueError("design: no design block and no materials.lining.compressive_strength to take as fck; "
                         "add design: {concrete: {fck: ...}}")
    p = DesignParameters(concrete=Concrete(fck=float(fck), fctm=float(fct) if fct else None))
    said = f"no design block: the lining's compressive strength {fck / 1e6:.3g} MPa as fck"
    said += f" and its tensile strength {fct / 1e6:.3g} MPa as fctm" if fct else ", fctm from fck (Table 3.1)"
    return p, said


@dataclass
class Extreme:
    value: float
    angle: float  # deg from +x towards +z (the crown at 90)
    time: float


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


def _pick_ring(rings, monitors: dict):
    if len(rings) == 1:
        return rings[0]
    ys = [p[1] for p in (monitors or {}).values() if p is not None]
    y = float(np.mean(ys)) if ys else 0.5 * (rings[0].y_min + rings[-1].y_max)
    return min(rings, key=lambda r: abs(0.5 * (r.y_min + r.y_max) - y))


def _extreme(values: np.ndarray, angle: np.ndarray, time: np.ndarray, largest: bool) -> Extreme:
    k = int(np.argmax(values) if largest else np.argmin(values))
    i, j = np.unravel_index(k, values.shape)
    return Extreme(float(values[i, j]), math.degrees(float(angle[j])), float(time[i]))


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


def condition_design(path: Path, condition: str, monitors: dict, params: DesignParameters) -> ConditionDesign | None:
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
    Nc, Mc = -r.N, r.M  # the capacity check's signs: compression positive, the inner face at the bottom
    checks = params.concrete_checks(Nc, Mc, h)  # every pair; the reinforced check on the hull below
    util = {"cracking": _extreme(checks["cracking"].utilisation, r.angle, r.time, True)}
    plain = np.where(np.isfinite(checks["plain"].utilisation), checks["plain"].utilisation, np.inf)
    util["plain concrete (EN 1992-1-1 §12.6.1)"] = _extreme(plain, r.angle, r.time, True)
    if params.reinforced:
        flatN, flatM = Nc.ravel(), Mc.ravel()
        cand = _hull_candidates(flatN, flatM)
        sec = params.section(h)
        u = (sec.utilisation_radial(flatN[cand], flatM[cand]) if params.utilisation == "radial"
             else sec.utilisation_constant_N(flatN[cand], flatM[cand]))
        k = int(cand[int(np.argmax(u))])
        i, j = np.unravel_index(k, Nc.shape)
        util[f"reinforced M–N ({params.utilisation})"] = Extreme(float(np.max(u)), math.degrees(float(r.angle[j])),
                                                                float(r.time[i]))
    inc = {q: float(np.max(np.abs(getattr(r, q) - getattr(r, q)[0]))) for q in ("N", "M", "V")}
    return ConditionDesign(condition, r.index, h, r.r_mid, ext, ovl, util, inc, free_body_difference(r))


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


@dataclass
class LiningDesign:
    """The designer's summary of the runs; `report_lines()` gives its markdown."""

    conditions: list[ConditionDesign]
    params: DesignParameters
    source: str
    closed_forms: list[ov.Ovaling] = field(default_factory=list)
    gamma: tuple[float, float, float] | None = None
    missing: list[str] = field(default_factory=list)

    def report_lines(self) -> list[str]:
        p = self.params
        out = [f"Section forces per metre of tunnel, integrated through the lining's thickness at each of the "
               f"ring's sections at every monitor sample (tq-solid); N tension positive, M positive with tension at "
               f"the inner face; angles from +x towards +z about the tunnel axis (crown 90°, invert 270°). Capacity "
               f"to {p.code} ({self.source}; γc {p.gamma_c:g}, γs {p.gamma_s:g}"
               + (", reinforced" if p.reinforced else ", plain concrete") + ").", ""]
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
            out += ["", "| check | largest utilisation | at | time (s) | verdict |", "|---|---:|---:|---:|---|"]
            for name, e in c.utilisation.items():
                verdict = "passes" if e.value <= 1 else ("cracks" if name == "cracking" else "**fails**")
                val = "no resistance" if not math.isfinite(e.value) else f"{e.value:.3g}"
                out.append(f"| {name} | {val} | {e.angle:.0f}° | {e.time:.3f} | {verdict} |")
            out.append("")
            d = c.free_body_difference
            if d and d["max|N|"] > 0:
                m = (f"{d['M'] / 1e3:.3g} kN m/m in M ({100 * d['M'] / d['max|M|']:.2g} % of max|M|)"
                     if math.isfinite(d["M"]) and d["max|M|"] > 0 else "M not compared (no moments)")
                out += [f"Equilibrium: over the run these design forces (stress resultants) differ from the ring's "
                        f"free-body forces, which balance its loads to round-off, by at most "
                        f"{100 * d['N'] / d['max|N|']:.2g} % (N) and {100 * d['V'] / d['max|N|']:.2g} % (V) of "
                        f"max|N| and {m}: the mesh's O(Δθ²) (in M mostly the radial-stress couple) and, in the "
                        "shaking, the one time step between them (docs/theory.md §7).", ""]
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


def lining_design(case, results) -> LiningDesign | None:
    """The designer's summary of the conditions whose results carry ring forces; None when none does."""
    params, source = design_parameters(case)
    monitors = case.data["output"].get("monitors") or {}
    done, missing = [], []
    for res in results:
        c = condition_design(Path(res.path), res.condition, monitors, params)
        if c is None:
            from ..ring_forces import ring_forces_note

            missing.append(f"{res.condition}: no lining section forces ({ring_forces_note(res.path)})")
        else:
            done.append(c)
    if not done:
        return None
    design = LiningDesign(done, params, source, missing=missing)
    motion = case.output_dir / "motion.h5"
    if motion.is_file():
        d = case.data
        rock, lin = d["materials"]["rock"], d["materials"]["lining"]
        design.gamma = free_field_shear_strain(case, motion)
        c0 = done[0]
        design.closed_forms = ov.all_methods(design.gamma[0], rock["youngs_modulus"], rock["poisson_ratio"],
                                             lin["youngs_modulus"], lin["poisson_ratio"], c0.thickness, c0.radius)
    return design
