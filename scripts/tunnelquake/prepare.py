"""A case's inputs in its results folder: the mesh (mesh/mesh.h5 for the solid, mesh/water.msh; rebuilt
only when the geometry or mesh keys changed) and the ground motion (motion.h5 and its figure)."""
from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from .children import say
from .files import DiskFull, atomic_h5, atomic_path
from .motion import MotionError, ProcessedMotion, from_case


def mesh_dir(case) -> Path:
    return case.output_dir / "mesh"


_UNSET = object()


def _fingerprint(case) -> str:
    from .case import case_geology, ground_layers, joint_hold, lining_joints_active
    from .schema import NEUTRAL

    # a mesh key at its neutral value is left out: the meshes made before the key stay current
    mesh = {k: v for k, v in case.data["mesh"].items() if NEUTRAL.get(f"mesh.{k}", _UNSET) != v}
    d = {"geometry": case.data["geometry"], "mesh": mesh}
    if ground_layers(case.data):  # only then, so that the meshes of cases without layers stay current
        d["layers"] = ground_layers(case.data)
    geology = case_geology(case.data)
    if geology is not None:  # likewise
        d["geology"] = case.data["geology"]
        if geology.fault is not None:  # its lining's end faces are their own group (meshing.build.LINING_END_FACES)
            d["lining_end_faces"] = True
    if lining_joints_active(case.data):  # likewise
        d["lining_joints"] = case.data["lining_joints"]["spacing"]
        if joint_hold(case.data) != "along_ring":  # likewise
            d["lining_joints_held_at"] = joint_hold(case.data)
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def current_mesh(case) -> dict | None:
    """The stamp of the results folder's mesh (fingerprint.json: its fingerprint and summary) when it
    was made from the case's present geometry and mesh keys and mesh.h5 is there; else None (also
    for a stamp that cannot be read)."""
    out = mesh_dir(case)
    try:
        old = json.loads((out / "fingerprint.json").read_text())
    except (OSError, ValueError):
        return None
    return old if old.get("fingerprint") == _fingerprint(case) and (out / "mesh.h5").is_file() else None


def build_case_mesh(case, out: Path) -> dict:
    """The case's meshes (its geometry, mesh keys, ground layers, geology and lining joints) built into
    `out`: meshing.build_tunnel_mesh's summary."""
    from .case import case_geology, ground_layers, joint_hold, joint_spacing
    from .meshing import build_tunnel_mesh

    d = case.data
    return build_tunnel_mesh(d["geometry"], d["mesh"], out, ground_layers(d), case_geology(d), joint_spacing(d),
                             joint_hold(d))


def make_mesh(case, force: bool = False) -> dict:
    """Build the mesh unless an up-to-date one (same geometry and mesh keys) is already there."""
    from .meshing import format_summary

    out = mesh_dir(case)
    stamp = out / "fingerprint.json"
    old = None if force else current_mesh(case)
    if old is not None:
        say(f"mesh: up to date in {out}")
        return old["summary"]
    out.mkdir(parents=True, exist_ok=True)
    say(f"mesh: building ({case.data['mesh']['mode']}) in {out}")
    fp = _fingerprint(case)
    stamp.unlink(missing_ok=True)  # the files are up to date only once all three are in place
    summary = json.loads(json.dumps(build_case_mesh(case, out), default=str))
    with atomic_path(stamp) as tmp:
        tmp.write_text(json.dumps({"fingerprint": fp, "summary": summary}, indent=1))
    for line in format_summary(summary).splitlines():
        say(line)
    return summary


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


def _motion_fingerprint(case) -> str:
    """What motion.h5 and its figure are made from: the ground_motion section, the contents of the
    record files it names, and the code that processes, writes and draws the motion (motion.py,
    this file)."""
    from .motion import resolve_path

    gm = case.data["ground_motion"]
    files = [gm.get("file")] + [(gm.get(k) or {}).get("file") for k in ("second_horizontal", "vertical")]
    h = hashlib.sha256(json.dumps(gm, sort_keys=True, default=str).encode())
    for f in files:
        if f:
            p = resolve_path(f, case.dir)
            h.update(p.read_bytes() if p.is_file() else b"missing")
    for src in (Path(__file__).with_name("motion.py"), Path(__file__)):
        h.update(src.read_bytes())
    return h.hexdigest()[:16]


MOTION_STAMP = "motion.json"


def make_motion(case, log: list[str] | None = None) -> tuple[ProcessedMotion, Path]:
    """Process the case's motion into motion.h5; what it says is also appended to `log`."""
    def tell(line: str) -> None:
        say(line)
        if log is not None:
            log.append(line)

    motion, notes = from_case(case.data["ground_motion"], case.dir)
    for n in notes:
        tell(f"NOTE: {n}")
    out = case.output_dir / "motion.h5"
    write_motion(motion, out)
    peaks = ", ".join(f"{c} {float(np.max(np.abs(a))):.4g}" for c, a in (("x", motion.ax), ("y", motion.ay), ("z", motion.az)))
    tell(f"motion: {motion.record.source}; {motion.ax.size} points at dt={motion.dt:g} s; "
         f"incident peaks {peaks} m/s^2 -> {out}")
    for s in motion.steps:
        tell(f"  - {s}")
    return motion, out


def motion_and_figure(case, reuse: bool = False, later: list | None = None) -> tuple[str, Path, Path] | None:
    """motion.h5 and its figure; (the record's source, motion.h5, the figure), or None after
    printing why (a record refused, a full disk). With `reuse` (`tunnelquake run`), the files an
    earlier run made from the same motion keys, record files and code (motion.json's fingerprint)
    are kept and what that run said is said again. With `later` (a list), a motion made afresh has
    its figure drawn later: the figure of an earlier motion is removed at once, and a function that
    draws the new one and then writes motion.json is appended to `later` (motion.json is written
    only once both files are in place, so a run stopped before it makes the motion again)."""
    fig = case.output_dir / "figures" / "fig03_input_motion.png"
    out = case.output_dir / "motion.h5"
    stamp = case.output_dir / MOTION_STAMP
    fp = _motion_fingerprint(case)
    if reuse and stamp.is_file() and out.is_file() and fig.is_file():
        try:
            old = json.loads(stamp.read_text())
        except (OSError, ValueError):
            old = {}
        if old.get("fingerprint") == fp:
            for line in old.get("lines", []):
                say(line)
            say(f"motion: up to date in {out} (and {fig.name})")
            return old["source"], out, fig
    stamp.unlink(missing_ok=True)  # up to date only once both files are in place
    lines: list[str] = []
    try:
        motion, out = make_motion(case, lines)
        text = json.dumps({"fingerprint": fp, "source": motion.record.source, "lines": lines}, indent=1)

        def figure_and_stamp() -> None:
            plot_motion(motion, fig)
            with atomic_path(stamp, len(text)) as tmp:
                tmp.write_text(text)

        if later is None:
            figure_and_stamp()
        else:
            fig.unlink(missing_ok=True)
            later.append(figure_and_stamp)
    except MotionError as e:
        print(f"error: {e}")
        return None
    except DiskFull as e:
        print(f"error: {e}", file=sys.stderr)
        return None
    return motion.record.source, out, fig
