"""The dictionaries of the water's OpenFOAM case (OpenFOAM v1912 + libtqFoam.so), written from
one description, `WaterCase` (docs/water.md):

    files = dictionaries(WaterCase(...))   # {"system/controlDict": text, "0/p": text, ...}
    write(WaterCase(...), folder)

`fluid_case.water_case` makes the description of condition dynamic_water from the case file and
the coupling settings; the water tests and benchmarks write their own, on the product's meshes or
on `pipe_block_mesh` (a blockMesh O-grid pipe), and state what they set otherwise as `overrides`
of these dictionaries (`dictionaries(w, overrides)`: a stock set-up, a tight reference solve), so
that every water case has one writer. The mesh (constant/polyMesh) is converted by
`fluid_case.write_water_case`, which sets its patch types from `patch_types`.

Patches: `interface` (the lining's inner face, a wall moved by the coupling) and the axial ends
`end_ymin`, `end_ymax`, each of one kind:

    empty      a slice one cell thick: no axial flow, the section closed
    wall       closed ends at rest (compressible water)
    open       p = 0 (hydrodynamic), inflow and outflow (pressureInletOutletVelocity)
    symmetry   a symmetry plane (slip wall)

The domain is closed unless an end is open. A closed domain solves p to an absolute 1e-6
(tolerance 1e-6; relTol 0): there the error of an unconverged pressure cannot leave through an
end and accumulates; an open one to 5 % of the incoming residual each step (`pressure_solver`).

Water models:

    incompressible   pimpleFoam, p kinematic (Pa / rho), laminar model tqNewtonian (libtqFoam.so:
                     laplacian(nuEff,U) alone, docs/water.md §10)
    compressible     rhoPimpleFoam, perfectFluid rho = rho0 + p/(R T) with R T0 = K/rho0, p in Pa,
                     laminar model tqNewtonian (its dropped term (mu/3) grad(div U) is about 1e-11
                     of grad p)

Interface: transpiration (static mesh, the wall velocity imposed on the fixed faces; docs/water.md
§6.2), the product's; or meshMotion (incompressible water only: the mesh follows the wall,
tqInterpolatedDisplacement), which the water tests verify. The numerics are those of the Benchmark in docs/water.md ("ours"): one PISO corrector, no
momentum predictor, p by tqProjected (PCG inside for compressible water, GAMG for incompressible),
Euler in time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from .foam_dict import Dimensions, Quoted, Uniform, foam_file

#: K: the water's temperature (rhoPimpleFoam's T stays there: no pressure work, dpdt no)
T0 = 293.15
#: m/s^2: the gravity of tqInterface's hydrostatic report
GRAVITY = 9.81
END_PATCHES = ("end_ymin", "end_ymax")
END_KINDS = ("empty", "wall", "open", "symmetry")
MODELS = ("incompressible", "compressible")
INTERFACE_MOTIONS = ("transpiration", "meshMotion")
LIBRARY = "libtqFoam.so"
#: the note under each file's header
NOTE = "written by tunnelquake.water_case"


class WaterCaseError(ValueError):
    """The description cannot be written as a water case; the message says which entry and why."""


@dataclass(frozen=True)
class WaterCase:
    """One water case. SI units; `exchange`: tqInterface's `exchange` dictionary (none: the water
    alone; replay: a fake solid from a motion table; coupler: fluid_case.exchange_dict)."""

    model: str  # incompressible | compressible
    ends: tuple[str, str]  # the kinds of end_ymin, end_ymax
    density: float  # kg/m^3
    viscosity: float  # Pa s (dynamic)
    bulk_modulus: float  # Pa: the compressible water's K (R = K / (rho0 T0)); unused by pimpleFoam
    delta_t: float  # s: the water's step
    end_time: float  # s
    write_interval: float  # s between written fields
    free_surface_level: float  # m: z of the free surface (tqInterface's hydrostatic report)
    exchange: dict = field(default_factory=lambda: {"type": "none"})
    # tqInterface sends its wall pressure less its area mean (the solid carries the uniform part)
    subtract_mean_pressure: bool = False
    # printed passes: None prints every pass, rolled-back ones too, with the linear solvers'
    # residual lines (water.log: verbose); a number prints the passes that reach a multiple of
    # it, the solver's own lines only there (water.log: brief; docs/water.md §2 "Log")
    log_interval: float | None = None
    # 0 for the structured all-hex meshes of tunnelquake.meshing (accurate with 0: force within
    # 2.5e-4 of the reference, 28 % cheaper a step); 1 for an unstructured gmsh mesh (a slice
    # needs it: spurious cross force 0.7 % with 0); docs/water.md, Benchmark
    non_orthogonal_correctors: int = 0
    # tqInterface's closed-domain check on the volume balance of the wall motion (its default 1e-3
    # when None; docs/water.md §7)
    volume_change_tolerance: float | None = None
    # restart checkpoints (docs/formats.md "Restart checkpoints"): tqInterface writes one every
    # `restart_windows` completed coupling windows into `restart_dir` (0: none), and starts from
    # `restart_from` when given
    restart_dir: str | None = None
    restart_windows: int = 0
    restart_from: str | None = None
    # the digest of the condition's input fingerprint (tunnelquake.fingerprint): tqInterface writes it
    # into each restart checkpoint and refuses to resume from one that carries another
    input_fingerprint: str | None = None
    # transpiration (the product's) or meshMotion (the mesh follows the wall; incompressible water
    # only: tqInterface refuses a density field on a moving mesh at start-up, docs/water.md)
    interface_motion: str = "transpiration"

    def __post_init__(self):
        if self.model not in MODELS:
            raise WaterCaseError(f"water model {self.model!r} is not one of {', '.join(MODELS)}")
        if len(self.ends) != 2 or any(e not in END_KINDS for e in self.ends):
            raise WaterCaseError(f"ends {self.ends!r}: two of {', '.join(END_KINDS)} (end_ymin, end_ymax)")
        if ("empty" in self.ends) and self.ends != ("empty", "empty"):
            raise WaterCaseError(f"ends {self.ends!r}: a slice has both ends empty")
        if (self.restart_windows > 0) != (self.restart_dir is not None):
            raise WaterCaseError(f"restart_windows {self.restart_windows} and restart_dir {self.restart_dir!r}: "
                                 "give both (a checkpoint every N > 0 windows into a folder) or neither")
        if self.restart_from is not None and self.restart_dir is None:
            raise WaterCaseError(f"restart_from {self.restart_from!r} needs restart_dir and restart_windows")
        if self.interface_motion not in INTERFACE_MOTIONS:
            raise WaterCaseError(f"interface_motion {self.interface_motion!r} is not one of "
                                 f"{', '.join(INTERFACE_MOTIONS)}")

    @property
    def compressible(self) -> bool:
        return self.model == "compressible"

    @property
    def mode(self) -> str:
        """slice (one cell thick, empty ends) or 3d."""
        return "slice" if self.ends[0] == "empty" else "3d"

    @property
    def closed(self) -> bool:
        """No open end: the domain's pressure level is not fixed by a boundary."""
        return "open" not in self.ends

    @property
    def solver(self) -> str:
        return "rhoPimpleFoam" if self.compressible else "pimpleFoam"

    @property
    def kinematic_viscosity(self) -> float:
        return self.viscosity / self.density


# ------------------------------------------------------------------------------------------------
# system/
# ------------------------------------------------------------------------------------------------
def control_dict(w: WaterCase) -> dict:
    interface = {
        "type": "tqInterface",
        "libs": [Quoted(LIBRARY)],
        "patch": "interface",
    }
    if w.volume_change_tolerance is not None:
        interface["volumeChangeTolerance"] = w.volume_change_tolerance
    # the density of the loads: rhoPimpleFoam's field rho, pimpleFoam's rhoInf (p kinematic)
    interface["rho"] = "rho" if w.compressible else "rhoInf"
    interface["rhoInf"] = w.density
    if w.compressible:  # the kinematic viscosity of the wall shear (mu / rho)
        interface["nu"] = w.kinematic_viscosity
    interface["wallPressure"] = "extrapolated"
    interface["logInterval"] = 0 if w.log_interval is None else w.log_interval
    interface["quietSolver"] = w.log_interval is not None
    # transpiration: static mesh (constant/dynamicMeshDict staticFvMesh), wall velocity on the
    # fixed faces, loads and wall flux on the displaced wall (docs/water.md)
    interface["interfaceMotion"] = w.interface_motion
    if w.restart_dir is not None:
        interface["restartDir"] = Quoted(w.restart_dir)
        interface["restartWindows"] = int(w.restart_windows)
        if w.restart_from is not None:
            interface["restartFrom"] = Quoted(w.restart_from)
        if w.input_fingerprint:
            interface["inputFingerprint"] = Quoted(w.input_fingerprint)  # a hex digest may start with a digit
    if w.subtract_mean_pressure:
        interface["subtractMeanPressure"] = True
    interface["geometricCorrection"] = True
    # reported only: the hydrostatic part is the solid's static load
    interface["hydrostatic"] = {"g": [0, 0, -GRAVITY], "freeSurfaceLevel": w.free_surface_level}
    interface["exchange"] = w.exchange
    return {
        "application": w.solver,
        "startFrom": "startTime",
        "startTime": 0,
        "stopAt": "endTime",
        "endTime": w.end_time,
        "deltaT": w.delta_t,
        # runTime control: with rollbacks the step index runs ahead of time (docs/water.md)
        "writeControl": "runTime",
        "writeInterval": w.write_interval,
        "purgeWrite": 0,
        "writeFormat": "binary",
        "writePrecision": 12,
        "timePrecision": 12,
        "runTimeModifiable": False,
        "libs": [Quoted(LIBRARY)],
        # the linear solvers' residual lines ("Solving for p, ..."), one per solve
        "DebugSwitches": {"SolverPerformance": 1 if w.log_interval is None else 0},
        "functions": {"interface": interface},
    }


def pressure_solver(closed: bool, compressible: bool) -> dict:
    """The p (and pFinal) controls. tqProjected (libtqFoam, docs/water.md §10): each step starts
    from the incoming p corrected by the best combination (A-norm) of the last 32 steps'
    increments, and an inner solver finishes when that is not enough: 1.23-1.25x cheaper a 3D step
    than GAMG alone after the first 100 steps, 1.5x a slice step, forces and wall pressures as close
    to the reference. Closed domain: an absolute 1e-6; open: 5 % of the incoming residual.
    Inner solver: compressible water's p equation carries psi/dt^2, a diagonal that keeps it well
    conditioned (a pressure wave crosses only a few cells a step), so PCG with DIC needs no
    coarse levels: on the 3D example's first second 0.84-0.92x GAMG's time a pass, every monitored
    peak equal to 6 digits (docs/benchmarks.md "The compressible water's pressure by PCG");
    symmetric Gauss-Seidel alone took 1.7x. Incompressible water's Poisson equation has no such
    diagonal: GAMG, mergeLevels 2 (two agglomeration levels merged into one, 5 % cheaper a step
    in 3D)."""
    inner = ({"solver": "PCG", "preconditioner": "DIC"} if compressible
             else {"solver": "GAMG", "smoother": "GaussSeidel", "mergeLevels": 2})
    return {"solver": "tqProjected", "vectors": 32,
            "tolerance": 1e-6 if closed else 0, "relTol": 0 if closed else 0.05,
            "inner": inner}


def fv_solution(w: WaterCase) -> dict:
    p = pressure_solver(w.closed, w.compressible)
    return {
        "solvers": {
            "p": p,
            "pFinal": dict(p),
            Quoted("U(Final)?"): {"solver": "smoothSolver", "smoother": "symGaussSeidel", "tolerance": 1e-9,
                                  "relTol": 0},
            # compressible water: T stays at T0 (the water is barotropic). h's residual is round-off
            # (0.005 before, 0.01 after 10 sweeps on the paper slice), under tolerance 1: h is not
            # swept and keeps T0. One sweep or ten gave the slice the same bits; no sweep moves the
            # results by less than 1e-7 of their peaks (docs/benchmarks.md "The water's energy equation")
            Quoted("(e|h)(Final)?"): {"solver": "smoothSolver", "smoother": "symGaussSeidel", "tolerance": 1,
                                      "relTol": 0, "maxIter": 1},
            Quoted("rho(Final)?"): {"solver": "diagonal"},
        },
        "PIMPLE": {
            "nOuterCorrectors": 1,
            "nCorrectors": 1,
            "momentumPredictor": False,
            "nNonOrthogonalCorrectors": w.non_orthogonal_correctors,
            # tqInterfaceVelocity needs it off (a moving mesh keeps the geometric conservation
            # through the swept-volume fluxes anyway)
            "correctPhi": False,
            "transonic": False,  # rhoPimpleFoam
            # a closed domain's pressure level (ignored when an end fixes p)
            "pRefCell": 0,
            "pRefValue": 0,
        },
    }


def fv_schemes() -> dict:
    return {
        # Euler: with the solid's central difference the wall velocity is the mid-step one, and
        # Euler reproduces a rigidly accelerating container exactly (docs/water.md)
        "ddtSchemes": {"default": "Euler"},
        "gradSchemes": {"default": "Gauss linear"},
        "divSchemes": {
            "default": "none",
            "div(phi,U)": "Gauss linear",
            # the explicit term of the stock Stokes model (unused by tqNewtonian; the benchmarks'
            # stock set-ups select Stokes), incompressible and compressible water
            "div((nuEff*dev2(T(grad(U)))))": "Gauss linear",
            "div(((rho*nuEff)*dev2(T(grad(U)))))": "Gauss linear",
            "div(phi,h)": "Gauss linear",
            "div(phi,K)": "Gauss linear",
        },
        "laplacianSchemes": {
            "default": "Gauss linear corrected",
            # the water's viscous term is tiny: its non-orthogonal correction (a second full
            # grad(U) every step) is not worth its cost (docs/water.md, Benchmark)
            "laplacian(nuEff,U)": "Gauss linear uncorrected",
            "laplacian((rho*nuEff),U)": "Gauss linear uncorrected",
            # the compressible water's enthalpy stays uniform (T at T0: fvSolution does not sweep
            # h): the non-orthogonal correction of its diffusion (a full grad(h) every pass)
            # corrects nothing
            "laplacian(alphahe,h)": "Gauss linear uncorrected",
        },
        "interpolationSchemes": {"default": "linear"},
        "snGradSchemes": {"default": "corrected"},
    }


# ------------------------------------------------------------------------------------------------
# constant/
# ------------------------------------------------------------------------------------------------
def thermophysical_properties(w: WaterCase) -> dict:
    """rho = rho0 + p/(R T) with R T0 = K/rho0, so that dp/drho = K/rho0 at the hydrodynamic p = 0
    of water at rest; no pressure work (dpdt no): T stays T0, psi = 1/(R T) constant. Written for
    either model (pimpleFoam does not read it)."""
    return {
        "thermoType": {"type": "heRhoThermo", "mixture": "pureMixture", "transport": "const", "thermo": "hConst",
                       "equationOfState": "perfectFluid", "specie": "specie", "energy": "sensibleEnthalpy"},
        "mixture": {
            "specie": {"molWeight": 18.015},
            "equationOfState": {"R": w.bulk_modulus / (w.density * T0), "rho0": w.density},
            "thermodynamics": {"Cp": 4181, "Hf": 0},
            "transport": {"mu": w.viscosity, "Pr": 7},
        },
        "dpdt": False,
    }


def transport_properties(w: WaterCase) -> dict:
    return {"transportModel": "Newtonian", "nu": w.kinematic_viscosity}


def turbulence_properties(w: WaterCase) -> dict:
    # tqNewtonian (libtqFoam.so, docs/water.md §10): the stock Stokes stress without its explicit
    # div(nuEff dev2(T(grad U))), zero for incompressible water (uniform nu, div U = 0): the viscous
    # term is laplacian(nuEff,U) alone. For the compressible water the dropped term is
    # (mu/3) grad(div U), div U = -(1/K) Dp/Dt: about 1e-11 of grad p at 5 Hz.
    return {"simulationType": "laminar", "laminar": {"laminarModel": "tqNewtonian"}}


def dynamic_mesh_dict(w: WaterCase) -> dict:
    # Transpiration: the mesh stays. meshMotion: the interface's points take the received
    # displacement and tqInterpolatedDisplacement moves the others, decaying linearly away from it
    if w.interface_motion == "transpiration":
        return {"dynamicFvMesh": "staticFvMesh"}
    return {"dynamicFvMesh": "dynamicMotionSolverFvMesh", "motionSolverLibs": [Quoted(LIBRARY)],
            "motionSolver": "tqInterpolatedDisplacement",
            "tqInterpolatedDisplacementCoeffs": {"patches": ["interface"], "decay": "linear"}}


# ------------------------------------------------------------------------------------------------
# 0/: the initial fields (the water at rest) and their boundary conditions
# ------------------------------------------------------------------------------------------------
ZERO = Uniform(0)
ZERO_VECTOR = Uniform([0, 0, 0])
#: each field: its class, dimensions, internal value, the interface's condition and the ends' by kind
FIELDS = {
    # velocity: the interface moves with the lining (no slip); closed ends are walls at rest
    "U": ("volVectorField", Dimensions([0, 1, -1, 0, 0, 0, 0]), ZERO_VECTOR,
          {"type": "tqInterfaceVelocity", "value": ZERO_VECTOR},
          {"wall": {"type": "tqInterfaceVelocity", "value": ZERO_VECTOR},
           "open": {"type": "pressureInletOutletVelocity", "value": ZERO_VECTOR}}),
    # hydrodynamic pressure (the hydrostatic part is the solid's static load): kinematic for
    # incompressible water (dimensions replaced below), Pa for compressible; open ends p = 0
    "p": ("volScalarField", Dimensions([1, -1, -2, 0, 0, 0, 0]), ZERO,
          {"type": "fixedFluxExtrapolatedPressure", "value": ZERO},
          {"wall": {"type": "fixedFluxExtrapolatedPressure", "value": ZERO},
           "open": {"type": "fixedValue", "value": ZERO}}),
    # temperature (compressible water): T0, insulated walls
    "T": ("volScalarField", Dimensions([0, 0, 0, 1, 0, 0, 0]), Uniform(T0),
          {"type": "zeroGradient"},
          {"wall": {"type": "zeroGradient"}, "open": {"type": "zeroGradient"}}),
    # mesh displacement: on the interface the received lining displacement (meshMotion)
    "pointDisplacement": ("pointVectorField", Dimensions([0, 1, 0, 0, 0, 0, 0]), ZERO_VECTOR,
                          {"type": "fixedValue", "value": ZERO_VECTOR},
                          {"wall": {"type": "calculated", "value": ZERO_VECTOR},
                           "open": {"type": "calculated", "value": ZERO_VECTOR},
                           "symmetry": {"type": "calculated", "value": ZERO_VECTOR}}),
}
_KINEMATIC_PRESSURE = Dimensions([0, 2, -2, 0, 0, 0, 0])
#: the condition of every field on an end of this kind unless the field says otherwise
_END_DEFAULT = {"empty": {"type": "empty"}, "symmetry": {"type": "symmetryPlane"}}


def field_dict(w: WaterCase, name: str) -> dict:
    cls, dims, internal, interface, by_kind = FIELDS[name]
    if name == "p" and not w.compressible:
        dims = _KINEMATIC_PRESSURE
    ends = [by_kind.get(kind, _END_DEFAULT.get(kind)) for kind in w.ends]
    boundary = {"interface": interface}
    if ends[0] == ends[1]:
        boundary[Quoted("end_y(min|max)")] = ends[0]
    else:
        boundary.update(zip(END_PATCHES, ends, strict=True))
    return {"dimensions": dims, "internalField": internal, "boundaryField": boundary}


def patch_types(w: WaterCase) -> dict[str, str]:
    """The types of the mesh's patches (constant/polyMesh/boundary)."""
    kinds = {"empty": "empty", "wall": "wall", "open": "patch", "symmetry": "symmetryPlane"}
    return {"interface": "wall", **{p: kinds[k] for p, k in zip(END_PATCHES, w.ends, strict=True)}}


# ------------------------------------------------------------------------------------------------
# the files
# ------------------------------------------------------------------------------------------------
class Whole(dict):
    """An override's sub-dictionary that replaces the entry as a whole (a linear solver's
    controls, a boundary condition) instead of being merged into it."""


def merged(base: dict, over: dict) -> dict:
    """`base` with `over` laid on it: a sub-dictionary in both merged entry by entry (unless it is
    a `Whole`), any other value replaced, an entry None removed. Neither argument is changed."""
    out = dict(base)
    for key, value in over.items():
        if value is None:
            out.pop(key, None)
        elif isinstance(value, dict) and not isinstance(value, Whole) and isinstance(out.get(key), dict):
            out[key] = merged(out[key], value)
        else:
            out[key] = value
    return out


def combined(first: dict, then: dict) -> dict:
    """Two overrides as one: `then` laid on `first` as `merged` does, but its None entries kept
    (each removes an entry of the writer's dictionaries)."""
    out = dict(first)
    for key, value in then.items():
        if isinstance(value, dict) and not isinstance(value, Whole) and isinstance(out.get(key), dict):
            inner = combined(out[key], value)
            out[key] = Whole(inner) if isinstance(out[key], Whole) else inner
        else:
            out[key] = value
    return out


def data(w: WaterCase, overrides: dict | None = None) -> dict[str, tuple[str, dict]]:
    """Every file of the case but the mesh as data: {path: (class, dictionary)}. `overrides`
    ({path: entries}, laid on with `merged`; a path of its own adds a dictionary, None removes a
    file): what a test or a benchmark sets otherwise than the product."""
    files = {
        "system/controlDict": control_dict(w),
        "system/fvSolution": fv_solution(w),
        "system/fvSchemes": fv_schemes(),
        "constant/thermophysicalProperties": thermophysical_properties(w),
        "constant/transportProperties": transport_properties(w),
        "constant/turbulenceProperties": turbulence_properties(w),
        "constant/dynamicMeshDict": dynamic_mesh_dict(w),
    }
    out = {path: ("dictionary", d) for path, d in files.items()}
    for name in ("U", "p", "pointDisplacement") + (("T",) if w.compressible else ()):
        out[f"0/{name}"] = (FIELDS[name][0], field_dict(w, name))
    for path, entries in (overrides or {}).items():
        if entries is None:
            out.pop(path, None)
        else:
            cls, d = out.get(path, ("dictionary", {}))
            out[path] = (cls, merged(d, entries))
    return out


def dictionaries(w: WaterCase, overrides: dict | None = None) -> dict[str, str]:
    """Every file of the case but the mesh: {path relative to the case: text} (`overrides`: see
    `data`)."""
    return {path: foam_file(d, path.split("/")[-1], cls=cls, note=NOTE)
            for path, (cls, d) in data(w, overrides).items()}


def write(w: WaterCase, folder: Path, overrides: dict | None = None) -> list[Path]:
    """Write every file of `dictionaries(w, overrides)` into `folder`; returns their paths."""
    out = []
    for rel, text in dictionaries(w, overrides).items():
        path = Path(folder) / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        out.append(path)
    return out


# ------------------------------------------------------------------------------------------------
# a test geometry: the pipe
# ------------------------------------------------------------------------------------------------
def pipe_block_mesh(w: WaterCase, radius: float, length: float, around: int, layers: int, axial: int = 1,
                    grading: float = 1.0) -> dict:
    """system/blockMeshDict of a water-filled pipe along y (cross-section x-z, centre on the y axis,
    from y = 0 to `length`): an O-grid of a centre square (half-side 0.35 R, `around` x `around`
    cells) and four outer blocks (`layers` cells out to the wall, the last `grading` times the
    first), `axial` cells along (a slice: 1, ends empty). Patches: interface (the wall), end_ymin,
    end_ymax of the types of `patch_types(w)`."""
    a = 0.35 * radius
    s = radius / math.sqrt(2)
    plane = [(-a, -a), (a, -a), (a, a), (-a, a), (-s, -s), (s, -s), (s, s), (-s, s)]
    vertices = [[x, 0.0, z] for x, z in plane] + [[x, float(length), z] for x, z in plane]

    def hexa(q):  # q: 4 vertex ids in the first plane, ordered so that the block extrudes along +y
        v0, v1, v3 = (vertices[i] for i in (q[0], q[1], q[3]))
        e1 = [v1[k] - v0[k] for k in range(3)]
        e3 = [v3[k] - v0[k] for k in range(3)]
        if e1[2] * e3[0] - e1[0] * e3[2] < 0:  # the y component of e1 x e3
            q = [q[0], q[3], q[2], q[1]]
        return list(q) + [i + 8 for i in q]

    cells = [1 if w.mode == "slice" else axial]
    blocks = ["hex", hexa([0, 1, 2, 3]), [around, around] + cells, "simpleGrading", [1, 1, 1]]
    for q in ([0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]):
        h = hexa(q)
        radial_first = (h[0] < 4) != (h[1] < 4)  # which local axis runs out to the wall
        n, g = ([layers, around], [grading, 1, 1]) if radial_first else ([around, layers], [1, grading, 1])
        blocks += ["hex", h, n + cells, "simpleGrading", g]
    edges = []
    for (i, j), (x, z) in {(4, 5): (0, -radius), (5, 6): (radius, 0), (6, 7): (0, radius),
                           (7, 4): (-radius, 0)}.items():
        edges += ["arc", i, j, [x, 0.0, z], "arc", i + 8, j + 8, [x, float(length), z]]
    quads = [[0, 1, 2, 3], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
    types = patch_types(w)
    return {
        "convertToMeters": 1,
        "vertices": vertices,
        "blocks": blocks,
        "edges": edges,
        "boundary": [
            "interface", {"type": types["interface"],
                          "faces": [[i, j, j + 8, i + 8] for i, j in ((4, 5), (5, 6), (6, 7), (7, 4))]},
            "end_ymin", {"type": types["end_ymin"], "faces": quads},
            "end_ymax", {"type": types["end_ymax"], "faces": [[i + 8 for i in q] for q in quads]},
        ],
        "mergePatchPairs": [],
    }
