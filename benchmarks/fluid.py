"""tunnelquake bench --fluid: run time against error for the water and coupled verification cases
side by side with the stock pimpleFoam set-up.

    tunnelquake bench FOLDER --fluid [--parts pipe pipe3d ring] [--repeat 3] [--update-docs]

Writes into FOLDER:

    fluid.md     the tables (ladders with errors, wall time, observed orders; stock/ours ratio)
    fluid.png    error against wall time, one line per ladder and error
    fluid.json   every run's figures

Ladders:
  rigid pipe, 2D slice (tests/verification/fluid_rigid_pipe: R 4.5 m, a = a0 cos ωt, 1 Hz, one
  period from rest; references p(θ) = −ρ a R cos θ and F = ρπR²L a0), on blockMesh O-grids of
  N = 32, 64, 128 (--full: and 256) faces around (N²/4 cells), 200 steps a period; and N = 64 at 25,
  50, 100, 200, 400 steps a period. Each setting runs with our water settings (tunnelquake.water_case's:
  transpiration, tuned PIMPLE, p by tqProjected + GAMG) and with the stock set-up of
  benchmarks/water_step/benchmark.py (pimpleFoam + displacementLaplacian,
  inverseDistance, movingWallVelocity + fixedFluxPressure, movingCone solvers), alternately,
  --repeat times: errors (deterministic) of both and the per-step time ratio (median of the
  per-round ratios).
  rigid pipe, 3D (--parts pipe3d; its own block in docs/benchmarks.md, `<!-- bench:fluid-pipe3d -->`,
  right after the fluid section): the same closed form on a closed pipe of L 9 m whose end plates
  move with it (pipe.make_pipe_case's walls; tunnel.make_case: stock movingWallVelocity +
  fixedFluxPressure on the moved mesh, ours slip on the static one), N = 16, 32, 64 around with
  3N/16 cells along, 200 steps a period; stock and ours alternately as above.
  water-filled ring (tunnelquake.verification.ring, the coupled chain tq-solid + coupler +
  rhoPimpleFoam, implicit IQN-ILS, slice): n around = 16, 32, 64; at 32 around
  the coupling tolerance 1e-3, 1e-4, 1e-5; reference: the thin-ring n = 2 frequency with the
  water's radius (references.ring_ovaling_frequency). The empty ring (tq-solid alone): 16 .. 128.

--from-json FOLDER/fluid.json renders the tables, figure and (with --update-docs) the section again
from an earlier run's figures without running anything; --note adds a line on the conditions.
--update-docs replaces the part of docs/benchmarks.md between `<!-- bench:fluid -->` and
`<!-- /bench:fluid -->` (appended if absent) and copies the figure to docs/bench/fluid.png; the 3D
pipe's block is replaced on its own (a --parts pipe3d run leaves the fluid section and figure alone).
Benchmarks, not tests: wall times are the machine's of the day; the errors are reproducible.
Needs libtqFoam.so and tq-solid (TQ_BUILD_DIR) and OpenFOAM v1912.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import functools
import json
import math
import shlex
import shutil
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from tunnelquake.paths import ROOT

from . import common
from .common import observed_orders

FLUID_BEGIN, FLUID_END = "<!-- bench:fluid -->", "<!-- /bench:fluid -->"
#: the 3D rigid pipe's own block, right after the fluid section (written by --parts pipe3d alone too)
PIPE3D_BEGIN, PIPE3D_END = "<!-- bench:fluid-pipe3d -->", "<!-- /bench:fluid-pipe3d -->"

#: rigid pipe (tests/verification/fluid_rigid_pipe/README.md)
PIPE_R = 4.5  # m
PIPE_A0 = 1.0  # m/s²
PIPE_FREQ = 1.0  # Hz
PIPE_L = 1.0  # m: the slice's thickness
PIPE_MESH_N = (32, 64, 128)  # faces around (--full: and 256)
PIPE_MESH_STEPS = 200  # steps a period in the mesh ladder
PIPE_STEP_N = 64
PIPE_STEPS = (25, 50, 100, 200, 400)
PIPE_SKIP = 5  # steps left out of the per-step time (start-up)
#: rigid pipe in 3D: closed (end plates moving with the pipe), the length of the water test's 3D pipe
PIPE3D_L = 9.0  # m
PIPE3D_N = (16, 32, 64)  # faces around
PIPE3D_NY16 = 3  # cells along the pipe per 16 faces around (3 m at N = 16, 1.7 × the wall face width)
PIPE3D_STEPS = 200  # steps a period (the 2D mesh ladder's)
RING_N = (16, 32, 64)
RING_TOLERANCES = (1e-3, 1e-4, 1e-5)
EMPTY_N = (16, 32, 64, 128)


class BenchError(RuntimeError):
    """A run of the fluid benchmark failed; the text names the run and why."""


@dataclass
class Ladder:
    """One ladder: its runs are dicts with 'setting' (text), 'size' (falls as the run is refined:
    1/N, Δt or 1/n), 'wall_s', and the error keys (relative, signed)."""

    name: str
    error_keys: tuple[str, ...]
    labels: tuple[str, ...]
    runs: list[dict] = field(default_factory=list)
    #: the value whose successive differences give a reference-free order; None: not a refinement
    #: ladder (a tolerance), no orders shown
    value_key: str | None = None


# ------------------------------------------------------------------------------------------------
# Arithmetic of the tables (tests/python/test_bench_fluid.py)
# ------------------------------------------------------------------------------------------------
def difference_orders(sizes: list[float], values: list[float]) -> list[float | None]:
    """Reference-free order from three successive runs with a constant refinement ratio r:
    p = log(|v_(i−2) − v_(i−1)| / |v_(i−1) − v_i|) / log r (Richardson). None for the first two
    runs, where the ratio is not constant, or where the differences vanish or change sign (no
    asymptotic range)."""
    out: list[float | None] = [None] * min(2, len(values))
    for i in range(2, len(values)):
        s0, s1, s2 = sizes[i - 2], sizes[i - 1], sizes[i]
        d0, d1 = values[i - 2] - values[i - 1], values[i - 1] - values[i]
        r0, r1 = s0 / s1, s1 / s2
        if d0 == 0 or d1 == 0 or (d0 > 0) != (d1 > 0) or r0 <= 1 or not math.isclose(r0, r1, rel_tol=1e-6):
            out.append(None)
        else:
            out.append(math.log(d0 / d1) / math.log(r0))
    return out


def pipe_errors(t, fx, omega: float, theta, p_wall, a_last: float, length: float = PIPE_L,
                radius: float = PIPE_R, rho: float = 1000.0, a0: float = PIPE_A0) -> dict:
    """Errors of one rigid-pipe run against p = p0 − ρ a R cos θ and F = −ρπR²L a:
    force: amplitude of the least-squares harmonic fit of F_x(t) (from the third row on) over
    ρπR²L a0, minus 1; pressure: the cos θ coefficient of the wall pressure at the last step fitted
    by p0 + A cos θ + B sin θ, over −ρ a_last R, minus 1; pressure_dev: the largest deviation of
    the wall pressure from the fit's p0 + the reference, over ρ a_last R (the test's measure)."""
    import numpy as np

    t, fx, theta, p_wall = (np.asarray(x, float) for x in (t, fx, theta, p_wall))
    m = np.column_stack([np.cos(omega * t[2:]), np.sin(omega * t[2:]), np.ones_like(t[2:])])
    (a, b, _), *_ = np.linalg.lstsq(m, fx[2:], rcond=None)
    f_ref = rho * math.pi * radius**2 * length * a0
    mp = np.column_stack([np.cos(theta), np.sin(theta), np.ones_like(theta)])
    (pa, _pb, p0), *_ = np.linalg.lstsq(mp, p_wall, rcond=None)
    p_ref = -rho * a_last * radius
    dev = np.abs(p_wall - p0 - p_ref * np.cos(theta)).max() / abs(p_ref)
    return {"force_error": float(math.hypot(a, b) / f_ref - 1), "pressure_error": float(pa / p_ref - 1),
            "pressure_dev": float(dev)}


def ratio_summary(stock: list[float], ours: list[float]) -> tuple[float, float, float, list[float]]:
    """Alternating rounds of the same setting: (median stock, median ours, median of the per-round
    ratios stock/ours, the per-round ratios)."""
    if len(stock) != len(ours) or not stock:
        raise ValueError(f"ratio_summary needs rounds of both: {len(stock)} stock, {len(ours)} ours")
    ratios = [s / o for s, o in zip(stock, ours, strict=True)]
    return statistics.median(stock), statistics.median(ours), statistics.median(ratios), ratios


def _fmt_order(o: float | None) -> str:
    return "–" if o is None else f"{o:.2f}"


def ladder_table(done: list[Ladder]) -> str:
    rows = ["| ladder | setting | error 1 | error 2 | order vs reference (1 / 2) | order from differences | "
            "wall s | ms/step |", "|---|---|---|---|---|---|---:|---:|"]
    for lad in done:
        sizes = [r["size"] for r in lad.runs]
        if lad.value_key:
            orders = [observed_orders(sizes, [r[k] for r in lad.runs]) for k in lad.error_keys]
            diff = difference_orders(sizes, [r[lad.value_key] for r in lad.runs])
        else:
            orders, diff = [[None] * len(lad.runs) for _ in lad.error_keys], None
        for i, r in enumerate(lad.runs):
            errs = [f"{lab} {100 * r[k]:+.3f} %" for k, lab in zip(lad.error_keys, lad.labels, strict=True)]
            errs += ["–"] * (2 - len(errs))
            order = " / ".join(_fmt_order(o[i]) for o in orders)
            per = f"{r['ms_per_step']:.2f}" if r.get("ms_per_step") is not None else "–"
            rows.append(f"| {lad.name} | {r['setting']} | {errs[0]} | {errs[1]} | {order} | "
                        f"{_fmt_order(diff[i]) if diff else '–'} | {r['wall_s']:.2f} | {per} |")
    return "\n".join(rows)


def pick(done: list[Ladder], targets: tuple[float, ...] = (0.05, 0.02, 0.01, 0.005, 0.001)) -> str:
    """For each ladder and target, the cheapest run (wall time) whose errors are all within it."""
    return common.cheapest_table(done, lambda _lad, r: r["setting"], "ladder", targets)


def ratio_table(pairs: list[dict]) -> str:
    rows = ["| pipe setting | ms/step wall: stock / ours | stock/ours wall (median; rounds) | ms/step CPU: stock / "
            "ours | stock/ours CPU (median) | force error stock / ours | wall-pressure error stock / ours |",
            "|---|---|---|---|---|---|---|"]
    for p in pairs:
        rounds = ", ".join(f"{x:.1f}" for x in p["ratios"])
        rows.append(f"| {p['setting']} | {p['stock_ms']:.2f} / {p['ours_ms']:.2f} | **{p['ratio']:.1f}×** ({rounds}) | "
                    f"{p['stock_cpu_ms']:.2f} / {p['ours_cpu_ms']:.2f} | {p['cpu_ratio']:.1f}× | "
                    f"{100 * p['stock_force_error']:+.3f} / {100 * p['ours_force_error']:+.3f} % | "
                    f"{100 * p['stock_pressure_error']:+.3f} / {100 * p['ours_pressure_error']:+.3f} % |")
    return "\n".join(rows)


def update_docs(text: str, new_section: str, begin: str = FLUID_BEGIN, end: str = FLUID_END) -> str:
    """Replace the fluid section of a page, or append it when the markers are absent (the harness's
    own marker replacement, with this section's markers)."""
    return common.update_docs(text, new_section, begin, end)


def update_docs_pipe3d(text: str, new_block: str) -> str:
    """Replace the 3D pipe's block (PIPE3D_BEGIN .. PIPE3D_END); when absent, insert it right after
    the fluid section's end marker (appended when that is absent too). The rest is left as it is."""
    if PIPE3D_BEGIN in text or FLUID_END not in text:
        return update_docs(text, new_block, PIPE3D_BEGIN, PIPE3D_END)
    head, tail = text.split(FLUID_END, 1)
    return f"{head}{FLUID_END}\n\n{new_block}{tail if tail.startswith(chr(10)) else chr(10) + tail}"


def is_pipe3d(name: str) -> bool:
    """Whether a ladder (by its name) is the 3D pipe's, rendered in its own block."""
    return name.startswith("rigid pipe 3D")


# ------------------------------------------------------------------------------------------------
# Rigid pipe: ours and the stock set-up on the same blockMesh meshes
# ------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def _fluid_modules():
    """The water case helpers (benchmarks/fluid_common, shared with the verification tests) and the
    stock/ours settings of the water step benchmark (benchmarks/water_step/benchmark.py): the same
    set-ups as docs/water.md §10, not a copy."""
    from .fluid_common import foamcase, pipe, tunnel
    from .water_step import benchmark as fb

    vs = fb.variants(closed=True)  # the slice is a closed domain
    # ours: the water case as the product writes it (no knob set); stock: the stock set-up on it
    settings = {"stock": dict(vs[0][2]), "ours": dict(vs[len(fb.STEPS) - 1][2])}
    return foamcase, pipe, tunnel, settings, fb


def pipe_cells(n_faces: int, ny: int = 1) -> tuple[int, int, int]:
    """(nq, nr, cells) of the O-grid with n_faces wall faces: nq = N/4 per block side, nr = 3nq/4
    layers (at least 2), ny cells along the axis."""
    if n_faces % 4 or n_faces < 8:
        raise BenchError(f"pipe faces around N = {n_faces} must be a multiple of 4, at least 8 (four O-grid blocks)")
    if ny < 1:
        raise BenchError(f"pipe cells along the axis ny = {ny} must be at least 1")
    nq = n_faces // 4
    nr = max(2, 3 * nq // 4)
    return nq, nr, (nq * nq + 4 * nq * nr) * ny


def pipe3d_axial(n_faces: int) -> int:
    """Cells along the 3D pipe for N faces around: PIPE3D_NY16 per 16 faces, so that the axial
    spacing refines with the wall faces at the same ratio (a mesh ladder with a constant ratio)."""
    if n_faces % 16:
        raise BenchError(f"3D pipe faces around N = {n_faces} must be a multiple of 16 (axial cells 3N/16)")
    return PIPE3D_NY16 * n_faces // 16


def pipe_mesh(root: Path, n_faces: int, ny: int | None = None) -> tuple[Path, int]:
    """blockMesh O-grid of the rigid-pipe test (pipe.make_pipe_case) with n_faces wall faces
    (pipe_cells): its polyMesh folder and cell count. ny None: the 2D slice (1 m, ends empty);
    else the closed 3D pipe of length PIPE3D_L with ny cells along it (ends: walls, moving with the
    pipe, tunnel.make_case)."""
    fc, pipe, _, _, _ = _fluid_modules()
    nq, nr, cells = pipe_cells(n_faces, ny or 1)
    case = root / (f"mesh-N{n_faces}" if ny is None else f"mesh3d-N{n_faces}-ny{ny}")
    poly = case / "constant" / "polyMesh"
    if not (poly / "owner").is_file():
        geom = dict(L=PIPE_L, two_d=True) if ny is None else dict(L=PIPE3D_L, two_d=False, ny=ny, open_ends=False)
        pipe.make_pipe_case(case, R=PIPE_R, nq=nq, nr=nr, dt=1.0, end_time=1.0, **geom)
        fc.run(case, "blockMesh")
    return poly, cells


def run_pipe(root: Path, poly: Path, variant: str, n_faces: int, steps_per_period: int,
             length: float = PIPE_L, tag: str = "") -> dict:
    """One rigid-pipe run (one period + one step from rest, a = a0 cos ωt) with `variant` ('stock'
    or 'ours'); its errors, wall time and ms per step (wall clock between the solver's step lines,
    steps PIPE_SKIP on; CPU from ExecutionTime, 10 ms resolution)."""
    import numpy as np

    fc, pipe, tunnel, settings, fb = _fluid_modules()
    if variant not in settings:
        raise BenchError(f"pipe variant {variant!r} is not one of {', '.join(settings)}")
    omega = 2 * math.pi * PIPE_FREQ
    dt = 1.0 / (PIPE_FREQ * steps_per_period)
    steps = steps_per_period + 1  # the last step's pressure follows a(T) = a0 (one step of lag)
    s = dict(settings[variant], steps=steps, dt=dt)
    case = root / f"{variant}{tag}-N{n_faces}-S{steps_per_period}"
    motion = tunnel.make_case(case, poly, s)
    t = np.arange(0, (steps + 3) * dt, dt)
    u, v = pipe.harmonic_lateral(t, PIPE_A0, omega)
    pipe.write_motion(motion, t, u, v)
    t0 = time.perf_counter()
    try:  # the water benchmark's own timed run (log.<solver> in the case)
        wall, cpu, _ = fb.run_timed(case, s.get("solver", "pimpleFoam"), 1)
    except RuntimeError as e:
        raise BenchError(str(e)) from None
    wall_s = time.perf_counter() - t0
    if len(wall) < PIPE_SKIP + 3:
        raise BenchError(f"{case}: {len(wall)} steps reported, expected {steps}")
    rows = fc.read_interface(case)
    if not (rows.accepted == 1).all():
        raise BenchError(f"{case}: interface.dat has rejected steps")
    last = sorted((p for p in (case / "postProcessing" / "interface").iterdir() if p.name != "0"),
                  key=lambda p: float(p.name))[-1].name
    faces = fc.read_faces(case, last)
    theta = np.arctan2(faces[:, 2], faces[:, 0])
    a_last = PIPE_A0 * math.cos(omega * (steps - 1) * dt)
    err = pipe_errors(rows.t, rows.Fx, omega, theta, faces[:, 6], a_last, length=length, rho=pipe.RHO)
    n = len(wall)
    return {"variant": variant, "laminar_model": s.get("laminarModel") or "tqNewtonian", "faces": n_faces, "steps_per_period": steps_per_period, "dt": dt, "steps": steps,
            "wall_faces": len(faces), **err, "wall_s": wall_s,
            "ms_per_step": 1000 * (wall[-1] - wall[PIPE_SKIP]) / (n - 1 - PIPE_SKIP),
            "cpu_ms_per_step": 1000 * (cpu[-1] - cpu[PIPE_SKIP]) / (n - 1 - PIPE_SKIP)}


def pipe_ladders(root: Path, repeat: int, full: bool = False, log=print) -> tuple[list[Ladder], list[dict]]:
    """The pipe's mesh and step ladders for both set-ups, alternating stock and ours `repeat` times
    at each setting; runs carry the medians of the times."""
    specs = [("mesh", n, PIPE_MESH_STEPS) for n in PIPE_MESH_N + ((256,) if full else ())] + [("step", PIPE_STEP_N, s) for s in PIPE_STEPS]
    lads = {(kind, v): Ladder(f"rigid pipe 2D, {kind}, {v}", ("force_error", "pressure_error"), ("F", "p"),
                              value_key="force_error")
            for kind in ("mesh", "step") for v in ("ours", "stock")}
    pairs = []
    cache: dict[tuple[int, int], dict[str, list[dict]]] = {}
    for kind, n, spp in specs:
        poly, cells = pipe_mesh(root, n)
        if (n, spp) not in cache:  # N = 128 at 200 steps is on both ladders: run once
            cache[(n, spp)] = {"stock": [], "ours": []}
            for _ in range(repeat):
                for v in ("stock", "ours"):
                    cache[(n, spp)][v].append(run_pipe(root, poly, v, n, spp))
        rounds = cache[(n, spp)]
        setting = f"N = {n} ({cells} cells), {spp} steps/period (Δt = {1 / (PIPE_FREQ * spp):.3g} s)"
        runs, pair = summarise_rounds(rounds, kind, setting, cells, 1.0 / n if kind == "mesh" else None)
        for v, r in runs.items():
            lads[(kind, v)].runs.append(r)
        # only one copy of a setting shared by both ladders (N = 128, 200 steps)
        if not any(p["setting"] == setting for p in pairs):
            pairs.append(pair)
        log(_pair_line(f"rigid pipe {kind}", pair))
    return [lads[k] for k in (("mesh", "ours"), ("mesh", "stock"), ("step", "ours"), ("step", "stock"))], pairs


def summarise_rounds(rounds: dict[str, list[dict]], kind: str, setting: str, cells: int,
                     size: float | None) -> tuple[dict[str, dict], dict]:
    """The alternating rounds of one pipe setting ({'stock': [run, ...], 'ours': [...]}): each
    variant's ladder run (its first round's errors, deterministic; the medians of the times; size
    None: the step Δt) and the stock/ours pair (medians of the per-round ratios, wall and CPU)."""
    runs = {}
    for v, rs in rounds.items():
        r = dict(rs[0])
        r.update(setting=setting, cells=cells, size=(r["dt"] if size is None else size),
                 wall_s=statistics.median(x["wall_s"] for x in rs),
                 ms_per_step=statistics.median(x["ms_per_step"] for x in rs),
                 cpu_ms_per_step=statistics.median(x["cpu_ms_per_step"] for x in rs),
                 rounds_ms=[x["ms_per_step"] for x in rs])
        runs[v] = r
    st, ou, ratio, ratios = ratio_summary([x["ms_per_step"] for x in rounds["stock"]],
                                          [x["ms_per_step"] for x in rounds["ours"]])
    # CPU from ExecutionTime has a 10 ms resolution: a floor keeps a tiny case's ratio finite
    cst, cou, cratio, cratios = ratio_summary([x["cpu_ms_per_step"] for x in rounds["stock"]],
                                              [max(x["cpu_ms_per_step"], 1e-9) for x in rounds["ours"]])
    pair = {"kind": kind, "setting": setting, "stock_ms": st, "ours_ms": ou, "ratio": ratio, "ratios": ratios,
            "stock_cpu_ms": cst, "ours_cpu_ms": cou, "cpu_ratio": cratio, "cpu_ratios": cratios,
            "steps": rounds["ours"][0]["steps"]}
    for v in ("stock", "ours"):
        pair[f"{v}_force_error"] = rounds[v][0]["force_error"]
        pair[f"{v}_pressure_error"] = rounds[v][0]["pressure_error"]
    return runs, pair


def _pair_line(what: str, pair: dict) -> str:
    return (f"  {what}: {pair['setting']}: ours F {100 * pair['ours_force_error']:+.3f} % p "
            f"{100 * pair['ours_pressure_error']:+.3f} %, stock F {100 * pair['stock_force_error']:+.3f} % p "
            f"{100 * pair['stock_pressure_error']:+.3f} %; ms/step stock {pair['stock_ms']:.2f} ours "
            f"{pair['ours_ms']:.2f}: {pair['ratio']:.1f}× wall, {pair['cpu_ratio']:.1f}× CPU")


def pipe3d_ladders(root: Path, repeat: int, log=print) -> tuple[list[Ladder], list[dict]]:
    """The closed 3D pipe (PIPE3D_L, end plates moving with it) on PIPE3D_N faces around
    (pipe3d_axial cells along it) at PIPE3D_STEPS steps a period, stock and ours alternately
    `repeat` times at each mesh; errors against the same closed form with L = PIPE3D_L."""
    lads = {v: Ladder(f"rigid pipe 3D, mesh, {v}", ("force_error", "pressure_error"), ("F", "p"),
                      value_key="force_error") for v in ("ours", "stock")}
    pairs = []
    for n in PIPE3D_N:
        ny = pipe3d_axial(n)
        poly, cells = pipe_mesh(root, n, ny)
        rounds: dict[str, list[dict]] = {"stock": [], "ours": []}
        for _ in range(repeat):
            for v in ("stock", "ours"):
                rounds[v].append(run_pipe(root, poly, v, n, PIPE3D_STEPS, length=PIPE3D_L, tag="-3d"))
        setting = (f"N = {n} × {ny} along ({cells} cells), {PIPE3D_STEPS} steps/period "
                   f"(Δt = {1 / (PIPE_FREQ * PIPE3D_STEPS):.3g} s)")
        runs, pair = summarise_rounds(rounds, "mesh3d", setting, cells, 1.0 / n)
        for v, r in runs.items():
            r["length"] = PIPE3D_L
            lads[v].runs.append(r)
        pairs.append(pair)
        log(_pair_line("rigid pipe 3D", pair))
    return [lads["ours"], lads["stock"]], pairs


# ------------------------------------------------------------------------------------------------
# The ring: water-filled (coupled) and empty
# ------------------------------------------------------------------------------------------------
def _ring_run(ring, folder: Path, setting: str, size: float) -> dict:
    from tunnelquake.verification.ring import run_ring

    res = run_ring(ring, folder, keep=False)
    if res.status != "completed":
        raise BenchError(f"ring run '{setting}' {res.status}: {res.reason} (folder {folder})")
    steps = res.windows or (round(res.t_reached / res.dt) if res.dt > 0 else 0)
    return {"setting": setting, "size": size, "frequency": res.frequency, "expected": res.expected,
            "frequency_error": res.error(), "wall_s": res.wall_s, "dt": res.dt, "steps": steps,
            "passes": res.passes, "passes_per_window": res.passes / res.windows if res.windows else None,
            "ms_per_step": 1000 * res.wall_s / steps if steps else None, "fit_rms": res.fit_rms,
            "water_cells": res.extra.get("water_cells", 0)}


def ring_ladders(root: Path, log=print) -> list[Ladder]:
    from tunnelquake.verification.ring import Ring

    base = Ring(n_through=1, length=0.5, periods=3.0, mode="slice", scheme="implicit", acceleration="iqn-ils")
    filled = Ladder("water-filled ring, n around (implicit IQN-ILS, tol 1e-4)", ("frequency_error",), ("f",),
                    value_key="frequency")
    for n in RING_N:
        ring = Ring(**{**base.__dict__, "n_around": n})
        r = _ring_run(ring, root / f"ring-{n}", f"{n} × 1 el.", 1.0 / n)
        r["setting"] += f", {r['water_cells']} water cells"
        filled.runs.append(r)
        log(f"  {filled.name}: {r['setting']}: f {r['frequency']:.4f} Hz ({100 * r['frequency_error']:+.3f} %), "
            f"{r['passes_per_window']:.2f} passes/window, {r['wall_s']:.1f} s")
    tol = Ladder("water-filled ring, coupling tolerance (32 around)", ("frequency_error",), ("f",))
    for t in RING_TOLERANCES:
        if t == base.tolerance and any(r["size"] == 1 / 32 for r in filled.runs):
            r = dict(next(r for r in filled.runs if r["size"] == 1 / 32))
        else:
            r = _ring_run(Ring(**{**base.__dict__, "n_around": 32, "tolerance": t}), root / f"ring-32-tol{t:g}", "", t)
        r.update(setting=f"tolerance {t:g} ({r['passes_per_window']:.2f} passes/window)", size=t)
        tol.runs.append(r)
        log(f"  {tol.name}: {r['setting']}: f {r['frequency']:.4f} Hz ({100 * r['frequency_error']:+.3f} %), "
            f"{r['wall_s']:.1f} s")
    empty = Ladder("empty ring, n around (tq-solid alone)", ("frequency_error",), ("f",), value_key="frequency")
    for n in EMPTY_N:
        r = _ring_run(Ring(**{**base.__dict__, "n_around": n, "water": False}), root / f"empty-{n}",
                      f"{n} × 1 el.", 1.0 / n)
        empty.runs.append(r)
        log(f"  {empty.name}: {r['setting']}: f {r['frequency']:.4f} Hz ({100 * r['frequency_error']:+.3f} %), "
            f"{r['wall_s']:.1f} s")
    return [filled, tol, empty]


# ------------------------------------------------------------------------------------------------
# Figure, section, command
# ------------------------------------------------------------------------------------------------
def plot(done: list[Ladder], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pipes = [d for d in done if d.name.startswith("rigid pipe")]
    rings = [d for d in done if not d.name.startswith("rigid pipe")]
    panels = [(p, title) for p, title in ((pipes, "rigid pipe 2D: ours and the stock set-up"),
                                          (rings, "ring n = 2 frequency: filled (coupled) and empty")) if p]
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 5), squeeze=False)
    for ax, (lads, title) in zip(axes[0], panels, strict=True):
        for lad in lads:
            for key, lab, style in zip(lad.error_keys, lad.labels, ("-o", "--s"), strict=False):
                t = [r["wall_s"] for r in lad.runs]
                e = [max(abs(r[key]), 1e-7) for r in lad.runs]
                ax.loglog(t, e, style, label=f"{lad.name}: {lab}")
        ax.set_xlabel("wall time per run (s)")
        ax.set_ylabel("|relative error| against the closed form")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def section(done: list[Ladder], pairs: list[dict], command: str, when: str, where: str, figure: str) -> str:
    models = sorted({r.get("laminar_model", "Stokes") for d in done for r in d.runs if r.get("variant") == "ours"})
    laminar = f"; laminar model {', '.join(models)}" if models else ""
    parts = [f"""{FLUID_BEGIN}
## Water and coupled verification: error against wall time, stock pimpleFoam ratio

`{command}`, {when}, {where}; `OMP_WAIT_POLICY=PASSIVE`, one thread / one rank per side. Errors
are relative, against the closed forms. **Rigid pipe** (tests/verification/fluid_rigid_pipe, 2D
slice, R 4.5 m, a = a0 cos ωt at {PIPE_FREQ:g} Hz from rest, one period): F = amplitude of the
harmonic fit of the resultant against ρπR²L a0; p = the cos θ coefficient of the wall pressure at
the last step against −ρ a R. blockMesh O-grids with N faces around. **ours**: the water case's
settings (transpiration, tuned PIMPLE, p by tqProjected + GAMG to 1e-6 in the closed
slice{laminar}); **stock**: the tutorial-like set-up of docs/water.md §10 (pimpleFoam + displacementLaplacian inverseDistance,
movingWallVelocity + fixedFluxPressure, movingCone solvers), both from
`benchmarks/water_step/benchmark.py`, run alternately on the same mesh and step;
times are medians of the rounds, ms/step the wall clock between the solver's step lines (steps
{PIPE_SKIP} on). **Ring** (`tunnelquake.verification.ring`, the coupled chain tq-solid + coupler +
rhoPimpleFoam, slice, implicit IQN-ILS): the n = 2 frequency after a pulse against the thin-ring
formula with the water's radius (9.293 Hz filled, 14.529 Hz empty); ms/step = wall per coupling
window. Order vs reference: log(e_i/e_(i+1)) / log(s_i/s_(i+1)) with s = 1/N, Δt or 1/n; order
from differences: Richardson's log(|v_(i−2) − v_(i−1)| / |v_(i−1) − v_i|) / log r of the force or
frequency itself (needs no reference; – where the differences change sign).

{ladder_table(done)}

![error against wall time]({figure})
"""]
    if pairs:
        parts.append(f"""**Stock pimpleFoam against ours, same mesh and step, same session** (rigid pipe):

{ratio_table(pairs)}
""")
    parts.append(f"""**Settings for a target accuracy** (the cheapest run of each ladder with all its errors
within the target; wall times of this machine):

{pick(done)}

{{reading}}
{FLUID_END}""")
    return "\n".join(parts)


#: the reading of the figures (errors are deterministic; written from the 2026-11-21 run's figures)
READING = """Reading it. **Rigid pipe, ours**: the resultant's error is the faceted wall's: the N-gon
encloses sin(2π/N)/(2π/N) of the circle's area (−0.64, −0.16, −0.04 % at N = 32, 64, 128) and the
measured −0.76, −0.23, −0.05 % converge with it at second order (observed 1.75, 2.06); the step
hardly matters (transpiration moves no mesh, so the moved wall's Euler term −(ωΔt)²/12 is absent:
−0.39 % at 25 steps a period, −0.23 % from 100 on at N = 64). The wall pressure's cos θ coefficient
at one instant is within 0.3 % from N = 64 and 50 steps a period on but does not fall further
(+0.09, +0.29 % at N = 64, 128; −0.01 … −0.23 % over the step ladder): a part of 0.1–0.3 % that
changes from step to step (cause not traced; the resultant's residual from the harmonic fit is
0.06 % rms, up to 0.3 % in single steps). **Stock**: 3.9–5.0× the CPU time a step of ours on the
same mesh and step (4.3–5.8× wall, medians of 3 alternating rounds; the paper slice's 5.2×,
docs/water.md §10), and less accurate: its wall conditions are first-order wrong for an
accelerating wall (docs/water.md §4): force +2.0, +1.25, +0.69 %, pressure +4.3, +1.9, +1.1 %
(orders 0.7–1.2 in the mesh); a smaller step does not help (force −0.14 % at 25 steps a period,
where its moving mesh's Euler term −0.53 % cancels it, rising to +1.42 % at 400). **Filled ring**:
+14.7, +2.02, −0.06 % at 16, 32, 64 around (order from the differences 2.6); the error crosses zero
between 32 and 64 around, so −0.06 % at 64 is not its accuracy: the Richardson limit of the three
is 9.250 Hz, −0.47 % from the thin-ring formula, the hex8 ring's thick-ring offset (empty ring:
+11.8, +1.19, −0.23, −0.54 % at 16 … 128 around, orders 2.9, 2.2 from the differences, limit
≈ −0.6 %). The coupling tolerance does not move the frequency (1e-3, 1e-4, 1e-5: within 5e-5
relative) but costs passes (3.4, 4.0, 4.8 a window: 139, 170, 251 s). **Which setting**: the
pipe's resultant within 1 % takes ours at N = 32 (256 cells; any step from 25 a period), within
0.25 % N = 64 and 50 steps a period, within 0.1 % N = 128; its wall pressure is within 0.3 % from
N = 64 and 50 steps a period and no better; the stock set-up needs N = 64 for 2 % and reaches 1 %
only through that cancellation at 25 steps a period, not by refinement. The filled ring needs 32 around for the coupled tests' 3 % (+2.0 %) and
64 for 0.5 % of the converged value, at coupling tolerance 1e-3 (the cheapest; 1e-4 is the
default). Wall times here are a loaded machine's: the CPU figures and ratios are the ones to use."""


def section_pipe3d(done: list[Ladder], pairs: list[dict], command: str, when: str, where: str) -> str:
    """The 3D pipe's block: its mesh ladder (ours, stock), the stock/ours ratios, the reading."""
    return f"""{PIPE3D_BEGIN}
### Rigid pipe in 3D (ours vs stock)

`{command}`, {when}, {where}; `OMP_WAIT_POLICY=PASSIVE`, one thread. The 2D rung's closed form
on a **closed 3D pipe** (R {PIPE_R:g} m, L {PIPE3D_L:g} m: the water test's 3D pipe,
tests/verification/fluid_rigid_pipe), end plates moving with it (walls in y = 0 and L: the stock
set-up's movingWallVelocity + fixedFluxPressure on the moved mesh, slip points; ours slip +
fixedFluxExtrapolatedPressure on the static mesh, exact for the uniform water of a rigid
translation), so p = p0 − ρ a R cos θ and F = ρπR²L a0 hold exactly (an open-ended pipe leaks at
the ends). blockMesh O-grids of N faces around and 3N/16 cells along (refined by 2 in all three
directions), {PIPE3D_STEPS} steps a period at {PIPE_FREQ:g} Hz, one period from rest; errors,
orders and timing as in the 2D rung (stock and ours alternately on the same mesh and step, medians
of the rounds; CPU from ExecutionTime).

{ladder_table(done)}

**Stock pimpleFoam against ours, 3D, same mesh and step, same session**:

{ratio_table(pairs)}

{{reading3d}}
{PIPE3D_END}"""


#: the reading of the 3D figures (errors deterministic; written from the 2026-11-21 run's figures)
READING3D = """Reading it. The closed 3D pipe gives the slice's own figures, as the closed form
says it must: **ours** F −2.52, −0.76, −0.23 % at N = 16, 32, 64 (the faceted wall's polygon area
is −2.55, −0.64, −0.16 %; the 2D rung's −0.76, −0.23 % at N = 32, 64), order 1.72, 1.75 against
the reference and 1.71 from the differences; wall pressure's cos θ coefficient −0.79, −0.18,
+0.09 %. The coefficient is the same in every axial layer (spread 2e-6 at N = 48, both set-ups),
so the moving end plates close the pipe; tests/python/test_openfoam_rigid_pipe_closed3d.py checks
that the 3D pipe's errors equal the slice's within 1e-4 and the layers agree within 1e-3.
**Stock**: F +2.31, +2.00, +1.25 %, p +11.0, +4.25, +1.89 % (the 2D stock's +2.0, +1.25 % force
at N = 32, 64: its first-order wall conditions, docs/water.md §4); its force is not in an
asymptotic range on these meshes (orders 0.21, 0.68; from the differences −1.28: they grow).
**Cost**: stock 5.4–6.6× the CPU time a step of ours (5.5–6.0× wall, medians of 3 alternating
rounds; the slice: 3.9–5.0× CPU). **Which setting**: ours' resultant within 1 % from N = 32
(1,536 cells, 0.7 s a period), within 0.25 % at N = 64 (12,288 cells, 3.5 s); the stock set-up's
force stays above 1 % on all three meshes (+1.25 % at N = 64, 18 s) and its wall pressure is
within 2 % only at N = 64. The whole rung (3 meshes × 3 rounds × 2 set-ups) took 82 s wall here."""


def ladders_from_json(data: dict) -> list[Ladder]:
    """The ladders of a fluid.json (--from-json): keys stored with them, or those of the ladder's kind."""
    out = []
    for d in data["ladders"]:
        pipe = d["name"].startswith("rigid pipe")
        keys = tuple(d.get("error_keys") or (("force_error", "pressure_error") if pipe else ("frequency_error",)))
        labels = tuple(d.get("labels") or (("F", "p") if pipe else ("f",)))
        value_key = d["value_key"] if "value_key" in d else (
            "force_error" if pipe else (None if "tolerance" in d["name"] else "frequency"))
        out.append(Ladder(d["name"], keys, labels, list(d["runs"]), value_key))
    return out


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="tunnelquake bench FOLDER --fluid", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", type=Path, help="where fluid.md, fluid.png and fluid.json are written")
    p.add_argument("--parts", nargs="+", choices=("pipe", "pipe3d", "ring"), default=["pipe", "pipe3d", "ring"],
                   help="pipe: the 2D slice ladders; pipe3d: the closed 3D pipe (its own docs block, "
                        "written alone when only it runs); ring: the ring ladders")
    p.add_argument("--repeat", type=int, default=3, help="alternating rounds of stock and ours per pipe setting")
    p.add_argument("--full", action="store_true", help="add the pipe at N = 256 (16,384 cells)")
    p.add_argument("--workdir", type=Path, default=None, help="run folders (default: a temporary one, removed)")
    p.add_argument("--update-docs", action="store_true",
                   help="replace the <!-- bench:fluid --> section of docs/benchmarks.md with this run's")
    p.add_argument("--from-json", type=Path, default=None,
                   help="no runs: rebuild fluid.md/png (and with --update-docs the docs section) from a fluid.json "
                        "written by an earlier run; the section names that run's command, date and machine")
    p.add_argument("--note", default="", help="a line on the conditions (load, nice) printed with the figures")
    args = p.parse_args(argv)
    if args.from_json:
        data = json.loads(args.from_json.read_text())
        data["note"] = args.note or data.get("note", "")
        return _render(args, data)
    if args.repeat < 1:
        print(f"tunnelquake bench --fluid: --repeat {args.repeat}: needs at least 1", file=sys.stderr)
        return 2
    from tunnelquake.paths import openfoam_library, solid_executable

    missing = [what for what, ok in (("libtqFoam.so", openfoam_library()), ("tq-solid", solid_executable()),
                                     ("pimpleFoam (OpenFOAM v1912)", shutil.which("pimpleFoam"))) if not ok]
    if missing:
        print(f"tunnelquake bench --fluid: {', '.join(missing)} not found: build (cmake --build <build>), set "
              "TQ_BUILD_DIR, install OpenFOAM v1912", file=sys.stderr)
        return 1
    args.folder.mkdir(parents=True, exist_ok=True)
    work = args.workdir or Path(tempfile.mkdtemp(prefix="tq-bench-fluid-"))
    work.mkdir(parents=True, exist_ok=True)
    done: list[Ladder] = []
    pairs: list[dict] = []
    try:
        if "pipe" in args.parts:
            lads, pairs = pipe_ladders(work, args.repeat, args.full, log=lambda s: print(s, flush=True))
            done += lads
        if "pipe3d" in args.parts:
            lads, pairs3d = pipe3d_ladders(work, args.repeat, log=lambda s: print(s, flush=True))
            done += lads
            pairs += pairs3d
        if "ring" in args.parts:
            done += ring_ladders(work, log=lambda s: print(s, flush=True))
    except BenchError as e:
        print(f"tunnelquake bench --fluid: {e}", file=sys.stderr)
        return 1
    data = {"date": _dt.datetime.now().strftime("%Y-%m-%d %H:%M"), "machine": common.machine(), "note": args.note,
            "command": "tunnelquake bench " + " ".join(shlex.quote(a) for a in argv[:1] + ["--fluid"] + argv[1:]),
            "pairs": pairs, "ladders": [{"name": d.name, "error_keys": d.error_keys, "labels": d.labels,
                                         "value_key": d.value_key, "runs": d.runs} for d in done]}
    (args.folder / "fluid.json").write_text(json.dumps(data, indent=1, default=float))
    rc = _render(args, data)
    if args.workdir is None:
        shutil.rmtree(work, ignore_errors=True)
    return rc


def _render(args: argparse.Namespace, data: dict) -> int:
    """fluid.md and fluid.png into the folder, and with --update-docs the docs section."""
    args.folder.mkdir(parents=True, exist_ok=True)
    every = ladders_from_json(data)
    done = [d for d in every if not is_pipe3d(d.name)]
    d3 = [d for d in every if is_pipe3d(d.name)]
    pairs = [p for p in data.get("pairs", []) if p.get("kind") != "mesh3d"]
    pairs3d = [p for p in data.get("pairs", []) if p.get("kind") == "mesh3d"]
    where = data["machine"] + (f" ({data['note']})" if data.get("note") else "")
    if getattr(args, "from_json", None):
        where += (f"; section written from that run's fluid.json by `tunnelquake bench {args.folder} --fluid "
                  f"--from-json {args.from_json}{' --update-docs' if args.update_docs else ''}`")
    docs = ROOT / "docs"
    target = docs / "benchmarks.md"
    texts = []
    if done:  # the 2D pipe and ring section (a --parts pipe3d run leaves it and its figure alone)
        plot(done, args.folder / "fluid.png")
        text = section(done, pairs, data["command"], data["date"], where, "fluid.png").replace("{reading}", READING)
        texts.append(text)
        print(text)
        if args.update_docs:
            (docs / "bench").mkdir(exist_ok=True)
            shutil.copyfile(args.folder / "fluid.png", docs / "bench" / "fluid.png")
            target.write_text(update_docs(target.read_text(), text.replace("(fluid.png)", "(bench/fluid.png)")))
            print(f"updated {target} and {docs / 'bench' / 'fluid.png'}")
    if d3:
        text = section_pipe3d(d3, pairs3d, data["command"], data["date"], where).replace("{reading3d}", READING3D)
        texts.append(text)
        print(text)
        if args.update_docs:
            target.write_text(update_docs_pipe3d(target.read_text(), text))
            print(f"updated {target} (3D rigid pipe block)")
    (args.folder / "fluid.md").write_text("\n\n".join(texts) + "\n")
    return 0
