"""What a run left in the results folder -> figures, CSV monitors, ParaView files and report.md
(post_case). Needs no solver; works on whatever results exist: a results file cut off mid-run, one
stopped before the shaking (no monitor sample), an unreadable one, a condition never run. Each is
reported as found; a figure that cannot be drawn is named with the reason, never a traceback.
On a full disk every output that fits is still written (each in place only once complete) and
OutputsNotWritten names the rest."""
from __future__ import annotations

import errno
from pathlib import Path

import numpy as np

from .children import say
from .files import DiskFull, atomic_path, is_no_space
from .scene import plan


class OutputsNotWritten(OSError):
    """Outputs of post the disk had no room for (a DiskFull each); the results files are untouched."""

    def __init__(self, failures: list[DiskFull]):
        self.failures = failures
        names = ", ".join(f.path.name for f in failures)
        super().__init__(errno.ENOSPC, f"{failures[0]} (not written: {names}; the results files are unchanged)")

    def __str__(self) -> str:
        return self.strerror


def _disk_full(e: OSError, path) -> DiskFull:
    return e if isinstance(e, DiskFull) else DiskFull(path)


def _write_csv(write, data, path: Path, unwritten: list) -> None:
    """`write(data, path)`; a full disk is noted in `unwritten` (named in post's last line with the other
    outputs that did not fit), any other error is raised."""
    try:
        write(data, path)
    except OSError as e:
        if not is_no_space(e):
            raise
        unwritten.append(_disk_full(e, path))


def _context(case, results, motion: dict | None) -> dict:
    """What the discussion of a comparison quotes: the record and its PGA, damping, R, water model,
    mode."""
    ctx = {"mode": case.data["mesh"]["mode"], "variant": case.variant, "case_dir": str(case.path.parent)}
    w = case.data.get("water") or {}
    model = w.get("model", "unknown")
    if model == "compressible" and w.get("bulk_modulus"):
        model += f" (K = {float(w['bulk_modulus']) / 1e9:.3g} GPa)"
    ctx["water_model"] = model
    if motion is not None:
        ctx["motion_source"] = motion["source"]
        ctx["pga"] = motion.get("pga")
    for r in results:
        if "rayleigh_alpha" in r.attrs:
            ctx["rayleigh_alpha"] = float(r.attrs["rayleigh_alpha"])
            ctx["rayleigh_beta"] = float(r.attrs.get("rayleigh_beta", 0.0))
        if "damage_constant" in r.input_attrs:
            ctx["damage_constant"] = float(r.input_attrs["damage_constant"])
    return ctx


def _run_state(P, res, csv_name: str) -> str:
    if not res.monitors:
        return (f"- {P.CONDITION_LABELS[res.condition]}: status **{res.status}**; no monitor (output.monitors is "
                f"empty), so no histories; {len(res.snapshots)} field snapshot(s)")
    if not res.samples:
        return (f"- {P.CONDITION_LABELS[res.condition]}: status **{res.status}**, no monitor sample: the run "
                f"stopped before the shaking ({res.stage_state()}); nothing of this condition is in the figures "
                f"and the tables below")
    line = (f"- {P.CONDITION_LABELS[res.condition]}: status **{res.status}**, {res.samples} monitor samples to "
            f"t = {res.t_end:.2f} s")
    if res.planned_end is not None:
        line += f" of the planned {res.planned_end:g} s"
    line += f"; {len(res.snapshots)} field snapshot(s); monitors in `{csv_name}`"
    if not res.complete:
        line += (f". **The run did not complete**: everything below for this condition is post-processed up to "
                 f"the last written step, t = {res.t_end:.4g} s")
        if res.incomplete_snapshots:
            line += f" (snapshot(s) {', '.join(res.incomplete_snapshots)} were cut off mid-write and are skipped)"
    return line


def _design(R, case, results, early=None) -> tuple[object | None, str]:
    """The design quantities (None when no result has lining forces) and a line for what was not
    made: a check the case cannot support is skipped with its reason, said once, and never fails
    the post of a completed run. `early`: post_early.EarlyPost (conditions' parts computed before)."""
    try:
        design = R.design_quantities(case, results, early.design_parts() if early is not None else None)
    except Exception as e:  # noqa: BLE001 - reported; the report keeps everything else
        say(f"design checks not made ({type(e).__name__}: {e})")
        return None, f"design checks not made ({type(e).__name__}: {e})"
    if design is not None:
        for line in dict.fromkeys(x for c in design.conditions for x in c.skipped if x):
            say(line)  # once, however many conditions it holds for
    return design, ""


#: The designer's figures: file name, caption.
DESIGN_FIGURES = (("design_envelopes.png", "design forces N, M, V around the ring: envelopes and the static state"),
                  ("design_mn.png", "M–N interaction of the section with the demand points"),
                  ("design_deformed.png", "deformed lining at the governing time (ovaling, scale in the title)"),
                  ("design_cracks.png", "crack pattern at the governing time (the field snapshot nearest it, both "
                                        "times in the title)"))


def _design_figure_jobs(design, figs: Path, jobs, results=()) -> None:
    """The designer's figures to draw (drawing.Jobs, keys `design:<file name>`); earlier ones removed."""
    from .design import figures as F

    figs.mkdir(parents=True, exist_ok=True)
    for name, _ in DESIGN_FIGURES:
        (figs / name).unlink(missing_ok=True)
        if name == "design_envelopes.png":
            jobs.add(f"design:{name}", F.fig_envelopes, design.conditions, figs / name)
        elif name == "design_deformed.png":
            jobs.add(f"design:{name}", F.fig_deformed, design.conditions, figs / name)
        elif name == "design_cracks.png":
            jobs.add(f"design:{name}", F.fig_cracks, design.conditions, results, figs / name)
        else:
            jobs.add(f"design:{name}", _fig_mn, design, figs / name)


def _fig_mn(design, path: Path):
    from .design import figures as F

    p = design.params
    sec = p.section(design.conditions[0].thickness) if p is not None and p.reinforced else None
    return F.fig_mn(design.conditions, sec, path)


def _design_figures(figs: Path, unwritten: list, drawn: dict) -> list[str]:
    """The lines of the designer's figures from their outcomes (`drawn`: drawing.draw_all's); each
    one that failed is named with the reason."""
    lines = []
    for name, caption in DESIGN_FIGURES:
        o = drawn[f"design:{name}"]
        if o.error is not None:
            e = o.error
            if is_no_space(e):
                unwritten.append(_disk_full(e, figs / name))
            else:
                say(f"{name}: not drawn ({type(e).__name__}: {e})")
            lines += [f"- {caption[:1].upper() + caption[1:]}: not drawn ({type(e).__name__}: {e})", ""]
            continue
        if o.value is not None:
            lines += [f"![{caption[:1].upper() + caption[1:]}](figures/{name})", ""]
    return lines


#: The report's figures: key, file name, caption.
FIGURES = (
    ("fig05", "fig05_hydrodynamic_pressure.png", "hydrodynamic pressure at the monitors, dynamic water"),
    ("fig06", "fig06_max_displacements.png", "maximum displacements"),
    ("fig07", "fig07_max_principal_stress.png", "maximum principal stress"),
    ("fig08", "fig08_damage_histories.png", "damage at the monitors"),
    ("fig09", "fig09_damage_section.png", "damage over the lining's middle section at the last snapshot"),
    ("fig10", "fig10_interface_zones.png", "rock–lining interface state at the last snapshot"),
    ("fig11", "fig11_lining_axis.png", "the lining's section forces along the tunnel (3D)"),
    ("fig12", "fig12_water_column.png", "the water's pressure along the axis and a surge tank's level, dynamic water"),
)


def _joint_rows(P, res, out: Path, unwritten: list, allowed: float | None) -> tuple[list[str], list[str]]:
    """A condition's lining joints: joints_<condition>.csv, one table row per joint (its peak
    opening, closing, slip and axial force over the run) and the watertightness line against
    lining_joints.allowed_opening."""
    J = res.joints
    if J is None or not len(J["time"]):
        return [], []
    f = out / f"joints_{res.condition}.csv"
    _write_csv(P.joints_csv, J, f, unwritten)
    label = P.CONDITION_LABELS[res.condition]
    rows = []
    for j, y in enumerate(J["y"]):
        i_open, i_close = int(np.argmax(J["opening_max"][:, j])), int(np.argmin(J["opening_min"][:, j]))
        i_slip, i_n = int(np.argmax(J["slip_max"][:, j])), int(np.argmax(np.abs(J["axial_force"][:, j])))
        rows.append(f"| {label} | {y:.4g} | {J['opening'][:, j].max():.4g} | {J['opening_max'][i_open, j]:.4g} at "
                    f"t = {J['time'][i_open]:.4g} s | {J['opening_min'][i_close, j]:.4g} | {J['slip_max'][i_slip, j]:.4g} "
                    f"| {J['axial_force'][i_n, j]:.4g} |")
    notes = []
    if allowed is not None:
        worst = J["opening_max"].max(axis=0)
        over = [f"y = {J['y'][j]:.4g} m ({worst[j]:.4g} m)" for j in range(len(J["y"])) if worst[j] > allowed]
        notes.append(f"- {label}: watertightness: " + (
            f"**{len(over)} of {len(J['y'])} joints open beyond the allowed {allowed:.4g} m**: " + ", ".join(over)
            if over else f"every joint's largest opening ({worst.max():.4g} m at y = {J['y'][int(np.argmax(worst))]:.4g} "
                         f"m) is within the allowed {allowed:.4g} m"))
    return rows, notes


def _water_column_lines(P, res, out: Path, unwritten: list) -> list[str]:
    """The water along the tunnel (open ends): its largest pressure along the axis, each surge tank's
    largest rise and fall of level, and water_column_<condition>.csv (post.water_column_csv); none
    without a water column."""
    W = res.water_column
    if W is None or not W["time"].size:
        return []
    _write_csv(P.water_column_csv, W, out / f"water_column_{res.condition}.csv", unwritten)
    i, j = np.unravel_index(int(np.argmax(np.abs(W["p"]))), W["p"].shape)
    lines = ["## The water along the tunnel", "",
             f"The water column's pressure along the axis ({len(W['y'])} stations from y = {W['y'][0]:.4g} to "
             f"{W['y'][-1]:.4g} m, carried by the solid's volume law): largest |p| {abs(W['p'][i, j]) / 1e3:.4g} kPa "
             f"at y = {W['y'][j]:.4g} m, t = {W['time'][i]:.4g} s; every station's history in "
             f"water_column_{res.condition}.csv and the figure below.", ""]
    for end in P.SURGE_LEVELS:
        h = W.get(f"level_{end}")
        if h is None or not h.size:
            continue
        up, down = int(np.argmax(h)), int(np.argmin(h))
        lines += [f"- The surge tank at y {end[1:]}: its level rose at most {h[up] * 1e3:.4g} mm above rest (t = "
                  f"{W['time'][up]:.4g} s) and fell at most {-h[down] * 1e3:.4g} mm below it (t = {W['time'][down]:.4g} "
                  "s).", ""]
    return lines


def joint_hold_note(hold: str) -> str:
    """What the rings' ties to the rock (lining_joints.held_at) mean for the joints' openings."""
    if hold == "ring_middle":
        return ("The rings are tied to the rock on their middle plane only (`lining_joints.held_at: ring_middle`): "
                "each moves with the ground there, so a joint opens by about the ground's axial strain times the "
                "ring length (docs/verification.md \"Lining joints\").")
    return ("The rings are tied to the rock along their length (`lining_joints.held_at: along_ring`): each strains "
            "with the ground, so a joint opens by less than the ground's axial strain times the ring length (12 m "
            "rings of the rock's own properties: 19 % less than with `ring_middle`, docs/verification.md "
            "\"Lining joints\").")


def _lining_axis(P, results, out: Path, unwritten: list, allowed_opening: float | None = None,
                 axes: dict | None = None, hold: str = "along_ring") -> list[str]:
    """The lining as a beam along the axis (3D results): per condition the largest |resultant|
    at the seismic start and over the snapshots, each with its y, the interface's largest slip,
    and the CSV of the whole profile (post.lining_along_axis, also put in `axes` by condition for
    the figure); with lining joints each joint's opening, slip and axial force, and the
    watertightness check."""
    rows, joint_rows, joint_notes = [], [], []
    for res in results:
        jr, jn = _joint_rows(P, res, out, unwritten, allowed_opening)
        joint_rows += jr
        joint_notes += jn
        axis = P.lining_along_axis(res)
        if axis is None:
            continue
        if axes is not None:
            axes[res.condition] = axis
        f = out / f"lining_axis_{res.condition}.csv"
        _write_csv(P.lining_axis_csv, axis, f, unwritten)
        for k, unit in P.AXIS_RESULTANTS.items():
            i, j = int(np.argmax(np.abs(axis["start"][k]))), int(np.argmax(axis["envelope"][k]))
            rows.append(f"| {P.CONDITION_LABELS[res.condition]} | {k} ({unit}) | {axis['start'][k][i]:.4g} at y = "
                        f"{axis['y'][i]:.4g} m | {axis['envelope'][k][j]:.4g} at y = {axis['y'][j]:.4g} m |")
        if axis["slip"] is not None:
            i = int(np.argmax(axis["slip"]["max"]))
            rows.append(f"| {P.CONDITION_LABELS[res.condition]} | interface slip (m), t = {axis['end_time']:.4g} s | "
                        f"– | {axis['slip']['max'][i]:.4g} at y = {axis['slip']['y'][i]:.4g} m |")
    if not rows and not joint_rows:
        return []
    lines = ["## The lining along the axis", ""]
    if rows:
        lines += ["The lining as a beam along the tunnel (x across, y along, z up): per axial layer its axial force N "
                  "(tension +), its moments M_h, M_v and shears V_h, V_v in the horizontal and the vertical plane "
                  "and its torsion T about the axis, from its elements' stresses (docs/solid_solver.md \"Fault "
                  "offset\"); the whole profiles in `lining_axis_<condition>.csv` and the figure of the lining's "
                  "section forces along the tunnel.", "",
                  "| condition | quantity | seismic start (the static state): largest \\|value\\| | over the "
                  "snapshots: largest \\|value\\| |", "|---|---|---:|---:|", *rows, ""]
    if joint_rows:
        lines += ["The lining's joints (lining_joints): per joint its opening along the axis (the mean over the "
                  "joint's area; > 0 open, < 0 closed), its largest and smallest at any pair, the slip across it and "
                  "the axial force through it (tension +), at the output times; the histories in "
                  "`joints_<condition>.csv` (docs/theory.md \"Lining joints\"). " + joint_hold_note(hold), "",
                  "| condition | joint y (m) | peak mean opening (m) | largest opening at a pair (m) | largest "
                  "closing (m) | largest slip (m) | largest \\|axial force\\| (N) |",
                  "|---|---:|---:|---:|---:|---:|---:|", *joint_rows, "", *joint_notes]
        if joint_notes:
            lines.append("")
    return lines


def post_case(case, early=None) -> Path:
    """Everything post makes from the results folder (see the module's text); report.md's path.
    `early`: the per-condition work `tunnelquake run` did beside a condition still running
    (post_early.EarlyPost), used for each condition whose results file is unchanged since; the
    outputs are the same files either way. The staging folder of that work is removed at the end."""
    from .post_early import discard

    try:
        return _post_case(case, early)
    finally:
        discard(case.output_dir)


def _post_case(case, early) -> Path:
    from . import paper
    from . import post as P
    from . import report as R
    from .fingerprint import check_post, record_post

    out = case.output_dir
    inputs_notes = check_post(case)  # refuses results of other inputs, naming the key
    figs = out / "figures"
    ref = paper if paper.applies(case.data) else None
    order = list(case.data["output"]["monitors"] or {})
    places = {m: R.monitor_place(case, p)[2] for m, p in (case.data["output"]["monitors"] or {}).items()}
    strength = R.lining_tensile_strength(case)
    motion = R.motion_summary(out / "motion.h5")
    fig03 = figs / "fig03_input_motion.png"
    lines = [f"# TunnelQuake report: {case.data['name']}", ""]
    lines += R.motion_section(motion, f"figures/{fig03.name}" if fig03.is_file() else None)
    lines += _wave_lines(case.data)
    lines += R.case_section(case)
    if inputs_notes:
        lines += ["## Inputs", "", *inputs_notes, ""]
        for n in inputs_notes:
            say(n[2:])
    lines += ["## Conditions", ""]
    results, stopped = [], []
    unwritten: list[DiskFull] = []
    planned = [c for c, _ in plan(case)]
    for cond in P.CONDITION_LABELS:
        f = out / f"results_{cond}.h5"
        if not f.is_file():
            if cond in planned:
                lines.append(f"- {P.CONDITION_LABELS[cond]}: no results (`{f.name}` was not written: the condition "
                             "was not run, or stopped before its solver started)")
                say(f"{cond}: no results file ({f.name})")
            continue
        try:
            res = early.result(cond, f) if early is not None else None
            if res is None:
                res = P.read_condition(f, cond, case.data["output"]["displacement_reference"])
        except (OSError, KeyError, ValueError, TypeError) as e:  # unreadable: say so, go on with the others
            lines.append(f"- {P.CONDITION_LABELS[cond]}: `{f.name}` cannot be read ({e})")
            say(f"{cond}: {f.name} cannot be read ({e})")
            continue
        csv_file = out / f"monitors_{cond}.csv"
        if early is None or not early.put_monitors(cond, csv_file):
            _write_csv(P.monitors_csv, res, csv_file, unwritten)
        lines.append(_run_state(P, res, csv_file.name))
        if not res.samples:
            say(f"{cond}: status '{res.status}', no monitor sample: stopped before the shaking ({res.stage_state()})")
            stopped.append(res)
            continue
        results.append(res)
        if not res.complete:
            say(f"{cond}: status '{res.status}': post-processed up to the last written step, t = {res.t_end:.4g} s")
    lines.append("")
    if stopped or results:
        lines += R.peaks_section(results, stopped, order, strength, places)
    if not results:
        lines += ["No condition has monitor samples yet: nothing to draw or compare. This report lists only "
                  "what exists.", ""]
    else:
        lines += R.differences_section(results, order)
        axes: dict = {}
        from .case import joint_hold

        lines += _lining_axis(P, results, out, unwritten,
                              (case.data.get("lining_joints") or {}).get("allowed_opening"), axes,
                              joint_hold(case.data))
        dyn = next((r for r in results if r.condition == "dynamic_water"), None)
        fluid = P.read_fluid_interface(out / "dynamic_water" / "fluid") if dyn is not None else None
        if dyn is not None:
            from .fluid_case import volume_law

            lines += R.water_side_check(dyn, fluid, carried=volume_law(case)[0] != "none")
            lines += _water_column_lines(P, dyn, out, unwritten)
        design, why = _design(R, case, results, early)
        if design is not None:
            lines[2:2] = design.summary_lines()  # what a designer reads first, after the title
        lines += R.lining_forces_section(design) if design is not None else (
            ["## Lining forces", "", f"- {why}", ""] if why else [])
        from .drawing import Jobs, draw_all

        jobs = Jobs()  # every figure and ParaView file, made in two processes (drawing.py)
        if design is not None:
            _design_figure_jobs(design, figs, jobs, results)
        made_early = _figure_jobs(P, ref, results, dyn, fluid, figs, order, strength, out, jobs, axes, early)
        drawn = {**draw_all(jobs), **made_early}
        if design is not None:
            lines += _design_figures(figs, unwritten, drawn)
        lines += _figures(ref, results, dyn, figs, out, unwritten, drawn)
        if ref is not None:
            ctx = _context(case, results, motion)
            if fluid is not None:
                ctx["fluid_interface"] = fluid
            made = {k: f"figures/{name}" for k, name, _ in FIGURES if (figs / name).is_file()}
            try:
                lines += ref.comparison_sections(results, made, ctx)
            except Exception as e:  # noqa: BLE001 - reported; the report keeps what was found above
                lines += [f"## Comparison with the {ref.LABEL}", "", f"Not made: {type(e).__name__}: {e}", ""]
                say(f"comparison with the {ref.LABEL} not made ({type(e).__name__}: {e})")
    report = out / "report.md"
    text = "\n".join(lines).rstrip("\n") + "\n"
    try:
        with atomic_path(report, len(text.encode())) as tmp:
            tmp.write_text(text)
    except DiskFull as e:
        unwritten.append(e)
    else:
        say(f"report: {report}")
        try:
            record_post(case)
        except DiskFull as e:
            unwritten.append(e)
    if unwritten:
        raise OutputsNotWritten(unwritten)
    return report


def _figure_jobs(P, ref, results, dyn, fluid, figs, order, strength, out, jobs, axes=None, early=None) -> dict:
    """The report's figures and the ParaView files to make (drawing.Jobs: keys fig05..fig11 and
    `xdmf:<condition>`); an earlier post's figures removed first. `ref`: the paper module when the
    case compares with it (its marks and bars in the figures); `axes`: the lining along the axis
    per condition (_lining_axis's), for fig11. A condition's ParaView files made early (`early`,
    post_early.EarlyPost) are moved into place here instead; their outcomes are returned by key."""
    figs.mkdir(parents=True, exist_ok=True)
    for _, fname, _ in FIGURES:  # an earlier post's figures, which this one may not draw again
        (figs / fname).unlink(missing_ok=True)
    name = {k: n for k, n, _ in FIGURES}
    if dyn is not None:
        jobs.add("fig05", P.fig_hydrodynamic_pressure, dyn, figs / name["fig05"], fluid, order=order,
                 **({"marks": ref.pressure_marks(), "mark_label": f"{ref.LABEL} peak"} if ref is not None else {}))
    jobs.add("fig06", P.fig_max_displacements, results, figs / name["fig06"], order=order,
             **({"reference": ref.displacement_bars, "reference_label": ref.LABEL, "unit": ref.DISPLACEMENT_UNIT}
                if ref is not None else {}))
    jobs.add("fig07", P.fig_principal_stress, results, figs / name["fig07"], order=order, strength=strength)
    jobs.add("fig08", P.fig_damage_histories, results, figs / name["fig08"], order=order)
    jobs.add("fig09", P.fig_damage_section, results, figs / name["fig09"])
    jobs.add("fig10", P.fig_interface_zones, results, figs / name["fig10"])
    jobs.add("fig11", P.fig_lining_axis, axes or {}, figs / name["fig11"])
    if dyn is not None:
        jobs.add("fig12", P.fig_water_column, dyn, figs / name["fig12"])
    made = {}
    for r in results:
        target = out / "paraview" / f"{r.condition}.xdmf"
        o = early.put_xdmf(r.condition, target) if early is not None else None
        if o is not None:
            made[f"xdmf:{r.condition}"] = o
        else:
            jobs.add(f"xdmf:{r.condition}", P.write_xdmf, r, target)
    return made


def _figures(ref, results, dyn, figs, out, unwritten: list, drawn: dict) -> list[str]:
    """The report's lines for the figures and the ParaView files from their outcomes (`drawn`:
    drawing.draw_all's); each one that failed is named with the reason, one the disk had no room
    for is added to `unwritten`. `ref`: the paper module (its figure numbers in the captions)."""
    made: dict[str, str] = {}
    failed: dict[str, str] = {}
    name = {k: n for k, n, _ in FIGURES}
    for key, _, _ in FIGURES:
        o = drawn.get(key)
        if o is None:
            continue
        if o.error is not None:
            e = o.error
            failed[key] = f"{type(e).__name__}: {e}"
            if is_no_space(e):  # named in post's last line with the other outputs that did not fit
                unwritten.append(_disk_full(e, figs / name[key]))
            else:
                say(f"{key}: not drawn ({failed[key]})")
        elif o.value is not None:
            made[key] = f"figures/{Path(o.value).name}"
    lines = ["## Figures", ""]
    for key, _, caption in FIGURES:
        title = ref.figure_caption(key, caption) if ref is not None else caption[:1].upper() + caption[1:]
        if key in made:
            lines += [f"![{title}]({made[key]})", ""]
        elif key in failed:
            lines += [f"- {title}: not drawn ({failed[key]})", ""]
        elif key in ("fig05", "fig12") and dyn is None:
            continue  # no dynamic-water condition: no water pressure to draw
        elif key == "fig12":
            continue  # no water column along the axis (closed ends, or a slice)
        elif key == "fig11":
            continue  # no lining along an axis (a slice, or 3D results without snapshots)
        else:
            why = ("no water pressure recorded (run by a tq-solid without the monitors' water_pressure)"
                   if key == "fig05" else "no damage recorded at the monitors" if key == "fig08"
                   else "no field snapshot in the results")
            lines += [f"- {title}: not drawn ({why})", ""]
    xdmfs = []
    for r in results:
        o = drawn[f"xdmf:{r.condition}"]
        if o.error is not None:
            e = o.error
            lines += [f"- ParaView file of {r.condition}: not written ({type(e).__name__}: {e})", ""]
            if is_no_space(e):  # named in post's last line
                unwritten.append(_disk_full(e, out / "paraview" / f"{r.condition}.xdmf"))
            else:
                say(f"{r.condition}: ParaView file not written ({type(e).__name__}: {e})")
            continue
        x = o.value
        if x is not None:
            xdmfs.append(x)
    if xdmfs:
        lines += ["ParaView (open the .xdmf; the heavy data are the .h5 beside it): "
                  + ", ".join(f"`{x.relative_to(out)}`" for x in xdmfs), ""]
    return lines


def _wave_lines(d: dict) -> list[str]:
    """With an incident_wave, what the record above drives: the plane wave through the DRM layer
    (the record's vertical-incidence peaks above are the processed record's, not the wave's)."""
    from .incident_wave import active, convention

    if not active(d):
        return []
    w = d["incident_wave"]
    if w["type"] == "h5drm":
        h = w["h5drm"]
        return [f"The free field enters through a domain-reduction layer {w['drm_offset']} element ring(s) in from "
                f"the sides and the base, read from the H5DRM file {h['file']} (factor {h['factor']:g}, crd_scale "
                f"{h['crd_scale']:g}; docs/user_guide.md \"Waves from any direction\"); the record above sets the "
                "run's length only.", ""]
    return [f"The record drives a plane {w['type']} wave, {w['angle']:g} deg from the vertical, travelling "
            f"{w['azimuth']:g} deg from the tunnel's axis towards x, as its {convention(d)} record (the component "
            f"{ {'P': 'z', 'SV': 'along the propagation direction', 'SH': 'across it'}[w['type']] }); it enters "
            f"through a domain-reduction layer {w['drm_offset']} element ring(s) in from the sides and the base "
            "(docs/user_guide.md \"Waves from any direction\"). The line above about the incident wave is the "
            "vertical-incidence reading of the record, not this wave's.", ""]
