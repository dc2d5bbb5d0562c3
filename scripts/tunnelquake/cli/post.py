"""tunnelquake post: turn what a run left in the results folder into figures, CSV and report.md.
Needs no solver; works on whatever results exist."""
from __future__ import annotations

from pathlib import Path

from .common import atomic_path, load_or_report, parser, say


def post_case(case) -> Path:
    out = case.output_dir
    lines = [f"# TunnelQuake report: {case.data['name']}", ""]
    motion_file = out / "motion.h5"
    if motion_file.is_file():
        import h5py

        with h5py.File(motion_file, "r") as f:
            src, proc = f.attrs["source"], f.attrs["processing"]
            n, dt = f["time"].size, float(f.attrs["dt"])
        lines += ["## Input motion", "", f"- source: `{src}`", f"- {n} points at dt = {dt:g} s", ""]
        lines += [f"- {s}" for s in str(proc).splitlines()] + [""]
        fig = out / "figures" / "fig03_input_motion.png"
        if fig.is_file():
            lines += [f"![input motion](figures/{fig.name})", ""]
    from .. import post as P

    lines += ["## Conditions", ""]
    results = []
    for cond in P.CONDITION_LABELS:
        f = out / f"results_{cond}.h5"
        if not f.is_file():
            continue
        try:
            res = P.read_condition(f, cond)
        except OSError as e:  # unreadable file: say so, keep going with the others
            lines.append(f"- {cond}: `{f.name}` cannot be read ({e})")
            continue
        results.append(res)
        csv_file = P.monitors_csv(res, out / f"monitors_{cond}.csv")
        n = min((m.time.size for m in res.monitors.values()), default=0)
        t_end = max((m.time[-1] for m in res.monitors.values() if m.time.size), default=0.0)
        lines.append(f"- {P.CONDITION_LABELS[cond]}: status **{res.status}**, {n} monitor samples to "
                     f"t = {t_end:.2f} s; monitors in `{csv_file.name}`")
    if not results:
        lines += ["No condition results yet: the solid solver's staged seismic run and the coupling are "
                  "being built (see the open issues). This report lists only what exists.", ""]
    else:
        figs = out / "figures"
        figs.mkdir(parents=True, exist_ok=True)
        P.fig_max_displacements(results, figs / "fig06_max_displacements.png")
        P.fig_principal_stress(results, figs / "fig07_max_principal_stress.png")
        lines += ["", "![max displacements](figures/fig06_max_displacements.png)",
                  "", "![max principal stress](figures/fig07_max_principal_stress.png)", "",
                  "## The paper's §3.3 numbers against ours", ""]
        lines += P.comparison_table(results) + [""]
    report = out / "report.md"
    with atomic_path(report) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    say(f"report: {report}")
    return report


def main(argv: list[str]) -> int:
    args = parser("post", __doc__).parse_args(argv)
    case = load_or_report(args.case)
    if case is None:
        return 1
    post_case(case)
    return 0
