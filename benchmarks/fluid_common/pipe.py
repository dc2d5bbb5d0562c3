"""Water-filled pipe cases (axis y, cross-section x-z) for the fluid verification tests.

make_pipe_case() writes a complete pimpleFoam case using libtqFoam.so:
- mesh: blockMesh O-grid (centre square + 4 outer blocks), radius R, length L;
  2D: one cell thick, ends 'empty'; 3D: ends end_ymin/end_ymax;
- interface patch 'interface' (the lining's inner face), U tqInterfaceVelocity,
  p fixedFluxExtrapolatedPressure;
- mesh motion tqInterpolatedDisplacement driven by the interface displacement
  (or displacementLaplacian for comparison);
- the tqInterface function object with a 'replay' exchange (fake solid) reading
  constant/wallMotion.dat, written by write_motion().
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import foamcase as fc

RHO = 1000.0
NU = 1.308e-6
#: Bulk modulus of water [Pa] (weakly compressible model)
K_WATER = 2.2e9
#: Reference temperature of the compressible model [K]
T0 = 293.15


def _blockmesh(
    R: float,
    L: float,
    nq: int,
    nr: int,
    ny: int,
    two_d: bool,
    ends: str,
    grading: float,
) -> str:
    a = 0.35 * R
    s = R / math.sqrt(2)
    plane = [(-a, -a), (a, -a), (a, a), (-a, a), (-s, -s), (s, -s), (s, s), (-s, s)]
    verts = [(x, 0.0, z) for x, z in plane] + [(x, L, z) for x, z in plane]

    def hexa(q):  # q: 4 in-plane vertex ids (first plane); right-handed check
        v = np.array([verts[i] for i in q])
        n = np.cross(v[1] - v[0], v[3] - v[0])
        if n[1] < 0:  # extrusion is +y: need (v1-v0)x(v3-v0) along +y
            q = [q[0], q[3], q[2], q[1]]
        return list(q) + [i + 8 for i in q]

    # (in-plane quad, cells along its first edge, cells along its second edge, grading)
    # radial grading 'g': ratio of last to first cell towards the wall
    blocks = []
    for q, n1, n2 in [([0, 1, 2, 3], nq, nq)]:
        blocks.append((hexa(q), n1, n2, "1 1 1"))
    # outer blocks: inner edge first, so the radial direction is the 2nd local axis
    for q in ([0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]):
        h = hexa(q)
        # after a possible reorder, find which local axis is radial
        v0, v1 = h[0], h[1]
        radial_first = (v0 < 4) != (v1 < 4)
        if radial_first:
            blocks.append((h, nr, nq, f"{grading} 1 1"))
        else:
            blocks.append((h, nq, nr, f"1 {grading} 1"))
    arcs = []
    mids = {(4, 5): (0, -R), (5, 6): (R, 0), (6, 7): (0, R), (7, 4): (-R, 0)}
    for (i, j), (x, z) in mids.items():
        arcs.append(f"    arc {i} {j} ({x} 0 {z})")
        arcs.append(f"    arc {i + 8} {j + 8} ({x} {L} {z})")
    vtxt = "\n".join(f"    ({x:.12g} {y:.12g} {z:.12g})" for x, y, z in verts)
    btxt = "\n".join(
        f"    hex ({' '.join(map(str, h))}) ({n1} {n2} {1 if two_d else ny}) simpleGrading ({g})"
        for h, n1, n2, g in blocks
    )

    def face(q, back=False):
        return f"({' '.join(str(i + (8 if back else 0)) for i in q)})"

    outer = " ".join(f"({i} {j} {j + 8} {i + 8})" for i, j in [(4, 5), (5, 6), (6, 7), (7, 4)])
    quads = [[0, 1, 2, 3], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
    ymin = " ".join(face(q) for q in quads)
    ymax = " ".join(face(q, True) for q in quads)
    return f"""
convertToMeters 1;
vertices
(
{vtxt}
);
blocks
(
{btxt}
);
edges
(
{chr(10).join(arcs)}
);
boundary
(
    interface {{ type wall; faces ({outer}); }}
    end_ymin {{ type {ends}; faces ({ymin}); }}
    end_ymax {{ type {ends}; faces ({ymax}); }}
);
mergePatchPairs ();
"""


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
    motion_solver: str = "tqInterpolated",
    rollbacks: int = 0,
    predictor_scale: float = 1.0,
    rollback_from: int = 1,
    grading: float = 1.0,
    ddt: str = "Euler",
    p_tol: float = 1e-10,
    p_controls: str | None = None,
    extra_functions: str = "",
    open_ends: bool = False,
    interface_motion: str = "meshMotion",
    water: str = "incompressible",
    bulk_modulus: float = K_WATER,
    hydrostatic: tuple[float, float] | None = None,
    laminar_model: str | None = None,
    nu: float = NU,
) -> Path:
    """Write the case; returns the path of the motion table to fill with write_motion().

    interface_motion: 'meshMotion' (the mesh follows the wall: motion_solver) or
    'transpiration' (static mesh, wall velocity imposed on the fixed faces).
    water: 'incompressible' (pimpleFoam, kinematic p) or 'compressible' (rhoPimpleFoam, p in
    Pa, linear equation of state rho = rho0 + p/K_rho with K = bulk_modulus; see
    compressible_files()).  hydrostatic (g, free-surface level): tqInterface reports the
    hydrostatic resultant with gravity (0 0 -g).  laminar_model: 'tqNewtonian' (libtqFoam, the
    default for incompressible water) or the stock 'Stokes' (the default for compressible water);
    nu: kinematic viscosity [m^2/s] (incompressible water).  p_controls: the pressure solver's
    dictionary body instead of PCG/DIC to p_tol (e.g. foamcase.water_p_controls())."""
    transpiration = interface_motion == "transpiration"
    compressible = water == "compressible"
    if water not in ("incompressible", "compressible"):
        raise ValueError(water)
    if laminar_model is None:
        laminar_model = "Stokes" if compressible else "tqNewtonian"
    case = Path(case)
    ends = "empty" if two_d else ("patch" if open_ends else "wall")
    fc.write(case, "system/blockMeshDict", _blockmesh(R, L, nq, nr, ny, two_d, ends, grading))
    motion = case / "constant" / "wallMotion.dat"
    wi = write_interval if write_interval is not None else end_time
    fc.write(
        case,
        "system/controlDict",
        f"""
application     {"rhoPimpleFoam" if compressible else "pimpleFoam"};
startFrom       startTime;
startTime       0;
stopAt          endTime;
endTime         {end_time!r};
deltaT          {dt!r};
writeControl    runTime;
writeInterval   {wi!r};
purgeWrite      0;
writeFormat     ascii;
writePrecision  14;
timePrecision   10;
runTimeModifiable false;
libs            ("{fc.LIBRARY}");
functions
{{
    interface
    {{
        type            tqInterface;
        libs            ("{fc.LIBRARY}");
        patch           interface;
        {"rho rho;" if compressible else f"rho rhoInf; rhoInf {RHO};"}
        {f"nu {NU};" if compressible else ""}
        wallPressure    extrapolated;
        interfaceMotion {interface_motion};
        {f"hydrostatic {{ g (0 0 {-hydrostatic[0]!r}); freeSurfaceLevel {hydrostatic[1]!r}; }}" if hydrostatic else ""}
        exchange
        {{
            type            replay;
            file            "{motion}";
            axisPoint       (0 0 0);
            axisDirection   (0 1 0);
            rollbacksPerStep {rollbacks};
            predictorScale  {predictor_scale!r};
            rollbackFromStep {rollback_from};
        }}
    }}
{extra_functions}
}}
""",
    )
    fc.write(
        case,
        "system/fvSchemes",
        f"""
ddtSchemes {{ default {ddt}; }}
gradSchemes {{ default Gauss linear; }}
divSchemes {{ default none; div(phi,U) Gauss linear; div((nuEff*dev2(T(grad(U))))) Gauss linear;
    div(((rho*nuEff)*dev2(T(grad(U))))) Gauss linear; div(phi,e) Gauss linear; div(phi,K) Gauss linear;
    div(phiv,p) Gauss linear; div(phi,h) Gauss linear; }}
laplacianSchemes {{ default Gauss linear corrected; }}
interpolationSchemes {{ default linear; }}
snGradSchemes {{ default corrected; }}
""",
    )
    closed = not open_ends
    fc.write(
        case,
        "system/fvSolution",
        f"""
solvers
{{
    "p(Final)?" {{ {p_controls or f"solver PCG; preconditioner DIC; tolerance {p_tol}; relTol 0;"} }}
    "U(Final)?" {{ solver smoothSolver; smoother symGaussSeidel; tolerance 1e-10; relTol 0; }}
    // energy (compressible water): T stays at T0 (no pressure work), h barely moves
    "(e|h)(Final)?" {{ solver smoothSolver; smoother symGaussSeidel; tolerance 1e-4; relTol 0; maxIter 10; }}
    "rho(Final)?" {{ solver diagonal; }}
    "cellDisplacement(Final)?" {{ solver PCG; preconditioner DIC; tolerance 1e-8; relTol 0; }}
}}
PIMPLE
{{
    nOuterCorrectors 1;
    nCorrectors     2;
    nNonOrthogonalCorrectors 0;
    correctPhi      no;
    {"pRefCell 0; pRefValue 0;" if closed and not compressible else ""}
    {"transonic no;" if compressible else ""}
}}
""",
    )
    fc.write(case, "constant/transportProperties", f"transportModel Newtonian;\nnu {nu!r};\n")
    if compressible:
        fc.write(case, "constant/thermophysicalProperties", thermophysical_properties(bulk_modulus))
    fc.write(case, "constant/turbulenceProperties", turbulence_properties(laminar_model))
    if transpiration:
        msolver = ""
    elif motion_solver == "tqInterpolated":
        msolver = """motionSolver    tqInterpolatedDisplacement;
tqInterpolatedDisplacementCoeffs { patches (interface); decay linear; }"""
    elif motion_solver == "laplacian":
        msolver = """motionSolverLibs ("libfvMotionSolvers.so");
motionSolver    displacementLaplacian;
displacementLaplacianCoeffs { diffusivity uniform; }"""
    elif motion_solver == "laplacianInverseDistance":
        msolver = """motionSolverLibs ("libfvMotionSolvers.so");
motionSolver    displacementLaplacian;
displacementLaplacianCoeffs { diffusivity inverseDistance (interface); }"""
    else:
        raise ValueError(motion_solver)
    fc.write(
        case,
        "constant/dynamicMeshDict",
        f"""
dynamicFvMesh   {"staticFvMesh" if transpiration else "dynamicMotionSolverFvMesh"};
motionSolverLibs ("{fc.LIBRARY}");
{msolver}
""",
    )
    # end points: interpolated by tqInterpolatedDisplacement ('calculated'); the stock
    # Laplacian needs a condition there: slip in the end plane
    end_d = "type slip;" if motion_solver.startswith("laplacian") else "type calculated; value uniform (0 0 0);"
    if two_d:
        end_u = end_p = end_d = "type empty;"
    elif open_ends:
        end_u = "type pressureInletOutletVelocity; value uniform (0 0 0);"
        end_p = "type fixedValue; value uniform 0;"
    else:
        end_u = "type tqInterfaceVelocity; value uniform (0 0 0);"
        end_p = "type fixedFluxExtrapolatedPressure; value uniform 0;"
    fc.write(
        case,
        "0/U",
        f"""
dimensions [0 1 -1 0 0 0 0];
internalField uniform (0 0 0);
boundaryField
{{
    interface {{ type tqInterfaceVelocity; value uniform (0 0 0); }}
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
    interface {{ type fixedFluxExtrapolatedPressure; value uniform 0; }}
    "end_y(min|max)" {{ {end_p} }}
}}
""",
        cls="volScalarField",
    )
    if compressible:
        # p in Pa (hydrodynamic, 0 at rest); T uniform and insulated
        text = (case / "0" / "p").read_text().replace("dimensions [0 2 -2 0 0 0 0];", "dimensions [1 -1 -2 0 0 0 0];")
        (case / "0" / "p").write_text(text)
        fc.write(
            case,
            "0/T",
            f"""
dimensions [0 0 0 1 0 0 0];
internalField uniform {T0};
boundaryField
{{
    interface {{ type zeroGradient; }}
    "end_y(min|max)" {{ {"type empty;" if two_d else "type zeroGradient;"} }}
}}
""",
            cls="volScalarField",
        )
    if transpiration:
        return motion
    write_point_displacement(case, end_d)
    return motion


def turbulence_properties(laminar_model: str = "tqNewtonian") -> str:
    """constant/turbulenceProperties of laminar water: 'tqNewtonian' (libtqFoam.so, incompressible
    with uniform nu: the viscous term is laplacian(nuEff,U) alone, docs/water.md §10) or the stock
    'Stokes' (also the explicit div(nuEff dev2(T(grad U))); the model of compressible water)."""
    if laminar_model not in ("tqNewtonian", "Stokes"):
        raise ValueError(f"laminar_model {laminar_model!r}: use 'tqNewtonian' or 'Stokes'")
    return f"simulationType laminar;\nlaminar {{ laminarModel {laminar_model}; }}\n"


def write_point_displacement(case: Path, end_condition: str) -> None:
    """0/pointDisplacement of a moving-mesh case: the interface moved by tqInterface (held at 0
    here), the axial ends with `end_condition`."""
    fc.write(
        case,
        "0/pointDisplacement",
        f"""
dimensions [0 1 0 0 0 0 0];
internalField uniform (0 0 0);
boundaryField
{{
    interface {{ type fixedValue; value uniform (0 0 0); }}
    "end_y(min|max)" {{ {end_condition} }}
}}
""",
        cls="pointVectorField",
    )


def thermophysical_properties(bulk_modulus: float = K_WATER) -> str:
    """Weakly compressible water for rhoPimpleFoam: rho = rho0 + p/(R T) (perfectFluid), with
    R T0 = K/rho0, so that dp/drho = K/rho0 (c = 1483 m/s for K = 2.2 GPa) at the hydrodynamic
    p = 0 of the water at rest; mu 1.308e-3 Pa s; no pressure work in the energy equation
    (dpdt no: T stays T0 to 1e-4 K, so psi = 1/(R T) is constant)."""
    r_gas = bulk_modulus / (RHO * T0)
    return f"""
thermoType
{{
    type            heRhoThermo;
    mixture         pureMixture;
    transport       const;
    thermo          hConst;
    equationOfState perfectFluid;
    specie          specie;
    energy          sensibleEnthalpy;
}}
mixture
{{
    specie          {{ molWeight 18.015; }}
    equationOfState {{ R {r_gas!r}; rho0 {RHO}; }}
    thermodynamics  {{ Cp 4181; Hf 0; }}
    transport       {{ mu {RHO * NU!r}; Pr 7; }}
}}
dpdt no;
"""


def harmonic_lateral(t: np.ndarray, a0: float, omega: float):
    """Rigid lateral (x) motion starting at rest: a = a0 cos(wt), v = a0/w sin(wt),
    u = a0/w^2 (1 - cos(wt))."""
    z = np.zeros_like(t)
    u = np.column_stack([a0 / omega**2 * (1 - np.cos(omega * t)), z, z])
    v = np.column_stack([a0 / omega * np.sin(omega * t), z, z])
    return u, v
