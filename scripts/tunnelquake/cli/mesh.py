"""tunnelquake mesh: build the all-hex gmsh mesh of the case -> mesh.h5 (rock, lining) + water.msh."""
from __future__ import annotations

import sys

from ..prepare import make_mesh
from .common import DiskFull, folder_held, load_or_report, parser


def main(argv: list[str]) -> int:
    p = parser("mesh", __doc__)
    p.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = p.parse_args(argv)
    case = load_or_report(args.case, args.variant)
    if case is None:
        return 1
    with folder_held(case, "tunnelquake mesh " + " ".join(map(str, argv))) as held:
        if not held:
            return 1
        try:
            make_mesh(case, force=args.force)
        except DiskFull as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
    return 0
