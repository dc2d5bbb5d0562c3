"""Benchmark: cost of one water step on the paper-size meshes, stock set-up against ours.

Not a test; prints a markdown table (docs/water.md, "Benchmark").  Meshes: the paper's water
mesh from tunnelquake.meshing.build_tunnel_mesh(PAPER_GEOMETRY, mode '3d': 14,784 cells,
R 4.5 m, L 80 m, open ends) and the 2D slice (mode 'slice': 336 cells, closed).  Wall motion
(fake solid, replay; tunnel.benchmark_motion): rigid lateral shaking 1 m/s^2 at 5 Hz, ovaling
(n = 2) U (1 - cos 2 pi 5 t) with U = 5 mm (3D) / 1 mm (slice), in 3D also a slow uniform radial
contraction; dt 1e-4 s (the
coupled step); mid-step wall velocities.  Every variant runs the tqInterface function object
(loads, exchange with the fake solid).

Every case is written by the product's writer (tunnelquake.water_case, through
benchmarks/fluid_common/tunnel.make_case): 'ours' is the water case exactly as the product writes
it; every other variant sets a few knobs of tunnel.SETTINGS, each one override of its dictionaries.
Variants: STEPS, the accepted changes from the stock set-up to ours, one at a time
(cumulative; the last rung is the product's case itself), then REJECTED, alternatives measured
against ours.  'stock': pimpleFoam +
displacementLaplacian with the settings of the stock tutorials (movingCone solvers and PIMPLE
controls, inverseDistance diffusivity as the wave-maker tutorials, movingWallVelocity +
fixedFluxPressure, runTimeModifiable, full log).  'stock' and 'ours' also run on 2 MPI ranks
(simple decomposition: along the axis in 3D, across x for the slice).

Timing: OpenFOAM's ExecutionTime (CPU time of rank 0) per step, mean over the steps after the
first 10; and the wall-clock time per step over the same steps, from the times at which the
solver's ExecutionTime lines arrive (read as they are written).  Each variant runs --repeat times
and the smallest figures are kept (the VM is shared with other jobs).  Accuracy: against a
reference run (moving mesh, 3 correctors, 1 non-orthogonal corrector, p to 1e-12): largest
difference of the resultant force over the steps after the first 10, relative to its largest
value, and of the wall pressure at the last step, relative to the largest wall pressure (slice:
closed, its pressure level is a convention: means removed).

Usage (from the repository root):
  TQ_BUILD_DIR=/tmp/build-water .venv/bin/python -m benchmarks.water_step.benchmark \
      [--mesh 3d slice] [--variants NAME ...] [--ranks 1 2] [--steps3d 100] [--steps2d 1000] [--repeat 3]
  ... benchmark.py --pair 5 [--variants NAME ...]: ours and each named variant (default: stock)
      alternately, 5 runs each; min and median of each and the ratios to ours.
  ... benchmark.py --from-case CASE [--variant NAME] [--pair 5] [--steps 300]: ours and the stock
      solvers alternately on the water case the product writes for CASE's dynamic_water (from_case.py).
"""

from __future__ import annotations

import argparse
import re
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from ..common import machine
from ..fluid_common import foamcase as fc
from ..fluid_common import tunnel

STOCK = dict(
    interface_motion="meshMotion",
    motion_solver="laplacian",
    laplacian_diffusivity="inverseDistance (interface)",
    cellDisplacement="solver PCG; preconditioner DIC; tolerance 1e-8; relTol 0;",
    wall="stock",
    p="solver GAMG; smoother GaussSeidel; tolerance 0; relTol 0.01; cacheAgglomeration no;",
    pFinal="solver GAMG; smoother GaussSeidel; tolerance 1e-6; relTol 0; cacheAgglomeration no;",
    pcorr="solver GAMG; smoother GaussSeidel; tolerance 0.02; relTol 0; cacheAgglomeration no;",
    U="solver smoothSolver; smoother symGaussSeidel; tolerance 1e-5; relTol 0;",
    laplacianU="Gauss linear corrected",
    nOuterCorrectors=2,
    nCorrectors=1,
    nNonOrthogonalCorrectors=0,
    momentumPredictor=True,
    correctPhi=True,
    log=True,
    runTimeModifiable=True,
    heapTuning=False,
    laminarModel="Stokes",
)

#: the overrides of the last step: none, every knob back to the water case's (tunnel.SETTINGS)
PRODUCT: dict = {}

GAMG = "solver GAMG; smoother GaussSeidel; tolerance 0; relTol {};"
#: p of a closed domain (the slice): the error of an unconverged incompressible pressure cannot
#: leave through an open end and accumulates; an absolute tolerance keeps it at the floor
GAMG_CLOSED = "solver GAMG; smoother GaussSeidel; tolerance 1e-6; relTol 0;"



def tqprojected(tol: float, rel: float, vectors: int = 32, extra: str = "") -> str:
    """p by tqProjected (libtqFoam): the incoming p corrected by its projection onto the last
    `vectors` steps' increments as the start, GAMG as in the step before it finishing."""
    return (f"solver tqProjected; vectors {vectors};{' ' + extra if extra else ''} tolerance {tol}; "
            f"relTol {rel}; inner {{ solver GAMG; smoother GaussSeidel; mergeLevels 2; }}")


#: (name, what, overrides of the previous variant): the accepted changes, one at a time
STEPS: list[tuple[str, str, dict]] = [
    ("stock", "stock tutorial set-up (movingCone solvers, displacementLaplacian)", STOCK),
    ("+explicit motion", "tqInterpolatedDisplacement instead of displacementLaplacian",
     dict(motion_solver="tqInterpolated")),
    ("+our wall conditions", "tqInterfaceVelocity + fixedFluxExtrapolatedPressure, correctPhi no",
     dict(wall="ours", correctPhi=False)),
    ("+1 outer corrector", "nOuterCorrectors 1, nCorrectors 2 (PISO)", dict(nOuterCorrectors=1, nCorrectors=2)),
    ("+transpiration", "static mesh, wall velocity on the fixed faces", dict(interface_motion="transpiration")),
    ("+1 corrector", "nCorrectors 1", dict(nCorrectors=1)),
    ("+no momentum predictor", "momentumPredictor no", dict(momentumPredictor=False)),
    ("+p GAMG relTol 0.1", "p and pFinal: GAMG, relTol 0.1 (tolerance 0)",
     dict(p=GAMG.format(0.1), pFinal=GAMG.format(0.1))),
    ("+uncorrected viscous Laplacian", "laplacian(nuEff,U) Gauss linear uncorrected",
     dict(laplacianU="Gauss linear uncorrected")),
    ("+log off", "no per-step solver/function-object lines, runTimeModifiable no",
     dict(log=False, runTimeModifiable=False)),
    ("+heap tuning", "tqInterface heapTuning: freed memory stays in the heap", dict(heapTuning=True)),
    ("+tqNewtonian", "laminarModel tqNewtonian: laplacian(nuEff,U) without the stock explicit "
     "div(nuEff dev2(T(grad U)))", dict(laminarModel="tqNewtonian")),
    ("+GAMG mergeLevels 2", "p and pFinal: GAMG merges two agglomeration levels into one (fewer, "
     "coarser levels)", dict(p_extra="mergeLevels 2;")),
    ("+p tqProjected = ours", "the water case as the product writes it (tunnelquake.water_case): p and pFinal "
     "tqProjected (libtqFoam: started from the projection onto the last 32 steps' increments, GAMG as before "
     "finishing to relTol 0.05), U to 1e-9", PRODUCT),
]

#: name of the last step (ours): the one 'stock' is compared with on 1 and 2 ranks
OURS = STEPS[-1][0]



def _gamg(name: str, extra: str) -> tuple[str, str, dict]:
    """A GAMG option of the pressure tried on top of ours: `extra` is appended to ours'
    p and pFinal (relTol 0.1 in 3D, absolute 1e-6 on the closed slice)."""
    return (f"ours, p GAMG {name}", f"p and pFinal as ours plus {extra}", dict(p_extra=extra))


def _smoother(name: str, smoother: str) -> tuple[str, str, dict]:
    """The pressure's GAMG with another smoother (relTol 0.1, the other options GAMG's defaults)."""
    body = f"solver GAMG; smoother {smoother}; tolerance 0; relTol 0.1;"
    return (name, f"p: GAMG with the {smoother} smoother", dict(p=body, pFinal=body))


def _p_body(name: str, what: str, body: str) -> tuple[str, str, dict]:
    """A pressure solver tried instead of ours: `body` for both p and pFinal."""
    return (name, what, dict(p=body, pFinal=body))


def _pcg_gamg(name: str, vcycles: int) -> tuple[str, str, dict]:
    """p by PCG preconditioned by `vcycles` GAMG V-cycles (GaussSeidel, mergeLevels 2), relTol 0.1."""
    return _p_body(name, f"p: PCG preconditioned by {vcycles} GAMG V-cycle(s) (GaussSeidel, mergeLevels 2), "
                         "relTol 0.1",
                   "solver PCG; preconditioner { preconditioner GAMG; smoother GaussSeidel; mergeLevels 2; "
                   f"nVcycles {vcycles}; }} tolerance 0; relTol 0.1;")


def _tqp(name: str, what: str, vectors: int = 32, rel: float = 0.05, extra: str = "") -> tuple[str, str, dict]:
    """ours' tqProjected pressure with other controls."""
    return _p_body(f"ours, tqProjected {name}", what, tqprojected(0, rel, vectors, extra))


def _apply(base: dict, over: dict) -> dict:
    """base updated by over; over's 'p_extra' is appended to the p and pFinal bodies instead."""
    v = dict(base)
    over = dict(over)
    extra = over.pop("p_extra", None)
    v.update(over)
    if extra:
        v["p"], v["pFinal"] = f"{v['p']} {extra}", f"{v['pFinal']} {extra}"
    return v


#: measured and rejected: (name, what, overrides of 'ours' or, for 'stock, ...', of the stock)
REJECTED: list[tuple[str, str, dict]] = [
    ("stock, uniform diffusivity", "the stock set-up with displacementLaplacian diffusivity uniform",
     dict(STOCK, laplacian_diffusivity="uniform")),
    ("stock, quadratic inverseDistance", "the stock set-up with diffusivity quadratic inverseDistance",
     dict(STOCK, laplacian_diffusivity="quadratic inverseDistance (interface)")),
    ("ours, p PCG/DIC 1e-6", "p: PCG/DIC to an absolute 1e-6",
     dict(p="solver PCG; preconditioner DIC; tolerance 1e-6; relTol 0;",
          pFinal="solver PCG; preconditioner DIC; tolerance 1e-6; relTol 0;")),
    ("ours, p PCG/DIC relTol 0.1", "p: PCG/DIC, relTol 0.1",
     dict(p="solver PCG; preconditioner DIC; tolerance 0; relTol 0.1;",
          pFinal="solver PCG; preconditioner DIC; tolerance 0; relTol 0.1;")),
    ("ours, p GAMG relTol 0.1", "p: GAMG, relTol 0.1 (the slice's tolerance; in 3D: ours without mergeLevels)",
     dict(p=GAMG.format(0.1), pFinal=GAMG.format(0.1))),
    ("ours, p GAMG 1e-6", "p: GAMG, absolute tolerance 1e-6", dict(p=GAMG_CLOSED, pFinal=GAMG_CLOSED)),
    ("ours, p GAMG relTol 0.01", "p: GAMG, relTol 0.01", dict(p=GAMG.format(0.01), pFinal=GAMG.format(0.01))),
    ("ours, p GAMG relTol 0.05", "p: GAMG, relTol 0.05", dict(p=GAMG.format(0.05), pFinal=GAMG.format(0.05))),
    _gamg("interpolateCorrection", "interpolateCorrection yes;"),
    _gamg("scaleCorrection no", "scaleCorrection no;"),
    _gamg("nCellsInCoarsestLevel 4", "nCellsInCoarsestLevel 4;"),
    _smoother("ours, p GAMG symGaussSeidel", "symGaussSeidel"),
    _gamg("nCellsInCoarsestLevel 100", "nCellsInCoarsestLevel 100;"),
    _gamg("nCellsInCoarsestLevel 100 direct", "nCellsInCoarsestLevel 100; directSolveCoarsest yes;"),
    _gamg("directSolveCoarsest", "directSolveCoarsest yes;"),
    _gamg("nPostSweeps 1", "nPostSweeps 1;"),
    _gamg("nPreSweeps 1 nPostSweeps 1", "nPreSweeps 1; nPostSweeps 1;"),
    _gamg("nFinestSweeps 1", "nFinestSweeps 1;"),
    ("ours, p GAMG 1 V-cycle", "p: GAMG, maxIter 1",
     dict(p="solver GAMG; smoother GaussSeidel; tolerance 0; relTol 0; maxIter 1;",
          pFinal="solver GAMG; smoother GaussSeidel; tolerance 0; relTol 0; maxIter 1;")),
    _smoother("ours, p DIC smoother", "DIC"),
    _p_body("ours, p GAMG mergeLevels 3", "p and pFinal: GAMG as ours with mergeLevels 3 instead of 2",
            GAMG.format(0.1) + " mergeLevels 3;"),
    _p_body("ours, p GAMG mergeLevels 4", "p and pFinal: GAMG as ours with mergeLevels 4 instead of 2",
            GAMG.format(0.1) + " mergeLevels 4;"),
    _pcg_gamg("ours, p PCG/GAMG", 1),
    _pcg_gamg("ours, p PCG/GAMG 2 V-cycles", 2),
    _tqp("relTol 0.1", "tqProjected with GAMG's relTol 0.1 (the GAMG step's)", rel=0.1),
    _tqp("relTol 0.02", "tqProjected, relTol 0.02", rel=0.02),
    _tqp("4 vectors", "tqProjected, 4 directions", vectors=4),
    _tqp("8 vectors", "tqProjected, 8 directions", vectors=8),
    _tqp("12 vectors", "tqProjected, 12 directions", vectors=12),
    _tqp("24 vectors", "tqProjected, 24 directions", vectors=24),
    _tqp("48 vectors", "tqProjected, 48 directions", vectors=48),
    _tqp("minIter 1", "tqProjected, at least one GAMG V-cycle a step", extra="minIter 1;"),
    ("ours, uncorrected p Laplacian", "all Laplacians uncorrected (mesh non-orthogonality up to 27 deg)",
     dict(laplacianP="Gauss linear uncorrected")),
    ("ours, moving mesh", "tqInterpolatedDisplacement instead of transpiration",
     dict(interface_motion="meshMotion")),
]

REFERENCE = dict(
    interface_motion="meshMotion",
    motion_solver="tqInterpolated",
    wall="ours",
    p="solver PCG; preconditioner DIC; tolerance 1e-12; relTol 0;",
    pFinal="solver PCG; preconditioner DIC; tolerance 1e-12; relTol 0;",
    U="solver smoothSolver; smoother symGaussSeidel; tolerance 1e-12; relTol 0;",
    laplacianU="Gauss linear corrected",
    nOuterCorrectors=1,
    nCorrectors=3,
    nNonOrthogonalCorrectors=1,
    momentumPredictor=True,
    correctPhi=False,
    log=False,
    laminarModel="Stokes",
)


def variants(closed: bool = False) -> list[tuple[str, str, dict]]:
    """Cumulative settings of each accepted step, then the rejected alternatives to 'ours'.
    closed (the slice): the p step uses GAMG_CLOSED."""
    out, cur, gamg = [], {}, {}
    for name, what, over in STEPS:
        if closed and name.startswith("+p GAMG"):
            name, what, over = ("+p GAMG 1e-6", "p and pFinal: GAMG, absolute tolerance 1e-6 (closed domain)",
                                dict(p=GAMG_CLOSED, pFinal=GAMG_CLOSED))
        cur = {} if over is PRODUCT else _apply(cur, over)
        out.append((name, what, cur))
        if name == "+GAMG mergeLevels 2":
            gamg = cur
    ours = cur
    for name, what, over in REJECTED:
        # 'ours, p ...': alternatives to the GAMG pressure solve, measured on that step (the
        # step before tqProjected, whose inner solver it is); the others on ours
        base = {} if name.startswith("stock") else gamg if name.startswith("ours, p ") else ours
        out.append((name, what, _apply(base, over)))
    return out


def run_timed(case: Path, solver: str, ranks: int) -> tuple[list[float], list[float], str]:
    """Run the solver; returns wall-clock times at each ExecutionTime line, the ExecutionTime
    values (CPU s) and the log."""
    cmd = [solver, "-case", str(case)]
    if ranks > 1:
        cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks)] + cmd + ["-parallel"]
    proc = subprocess.Popen(cmd, env=fc.env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            bufsize=1)
    wall, cpu, lines = [], [], []
    pat = re.compile(r"ExecutionTime = ([0-9.eE+-]+) s")
    for line in proc.stdout:
        lines.append(line)
        m = pat.search(line)
        if m:
            wall.append(time.perf_counter())
            cpu.append(float(m.group(1)))
    proc.wait()
    log = "".join(lines)
    Path(case, f"log.{solver}").write_text(log)
    if proc.returncode != 0 or "FOAM FATAL" in log:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{log[-3000:]}")
    return wall, cpu, log


def decompose(case: Path, ranks: int, slice_mode: bool) -> None:
    n = f"({ranks} 1 1)" if slice_mode else f"(1 {ranks} 1)"  # slice: across x; 3D: along the axis
    fc.write(case, "system/decomposeParDict",
             f"numberOfSubdomains {ranks};\nmethod simple;\nsimpleCoeffs {{ n {n}; delta 0.001; }}\n")
    fc.run(case, "decomposePar", "-force")


def measure(root: Path, poly: Path, mode: str, name: str, settings: dict, steps: int, ranks: int = 1,
            repeat: int = 1, write_every: int = 0) -> dict:
    """Run a variant `repeat` times; the smallest per-step figures (the VM is shared: the
    smallest is the least disturbed by other jobs)."""
    case = root / f"{mode}-{re.sub(r'[^A-Za-z0-9]+', '_', name)}-np{ranks}"
    s = dict(settings)
    s["steps"] = steps
    if write_every:
        s["write_interval"] = write_every * s.get("dt", tunnel.SETTINGS["dt"])
    best: dict = {}
    for _ in range(repeat):
        motion = tunnel.make_case(case, poly, s)
        # the closed slice: ovaling 1 mm (its second-order volume change stays below the
        # incompressible closed-domain check, 1e-3 of the wall flux, over the run)
        tunnel.benchmark_motion(motion, s.get("dt", tunnel.SETTINGS["dt"]), steps, radial=(mode == "3d"),
                                uo0=5e-3 if mode == "3d" else 1e-3)
        if ranks > 1:
            decompose(case, ranks, mode == "slice")
        wall, cpu, log = run_timed(case, s.get("solver", "pimpleFoam"), ranks)
        skip = 10
        dw = np.diff(wall[skip:])
        its = [int(x) for x in re.findall(r"Solving for cellDisplacement\w*, .*No Iterations (\d+)", log)]
        r = dict(
            case=case,
            # mean: the output of a parallel run arrives in bursts (median of gaps is meaningless)
            wall_ms=1000 * float(np.mean(dw)),
            cpu_ms=1000 * (cpu[-1] - cpu[skip]) / (len(cpu) - 1 - skip),
            motion_its=float(np.sum(its)) / len(cpu) if its else 0.0,
        )
        for k in ("wall_ms", "cpu_ms"):
            best[k] = min(best.get(k, np.inf), r[k])
        best.update(case=case, motion_its=r["motion_its"])
    return best


def compare(case: Path, ref: Path, skip: int = 10, closed: bool = False) -> tuple[float, float]:
    """(resultant force difference, wall pressure difference), relative; the first `skip` steps
    (start from rest) are left out.  The wall pressure: largest difference over the write times
    the two runs share after the first `skip` steps (the last step only, unless --write-every),
    relative to the reference's largest wall pressure over them.  closed: the pressure level of a
    closed domain is a convention (pRefCell, which also depends on the decomposition): wall
    pressures are compared after removing their means."""
    a, b = fc.read_interface(case), fc.read_interface(ref)
    n = min(len(a), len(b))
    fa = np.column_stack([a.Fx, a.Fy, a.Fz])[skip:n]
    fb = np.column_stack([b.Fx, b.Fy, b.Fz])[skip:n]
    df = np.abs(fa - fb).max() / np.abs(fb).max()
    dt = float(b.t[1] - b.t[0]) if len(b.t) > 1 else 0.0

    def times(c: Path) -> set[str]:
        return {p.name for p in (c / "postProcessing" / "interface").iterdir()
                if p.name != "0" and float(p.name) > skip * dt * (1 + 1e-9)}

    ta, tb = times(case), times(ref)
    shared = sorted(ta & tb, key=float)
    if not shared:
        shared = [max(tb, key=float)]
    order = None
    worst, peak = 0.0, 0.0
    for name in shared:
        xa, pa = _faces(case, name)
        xb, pb = _faces(ref, name)
        if order is None:
            order = _match(xa, xb)
        pa = pa[order]
        if closed:
            pa, pb = pa - pa.mean(), pb - pb.mean()
        worst = max(worst, float(np.abs(pa - pb).max()))
        peak = max(peak, float(np.abs(pb).max()))
    return float(df), worst / peak


def _faces(case: Path, time_name: str) -> tuple[np.ndarray, np.ndarray]:
    """Wall face centres and pressures written at time_name (every rank's file)."""
    base = case / "postProcessing" / "interface" / time_name
    files = sorted(base.glob("faces*.dat"))
    data = np.vstack([np.loadtxt(f, comments="#", ndmin=2) for f in files])
    return data[:, 0:3], data[:, 6]


def _match(xa: np.ndarray, xb: np.ndarray) -> np.ndarray:
    """Index into xa of the face nearest each face of xb: the same faces in any rank split and on
    a moved mesh (the wall moves by centimetres, faces are tens of centimetres apart; sorting by
    coordinates instead pairs different faces where two centres nearly tie)."""
    from scipy.spatial import cKDTree

    _, idx = cKDTree(xa).query(xb)
    if len(set(idx.tolist())) != len(xb):
        raise RuntimeError("wall faces of the two runs do not match one to one")
    return idx


def from_case_pairs(a, root: Path) -> int:
    """--from-case: ours and stock alternately on the water case the product writes (from_case.py);
    OpenFOAM's CPU ms a step after the first 10, each round's ratio, the medians."""
    from . import from_case as fcase

    copy = fcase.short_copy(Path(a.from_case), root / "run")
    fluid = fcase.run_short(copy, a.variant)
    w, axis, differ = fcase.product_description(copy, a.variant, fluid)
    cells = int(re.search(r"nCells:\s*(\d+)", (fluid / "constant/polyMesh/owner").read_text(errors="replace")[:2000])
                .group(1))
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}, {machine()}, work dir {root}")
    print(f"# the product's water case ({fluid}): {w.solver}, {w.model} water, {w.mode}, {cells} cells, "
          f"ends {w.ends[0]}, step {w.delta_t:.6g} s (the coupling window); the writer's files "
          f"{'identical to the run' if not differ else 'differ from the run: ' + ', '.join(differ)} "
          "(the exchange aside)", flush=True)
    rounds = max(a.pair, 1) if a.pair else 5
    cpu: dict[str, list[float]] = {"ours": [], "stock": []}
    for _ in range(rounds):
        for name in ("ours", "stock"):
            time.sleep(a.pause)
            case = root / name
            fcase.write_variant(w, axis, fluid, case, a.steps, stock=STOCK if name == "stock" else None)
            _wall, c, _log = run_timed(case, w.solver, 1)
            skip = 10
            cpu[name].append(1000 * (c[-1] - c[skip]) / (len(c) - 1 - skip))
        print(f"round {len(cpu['ours'])}: CPU ms a step ours {cpu['ours'][-1]:.3f}, stock {cpu['stock'][-1]:.3f}, "
              f"stock/ours {cpu['stock'][-1] / cpu['ours'][-1]:.2f}", flush=True)
    ratios = [s / o for s, o in zip(cpu["stock"], cpu["ours"], strict=True)]
    print(f"{w.mode} {cells} cells, {a.steps} steps, {rounds} rounds: ours median {statistics.median(cpu['ours']):.3f}"
          f" ms, stock median {statistics.median(cpu['stock']):.3f} ms; stock/ours by round "
          f"{', '.join(f'{x:.2f}' for x in ratios)}; median {statistics.median(ratios):.2f}")
    if not a.keep:
        shutil.rmtree(root)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", nargs="+", default=["3d", "slice"])
    ap.add_argument("--variants", nargs="+", default=None, help="names from STEPS/REJECTED (default: all)")
    ap.add_argument("--ranks", nargs="+", type=int, default=[1, 2],
                    help="rank counts for 'stock' and 'ours' (the other variants run on 1)")
    ap.add_argument("--steps3d", type=int, default=100)
    ap.add_argument("--steps2d", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--pair", type=int, default=0,
                    help="instead of the table: N alternating runs of ours and each of --variants "
                         "(default: stock), 1 rank, per mesh; min and median of each and their ratio to ours")
    ap.add_argument("--pause", type=float, default=0.0,
                    help="seconds of idle before each timed run (--pair), so that no run starts right "
                         "after another's load")
    ap.add_argument("--write-every", type=int, default=0,
                    help="write every N steps and compare the wall pressure at each write (the "
                         "largest difference; default: the last step only). The writes are in the "
                         "timed steps: use it for the accuracy columns, not the times")
    ap.add_argument("--from-case", default=None, metavar="CASE",
                    help="instead of the paper-size meshes: the water case the product writes for CASE's "
                         "condition dynamic_water (a short coupled run writes it; from_case.py), ours and "
                         "the stock solvers alternately --pair times (default 5), --steps steps")
    ap.add_argument("--variant", default=None, help="with --from-case: the case file's variant")
    ap.add_argument("--steps", type=int, default=300, help="with --from-case: water steps a run")
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--keep", action="store_true")
    a = ap.parse_args(argv)
    root = Path(a.workdir or tempfile.mkdtemp(prefix="tq-water-bench-"))
    root.mkdir(parents=True, exist_ok=True)
    if a.from_case:
        return from_case_pairs(a, root)
    print(f"# {time.strftime('%Y-%m-%d %H:%M')}, {machine()}, best of {a.repeat}, work dir {root}")
    print("| mesh | cells | variant | ranks | ms/step CPU | ms/step wall | motion its/step "
          "| ΔF/F_max | Δp_w/p_max |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|")
    if a.pair:
        for mode in a.mesh:
            poly = tunnel.prepare_mesh(mode, root / f"mesh-{mode}")
            steps = a.steps3d if mode == "3d" else a.steps2d
            vs = {name: s for name, _what, s in variants(closed=(mode == "slice"))}
            others = [n for n in (a.variants or ["stock"]) if n != OURS]
            for n in others:
                if n not in vs:
                    raise SystemExit(f"--variants: unknown variant {n!r}; known: {', '.join(vs)}")
            names = ["ours"] + others  # alternately: ours, stock, ours, stock, ...
            settings = dict(vs, ours=vs[OURS])
            runs: dict[str, list[dict]] = {n: [] for n in names}
            for _ in range(a.pair):
                for name in names:
                    tag = re.sub(r"[^A-Za-z0-9]+", "_", name)
                    time.sleep(a.pause)
                    runs[name].append(measure(root, poly, mode, f"pair-{tag}", settings[name], steps))
            out = {}
            for name, rs in runs.items():
                cpu = [r["cpu_ms"] for r in rs]
                wall = [r["wall_ms"] for r in rs]
                out[name] = (min(cpu), statistics.median(cpu), min(wall), statistics.median(wall))
                print(f"{mode} {name}: CPU ms/step {', '.join(f'{x:.2f}' for x in cpu)}; min {out[name][0]:.2f} "
                      f"median {out[name][1]:.2f}; wall min {out[name][2]:.2f} median {out[name][3]:.2f} "
                      f"({len(rs)} runs)", flush=True)
            o = out["ours"]
            for name in others:
                r = out[name]
                # each round's ratio: the two runs next to each other, under the same load
                rounds = [x["cpu_ms"] / y["cpu_ms"] for x, y in zip(runs[name], runs["ours"], strict=True)]
                print(f"{mode} {name}/ours: CPU {r[0] / o[0]:.2f} (min) {r[1] / o[1]:.2f} (median); "
                      f"wall {r[2] / o[2]:.2f} (min) {r[3] / o[3]:.2f} (median); CPU by round "
                      f"{', '.join(f'{x:.2f}' for x in rounds)}, median {statistics.median(rounds):.2f}", flush=True)
        if not a.keep:
            shutil.rmtree(root)
        return 0
    for mode in a.mesh:
        poly = tunnel.prepare_mesh(mode, root / f"mesh-{mode}")
        ncells = int(re.search(r"nCells:\s*(\d+)", (poly / "owner").read_text(errors="replace")[:2000]).group(1))
        steps = a.steps3d if mode == "3d" else a.steps2d
        ref = measure(root, poly, mode, "reference", REFERENCE, steps, write_every=a.write_every)
        vs = variants(closed=(mode == "slice"))
        ours = vs[len(STEPS) - 1][2]
        for name, _what, settings in vs:
            if a.variants and name not in a.variants:
                continue
            if name.startswith("ours,") and settings == ours:
                continue  # the same as ours on this mesh
            rank_list = a.ranks if name in ("stock", OURS) else [1]
            for ranks in rank_list:
                r = measure(root, poly, mode, name, settings, steps, ranks, a.repeat, a.write_every)
                df, dp = compare(r["case"], ref["case"], closed=(mode == "slice"))
                print(f"| {mode} | {ncells} | {name} | {ranks} | {r['cpu_ms']:.2f} | {r['wall_ms']:.2f} | "
                      f"{r['motion_its']:.1f} | {df:.1e} | {dp:.1e} |", flush=True)
    if not a.keep:
        shutil.rmtree(root)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
