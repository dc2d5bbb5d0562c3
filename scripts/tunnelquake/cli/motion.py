"""tunnelquake motion: read or synthesise the ground motion, process it, write motion.h5 and a figure."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..files import atomic_h5
from ..motion import MotionError, ProcessedMotion, from_case
from .common import DiskFull, atomic_path, folder_held, load_or_report, parser, say


def write_motion(motion: ProcessedMotion, path: Path) -> None:
    with atomic_h5(path) as f:
        f.attrs["format"] = "tunnelquake-motion"
        f.attrs["version"] = 1
        f.attrs["dt"] = motion.dt
        f.attrs["convention"] = motion.convention
        f.attrs["source"] = motion.record.source
        f.attrs["record_name"] = motion.record.name
        f.attrs["processing"] = "\n".join(motion.steps)
        f["time"] = motion.time
        f["incident_ax"] = motion.ax  # m/s^2, incident (up-going) wave at the base: across the tunnel
        f["incident_ay"] = motion.ay  # along the tunnel's axis
        f["incident_az"] = motion.az  # vertical
        f["record_acc"] = motion.record.acc


def plot_motion(motion: ProcessedMotion, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    factor = 2.0 if motion.convention == "outcrop" else 1.0
    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.plot(motion.time, factor * motion.ax, lw=0.8, label="x (across the tunnel)")
    if np.any(motion.ay):
        ax.plot(motion.time, factor * motion.ay, lw=0.8, label="y (along the axis)", alpha=0.8)
    ax.plot(motion.time, factor * motion.az, lw=0.8, label="z (vertical)", alpha=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("acceleration (m/s$^2$)")
    ax.set_title(f"Input motion: {motion.record.name}")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)


def make_motion(case) -> tuple[ProcessedMotion, Path]:
    motion, notes = from_case(case.data["ground_motion"], case.dir)
    for n in notes:
        say(f"NOTE: {n}")
    out = case.output_dir / "motion.h5"
    write_motion(motion, out)
    peaks = ", ".join(f"{c} {float(np.max(np.abs(a))):.4g}" for c, a in (("x", motion.ax), ("y", motion.ay), ("z", motion.az)))
    say(f"motion: {motion.record.source}; {motion.ax.size} points at dt={motion.dt:g} s; "
        f"incident peaks {peaks} m/s^2 -> {out}")
    for s in motion.steps:
        say(f"  - {s}")
    return motion, out


def motion_and_figure(case) -> tuple[ProcessedMotion, Path, Path] | None:
    """motion.h5 and its figure; None after printing why (a record refused, a full disk)."""
    fig = case.output_dir / "figures" / "fig03_input_motion.png"
    try:
        motion, out = make_motion(case)
        plot_motion(motion, fig)
    except MotionError as e:
        print(f"error: {e}")
        return None
    except DiskFull as e:
        print(f"error: {e}", file=sys.stderr)
        return None
    return motion, out, fig


def main(argv: list[str]) -> int:
    args = parser("motion", __doc__).parse_args(argv)
    case = load_or_report(args.case, args.variant)
    if case is None:
        return 1
    with folder_held(case, "tunnelquake motion " + " ".join(map(str, argv))) as held:
        if not held:
            return 1
        made = motion_and_figure(case)
        if made is None:
            return 1
        say(f"figure: {made[2]}")
    return 0
