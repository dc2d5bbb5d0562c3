"""Restart checkpoints of a run's conditions: where tq-solid writes them and the last complete one
(docs/user_guide.md "Resuming a run", docs/formats.md "Restart checkpoints")."""
from __future__ import annotations

import json
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
