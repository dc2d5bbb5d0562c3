"""Water-filled pipe cases (axis y, cross-section x-z) for the water verification tests and
benchmarks, written by the product's writer (tunnelquake.water_case):

make_pipe_case() writes a complete case: the mesh (water_case.pipe_block_mesh, run blockMesh),
the dictionaries of water_case.dictionaries for a WaterCase of this pipe (the product's
numerics), and what a test sets otherwise as the writer's overrides (`overrides()` builds the
common ones: a tight pressure solve, another time scheme, the stock Laplacian mesh motion);
tqInterface's exchange is 'replay' (a fake solid) reading constant/wallMotion.dat, written by
write_motion().
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tunnelquake import water_case as wc
from tunnelquake.case import WATER_BULK_MODULUS
from tunnelquake.foam_dict import Quoted, parse

RHO = 1000.0
NU = 1.308e-6
#: Bulk modulus of water [Pa] (weakly compressible model): the case's default
K_WATER = WATER_BULK_MODULUS
#: Reference temperature of the compressible model [K]
T0 = wc.T0
#: the tqInterface gravity of every water case (its hydrostatic report)
GRAVITY = wc.GRAVITY
#: the stock Laplacian mesh motions (displacementLaplacian) by name, their diffusivity
LAPLACIAN_DIFFUSIVITY = {"laplacian": "uniform", "laplacianInverseDistance": "inverseDistance (interface)"}


def replay_exchange(motion: Path, axis_point=(0.0, 0.0, 0.0), rollbacks: int = 0, predictor_scale: float = 1.0,
                    rollback_from: int = 1) -> dict:
    """tqInterface's exchange with a fake solid replaying the motion table `motion`
    (write_motion), rolled back `rollbacks` times a step from step `rollback_from` on, the first
    attempt's motion `predictor_scale` times the table's (replayExchange.H)."""
    out = {"type": "replay", "file": Quoted(str(motion)), "axisPoint": list(axis_point), "axisDirection": [0, 1, 0]}
    if rollbacks:
        out.update(rollbacksPerStep=rollbacks, predictorScale=predictor_scale, rollbackFromStep=rollback_from)
    return out


def solver_controls(body: str) -> wc.Whole:
    """A linear solver's entries from their OpenFOAM text (`solver PCG; tolerance 1e-8; ...`), to
    replace the water case's entry as a whole."""
    return wc.Whole(parse(body))


def laplacian_motion(diffusivity: str, cell_displacement: str = "solver PCG; preconditioner DIC; "
                     "tolerance 1e-8; relTol 0;", slip_ends: bool = True) -> dict:
    """Overrides: the mesh moved by the stock displacementLaplacian (`diffusivity`) instead of
    tqInterpolatedDisplacement; its axial ends (slip_ends: not a slice's) slip in their planes."""
    out = {
        "constant/dynamicMeshDict": {"motionSolverLibs": [Quoted("libfvMotionSolvers.so")],
                                     "motionSolver": "displacementLaplacian",
                                     "tqInterpolatedDisplacementCoeffs": None,
                                     "displacementLaplacianCoeffs": {"diffusivity": diffusivity}},
        "system/fvSolution": {"solvers": {Quoted("cellDisplacement(Final)?"): solver_controls(cell_displacement)}},
    }
    if slip_ends:
        out["0/pointDisplacement"] = {"boundaryField": {Quoted("end_y(min|max)"): wc.Whole(type="slip")}}
    return out


def overrides(slice_mode: bool, p_tol: float | None = None, u_tol: float | None = None, ddt: str | None = None,
              motion_solver: str = "tqInterpolated", laminar_model: str | None = None,
              functions: dict | None = None) -> dict:
    """The writer's overrides a pipe test asks for: p and pFinal by PCG/DIC to an absolute `p_tol`
    (a solve far below the discretisation error) instead of the product's, U to `u_tol`; the time
    scheme `ddt`;
    the stock Laplacian mesh motion (LAPLACIAN_DIFFUSIVITY); another laminar model; more
    function objects."""
    out: dict = {}

    def lay(more: dict) -> None:
        out.update(wc.combined(out, more))

    if p_tol is not None:
        pcg = wc.Whole(solver="PCG", preconditioner="DIC", tolerance=p_tol, relTol=0)
        lay({"system/fvSolution": {"solvers": {"p": pcg, "pFinal": wc.Whole(pcg)}}})
    if u_tol is not None:
        lay({"system/fvSolution": {"solvers": {Quoted("U(Final)?"): {"tolerance": u_tol}}}})
    if ddt is not None:
        lay({"system/fvSchemes": {"ddtSchemes": {"default": ddt}}})
    if motion_solver != "tqInterpolated":
        if motion_solver not in LAPLACIAN_DIFFUSIVITY:
            raise ValueError(f"motion_solver {motion_solver!r}: tqInterpolated or one of {', '.join(LAPLACIAN_DIFFUSIVITY)}")
        lay(laplacian_motion(LAPLACIAN_DIFFUSIVITY[motion_solver], slip_ends=not slice_mode))
    if laminar_model is not None:
        lay({"constant/turbulenceProperties": {"laminar": {"laminarModel": laminar_model}}})
    if functions:
        lay({"system/controlDict": {"functions": functions}})
    return out


def write_motion(
    path: Path,
    t: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    ur: np.ndarray | None = None,
    vr: np.ndarray | None = None,
    uo: np.ndarray | None = None,
    vo: np.ndarray | None = None,
) -> None:
    """Fake-solid motion table: t ux uy uz vx vy vz [ur vr [uo vo]] (SI); ur/vr uniform radial,
    uo/vo ovaling n = 2 amplitude (replayExchange.H)."""
    cols = [t[:, None], u, v]
    header = "t ux uy uz vx vy vz"
    if ur is not None or uo is not None:
        z = np.zeros_like(t)
        cols += [(ur if ur is not None else z)[:, None], (vr if vr is not None else z)[:, None]]
        header += " ur vr"
    if uo is not None:
        cols += [uo[:, None], vo[:, None]]
        header += " uo vo"
    np.savetxt(path, np.hstack(cols), fmt="%.17g", header=header)


def make_pipe_case(
    case: Path,
    *,
    R: float = 4.5,
    L: float = 1.0,
    nq: int = 16,
    nr: int = 12,
    ny: int = 1,
    two_d: bool = True,
    dt: float,
    end_time: float,
    write_interval: float | None = None,
    rollbacks: int = 0,
    predictor_scale: float = 1.0,
    rollback_from: int = 1,
    grading: float = 1.0,
    open_ends: bool = False,
    interface_motion: str = "meshMotion",
    water: str = "incompressible",
    bulk_modulus: float = K_WATER,
    free_surface_level: float = 0.0,
    nu: float = NU,
    log_interval: float | None = None,
    more: dict | None = None,
    **kw,
) -> Path:
    """Write the case (its mesh by `blockMesh`, not run here); returns the path of the motion table
    to fill with write_motion().

    The pipe: radius R, length L, O-grid nq x nq centre and nr layers (pipe_block_mesh), ny cells
    along in 3D (two_d False; ends walls, or open with open_ends). The water (WaterCase):
    'incompressible' (pimpleFoam) or 'compressible' (rhoPimpleFoam, K = bulk_modulus), kinematic
    viscosity nu, free surface at z = free_surface_level (tqInterface's hydrostatic report);
    interface_motion 'meshMotion' (the mesh follows the wall) or 'transpiration' (static mesh,
    the product's). `kw`: the overrides() a test asks for (p_tol, u_tol, ddt, motion_solver,
    laminar_model, functions); `more`: further overrides of the writer's dictionaries, laid on
    last. Fields are written as text (fc.read_internal_field)."""
    case = Path(case)
    ends = "empty" if two_d else ("open" if open_ends else "wall")
    motion = case / "constant" / "wallMotion.dat"
    w = wc.WaterCase(
        model=water, ends=(ends, ends), density=RHO, viscosity=RHO * nu, bulk_modulus=bulk_modulus,
        delta_t=dt, end_time=end_time, write_interval=write_interval if write_interval is not None else end_time,
        free_surface_level=free_surface_level,
        exchange=replay_exchange(motion, rollbacks=rollbacks, predictor_scale=predictor_scale,
                                 rollback_from=rollback_from),
        log_interval=log_interval, interface_motion=interface_motion)
    over = wc.combined({"system/controlDict": {"writeFormat": "ascii"},
                      "system/blockMeshDict": wc.pipe_block_mesh(w, R, L, nq, nr, ny, grading)},
                     overrides(two_d, **kw))
    wc.write(w, case, wc.combined(over, more or {}))
    return motion


def harmonic_lateral(t: np.ndarray, a0: float, omega: float):
    """Rigid lateral (x) motion starting at rest: a = a0 cos(wt), v = a0/w sin(wt),
    u = a0/w^2 (1 - cos(wt))."""
    z = np.zeros_like(t)
    u = np.column_stack([a0 / omega**2 * (1 - np.cos(omega * t)), z, z])
    v = np.column_stack([a0 / omega * np.sin(omega * t), z, z])
    return u, v
