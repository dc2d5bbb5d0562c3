"""Shared pieces of the subcommands: argument parsing, case loading with clear errors, atomic writes."""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import threading
from pathlib import Path

from ..case import Case, CaseError, load_case


def parser(prog: str, description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=f"tunnelquake {prog}", description=description)
    p.add_argument("case", type=Path, help="the case file (case.yaml) or the folder holding it")
    p.add_argument("--variant", metavar="NAME", default=None,
                   help="lay the case file's 'variants: NAME:' keys over the rest of it (e.g. 3d in "
                        "cases/paper_tunnel); its results go to '<output.directory>_NAME' unless it sets "
                        "output.directory")
    return p


def case_path(p: Path) -> Path:
    return p / "case.yaml" if p.is_dir() else p


def load_or_report(path: Path, variant: str | None = None) -> Case | None:
    """Load and validate a case (with `variant` laid over it, if given); on problems print them
    all (stderr) and return None."""
    try:
        case = load_case(case_path(path), variant)
    except CaseError as e:
        print(f"error: {e}", file=sys.stderr)
        return None
    for w in case.warnings:
        print(f"warning: {w}", file=sys.stderr)
    return case


@contextlib.contextmanager
def atomic_path(target: Path):
    """Yield a temporary path beside `target`; move it into place only if the block succeeds,
    so a crash never leaves a half-written file under the final name."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


#: set while a run is being stopped by a signal: its threads' progress lines are dropped, so that
#: the one line saying what was stopped is the last thing printed
QUIET = threading.Event()


def say(msg: str) -> None:
    if QUIET.is_set():
        return
    print(f"[tunnelquake] {msg}", flush=True)
