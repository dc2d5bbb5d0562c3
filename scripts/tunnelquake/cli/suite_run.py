"""`tunnelquake run` of a case with a `suite:` (suite_launch.py): every member x condition, members in
parallel on a process pool (this machine's cores) or on MPI ranks (mpi4py.futures), then
suite_report.md; or, with --slurm, a Slurm job array of the members.
"""
from __future__ import annotations

from ..suite_launch import SuiteOptions, run_suite


def add_arguments(p) -> None:
    p.add_argument("--workers", type=int, metavar="N", default=None,
                   help="suite: members run at once (default: suite.workers, or the cores // a member's)")
    p.add_argument("--executor", choices=("local", "mpi"), default=None,
                   help="suite: local process pool, or mpi4py.futures' MPIPoolExecutor (the default under "
                        "`mpiexec -n N python -m mpi4py.futures -m tunnelquake run ...`)")
    p.add_argument("--resume", action="store_true",
                   help="keep the completed conditions and continue the others from their restart checkpoints "
                        "(none: start afresh); suite: run only the members not finished, each so")
    p.add_argument("--slurm", action="store_true",
                   help="suite: write the members and a Slurm job-array script (suite.slurm), run nothing")


def main(case, args, argv) -> int:
    """Run the suite of `case` (the parsed `tunnelquake run` arguments `args`) holding its folder."""
    opts = SuiteOptions(case_arg=str(args.case), workers=args.workers, executor=args.executor, resume=args.resume,
                        slurm=args.slurm, no_post=args.no_post)
    return run_suite(case, "tunnelquake run " + " ".join(map(str, argv)), opts)
