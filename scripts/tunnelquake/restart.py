"""Restart checkpoints of a run's conditions: where tq-solid writes them and the last complete one
(docs/user_guide.md "Resuming a run", docs/formats.md "Restart checkpoints")."""
from __future__ import annotations

import json
import math
from pathlib import Path


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
