"""tunnelquake bench FOLDER [--fluid | --paper | --peer | --stress] ...: the benchmarks.

They live outside the installed package, in the repository's benchmarks/ (they need its build,
cases and docs); this command runs `python -m benchmarks ARGS` from there with this interpreter and this
`tunnelquake`, and returns its exit status. `tunnelquake bench --help` prints the solid ladders'
options; `--fluid --help` and `--paper --help` those of the other two.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from ..paths import ROOT


def main(argv: list[str]) -> int:
    if not (ROOT / "benchmarks" / "__main__.py").is_file():
        print(f"tunnelquake bench: no benchmarks/ in {ROOT}: the benchmarks run from a checkout of the "
              "repository (an installed package has none)", file=sys.stderr)
        return 2
    package_parent = str(Path(__file__).resolve().parents[2])  # this tunnelquake, not another one
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), package_parent, env.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, "-m", "benchmarks", *argv], env=env).returncode
