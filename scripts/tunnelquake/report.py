"""The report of any case (report.md): the case as run (geometry, materials, water, monitors), the
input motion and its PGA, per condition a table of the monitors' peaks with their times, the
differences between conditions, the water side's cross-check, and the place of the lining forces.

Everything is read from the case and from what the runs wrote (results_<condition>.h5, motion.h5):
a quantity a condition does not have (the water pressure without water) is left out, never shown
as a blank number. A comparison with a published run is paper.py's, added after these sections
when the case asks for it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .post import CONDITION_LABELS, REFERENCE_WORDS, ConditionResult, peaks

#: Standard gravity, m/s^2, to state accelerations in g as well.
G = 9.80665


@dataclass(frozen=True)
class Quantity:
    key: str  # key in post.peaks
    label: str
    unit: str
    scale: float  # SI value x scale = shown value
    time_key: str  # key in post.peaks of the time of the peak


#: The quantities of the peak tables, in their order. Displacements are relative to the state at
#: the start of the shaking (tq-solid's monitors), the water pressure is its dynamic part (the
#: hydrostatic pressure is a static load of the solid).
QUANTITIES = (
    Quantity("max_ux", "max \\|u_x\\|", "mm", 1e3, "t_max_ux"),
    Quantity("max_uy", "max \\|u_y\\|", "mm", 1e3, "t_max_uy"),
    Quantity("max_uz", "max \\|u_z\\|", "mm", 1e3, "t_max_uz"),
    Quantity("max_tension", "max principal stress σ3", "MPa", 1e-6, "t_max_tension"),
    Quantity("min_sigma1", "min principal stress σ1", "MPa", 1e-6, "t_min_sigma1"),
    Quantity("max_damage", "max damage D", "", 1.0, "t_max_damage"),
    Quantity("hydrodynamic_pressure_peak", "peak \\|dynamic water pressure\\|", "MPa", 1e-6,
             "hydrodynamic_pressure_peak_time"),
)
#: Pairs of conditions whose peaks the report subtracts (later − earlier): what the static water
#: changes, what the water's motion changes, and both.
DIFFERENCES = (("static_water", "no_water"), ("dynamic_water", "static_water"), ("dynamic_water", "no_water"))


def fmt(v: float, digits: int = 4) -> str:
    """A value as the report shows it (`digits` significant digits)."""
    return f"{v:.{digits}g}"


def fmt_time(t: float) -> str:
    """A time as the report shows it, s."""
    return f"{t:.3f}"


def difference(x: float, y: float, scale: float) -> tuple[str, str]:
    """y − x as shown (scaled) and in % of |x|; "0" where the two agree to round-off (1e-9 of the
    larger), "—" for the % of a zero x."""
    d = y - x
    if abs(d) <= 1e-9 * max(abs(x), abs(y)):
        return "0", "0" if x != 0 else "—"
    return f"{d * scale:+.4g}", (f"{100 * d / abs(x):+.2f}" if x != 0 else "—")


def _head(q: Quantity) -> str:
    return f"{q.label} ({q.unit})" if q.unit else q.label


# ---- the case ---------------------------------------------------------------------------------

def motion_summary(path: Path) -> dict | None:
    """What motion.h5 says of the input: source, record name, points, dt, convention, processing
    steps, and the peaks of the record as processed (the outcrop's, twice the incident wave, for
    an outcrop record): `pga` (x) and, per component written, `peak_<c>` in m/s^2."""
    if not Path(path).is_file():
        return None
    import h5py

    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        conv = str(a.get("convention", "outcrop"))
        factor = 2.0 if conv == "outcrop" else 1.0
        out = {"source": str(a.get("source", "unknown")), "record_name": str(a.get("record_name", "")),
               "dt": float(a.get("dt", float("nan"))), "points": int(f["time"].size) if "time" in f else 0,
               "convention": conv, "processing": [s for s in str(a.get("processing", "")).splitlines() if s]}
        for c in "xyz":
            if f"incident_a{c}" in f and f[f"incident_a{c}"].size:
                out[f"peak_{c}"] = factor * float(np.max(np.abs(f[f"incident_a{c}"][...])))
        out["pga"] = out.get("peak_x")
    return out


def motion_section(motion: dict | None, figure: str | None) -> list[str]:
    if motion is None:
        return ["## Input motion", "", "No motion.h5 in the results folder (run `tunnelquake motion`).", ""]
    lines = ["## Input motion", "", f"- source: `{motion['source']}`"]
    if motion["record_name"]:
        lines.append(f"- record: {motion['record_name']}")
    lines.append(f"- {motion['points']} points at dt = {motion['dt']:g} s")
    where = "at the outcrop (the incident wave is half of it)" if motion["convention"] == "outcrop" else \
        "of the incident wave"
    for c, name in (("x", "PGA (x, horizontal)"), ("y", "peak (y, horizontal along the axis)"),
                    ("z", "peak (z, vertical)")):
        v = motion.get(f"peak_{c}")
        if v is not None and (c == "x" or v > 0):
            lines.append(f"- {name} {where}: {v:.4g} m/s² = {v / G:.4g} g")
    lines += [""] + [f"- {s}" for s in motion["processing"]] + [""]
    if figure:
        lines += [f"![input motion]({figure})", ""]
    return lines


def lining_radii(case) -> tuple[float, float]:
    """Inner and outer radius of the lining, m."""
    g = case.data["geometry"]
    return g["excavated_radius"] - g["lining_thickness"], g["excavated_radius"]


def monitor_place(case, point) -> tuple[float, float, str]:
    """(r from the tunnel axis in the x–z plane, angle from the crown towards +x in degrees, and
    lining / rock / water) of a monitor point."""
    g = case.data["geometry"]
    dx, dz = point[0] - g["tunnel_centre_x"], point[2] - g["tunnel_centre_z"]
    r = math.hypot(dx, dz)
    a, b = lining_radii(case)
    tol = 1e-6 * max(np.ptp(g["x_range"]), np.ptp(g["z_range"]))
    where = "lining" if a - tol <= r <= b + tol else ("rock" if r > b else "water")
    return r, math.degrees(math.atan2(dx, dz)), where


def _mpa(v) -> str:
    return "—" if v is None else f"{v / 1e6:.4g}"


def _portal_line(d: dict) -> list[str]:
    """The portal's geometry as meshed (geology.portal), none without one."""
    po = (d.get("geology") or {}).get("portal") or {}
    if po.get("station") is None:
        return []
    from .case import case_geology, ground_layers
    from .meshing.params import portal_bench, resolve

    plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    head = plan.zmax - plan.geology.slope.height
    return [f"- portal: the tunnel leaves the hillside through a face at y = {po['station']:g} m, looking towards -y; "
            f"in front of it the ground cut down to the bench z = {portal_bench(plan):g} m and the lining ended; the "
            f"face's head {head - plan.zc - plan.radius_outer:.4g} m over the crown, the slope above it "
            f"{po['slope_deg']:g}° (skew {po.get('skew_deg') or 0:g}°) up to z = {plan.zmax:g} m"]


def _half_block(d: dict) -> str:
    """The words for a half block (mesh.symmetry: mid_length), empty for a whole one."""
    from .case import half_block

    if not half_block(d):
        return ""
    y0, y1 = d["geometry"]["y_range"]
    mid = 0.5 * (y0 + y1)
    return (f", of which the half y {y0:g} … {mid:g} m is meshed (mesh.symmetry: mid_length): the scene is "
            f"symmetric about y = {mid:g} m, its plane of symmetry on rollers (u_y = 0)")


def case_section(case) -> list[str]:
    """Geometry, materials, water and monitors of the case as it ran."""
    d = case.data
    g = d["geometry"]
    a, b = lining_radii(case)
    lines = ["## The case", "",
             f"- tunnel: excavated radius {b:g} m (diameter {2 * b:g} m), lining {g['lining_thickness']:g} m thick "
             f"(inner radius {a:g} m), axis at x = {g['tunnel_centre_x']:g} m, z = {g['tunnel_centre_z']:g} m",
             f"- block: x {g['x_range'][0]:g} … {g['x_range'][1]:g} m, y {g['y_range'][0]:g} … {g['y_range'][1]:g} m, "
             f"z {g['z_range'][0]:g} … {g['z_range'][1]:g} m; mesh mode {d['mesh']['mode']}"
             + _half_block(d)]
    lines += _portal_line(d)
    w = d.get("water") or {}
    wet = [c for c in d["conditions"] if c != "no_water"]
    if wet:
        model = w.get("model", "")
        if model == "compressible":
            model += f", K = {w['bulk_modulus'] / 1e9:.3g} GPa"
        lines.append(f"- water ({', '.join(wet)}): head {w.get('head', 0):g} m at the axis, "
                     f"{w.get('density', 1000):g} kg/m³, {model}")
    lines += inputs_echo(d)
    lines += ["", "| material | model | E (GPa) | ν | ρ (kg/m³) | c (MPa) | φ (°) | σt (MPa) | σc (MPa) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for name, m in d["materials"].items():
        phi = "—" if m.get("friction_angle") is None else f"{m['friction_angle']:g}"
        lines.append(f"| {name} | {m['model']} | {m['youngs_modulus'] / 1e9:.4g} | {m['poisson_ratio']:g} | "
                     f"{m['density']:g} | {_mpa(m.get('cohesion'))} | {phi} | {_mpa(m.get('tensile_strength'))} | "
                     f"{_mpa(m.get('compressive_strength'))} |")
    lines += ["", "| monitor | x (m) | y (m) | z (m) | r from the axis (m) | angle from the crown (°) | in |",
              "|---|---|---|---|---|---|---|"]
    for name, p in (d["output"]["monitors"] or {}).items():
        r, ang, where = monitor_place(case, p)
        lines.append(f"| {name} | {p[0]:g} | {p[1]:g} | {p[2]:g} | {r:.4g} | {ang:.1f} | {where} |")
    if not d["output"]["monitors"]:
        lines.append("| (none: output.monitors is empty) | | | | | | |")
    return lines + [""]


def inputs_echo(d: dict) -> list[str]:
    """The other inputs that shaped the answer, as the run took them: the ground's layers, the
    in-situ stress ratios, the stages, the interface, the damping and the motion's components."""
    out = []
    layers = d.get("layers") or []
    if layers:
        out.append("- ground layers from the surface down: " + ", ".join(
            f"{x['material']} " + (f"to z = {x['bottom']:g} m" if x["bottom"] is not None else f"{x['thickness']:g} m")
            for x in layers) + "; below them the rock")
    ins, st = d["in_situ"], d["stages"]
    if "in_situ" in st["sequence"]:
        out.append(f"- in-situ stress: σx = {ins['kx']:g} σv, σy = {ins['ky']:g} σv, σz = {ins['kz']:g} σv (K0), "
                   f"gravity {ins['gravity']:g} m/s²")
    out.append(f"- stages: {', '.join(st['sequence'])}; release fraction {st['release_fraction']:g} before the lining")
    i = d["interface"]
    out.append(f"- rock–lining interface: {i['model']}" + (
        f", μs {i['static_friction']:g}, μd {i['dynamic_friction']:g}, cohesion {i['cohesion'] / 1e6:.3g} MPa, "
        f"{i['after_failure'].replace('_', ' ')} after failure" if i["model"] == "dynamic_contact" else ""))
    dm = d["damping"]
    out.append(f"- damping: {dm['model'].replace('_', ' ')}, ratio {dm['ratio']:g} at "
               + (f"{dm['frequencies'][0]:g} Hz" if dm["model"] == "mass_proportional" else
                  f"{dm['frequencies'][0]:g} and {dm['frequencies'][1]:g} Hz"))
    gm = d["ground_motion"]
    vert = ("a vertical record of its own" if gm["vertical"]["file"] is not None else
            f"vertical = {gm['vertical_ratio']:g} × the horizontal" if gm["vertical_ratio"] is not None else "none")
    out.append(f"- ground motion: {gm['source']}, azimuth {gm['azimuth']:g}°, {vert}"
               + (", a second horizontal record" if gm["second_horizontal"]["file"] is not None else "")
               + f", {gm['convention']} convention, low-pass {gm['cutoff_frequency']:g} Hz")
    if d["mesh"]["mode"] != "slice" and any(c != "no_water" for c in d["conditions"]):
        out.append(f"- water ends: {d['water']['ends']}")
    return out


def lining_tensile_strength(case) -> float | None:
    """The lining's tension cut-off σt (Pa), None when its model has none."""
    return (case.data["materials"].get("lining") or {}).get("tensile_strength")


# ---- peaks per condition ----------------------------------------------------------------------

def peak_table(res: ConditionResult, order: list[str], strength: float | None = None,
               places: dict[str, str] | None = None) -> list[str]:
    """The monitors' peaks of one condition with the time of each, a column pair per quantity the
    condition has (a quantity no monitor recorded is left out); with the lining's tensile strength,
    σ3 / σt for the monitors in the lining."""
    pk = peaks(res)
    names = [m for m in order if m in pk] + sorted(m for m in pk if m not in order)
    qs = [q for q in QUANTITIES if any(np.isfinite(pk[m].get(q.key, np.nan)) for m in names)]
    if "max_uy" in pk.get(names[0], {}) and all(pk[m].get("max_uy", 0.0) == 0.0 for m in names):
        qs = [q for q in qs if q.key != "max_uy"]  # a plane run: no y motion to show
    head = ["monitor"]
    for q in qs:
        head += [_head(q), "at t (s)"]
        if q.key == "max_tension" and strength:
            head.append("σ3 / σt (lining)")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for m in names:
        row = [m]
        for q in qs:
            v, t = pk[m].get(q.key, np.nan), pk[m].get(q.time_key, np.nan)
            if not np.isfinite(v):
                row += ["—", "—"]
            else:  # an undamaged monitor has no time of its damage
                row += [fmt(v * q.scale), fmt_time(t) if q.key != "max_damage" or v > 0 else "—"]
            if q.key == "max_tension" and strength:
                inside = places is None or places.get(m) == "lining"
                row.append(f"{v / strength:.3f}" if np.isfinite(v) and inside else "—")
        lines.append("| " + " | ".join(row) + " |")
    return lines


def peaks_section(results: list[ConditionResult], stopped: list[ConditionResult], order: list[str],
                  strength: float | None, places: dict[str, str] | None) -> list[str]:
    """Per condition: the peak table over the run's samples, or "no sample" for a run that stopped
    before the shaking."""
    ref = next((r.displacement_reference for r in results + stopped), "absolute")
    lines = ["## Peaks at the monitors", "",
             "Per condition, the largest value of each monitor's history and the time it is first reached. "
             f"Displacements are {REFERENCE_WORDS[ref]} (output.displacement_reference: {ref}), from the start of "
             "the shaking; σ3 is the most tensile principal stress, "
             "σ1 the most compressive (tension positive); the water pressure is the dynamic part acting on "
             "the lining (the hydrostatic part is a static load)."
             + (f" σt = {strength / 1e6:.4g} MPa is the lining's tensile strength." if strength else ""), ""]
    by = {r.condition: r for r in results + stopped}
    for cond in CONDITION_LABELS:
        res = by.get(cond)
        if res is None:
            continue
        if not res.monitors:
            lines += [f"### {CONDITION_LABELS[cond]}", "", "No monitor: output.monitors is empty.", ""]
            continue
        if not res.samples:
            lines += [f"### {CONDITION_LABELS[cond]}", "",
                      f"No sample: the run stopped before the shaking ({res.stage_state()}).", ""]
            continue
        t0 = float(min(mo.time[0] for mo in res.monitors.values()))
        lines += [f"### {CONDITION_LABELS[cond]}: {res.samples} samples, t = {fmt_time(t0)} … "
                  f"{fmt_time(res.t_end)} s", ""]
        lines += peak_table(res, order, strength, places) + [""]
    return lines


def differences_section(results: list[ConditionResult], order: list[str]) -> list[str]:
    """For each pair of DIFFERENCES both run, the change of every peak both conditions have, over
    the time both runs cover: the two values, their difference, and the difference in % of the
    first condition's value."""
    by = {r.condition: r for r in results}
    pairs = [(b, a) for b, a in DIFFERENCES if a in by and b in by]
    if not pairs:
        return []
    lines = ["## Differences between conditions", ""]
    for b, a in pairs:
        w = min(by[a].t_end, by[b].t_end)
        pa, pb = peaks(by[a], w), peaks(by[b], w)
        names = [m for m in order if m in pa and m in pb] + sorted(m for m in pa if m in pb and m not in order)
        lines += [f"### {CONDITION_LABELS[b]} − {CONDITION_LABELS[a]} (peaks over t ≤ {fmt_time(w)} s)", "",
                  f"| quantity | monitor | {a} | {b} | {b} − {a} | change (%) |", "|---|---|---|---|---|---|"]
        for q in QUANTITIES:
            for m in names:
                x, y = pa[m].get(q.key, np.nan), pb[m].get(q.key, np.nan)
                if not (np.isfinite(x) and np.isfinite(y)):
                    continue
                if q.key == "max_uy" and x == 0.0 and y == 0.0:
                    continue
                diff, pct = difference(x, y, q.scale)
                lines.append(f"| {_head(q)} | {m} | {fmt(x * q.scale)} | {fmt(y * q.scale)} | {diff} | {pct} |")
        lines.append("")
    return lines


# ---- the water side ---------------------------------------------------------------------------

def water_side_check(res: ConditionResult | None, fluid: dict | None, carried: bool = False) -> list[str]:
    """The pressure the lining is loaded with (the coupling's force at the monitors) against the
    water's own accepted area-mean wall pressure, over the time both cover. `carried`: tq-solid
    carries the enclosed water's uniform pressure (fluid_case.volume_law), so the water's own
    pressure is only the rest and the two are stated, not compared."""
    if res is None or fluid is None:
        return []
    mons = [mo for mo in res.monitors.values() if "water_pressure" in mo.extra]
    if not mons:
        return []
    if not (len(mons[0].extra["water_pressure_time"]) and len(fluid["time"])):
        return []  # a run stopped before either side wrote a sample: nothing to set side by side
    t_end = min(float(mons[0].extra["water_pressure_time"][-1]), float(fluid["time"][-1]))
    both = [mo.extra["water_pressure"][mo.extra["water_pressure_time"] <= t_end] for mo in mons]
    mine = fluid["p_mean"][fluid["time"] <= t_end]
    if not (mine.size and all(b.size for b in both)):
        return []  # the two cover no common time
    solid = max(float(np.max(np.abs(b))) for b in both)
    water = float(np.max(np.abs(mine)))
    scheme = res.coupling.get("scheme", "unknown")
    if carried:
        return ["## Water side cross-check", "",
                "tq-solid carries the enclosed water's uniform pressure (and, by default, its rigid translation) "
                "itself (coupling.volume_law: solid), and the monitors' hydrodynamic pressure includes that part; "
                "the water's own area-mean wall pressure (`dynamic_water/fluid/postProcessing/*/*/interface.dat`) "
                "is only what the water solver adds to it. Up to t = "
                f"{t_end:.2f} s the largest of the first at the monitors is {solid / 1e6:.4g} MPa, of the second "
                f"{water / 1e6:.4g} MPa (coupling scheme `{scheme}`): two different quantities, so their ratio is "
                "not a check of the coupling.", ""]
    out = ["## Water side cross-check", "",
           f"Up to t = {t_end:.2f} s the largest |hydrodynamic pressure| the coupling applies at the monitors is "
           f"{solid / 1e6:.4g} MPa; the water's own largest |area-mean wall pressure| over its accepted steps "
           f"(`dynamic_water/fluid/postProcessing/*/*/interface.dat`) is {water / 1e6:.4g} MPa: ratio "
           f"{solid / water:.2f} (coupling scheme `{scheme}`)." if water > 0 else
           f"The water's area-mean wall pressure stays 0 up to t = {t_end:.2f} s.", ""]
    if water > 0 and solid / water > 2:
        out += ["The lining is loaded well above what the water's accepted state holds: a local value can exceed "
                "the mean, but a ratio this large means the force the solid applies is not the water's answer "
                "to the accepted motion" + (" (with the `paper` scheme the solid applies the R3 of the "
                                            "predictor pass, docs/coupler.md)" if scheme == "paper" else "")
                + ". The hydrodynamic pressure figure shows both.", ""]
    return out


# ---- lining forces: the designer's section ------------------------------------------------------
#
# Per condition, the thrust N, moment M and shear V around the ring (envelopes), the ovaling, the
# capacity utilisation of the section, the largest difference of the design forces from the ring's
# free-body (equilibrium) forces and the closed-form ovaling (design/lining.py, from the ring forces
# tq-solid writes: ring_forces.py).

def design_quantities(case, results: list[ConditionResult], known: dict | None = None):
    """The design quantities of the runs (ring forces, envelopes, ovaling, capacity, the closed-form
    ovaling), or None when no results file carries lining section forces. `known`: conditions' parts
    computed earlier (design.lining.lining_design)."""
    from .design.lining import lining_design

    return lining_design(case, results, known)


def lining_forces_section(design=None) -> list[str]:
    """The report's "Lining forces" section from a design-quantities object; nothing when None.
    The object gives its own markdown lines (`report_lines()`), so the reader and the capacity
    check decide what they show."""
    if design is None:
        return []
    return ["## Lining forces", "", *design.report_lines(), ""]
