"""Water cases on the tunnel's own water mesh (tunnelquake.meshing.build_tunnel_mesh), for the
benchmark (benchmarks/water_step) and the verification tests.

prepare_mesh(mode, dest): builds the paper's mesh (PAPER_GEOMETRY, mode '3d' or 'slice'),
converts water.msh with gmshToFoam and sets the patch types (interface: wall; slice ends:
empty); returns the constant/polyMesh folder, reused by every case of that mesh.

make_case(case, polymesh, settings): a complete pimpleFoam case with libtqFoam.so, written
from a settings dict (defaults: SETTINGS, "ours"), with the fake solid ('replay') reading
constant/wallMotion.dat.  Axial ends from the mesh: 'empty' (slice), 'wall' (a closed pipe:
end plates moving with it, ends_are_walls) or open (p fixed, the tunnel's 3D mesh).  The settings cover the whole of what the benchmark compares:
mesh motion (stock displacementLaplacian, tqInterpolatedDisplacement, transpiration), wall
conditions (stock movingWallVelocity + fixedFluxPressure, or ours), linear solvers and PIMPLE
controls, logging.
"""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np

from . import foamcase as fc
from . import pipe

# The tunnel axis of PAPER_GEOMETRY: along y through (0, *, 32)
AXIS_POINT = (0.0, 0.0, 32.0)

#: Settings of a case; every benchmark variant is a few overrides of these.
SETTINGS: dict = {
    # interface motion: 'meshMotion' (the mesh follows the wall) or 'transpiration' (static)
    "interface_motion": "transpiration",
    # mesh motion solver when interface_motion is meshMotion:
    #   'tqInterpolated' | 'laplacian' (stock displacementLaplacian)
    "motion_solver": "tqInterpolated",
    "laplacian_diffusivity": "inverseDistance (interface)",
    "cellDisplacement": "solver PCG; preconditioner DIC; tolerance 1e-8; relTol 0;",
    # wall conditions: 'ours' (tqInterfaceVelocity + fixedFluxExtrapolatedPressure) or
    # 'stock' (movingWallVelocity + fixedFluxPressure)
    "wall": "ours",
    # linear solvers (OpenFOAM dictionary bodies)
    # the water case's (tqProjected, GAMG inside; open ends: relative tolerance)
    "p": fc.water_p_controls(closed=False),
    "pFinal": fc.water_p_controls(closed=False),
    "U": "solver smoothSolver; smoother symGaussSeidel; tolerance 1e-8; relTol 0;",
    "pcorr": "solver PCG; preconditioner DIC; tolerance 1e-2; relTol 0;",
    # PIMPLE
    # the viscous Laplacian of the momentum equation: 'corrected' adds a non-orthogonal
    # correction built from a second full grad(U) every step; water's viscous term is tiny
    "laplacianU": "Gauss linear uncorrected",
    "laplacianP": "Gauss linear corrected",
    # laminar stress model (constant/turbulenceProperties): 'tqNewtonian' (libtqFoam: only
    # laplacian(nuEff,U)) or the stock 'Stokes' (adds the explicit div(nuEff dev2(T(grad U))))
    "laminarModel": "tqNewtonian",
    "nOuterCorrectors": 1,
    "nCorrectors": 1,
    "nNonOrthogonalCorrectors": 0,
    "momentumPredictor": False,
    "correctPhi": False,
    # per-step screen output: solver performance lines and the function object's lines
    "log": False,
    "runTimeModifiable": False,
    # tqInterface
    "wallPressure": "extrapolated",
    "geometricCorrection": True,
    # keep freed memory in the heap (tqInterface heapTuning)
    "heapTuning": True,
    "extra_functions": "",
    # run
    "dt": 1e-4,
    "steps": 100,
    "write_interval": None,  # None: only at the end
    "solver": "pimpleFoam",
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
    fc.write(case, "system/controlDict", "application pimpleFoam; startTime 0; endTime 1; deltaT 1;"
             " writeControl timeStep; writeInterval 1;\n")
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


def _solver_entry(name: str, body: str) -> str:
    return f"    {name} {{ {body} }}\n"


def make_case(case: Path, polymesh: Path, settings: dict | None = None) -> Path:
    """Write the case from `settings` (overrides of SETTINGS); returns the motion table path."""
    s = dict(SETTINGS)
    s.update(settings or {})
    case = Path(case)
    if case.exists():
        shutil.rmtree(case)
    shutil.copytree(polymesh, case / "constant" / "polyMesh")
    boundary = (case / "constant" / "polyMesh" / "boundary").read_text()
    slice_mode = "empty" in boundary
    closed_ends = not slice_mode and ends_are_walls(boundary)
    moving = s["interface_motion"] == "meshMotion"
    motion = case / "constant" / "wallMotion.dat"
    steps, dt = s["steps"], s["dt"]
    wi = s["write_interval"] if s["write_interval"] is not None else steps * dt
    log = "true" if s["log"] else "false"
    debug = "" if s["log"] else "DebugSwitches { SolverPerformance 0; }\n"
    fc.write(
        case,
        "system/controlDict",
        f"""
application     {s["solver"]};
startFrom       startTime;
startTime       0;
stopAt          endTime;
endTime         {steps * dt!r};
deltaT          {dt!r};
writeControl    runTime;
writeInterval   {wi!r};
purgeWrite      0;
writeFormat     binary;
writePrecision  14;
timePrecision   10;
runTimeModifiable {"true" if s["runTimeModifiable"] else "false"};
{debug}libs            ("{fc.LIBRARY}");
functions
{{
    interface
    {{
        type            tqInterface;
        libs            ("{fc.LIBRARY}");
        log             {log};
        patch           interface;
        rho             rhoInf;
        rhoInf          {pipe.RHO};
        wallPressure    {s["wallPressure"]};
        interfaceMotion {s["interface_motion"]};
        geometricCorrection {"yes" if s["geometricCorrection"] else "no"};
        heapTuning      {"yes" if s["heapTuning"] else "no"};
        exchange
        {{
            type            replay;
            file            "{motion}";
            axisPoint       ({AXIS_POINT[0]} {AXIS_POINT[1]} {AXIS_POINT[2]});
            axisDirection   (0 1 0);
        }}
    }}
{s["extra_functions"]}
}}
""",
    )
    fc.write(
        case,
        "system/fvSchemes",
        f"""
ddtSchemes {{ default Euler; }}
gradSchemes {{ default Gauss linear; }}
divSchemes {{ default none; div(phi,U) Gauss linear; div((nuEff*dev2(T(grad(U))))) Gauss linear; }}
laplacianSchemes {{ default {s["laplacianP"]}; laplacian(nuEff,U) {s["laplacianU"]}; }}
interpolationSchemes {{ default linear; }}
snGradSchemes {{ default corrected; }}
""",
    )
    solvers = (
        _solver_entry("p", s["p"])
        + _solver_entry("pFinal", s["pFinal"])
        + _solver_entry('"U(Final)?"', s["U"])
        + _solver_entry('"pcorr(Final)?"', s["pcorr"])
        + _solver_entry('"cellDisplacement(Final)?"', s["cellDisplacement"])
    )
    fc.write(
        case,
        "system/fvSolution",
        f"""
solvers
{{
{solvers}}}
PIMPLE
{{
    nOuterCorrectors {s["nOuterCorrectors"]};
    nCorrectors     {s["nCorrectors"]};
    nNonOrthogonalCorrectors {s["nNonOrthogonalCorrectors"]};
    momentumPredictor {"yes" if s["momentumPredictor"] else "no"};
    correctPhi      {"yes" if s["correctPhi"] else "no"};
    pRefCell 0;
    pRefValue 0;
}}
""",
    )
    fc.write(case, "constant/transportProperties", f"transportModel Newtonian;\nnu {pipe.NU};\n")
    fc.write(case, "constant/turbulenceProperties", pipe.turbulence_properties(s["laminarModel"]))
    if not moving:
        dyn = "dynamicFvMesh staticFvMesh;\n"
    elif s["motion_solver"] == "tqInterpolated":
        dyn = f"""dynamicFvMesh dynamicMotionSolverFvMesh;
motionSolverLibs ("{fc.LIBRARY}");
motionSolver tqInterpolatedDisplacement;
tqInterpolatedDisplacementCoeffs {{ patches (interface); decay linear; }}
"""
    else:
        dyn = f"""dynamicFvMesh dynamicMotionSolverFvMesh;
motionSolverLibs ("libfvMotionSolvers.so");
motionSolver displacementLaplacian;
displacementLaplacianCoeffs {{ diffusivity {s["laplacian_diffusivity"]}; }}
"""
    fc.write(case, "constant/dynamicMeshDict", dyn)

    if s["wall"] == "stock":
        wall_u = "type movingWallVelocity; value uniform (0 0 0);"
        wall_p = "type fixedFluxPressure; value uniform 0;"
    else:
        wall_u = "type tqInterfaceVelocity; value uniform (0 0 0);"
        wall_p = "type fixedFluxExtrapolatedPressure; value uniform 0;"
    if slice_mode:
        end_u = end_p = end_d = "type empty;"
    elif closed_ends:
        # closed 3D pipe (ends of type wall, e.g. pipe.make_pipe_case's blockMesh): the end plates
        # move with the pipe. Stock: the moving mesh carries them (movingWallVelocity); ours on a
        # moving mesh the same through tqInterfaceVelocity; ours with transpiration (static mesh)
        # sees only their in-plane motion for a lateral shake: slip (no flux, no shear) is exact
        # for a rigid translation, whose water moves uniformly with the pipe
        if s["wall"] == "stock":
            end_u, end_p = "type movingWallVelocity; value uniform (0 0 0);", "type fixedFluxPressure; value uniform 0;"
        else:
            end_u = "type slip;" if not moving else "type tqInterfaceVelocity; value uniform (0 0 0);"
            end_p = "type fixedFluxExtrapolatedPressure; value uniform 0;"
        end_d = "type slip;" if s["motion_solver"] == "laplacian" else "type calculated; value uniform (0 0 0);"
    else:
        end_u = "type pressureInletOutletVelocity; value uniform (0 0 0);"
        end_p = "type fixedValue; value uniform 0;"
        # ends: the Laplacian needs a condition there (slip in the end plane); the interpolated
        # motion moves them itself
        end_d = "type slip;" if s["motion_solver"] == "laplacian" else "type calculated; value uniform (0 0 0);"
    fc.write(
        case,
        "0/U",
        f"""
dimensions [0 1 -1 0 0 0 0];
internalField uniform (0 0 0);
boundaryField
{{
    interface {{ {wall_u} }}
    "end_y(min|max)" {{ {end_u} }}
}}
""",
        cls="volVectorField",
    )
    fc.write(
        case,
        "0/p",
        f"""
dimensions [0 2 -2 0 0 0 0];
internalField uniform 0;
boundaryField
{{
    interface {{ {wall_p} }}
    "end_y(min|max)" {{ {end_p} }}
}}
""",
        cls="volScalarField",
    )
    if moving:
        pipe.write_point_displacement(case, end_d)
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
