"""tunnelquake motion: read or synthesise the ground motion, process it, write motion.h5 and a figure."""
from __future__ import annotations

from ..prepare import motion_and_figure
from .common import folder_held, load_or_report, parser, say


def main(argv: list[str]) -> int:
    args = parser("motion", __doc__).parse_args(argv)
    case = load_or_report(args.case, args.variant)
    if case is None:
        return 1
    with folder_held(case, "tunnelquake motion " + " ".join(map(str, argv))) as held:
        if not held:
            return 1
        made = motion_and_figure(case)
        if made is None:
            return 1
        say(f"figure: {made[2]}")
    return 0
