"""tunnelquake run: the main job. Validates the case, meshes it, prepares the motion, then runs each
condition with only the solvers it needs, and post-processes.

  no_water       solid only (rock + lining), no fluid process, no coupling
  static_water   solid only, with the hydrostatic pressure on the lining's inner face
  dynamic_water  solid + OpenFOAM water, coupled every step
"""
from __future__ import annotations

import sys

from ..launch import run_held
from .common import add_ranks_argument, load_for_ranks, parser


def main(argv: list[str]) -> int:
    """Validate, take the results folder (one run at a time), then do the job under a supervisor
    that turns SIGINT, SIGTERM and SIGHUP into an orderly stop."""
    p = parser("run", __doc__)
    p.add_argument("--no-post", action="store_true", help="skip post-processing")
    add_ranks_argument(p)
    from . import suite_run

    suite_run.add_arguments(p)
    args = p.parse_args(argv)
    case = load_for_ranks(args)
    if case is None:
        return 1
    if case.data["suite"]["records"] is not None and args.ranks > 1:
        print(f"error: --ranks {args.ranks}: a record suite runs its members side by side (--workers); run it "
              "without --ranks", file=sys.stderr)
        return 1
    if case.data["suite"]["records"] is not None:
        return suite_run.main(case, args, argv)
    used = [f"--{k}" for k in ("workers", "executor", "slurm") if getattr(args, k) not in (None, False)]
    if used:
        print(f"error: {', '.join(used)}: only for a case with a suite: section (docs/user_guide.md \"Record "
              "suites\")", file=sys.stderr)
        return 1
    return run_held(case, "tunnelquake run " + " ".join(map(str, argv)), resume=args.resume, post=not args.no_post,
                    ranks=args.ranks)
