"""tunnelquake compare A B: whether two runs' results are equal, byte for byte (results files, monitors,
report; wall-clock figures and the runs' own paths left out). A and B are results folders or case files,
or two results files (.h5). Exit 0 when equal, 1 when anything differs (each difference listed), 2
when there is nothing to compare or a run is still writing them (said why)."""
from __future__ import annotations

import argparse
from pathlib import Path

from .common import say


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="tunnelquake compare", description=__doc__)
    p.add_argument("a", type=Path, help="results folder (or case file) of the first run")
    p.add_argument("b", type=Path, help="results folder (or case file) of the second run")
    args = p.parse_args(argv)
    from ..compare import CompareError, compare_runs

    try:
        c = compare_runs(args.a, args.b)
    except (FileNotFoundError, CompareError) as e:
        say(f"compare: {e}")
        return 2
    for name in c.compared:
        diff = c.differences.get(name, [])
        say(f"{name}: {'equal' if not diff else f'{len(diff)} difference(s)'}")
        for line in diff:
            say(f"  {line}")
    for name in c.only_in_one:
        say(f"{name}: only in one of the two folders")
    if not c.compared:
        say("compare: no results file, monitors or report in common")
        return 2
    say("equal" if c.equal else "different")
    return 0 if c.equal else 1
