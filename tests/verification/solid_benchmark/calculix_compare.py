"""Benchmark: tq-solid against CalculiX explicit dynamics on the same elastic box (issue 3).

Not a test (CI does not run it); prints a markdown table for docs/benchmarks.md.

Problem (written by ``tq-solid-bench --column P --dt DT --write-ccx deck.inp``, so both codes get
the same nodes, elements, loads and step): an n x n x n box of 1 m hex8 elements, E = 8 GPa,
nu = 0.27, rho = 2700 kg/m^3; base on rollers (u_z = 0), sides on rollers (u_x = 0 on the x
faces, u_y = 0 on the y faces), a step pressure P on the top as nodal forces P A/4 per quad
corner, starting from rest, a fixed step DT for N increments. tq-solid runs its one-point
assumed-strain hex8; CalculiX 2.20 (Debian's calculix-ccx) runs C3D8R under
``*DYNAMIC, EXPLICIT, DIRECT`` with minimum = maximum increment = DT.

Physics cross-check: the model is a constrained 1D column, so before the wave reflected at the
base returns (t < 2 H / c_p) the top moves as u_z = -P t / (rho c_p) (a step load on a half
space); each code's top-centre u_z after N increments is compared with that and with the other
code. Tolerance 2 % (the discrete wave front rings about the continuous one; both codes see
the same ringing to the extent that their time integrators agree).

Timing: tq-solid-bench's own clock over the N steps (µs per element-step). CalculiX's wall time
includes reading the deck and building the model, so it is run with N and with N/10 increments
and the difference is divided by the element-increments in between. The codes alternate
(--repeat rounds), medians. Both on 1 thread (OMP_NUM_THREADS=1, and CalculiX's own CCX_NPROC_* /
NUMBER_OF_CPUS variables set to 1). The comparison itself is tunnelquake.bench_calculix, which
`tunnelquake bench --peer` also runs (into docs/benchmarks.md's generated solid section).

Usage (from the repository root):
  TQ_BUILD_DIR=/tmp/build-perf .venv/bin/python tests/verification/solid_benchmark/calculix_compare.py \
      [--n 40] [--steps 100] [--dt 1.5e-4] [--pressure 1e6] [--repeat 3] [--workdir /tmp/tq-ccx]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
from tunnelquake.bench_calculix import PeerError, compare, markdown  # noqa: E402


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
    print(f"date {datetime.date.today()}, machine {platform.node()} ({platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores), calculix-ccx {r.ccx_version}, 1 thread each\n")
    print(markdown(r))
    if not r.agree:
        sys.exit(1)


if __name__ == "__main__":
    main()
