"""Shared pieces of the subcommands: argument parsing, case loading with clear errors (tunnelquake.case_file),
atomic writes (tunnelquake.files)."""
from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from ..case import Case
from ..case_file import load_or_report  # noqa: F401 - the subcommands' imports
from ..children import QUIET, say  # noqa: F401 - the subcommands' imports
from ..files import DiskFull, atomic_path, is_no_space  # noqa: F401 - the subcommands' imports


def parser(prog: str, description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=f"tunnelquake {prog}", description=description)
    p.add_argument("case", type=Path, help="the case file (case.yaml) or the folder holding it")
    p.add_argument("--variant", metavar="NAME", default=None,
                   help="lay the case file's 'variants: NAME:' keys over the rest of it (e.g. 3d in "
                        "cases/paper_tunnel); its results go to '<output.directory>_NAME' unless it sets "
                        "output.directory")
    return p


def add_ranks_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ranks", type=int, metavar="N", default=1,
                   help="run the solid on N MPI ranks, the model partitioned between them (mpirun -np N; "
                        "docs/architecture.md \"The solid on ranks\" says what runs on ranks)")


def refuse_ranks(case: Case, ranks: int) -> bool:
    """True (after printing why) when the case cannot run its solid on `ranks` ranks."""
    from ..solid_ranks import ranks_refusal, refusal_message

    reasons = ranks_refusal(case, ranks)
    if reasons:
        print(f"error: {refusal_message(ranks, reasons)}", file=sys.stderr)
    return bool(reasons)


def load_for_ranks(args: argparse.Namespace) -> Case | None:
    """The case of the command line (args.case, args.variant) when it loads and its solid can run on
    args.ranks ranks; None after printing why not."""
    case = load_or_report(args.case, args.variant)
    if case is None or refuse_ranks(case, args.ranks):
        return None
    return case


@contextlib.contextmanager
def folder_held(case: Case, command: str):
    """Hold the case's results folder for a command that writes into it (mesh, motion, post by
    hand): yields True, or prints who holds it and yields False. `run` holds it for its whole run."""
    from ..runlock import RunLockBusy, run_lock

    try:
        with run_lock(case.output_dir, command):
            yield True
    except RunLockBusy as e:
        print(f"error: {e}", file=sys.stderr)
        yield False
