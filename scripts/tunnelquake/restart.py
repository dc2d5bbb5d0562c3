"""Restart checkpoints of a run's conditions: where tq-solid writes them and the last complete one
(docs/user_guide.md "Resuming a run", docs/formats.md "Restart checkpoints")."""
from __future__ import annotations

import json
import math
from pathlib import Path

from . import children
from .scene import plan


def checkpoint_dir(case, cond: str) -> Path:
    """Where tq-solid writes the condition's restart checkpoints (docs/formats.md "Restart checkpoints")."""
    return case.output_dir / cond / "checkpoint"


def checkpoint_manifest(case, cond: str) -> dict | None:
    """The condition's last complete restart checkpoint (its checkpoint.json), or None."""
    try:
        m = json.loads((checkpoint_dir(case, cond) / "checkpoint.json").read_text())
    except (OSError, ValueError):
        return None
    return m if isinstance(m, dict) and m.get("format") == "tunnelquake-checkpoint" else None


def checkpoint_windows(interval: float, window_size: float) -> int:
    """Coupled with the water: the windows between two restart checkpoints, the rule tq-solid
    applies too (max(1, round(interval / window_size)), 0 for no checkpoint)."""
    if interval <= 0:
        return 0
    return max(1, int(math.floor(interval / window_size + 0.5)))


def coupled_resume_point(case, cond: str) -> dict | None:
    """The last coupling window for which both sides of a coupled condition wrote a whole restart
    checkpoint: the solid's manifest of it (checkpoint-<n>.json, its files of the sizes named) with
    `fluid` added, the water's fluid-<window>.bin beside it; None when there is none."""
    folder = checkpoint_dir(case, cond)
    best = None
    for path in folder.glob("checkpoint-*.json"):
        try:
            m = json.loads(path.read_text())
            window = int(m["window"])
            whole = all((folder / m[k]).stat().st_size == int(m[f"{k}_bytes"]) for k in ("solid", "results"))
        except (OSError, ValueError, KeyError, TypeError):
            continue
        fluid = folder / f"fluid-{window:09d}.bin"
        if whole and fluid.is_file() and (best is None or int(m["sequence"]) > int(best["sequence"])):
            best = {**m, "fluid": str(fluid)}
    return best


def results_status(res: Path) -> str | None:
    """The status attribute of a results file (None when there is no readable file)."""
    import h5py

    try:
        with children.FORK_LOCK, h5py.File(res, "r") as f:
            status = f.attrs.get("status", "")
    except OSError:
        return None
    return status.decode() if isinstance(status, bytes) else str(status)


def resume_plan(case) -> tuple[dict[str, str], str | None, bool]:
    """What `run --resume` does with each planned condition: 'completed' (kept as it is),
    'checkpoint' (tq-solid continues from its last restart checkpoint) or 'start' (no checkpoint:
    from the beginning); then why there is nothing to resume (None when there is) and whether the
    run starts afresh (no checkpoint anywhere, nothing completed: a requeued job killed before its
    first checkpoint) rather than keeping a finished run."""
    what: dict[str, str] = {}
    for cond, parts in plan(case):
        if results_status(case.output_dir / f"results_{cond}.h5") == "completed":
            what[cond] = "completed"
        elif ("fluid" not in parts and checkpoint_manifest(case, cond) is not None) or (
                "fluid" in parts and coupled_resume_point(case, cond) is not None):
            what[cond] = "checkpoint"
        else:
            what[cond] = "start"
    variant = f" --variant {case.variant}" if case.variant else ""
    if what and all(v == "completed" for v in what.values()):
        return what, (f"nothing to resume: every condition in {case.output_dir} completed ({', '.join(what)}); "
                      f"the results are kept as they are (`tunnelquake post {case.path}{variant}` reports them, "
                      f"`tunnelquake run {case.path}{variant}` without --resume runs them again)"), False
    if "checkpoint" not in what.values() and "completed" not in what.values():
        interval = float(case.data["output"]["checkpoint_interval"])
        why = ("output.checkpoint_interval is 0: no checkpoint is written" if interval <= 0 else
               f"a run writes its first after output.checkpoint_interval = {interval:g} s of shaking")
        return what, (f"nothing to resume in {case.output_dir}: no condition has a restart checkpoint ({why}) and "
                      "none completed: starting afresh"), True
    return what, None, False
