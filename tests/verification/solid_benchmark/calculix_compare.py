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

Timing: tq-solid-bench's own clock over the N steps (median of --repeat runs, µs per
element-step). CalculiX's wall time includes reading the deck and building the model, so it is
run with N and with N/10 increments and the difference is divided by the element-increments in
between (median of --repeat pairs). Both on 1 thread (OMP_NUM_THREADS=1, and CalculiX's own
CCX_NPROC_* / NUMBER_OF_CPUS variables set to 1).

Usage (from the repository root):
  TQ_BUILD_DIR=/tmp/build-perf .venv/bin/python tests/verification/solid_benchmark/calculix_compare.py \
      [--n 40] [--steps 100] [--dt 1.5e-4] [--pressure 1e6] [--repeat 3] [--workdir /tmp/tq-ccx]
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
E, NU, RHO = 8e9, 0.27, 2700.0  # tq-solid-bench's material


def p_wave_speed() -> float:
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    return math.sqrt((lam + 2 * mu) / RHO)


def one_thread_env() -> dict[str, str]:
    env = dict(os.environ)
    for k in ("OMP_NUM_THREADS", "CCX_NPROC_RESULTS", "CCX_NPROC_EQUATION_SOLVER", "NUMBER_OF_CPUS"):
        env[k] = "1"
    return env


def run_tq(bench: Path, args: argparse.Namespace, steps: int, deck: Path | None, repeat: int,
           generic: bool = False) -> tuple[float, float]:
    cmd = [str(bench), "--n", str(args.n), "--steps", str(steps), "--repeat", str(repeat), "--threads", "1",
           "--column", repr(args.pressure), "--dt", repr(args.dt)]
    if deck is not None:
        cmd += ["--write-ccx", str(deck)]
    if generic:
        cmd.append("--generic")
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=one_thread_env()).stdout
    us = float(re.search(r"median ([0-9.eE+-]+) us per element-step", out).group(1))
    uz = float(re.search(r"u_z = ([0-9.eE+-]+) m", out).group(1))
    return us, uz


def run_ccx(ccx: str, deck: Path) -> tuple[float, float]:
    """Wall time (s) of one CalculiX run and the monitor node's final u_z (m)."""
    job = deck.with_suffix("")
    t0 = time.perf_counter()
    res = subprocess.run([ccx, "-i", job.name], cwd=deck.parent, capture_output=True, text=True, env=one_thread_env())
    wall = time.perf_counter() - t0
    if res.returncode != 0 or "*ERROR" in res.stdout:
        sys.exit(f"CalculiX failed on {deck}:\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}")
    dat = job.with_suffix(".dat").read_text().split("\n")
    rows = [ln.split() for ln in dat if re.match(r"^\s*\d+\s+[-0-9.E+]+\s+[-0-9.E+]+\s+[-0-9.E+]+\s*$", ln)]
    if not rows:
        sys.exit(f"no displacement in {job.with_suffix('.dat')}")
    return wall, float(rows[-1][3])


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
    bench = build / "solid_solver" / "tq-solid-bench"
    ccx = shutil.which("ccx")
    if not bench.exists():
        sys.exit(f"{bench} not found: build it (cmake --build {build} --target tq-solid-bench) or set TQ_BUILD_DIR")
    if ccx is None:
        sys.exit("ccx not found: install Debian's calculix-ccx (scripts/bootstrap.sh installs it)")
    cp = p_wave_speed()
    height = float(args.n)
    t_end = args.steps * args.dt
    if t_end >= 2 * height / cp:
        sys.exit(f"t = {t_end:.4g} s reaches the reflected wave (2H/c_p = {2 * height / cp:.4g} s): use fewer steps")
    args.workdir.mkdir(parents=True, exist_ok=True)
    short = max(1, args.steps // 10)
    deck_long, deck_short = args.workdir / "box_long.inp", args.workdir / "box_short.inp"
    run_tq(bench, args, short, deck_short, 1)
    tq_us, tq_uz = run_tq(bench, args, args.steps, deck_long, args.repeat)
    tq_gen_us, tq_gen_uz = run_tq(bench, args, args.steps, None, args.repeat, generic=True)
    elems = args.n**3
    ccx_us, ccx_uz = [], 0.0
    for _ in range(args.repeat):
        w_long, ccx_uz = run_ccx(ccx, deck_long)
        w_short, _ = run_ccx(ccx, deck_short)
        ccx_us.append(1e6 * (w_long - w_short) / (elems * (args.steps - short)))
        ccx_total = w_long
    ccx_med = statistics.median(ccx_us)
    exact = -args.pressure * t_end / (RHO * cp)
    ver = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "calculix-ccx"], capture_output=True, text=True).stdout

    def rel(a: float, b: float) -> float:
        return abs(a - b) / abs(b)

    print(f"date {datetime.date.today()}, machine {platform.node()} ({platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores), calculix-ccx {ver or '?'}, 1 thread each")
    print(f"box {args.n}^3 = {elems} hex8, {args.steps} increments of {args.dt:g} s, step pressure "
          f"{args.pressure:g} Pa, c_p {cp:.2f} m/s\n")
    print("| code | element | µs per element-increment (median) | top-centre u_z after N (m) | vs 1D exact |")
    print("|---|---|---:|---:|---:|")
    print(f"| tq-solid (AVX2 path) | one-point hex8, assumed-strain hourglass | {tq_us:.3f} | {tq_uz:.6e} | "
          f"{100 * (tq_uz - exact) / abs(exact):+.2f} % |")
    print(f"| tq-solid (generic x86-64 path) | same | {tq_gen_us:.3f} | {tq_gen_uz:.6e} | "
          f"{100 * (tq_gen_uz - exact) / abs(exact):+.2f} % |")
    print(f"| CalculiX {ver} | C3D8R, *DYNAMIC, EXPLICIT | {ccx_med:.3f} (whole run {ccx_total:.1f} s) | "
          f"{ccx_uz:.6e} | {100 * (ccx_uz - exact) / abs(exact):+.2f} % |")
    print(f"\nratio CalculiX / tq-solid: {ccx_med / tq_us:.1f}x (generic path {ccx_med / tq_gen_us:.1f}x); "
          f"1D exact u_z = -P t/(rho c_p) = {exact:.6e} m; tq vs CalculiX {100 * rel(tq_uz, ccx_uz):.2f} %")
    ok = rel(tq_uz, exact) < 0.02 and rel(ccx_uz, exact) < 0.02 and rel(tq_uz, ccx_uz) < 0.02
    print("physics cross-check (2 %):", "agree" if ok else "DISAGREE")
    if not ok:
        sys.exit(1)


if __name__ == "__main__":
    main()
