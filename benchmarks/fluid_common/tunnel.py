"""Water cases on the tunnel's own water mesh (tunnelquake.meshing.build_tunnel_mesh), for the
benchmark (benchmarks/water_step) and the verification tests, written by the product's writer
(tunnelquake.water_case).

prepare_mesh(mode, dest): builds the paper's mesh (PAPER_GEOMETRY, mode '3d' or 'slice'),
converts water.msh with gmshToFoam and sets the patch types (interface: wall; slice ends:
empty); returns the constant/polyMesh folder, reused by every case of that mesh.

make_case(case, polymesh, settings): a complete case: the dictionaries the product writes for
this mesh's water (water_case.WaterCase: incompressible water, pimpleFoam; ends from the mesh:
'empty' (slice), 'wall' (a closed pipe, ends_are_walls) or open (p fixed, the tunnel's 3D
mesh)), with the fake solid ('replay') reading constant/wallMotion.dat. `settings` changes
named knobs (SETTINGS) from the product's; each knob is one override of the writer's
dictionaries (`overrides`), so that a benchmark variant (the stock set-up, a rejected
alternative, a tight reference) is the product's case with what it sets otherwise, and the
empty settings are the product's case itself.
"""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np

from tunnelquake import water_case as wc
from tunnelquake.foam_dict import Quoted, Uniform, foam_file

from . import foamcase as fc
from . import pipe

# The tunnel axis of PAPER_GEOMETRY: along y through (0, *, 32)
AXIS_POINT = (0.0, 0.0, 32.0)

#: The knobs of a case and their defaults; None: the product's (water_case) entry. Every benchmark
#: variant is a few of these set.
SETTINGS: dict = {
    # interface motion: 'transpiration' (static mesh, the product's) or 'meshMotion'
    "interface_motion": "transpiration",
    # mesh motion solver when interface_motion is meshMotion: 'tqInterpolated' (the writer's) or
    # 'laplacian' (stock displacementLaplacian with laplacian_diffusivity and cellDisplacement)
    "motion_solver": "tqInterpolated",
    "laplacian_diffusivity": "inverseDistance (interface)",
    "cellDisplacement": "solver PCG; preconditioner DIC; tolerance 1e-8; relTol 0;",
    # wall conditions: 'ours' (tqInterfaceVelocity + fixedFluxExtrapolatedPressure) or
    # 'stock' (movingWallVelocity + fixedFluxPressure)
    "wall": "ours",
    # linear solvers (OpenFOAM dictionary bodies; None: the water case's)
    "p": None,
    "pFinal": None,
    "U": None,
    "pcorr": None,
    # the Laplacians: of the momentum equation's viscous term and all others (default)
    "laplacianU": None,
    "laplacianP": None,
    # laminar stress model (constant/turbulenceProperties): 'tqNewtonian' (libtqFoam: only
    # laplacian(nuEff,U)) or the stock 'Stokes' (adds the explicit div(nuEff dev2(T(grad U))))
    "laminarModel": None,
    # PIMPLE
    "nOuterCorrectors": None,
    "nCorrectors": None,
    "nNonOrthogonalCorrectors": None,
    "momentumPredictor": None,
    "correctPhi": None,
    # per-step screen output: False: the solver's step lines and tqInterface's force lines each
    # step (water_case log_interval = the step), no linear-solver lines; True: everything
    # (log_interval None: the solver's residual lines too)
    "log": False,
    "runTimeModifiable": None,
    # tqInterface
    "wallPressure": None,
    "geometricCorrection": None,
    # keep freed memory in the heap (tqInterface heapTuning; its default yes)
    "heapTuning": None,
    # more function objects: {name: dictionary}
    "functions": None,
    # run
    "dt": 1e-4,
    "steps": 100,
    "write_interval": None,  # None: only at the end
}


def prepare_mesh(mode: str, dest: Path) -> Path:
    """Paper-size water mesh ('3d' or 'slice') as an OpenFOAM polyMesh; returns its folder."""
    from tunnelquake.meshing import PAPER_GEOMETRY, build_tunnel_mesh

    dest = Path(dest)
    poly = dest / "case" / "constant" / "polyMesh"
    if (poly / "owner").exists():
        return poly
    shutil.rmtree(dest, ignore_errors=True)
    dest.mkdir(parents=True)
    build_tunnel_mesh(PAPER_GEOMETRY, {"mode": mode}, dest / "mesh")
    case = dest / "case"
    # the least controlDict gmshToFoam reads
    (case / "system").mkdir(parents=True)
    (case / "system" / "controlDict").write_text(foam_file(
        {"application": "pimpleFoam", "startTime": 0, "endTime": 1, "deltaT": 1, "writeControl": "timeStep",
         "writeInterval": 1}, "controlDict"))
    fc.run(case, "gmshToFoam", str(dest / "mesh" / "water.msh"))
    boundary = poly / "boundary"
    fc.run(case, "foamDictionary", str(boundary), "-entry", "entry0/interface/type", "-set", "wall",
           log="foamDictionary.interface")
    if mode == "slice":
        for e in ("end_ymin", "end_ymax"):
            fc.run(case, "foamDictionary", str(boundary), "-entry", f"entry0/{e}/type", "-set", "empty",
                   log=f"foamDictionary.{e}")
    return poly


def ends_are_walls(boundary: str) -> bool:
    """Whether a polyMesh boundary file's axial ends (end_ymin, end_ymax) are both of type wall:
    a closed pipe (pipe.make_pipe_case, open_ends False); gmshToFoam's open ends are 'patch'."""
    types = {m.group(1): m.group(2) for m in re.finditer(r"\b(end_y(?:min|max))\s*\{[^}]*?\btype\s+(\w+)\s*;", boundary)}
    return len(types) == 2 and all(t == "wall" for t in types.values())


def overrides(s: dict, ends: str, moving: bool) -> dict:
    """The writer's overrides of the knobs `s` (SETTINGS with a variant's values) on a mesh with
    ends of kind `ends` (empty, wall or open); `moving`: the mesh follows the wall."""
    fv_solution: dict = {"solvers": {}, "PIMPLE": {}}
    for name in ("p", "pFinal"):
        if s[name] is not None:
            fv_solution["solvers"][name] = pipe.solver_controls(s[name])
    if s["U"] is not None:
        fv_solution["solvers"][Quoted("U(Final)?")] = pipe.solver_controls(s["U"])
    if s["pcorr"] is not None:
        fv_solution["solvers"][Quoted("pcorr(Final)?")] = pipe.solver_controls(s["pcorr"])
    for key in ("nOuterCorrectors", "nCorrectors", "nNonOrthogonalCorrectors", "momentumPredictor", "correctPhi"):
        if s[key] is not None:
            fv_solution["PIMPLE"][key] = s[key]
    laplacians = {}
    if s["laplacianP"] is not None:
        laplacians["default"] = s["laplacianP"]
    if s["laplacianU"] is not None:
        laplacians["laplacian(nuEff,U)"] = s["laplacianU"]
    interface = {k: s[k] for k in ("wallPressure", "geometricCorrection", "heapTuning") if s[k] is not None}
    control = {"functions": {"interface": interface, **(s["functions"] or {})}}
    if s["runTimeModifiable"] is not None:
        control["runTimeModifiable"] = s["runTimeModifiable"]
    out = {"system/fvSolution": fv_solution, "system/fvSchemes": {"laplacianSchemes": laplacians},
           "system/controlDict": control}
    if s["laminarModel"] is not None:
        out["constant/turbulenceProperties"] = {"laminar": {"laminarModel": s["laminarModel"]}}
    if moving and s["motion_solver"] == "laplacian":
        out = wc.combined(out, pipe.laplacian_motion(s["laplacian_diffusivity"], s["cellDisplacement"],
                                                   slip_ends=ends != "empty"))
    elif moving and s["motion_solver"] != "tqInterpolated":
        raise ValueError(f"motion_solver {s['motion_solver']!r}: tqInterpolated or laplacian")
    if s["wall"] == "stock":
        # the stock moving-wall pair on the wall, and on closed ends (the moving mesh carries them)
        u = wc.Whole(type="movingWallVelocity", value=Uniform([0, 0, 0]))
        p = wc.Whole(type="fixedFluxPressure", value=Uniform(0))
        walls = ["interface"] + ([Quoted("end_y(min|max)")] if ends == "wall" else [])
        out["0/U"] = {"boundaryField": {w: u for w in walls}}
        out["0/p"] = {"boundaryField": {w: p for w in walls}}
    elif s["wall"] != "ours":
        raise ValueError(f"wall {s['wall']!r}: ours or stock")
    return out


def make_case(case: Path, polymesh: Path, settings: dict | None = None) -> Path:
    """Write the case from `settings` (knobs of SETTINGS set otherwise); returns the motion table
    path. With no settings: the case the product writes for this water."""
    s = dict(SETTINGS)
    unknown = set(settings or {}) - set(s)
    if unknown:
        raise ValueError(f"unknown case settings {sorted(unknown)}; known: {', '.join(s)}")
    s.update(settings or {})
    case = Path(case)
    if case.exists():
        shutil.rmtree(case)
    shutil.copytree(polymesh, case / "constant" / "polyMesh")
    boundary = (case / "constant" / "polyMesh" / "boundary").read_text()
    ends = "empty" if "empty" in boundary else "wall" if ends_are_walls(boundary) else "open"
    moving = s["interface_motion"] == "meshMotion"
    motion = case / "constant" / "wallMotion.dat"
    steps, dt = s["steps"], s["dt"]
    w = wc.WaterCase(
        model="incompressible", ends=(ends, ends), density=pipe.RHO, viscosity=pipe.RHO * pipe.NU,
        bulk_modulus=pipe.K_WATER, delta_t=dt, end_time=steps * dt,
        write_interval=s["write_interval"] if s["write_interval"] is not None else steps * dt,
        free_surface_level=AXIS_POINT[2], exchange=pipe.replay_exchange(motion, AXIS_POINT),
        log_interval=None if s["log"] else dt, interface_motion=s["interface_motion"])
    wc.write(w, case, overrides(s, ends, moving))
    return motion


def benchmark_motion(path: Path, dt: float, steps: int, radial: bool, freq: float = 5.0, a0: float = 1.0,
                     ur0: float = 0.01, uo0: float = 0.005) -> None:
    """Wall motion of the benchmark, from rest: rigid lateral (x) shaking a0 cos(2 pi f t), ovaling
    (n = 2) uo = uo0 (1 - cos(2 pi f t)), and (radial: 3D, open ends) a slow uniform contraction
    ur = -ur0 (1 - cos(pi t))/2.  Velocities are the mid-step ones (u_k - u_{k-1})/dt, as the
    solid's central difference gives."""
    t = np.arange(0, (steps + 3) * dt, dt)
    w = 2 * math.pi * freq
    u, _ = pipe.harmonic_lateral(t, a0, w)
    ur = -ur0 * (1 - np.cos(math.pi * t)) / 2 if radial else np.zeros_like(t)
    uo = uo0 * (1 - np.cos(w * t))

    def rate(x):
        return np.concatenate([np.zeros((1,) + x.shape[1:]), np.diff(x, axis=0) / dt])

    pipe.write_motion(path, t, u, rate(u), ur, rate(ur), uo, rate(uo))
