"""tq-solid against CalculiX explicit dynamics on the same deck (the peer run of `tunnelquake bench --peer`).

Used by `tunnelquake bench --peer` (the ratio goes into the generated solid section of
docs/benchmarks.md) and by benchmarks/calculix_compare.py.

Problem (written by ``tq-solid-bench --column P --dt DT --write-ccx deck.inp``, so both codes get
the same nodes, elements, loads and step): an n x n x n box of 1 m hex8 elements, E = 8 GPa,
nu = 0.27, rho = 2700 kg/m^3; base on rollers (u_z = 0), sides on rollers (u_x = 0 on the x
faces, u_y = 0 on the y faces), a step pressure P on the top as nodal forces P A/4 per quad
corner, starting from rest, a fixed step DT for N increments. tq-solid runs its one-point
assumed-strain hex8; CalculiX (Debian's calculix-ccx) runs C3D8R under
``*DYNAMIC, EXPLICIT, DIRECT`` with minimum = maximum increment = DT.

Physics cross-check: the model is a constrained 1D column, so before the wave reflected at the
base returns (t < 2 H / c_p) the top moves as u_z = -P t / (rho c_p) (a step load on a half
space); each code's top-centre u_z after N increments is compared with that and with the other
code. Tolerance 2 % (the discrete wave front rings about the continuous one; both codes see
the same ringing to the extent that their time integrators agree).

Timing: tq-solid-bench's own clock over the N steps (µs per element-step). CalculiX's wall time
includes reading the deck and building the model, so it is run with N and with N/10 increments
and the difference is divided by the element-increments in between. The two codes alternate
(tq, CalculiX N, CalculiX N/10, repeated); the ratio is the median of the rounds' ratios, the
table's times the medians of the rounds. Both on 1 thread
(OMP_NUM_THREADS=1, and CalculiX's own CCX_NPROC_* / NUMBER_OF_CPUS variables set to 1).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import statistics
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

E, NU, RHO = 8e9, 0.27, 2700.0  # tq-solid-bench's material
TOLERANCE = 0.02  # physics cross-check (see the module docstring)


class PeerError(RuntimeError):
    """The comparison could not be run (a program failed or printed no result)."""


@dataclass
class PeerResult:
    n: int
    steps: int
    dt: float
    pressure: float
    ccx_version: str
    tq_us: list[float] = field(default_factory=list)
    tq_generic_us: list[float] = field(default_factory=list)
    ccx_us: list[float] = field(default_factory=list)
    ccx_whole_s: list[float] = field(default_factory=list)
    tq_uz: float = 0.0
    tq_generic_uz: float = 0.0
    ccx_uz: float = 0.0

    @property
    def elements(self) -> int:
        return self.n**3

    @property
    def exact_uz(self) -> float:
        return -self.pressure * self.steps * self.dt / (RHO * p_wave_speed())

    def pair_ratios(self, generic: bool = False) -> list[float]:
        """CalculiX / tq-solid µs per element-increment of each alternating round."""
        return [c / t for c, t in zip(self.ccx_us, self.tq_generic_us if generic else self.tq_us, strict=False)]

    def ratio(self, generic: bool = False) -> float:
        """Median over the rounds of the ratio measured within each round (the machine is shared:
        a round's two codes see the same load, successive rounds need not)."""
        return statistics.median(self.pair_ratios(generic))

    @property
    def answer_difference(self) -> float:
        """|u_z(tq) − u_z(CalculiX)| / |u_z(CalculiX)|."""
        return abs(self.tq_uz - self.ccx_uz) / abs(self.ccx_uz)

    @property
    def agree(self) -> bool:
        ex = self.exact_uz
        return (abs(self.tq_uz - ex) < TOLERANCE * abs(ex) and abs(self.ccx_uz - ex) < TOLERANCE * abs(ex)
                and self.answer_difference < TOLERANCE)


def p_wave_speed() -> float:
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    return math.sqrt((lam + 2 * mu) / RHO)


def one_thread_env() -> dict[str, str]:
    env = dict(os.environ)
    for k in ("OMP_NUM_THREADS", "CCX_NPROC_RESULTS", "CCX_NPROC_EQUATION_SOLVER", "NUMBER_OF_CPUS"):
        env[k] = "1"
    env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    return env


def bench_executable(build: Path) -> Path:
    return build / "solid_solver" / "tq-solid-bench"


def missing_reason(build: Path) -> str | None:
    """Why the comparison cannot run here (None: it can)."""
    if shutil.which("ccx") is None:
        return "ccx (CalculiX) not found on PATH: install Debian's calculix-ccx (scripts/bootstrap.sh installs it)"
    if not bench_executable(build).is_file():
        return (f"{bench_executable(build)} not found: build it (cmake --build {build} --target tq-solid-bench) "
                "or set TQ_BUILD_DIR")
    return None


def _run_tq(bench: Path, n: int, steps: int, dt: float, pressure: float, deck: Path | None,
            generic: bool = False) -> tuple[float, float]:
    cmd = [str(bench), "--n", str(n), "--steps", str(steps), "--repeat", "1", "--threads", "1",
           "--column", repr(pressure), "--dt", repr(dt)]
    if deck is not None:
        cmd += ["--write-ccx", str(deck)]
    if generic:
        cmd.append("--generic")
    res = subprocess.run(cmd, capture_output=True, text=True, env=one_thread_env())
    if res.returncode != 0:
        raise PeerError(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr.strip()[-1000:]}")
    us = re.search(r"median ([0-9.eE+-]+) us per element-step", res.stdout)
    uz = re.search(r"u_z = ([0-9.eE+-]+) m", res.stdout)
    if not us or not uz:
        raise PeerError(f"{bench.name} printed no timing or u_z:\n{res.stdout[-1000:]}")
    return float(us.group(1)), float(uz.group(1))


def _run_ccx(ccx: str, deck: Path) -> tuple[float, float]:
    """Wall time (s) of one CalculiX run and the monitor node's final u_z (m)."""
    job = deck.with_suffix("")
    t0 = time.perf_counter()
    res = subprocess.run([ccx, "-i", job.name], cwd=deck.parent, capture_output=True, text=True, env=one_thread_env())
    wall = time.perf_counter() - t0
    if res.returncode != 0 or "*ERROR" in res.stdout:
        raise PeerError(f"CalculiX failed on {deck}:\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}")
    dat = job.with_suffix(".dat").read_text().split("\n")
    rows = [ln.split() for ln in dat if re.match(r"^\s*\d+\s+[-0-9.E+]+\s+[-0-9.E+]+\s+[-0-9.E+]+\s*$", ln)]
    if not rows:
        raise PeerError(f"no displacement in {job.with_suffix('.dat')}")
    return wall, float(rows[-1][3])


def compare(build: Path, *, n: int = 40, steps: int = 100, dt: float = 1.5e-4, pressure: float = 1e6,
            repeat: int = 3, workdir: Path = Path("/tmp/tq-ccx"), generic: bool = True) -> PeerResult:
    """Run both codes on the same deck, alternating, and return the figures (raises PeerError)."""
    reason = missing_reason(build)
    if reason:
        raise PeerError(reason)
    ccx = shutil.which("ccx")
    assert ccx is not None
    bench = bench_executable(build)
    height = float(n)
    t_end = steps * dt
    if t_end >= 2 * height / p_wave_speed():
        raise PeerError(f"t = {t_end:.4g} s reaches the reflected wave (2H/c_p = {2 * height / p_wave_speed():.4g} s): "
                        "use fewer steps")
    workdir.mkdir(parents=True, exist_ok=True)
    short = max(1, steps // 10)
    deck_long, deck_short = workdir / "box_long.inp", workdir / "box_short.inp"
    _run_tq(bench, n, short, dt, pressure, deck_short)
    ver = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "calculix-ccx"], capture_output=True,
                         text=True).stdout.strip()
    r = PeerResult(n=n, steps=steps, dt=dt, pressure=pressure, ccx_version=ver or "?")
    for i in range(repeat):
        us, r.tq_uz = _run_tq(bench, n, steps, dt, pressure, deck_long if i == 0 else None)
        r.tq_us.append(us)
        if generic:
            us, r.tq_generic_uz = _run_tq(bench, n, steps, dt, pressure, None, generic=True)
            r.tq_generic_us.append(us)
        w_long, r.ccx_uz = _run_ccx(ccx, deck_long)
        w_short, _ = _run_ccx(ccx, deck_short)
        r.ccx_us.append(1e6 * (w_long - w_short) / (r.elements * (steps - short)))
        r.ccx_whole_s.append(w_long)
    return r


def markdown(r: PeerResult) -> str:
    """The side-by-side table, the ratio and the answer difference."""
    ex = r.exact_uz

    def pct(uz: float) -> str:
        return f"{100 * (uz - ex) / abs(ex):+.2f} %"

    med = statistics.median
    rows = [
        "| code | element | µs per element-increment (median) | top-centre u_z after N (m) | vs 1D exact |",
        "|---|---|---:|---:|---:|",
        f"| tq-solid (AVX2 path) | one-point hex8, assumed-strain hourglass | {med(r.tq_us):.3f} | "
        f"{r.tq_uz:.6e} | {pct(r.tq_uz)} |",
    ]
    if r.tq_generic_us:
        rows.append(f"| tq-solid (generic x86-64 path) | same | {med(r.tq_generic_us):.3f} | {r.tq_generic_uz:.6e} | "
                    f"{pct(r.tq_generic_uz)} |")
    rows.append(f"| CalculiX {r.ccx_version} | C3D8R, *DYNAMIC, EXPLICIT | {med(r.ccx_us):.3f} (whole run "
                f"{med(r.ccx_whole_s):.1f} s) | {r.ccx_uz:.6e} | {pct(r.ccx_uz)} |")
    generic = f" (generic path {r.ratio(generic=True):.1f}×)" if r.tq_generic_us else ""
    rows.append("")
    rows.append(
        f"Box {r.n}³ = {r.elements:,} hex8, {r.steps} increments of {r.dt:g} s, step pressure {r.pressure:g} Pa, "
        f"c_p {p_wave_speed():.2f} m/s, {len(r.ccx_us)} alternating rounds, 1 thread each. "
        f"**Ratio CalculiX / tq-solid: {r.ratio():.1f}×**{generic} per element-increment (median of the "
        f"rounds' ratios; rounds {', '.join(f'{x:.1f}' for x in r.pair_ratios())}); answer difference "
        f"|u_z(tq) − u_z(CalculiX)| / |u_z(CalculiX)| = {100 * r.answer_difference:.2f} %; 1D exact "
        f"u_z = −P t/(ρ c_p) = {ex:.6e} m; physics cross-check (all three within {100 * TOLERANCE:g} %): "
        f"{'agree' if r.agree else 'DISAGREE'}.")
    return "\n".join(rows)
