"""tunnelquake post: turn what a run left in the results folder into figures, CSV, ParaView files and
report.md. Needs no solver; works on whatever results exist: a results file cut off mid-run, one
stopped before the shaking (no monitor sample), an unreadable one, a condition never run. Each is
reported as found; a figure that cannot be drawn is named with the reason, never a traceback.
On a full disk every output that fits is still written (each in place only once complete), the
state of each condition is said on the terminal, and post ends with one line naming what was not
written and the space free, exit code 1."""
from __future__ import annotations

import sys

from ..case_report import OutputsNotWritten, post_case
from ..fingerprint import InputsChanged
from .common import folder_held, load_or_report, parser, say


def main(argv: list[str]) -> int:
    args = parser("post", __doc__).parse_args(argv)
    case = load_or_report(args.case, args.variant)
    if case is None:
        return 1
    with folder_held(case, "tunnelquake post " + " ".join(map(str, argv))) as held:
        if not held:
            return 1
        if case.data["suite"]["records"] is not None:
            from ..suite_members import plan_members, read_state, write_report

            members = plan_members(case)
            say(f"suite report: {write_report(case, members, {m.name: read_state(m.folder) for m in members})}")
            return 0
        try:
            post_case(case)
        except (OutputsNotWritten, InputsChanged) as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
    return 0
