"""Benchmark: cost of a water step with each mesh motion (not a test; prints figures).

Runs pimpleFoam on the water-filled pipe (R 4.5 m) with the fake solid replaying a
wall motion (rigid lateral translation a0 cos(wt) plus a slow uniform radial
contraction, open ends so the water can leave), for:
  static        no mesh motion (staticFvMesh, exchange none): the flow solve alone
  tqInterpolated  explicit O(N) interpolation (libtqFoam.so)
  laplacian     stock displacementLaplacian, uniform diffusivity, PCG/DIC 1e-8
  laplacianGAMG displacementLaplacian, GAMG 1e-6 (a tuned stock setting)
and prints ms per step (mean of the steps after the first five, from pimpleFoam's
ExecutionTime) and the cellDisplacement iterations per step.

Usage (from the repository root): .venv/bin/python -m benchmarks.mesh_motion [--cells3d 15000] [--steps 40]
Figures go to docs/water.md by hand (with the machine and date).
"""

from __future__ import annotations

import argparse
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from tunnelquake import water_case as wc
from tunnelquake.foam_dict import Quoted

from .fluid_common import foamcase as fc
from .fluid_common import pipe


def ms_per_step(log: str, skip: int = 5) -> float:
    t = np.array([float(x) for x in re.findall(r"ExecutionTime = ([0-9.eE+-]+) s", log)])
    return float(np.diff(t[skip:]).mean() * 1000)


def motion_iterations(log: str) -> float:
    its = [int(x) for x in re.findall(r"Solving for cellDisplacement\w*, .*No Iterations (\d+)", log)]
    return float(np.mean(its)) if its else 0.0


def run_variant(root: Path, name: str, geom: dict, steps: int, dt: float, gamg: bool) -> dict:
    case = root / name
    solver = {"static": "tqInterpolated", "laplacianGAMG": "laplacian"}.get(name, name)
    gamg = {"solver": "GAMG", "smoother": "GaussSeidel", "tolerance": 1e-7}
    more: dict = {"system/fvSolution": {"solvers": {"p": wc.Whole(gamg, relTol=0.01),
                                                    "pFinal": wc.Whole(gamg, relTol=0)}}}
    if name == "laplacianGAMG":
        more["system/fvSolution"]["solvers"][Quoted("cellDisplacement(Final)?")] = wc.Whole(
            solver="GAMG", smoother="GaussSeidel", tolerance=1e-6, relTol=0)
    if name == "static":  # the mesh and the wall at rest: the step without any motion
        more["constant/dynamicMeshDict"] = {"dynamicFvMesh": "staticFvMesh", "motionSolverLibs": None,
                                            "motionSolver": None, "tqInterpolatedDisplacementCoeffs": None}
        more["system/controlDict"] = {"functions": {"interface": {"exchange": {
            "type": "none", "file": None, "axisPoint": None, "axisDirection": None}}}}
    motion = pipe.make_pipe_case(case, dt=dt, end_time=steps * dt, write_interval=1e9, motion_solver=solver,
                                 more=more, **geom)
    t = np.arange(0, (steps + 3) * dt, dt)
    omega = 2 * np.pi * 5.0
    u, v = pipe.harmonic_lateral(t, 1.0, omega)
    ur = -0.01 * (1 - np.cos(2 * np.pi * 0.5 * t)) / 2
    vr = -0.01 * np.pi * 0.5 * np.sin(2 * np.pi * 0.5 * t)
    if geom.get("two_d", True):
        ur, vr = 0 * ur, 0 * vr  # closed 2D slice: volume-preserving motion only
    pipe.write_motion(motion, t, u, v, ur, vr)
    fc.run(case, "blockMesh")
    log = fc.run(case, "pimpleFoam", timeout=1200)
    ncells = int(re.search(r"nCells:\s*(\d+)", (case / "log.blockMesh").read_text()).group(1))
    return dict(name=name, cells=ncells, ms=ms_per_step(log), motion_its=motion_iterations(log))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args(argv)
    root = Path(tempfile.mkdtemp(prefix="tq-motion-bench-"))
    meshes = {
        "3D pipe (open ends)": dict(two_d=False, L=9.0, ny=20, nq=14, nr=10, open_ends=True),
        "2D slice": dict(two_d=True, L=1.0, nq=16, nr=12),
    }
    print("| mesh | cells | mesh motion | ms/step | motion iterations/step |")
    print("|---|---:|---|---:|---:|")
    for label, geom in meshes.items():
        for name in ("static", "tqInterpolated", "laplacian", "laplacianGAMG"):
            r = run_variant(root / label.split()[0], name, geom, args.steps, 1e-3, False)
            print(
                f"| {label} | {r['cells']} | {name} | {r['ms']:.2f} | {r['motion_its']:.0f} |",
                flush=True,
            )
    if not args.keep:
        shutil.rmtree(root)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
