"""tunnelquake post: turn what a run left in the results folder into figures, CSV, ParaView files and
report.md. Needs no solver; works on whatever results exist: a results file cut off mid-run, one
stopped before the shaking (no monitor sample), an unreadable one, a condition never run. Each is
reported as found; a figure that cannot be drawn is named with the reason, never a traceback."""
from __future__ import annotations

from pathlib import Path

from ..scene import plan
from .common import atomic_path, load_or_report, parser, say


def _context(case, results) -> dict:
    """What the discussion of the differences quotes: the record, damping, R, water model, mode."""
    ctx = {"mode": case.data["mesh"]["mode"]}
    w = case.data.get("water") or {}
    model = w.get("model", "unknown")
    if model == "compressible" and w.get("bulk_modulus"):
        model += f" (K = {float(w['bulk_modulus']) / 1e9:.3g} GPa)"
    ctx["water_model"] = model
    motion_file = case.output_dir / "motion.h5"
    if motion_file.is_file():
        import h5py

        with h5py.File(motion_file, "r") as f:
            ctx["motion_source"] = str(f.attrs.get("source", "unknown"))
    for r in results:
        if "rayleigh_alpha" in r.attrs:
            ctx["rayleigh_alpha"] = float(r.attrs["rayleigh_alpha"])
            ctx["rayleigh_beta"] = float(r.attrs.get("rayleigh_beta", 0.0))
        if "damage_constant" in r.input_attrs:
            ctx["damage_constant"] = float(r.input_attrs["damage_constant"])
    return ctx


def _run_state(P, res, csv_name: str) -> str:
    if not res.samples:
        return (f"- {P.CONDITION_LABELS[res.condition]}: status **{res.status}**, no monitor sample: the run "
                f"stopped before the shaking ({res.stage_state()}); nothing of this condition is in the figures "
                f"and the comparison below")
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


def post_case(case) -> Path:
    out = case.output_dir
    lines = [f"# TunnelQuake report: {case.data['name']}", ""]
    motion_file = out / "motion.h5"
    figs = out / "figures"
    if motion_file.is_file():
        import h5py

        with h5py.File(motion_file, "r") as f:
            src, proc = f.attrs["source"], f.attrs["processing"]
            n, dt = f["time"].size, float(f.attrs["dt"])
        lines += ["## Input motion", "", f"- source: `{src}`", f"- {n} points at dt = {dt:g} s", ""]
        lines += [f"- {s}" for s in str(proc).splitlines()] + [""]
        fig = figs / "fig03_input_motion.png"
        if fig.is_file():
            lines += [f"![input motion](figures/{fig.name})", ""]
    from .. import post as P

    lines += ["## Conditions", ""]
    results = []
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
            res = P.read_condition(f, cond)
        except (OSError, KeyError, ValueError, TypeError) as e:  # unreadable: say so, go on with the others
            lines.append(f"- {P.CONDITION_LABELS[cond]}: `{f.name}` cannot be read ({e})")
            say(f"{cond}: {f.name} cannot be read ({e})")
            continue
        csv_file = P.monitors_csv(res, out / f"monitors_{cond}.csv")
        lines.append(_run_state(P, res, csv_file.name))
        if not res.samples:
            say(f"{cond}: status '{res.status}', no monitor sample: stopped before the shaking ({res.stage_state()})")
            continue
        results.append(res)
        if not res.complete:
            say(f"{cond}: status '{res.status}': post-processed up to the last written step, t = {res.t_end:.4g} s")
    if not results:
        lines += ["", "No condition has monitor samples yet: nothing to draw or compare. This report lists only "
                  "what exists.", ""]
    else:
        figs.mkdir(parents=True, exist_ok=True)
        made: dict[str, str] = {}
        failed: dict[str, str] = {}

        def keep(key, draw, *args):
            try:
                path = draw(*args)
            except Exception as e:  # noqa: BLE001 - one figure that fails must not lose the report
                failed[key] = f"{type(e).__name__}: {e}"
                say(f"{key}: not drawn ({failed[key]})")
                return
            if path is not None:
                made[key] = f"figures/{Path(path).name}"

        dyn = next((r for r in results if r.condition == "dynamic_water"), None)
        fluid = P.read_fluid_interface(out / "dynamic_water" / "fluid") if dyn is not None else None
        if dyn is not None:
            keep("fig05", P.fig_hydrodynamic_pressure, dyn, figs / "fig05_hydrodynamic_pressure.png", fluid)
        keep("fig06", P.fig_max_displacements, results, figs / "fig06_max_displacements.png")
        keep("fig07", P.fig_principal_stress, results, figs / "fig07_max_principal_stress.png")
        keep("fig08", P.fig_damage_histories, results, figs / "fig08_damage_histories.png")
        keep("fig09", P.fig_damage_section, results, figs / "fig09_damage_section.png")
        keep("fig10", P.fig_interface_zones, results, figs / "fig10_interface_zones.png")
        titles = {"fig05": "Fig. 5: hydrodynamic pressure at the monitors, condition 3",
                  "fig06": "Fig. 6: maximum displacements", "fig07": "Fig. 7: maximum principal stress",
                  "fig08": "Fig. 8: damage at the monitors",
                  "fig09": "Fig. 9: damage over the lining's middle section at the last snapshot",
                  "fig10": "Fig. 10: rock–lining interface state at the last snapshot"}
        lines += ["", "## Figures", ""]
        for key, title in titles.items():
            if key in made:
                lines += [f"![{title}]({made[key]})", ""]
            elif key in failed:
                lines += [f"- {title}: not drawn ({failed[key]})", ""]
            else:
                why = ("no water pressure recorded (condition 3 not run, or run by a tq-solid without the "
                       "monitors' water_pressure)" if key == "fig05" else "no field snapshot in the results")
                lines += [f"- {title}: not drawn ({why})", ""]
        xdmfs = []
        for r in results:
            try:
                x = P.write_xdmf(r, out / "paraview" / f"{r.condition}.xdmf")
            except Exception as e:  # noqa: BLE001 - reported; the rest of the report still follows
                lines += [f"- ParaView file of {r.condition}: not written ({type(e).__name__}: {e})", ""]
                say(f"{r.condition}: ParaView file not written ({type(e).__name__}: {e})")
                continue
            if x is not None:
                xdmfs.append(x)
        if xdmfs:
            lines += ["ParaView (open the .xdmf; the heavy data are the .h5 beside it): "
                      + ", ".join(f"`{x.relative_to(out)}`" for x in xdmfs), ""]
        from ..report import comparison_sections

        ctx = _context(case, results)
        if fluid is not None:
            ctx["fluid_interface"] = fluid
        try:
            lines += comparison_sections(results, made, ctx)
        except Exception as e:  # noqa: BLE001 - reported; the report keeps what was found above
            lines += ["## The paper's §3.3 numbers against ours", "",
                      f"Not made: {type(e).__name__}: {e}", ""]
            say(f"comparison with the paper not made ({type(e).__name__}: {e})")
    report = out / "report.md"
    with atomic_path(report) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    say(f"report: {report}")
    return report


def main(argv: list[str]) -> int:
    args = parser("post", __doc__).parse_args(argv)
    case = load_or_report(args.case, args.variant)
    if case is None:
        return 1
    if case.data["suite"]["records"] is not None:
        from ..suite import plan_members, write_report
        from .suite_run import read_state

        members = plan_members(case)
        say(f"suite report: {write_report(case, members, {m.name: read_state(m.folder) for m in members})}")
        return 0
    post_case(case)
    return 0
