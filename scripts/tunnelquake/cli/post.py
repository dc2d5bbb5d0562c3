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
    results = sorted(out.glob("results_*.h5"))
    lines += ["## Conditions", ""]
    if not results:
        lines += ["No condition results yet: the solid solver and the coupling are being built "
                  "(see the open issues). This report lists only what exists.", ""]
    for r in results:
        lines.append(f"- {r.name}")
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
