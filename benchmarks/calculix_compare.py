"""Benchmark: tq-solid against CalculiX explicit dynamics on the same elastic box.

Not a test (CI does not run it); prints a markdown table for docs/benchmarks.md.

The problem (the same deck for both codes, written by ``tq-solid-bench --write-ccx``), the physics
cross-check (u_z = -P t / (rho c_p) before the reflection, tolerance 2 %) and the timing method are
described in, and run by, benchmarks/calculix.py, which `tunnelquake bench --peer` also runs
(into docs/benchmarks.md's generated solid section).

Usage (from the repository root):
  TQ_BUILD_DIR=/tmp/build-perf .venv/bin/python -m benchmarks.calculix_compare \
      [--n 40] [--steps 100] [--dt 1.5e-4] [--pressure 1e6] [--repeat 3] [--workdir /tmp/tq-ccx]
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
from pathlib import Path

from .calculix import PeerError, compare, markdown
from .common import machine

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=40, help="elements per edge (default 40: 64,000 elements)")
    ap.add_argument("--steps", type=int, default=100, help="increments (default 100)")
    ap.add_argument("--dt", type=float, default=1.5e-4, help="fixed step (s), below CalculiX's Courant estimate")
    ap.add_argument("--pressure", type=float, default=1e6, help="step pressure on the top (Pa)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/tq-ccx"))
    args = ap.parse_args()

    build = Path(os.environ.get("TQ_BUILD_DIR", ROOT / "build"))
    try:
        r = compare(build, n=args.n, steps=args.steps, dt=args.dt, pressure=args.pressure, repeat=args.repeat,
                    workdir=args.workdir)
    except PeerError as e:
        sys.exit(str(e))
    print(f"date {datetime.date.today()}, machine {machine()}, calculix-ccx {r.ccx_version}, 1 thread each\n")
    print(markdown(r))
    if not r.agree:
        sys.exit(1)


if __name__ == "__main__":
    main()
