"""`tunnelquake` command line: one module per subcommand, each with main(argv) -> exit code.

    tunnelquake check  case.yaml    validate a case without running anything
    tunnelquake mesh   case.yaml    gmsh mesh -> mesh.h5 (solid) + water.msh
    tunnelquake motion case.yaml    ground motion -> motion.h5 + input figure
    tunnelquake run    case.yaml    mesh, motion, then each condition with only the solvers it needs
                                    (a case with suite: every member x condition, suite_report.md)
    tunnelquake post   case.yaml    results -> CSV monitors, figures, report
    tunnelquake compare A B         whether two runs' results are equal, byte for byte
    tunnelquake bench  FOLDER       the benchmarks (benchmarks/ of the repository: python -m benchmarks)
"""
from __future__ import annotations

import sys

COMMANDS = ("check", "mesh", "motion", "run", "post", "compare", "bench")


def main(argv: list[str] | None = None) -> int:
    """The `tunnelquake` command; `argv` None reads the process's arguments (a program, not a call)."""
    code = _command(list(sys.argv[1:] if argv is None else argv))
    if argv is None:
        from ..supervise import exit_now_if_left_running

        exit_now_if_left_running(code)
    return code


def _command(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if argv else 2
    if argv[0] == "--version":
        from .. import __version__

        print(f"tunnelquake {__version__}")
        return 0
    cmd, rest = argv[0], argv[1:]
    if cmd not in COMMANDS:
        print(f"tunnelquake: unknown command '{cmd}'; use one of: {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    import importlib

    module = importlib.import_module(f".{cmd}", __name__)
    return module.main(rest)


if __name__ == "__main__":
    sys.exit(main())
