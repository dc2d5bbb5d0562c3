"""The OpenFOAM case of condition dynamic_water, written from the case (tunnelquake.water_case: every
dictionary generated from one description) on the case's water mesh (results/mesh/water.msh),
coupled to tq-solid through the coupler (docs/water.md §8, docs/coupler.md "Running condition 3").

    window_size = coupling_window_size(k, solid_step)                       # k solid steps, pinned
    settings = coupling_settings(case, window_size, address_file, token)   # one source of truth
    solid_coupling_attrs(settings)   -> the /coupling attributes of solid_input.h5
    exchange_dict(settings)          -> the fluid's `exchange { type coupler; ... }` dictionary (data)
    water_case(case, settings, slice_mode) -> water_case.WaterCase, the description of the case
    write_water_case(water, water_msh, folder) -> FluidCase: dictionaries, mesh converted and checked
    build_fluid_case(case, water_msh, folder, settings, slice_mode) -> FluidCase (the two above)

The two sides' coupling configurations are compared item by item in the coupler's handshake, so
both are written from the same `settings`: mesh name, participants, scheme, tolerance,
iterations, acceleration, relaxation, the fields the solid writes (in order), the map, the window
size and the number of windows are pinned on both sides (none is left to a side's default).

Water models (case `water` section):

    compressible     rhoPimpleFoam, perfectFluid with R T0 = K / rho0 (K = water.bulk_modulus), p in Pa,
                     the laminar model tqNewtonian (its dropped (mu/3) grad(div U) about 6e-12 of grad p)
    incompressible   pimpleFoam, nu = viscosity / density, p kinematic, the laminar model
                     tqNewtonian (libtqFoam.so: laplacian(nuEff,U) alone, docs/water.md §10)

Slice mode (mesh attribute `slice` = 1): the ends are `empty`, the section closed. 3D: `ends:
closed` (walls, compressible water in OpenFOAM) or `ends: open`, each end (`end_ymin`, `end_ymax`) a
reservoir (p = 0), a valve (a wall) or a surge tank (p = 0 for the water solver; the tank's level is
tq-solid's).

What each water model means for the two sides is decided in one place, `water_split()` (its
WaterSplit: tq-solid's part into /coupling, OpenFOAM's into the water case). With the volume law in
the solid (the default; docs/coupler.md "Volume law in the solid") tq-solid sets the water's
volumetric pressure implicitly each step: one uniform pressure in a closed section (a slice, or 3D with closed ends), one per plane of wet nodes joined by the axial plug
flow with open ends (p = -K dV/V, or the volume held for incompressible water), and by default the
water's rigid translation too (`water_density` in the settings). OpenFOAM gets the wall motion less
those modes, and in a closed section sends its wall pressure less its area mean (tqInterface
`subtractMeanPressure`): its answer to the lining's deformation. Incompressible water is then solved
by rhoPimpleFoam with REMAINDER_BULK_MODULUS, closed or open: the volume change is the solid's
constraint, and OpenFOAM's stiffness only makes a closed domain's pressure well posed (pimpleFoam as
the remainder with open ends did not run the record through: docs/stability.md "Open ends in 3D").
pimpleFoam solves incompressible water when the whole pressure is exchanged (`volume_law: water`).
Interface: transpiration. nNonOrthogonalCorrectors 0: the meshes of
tunnelquake.meshing are structured all-hex (docs/water.md §10).

The token is not written into the case: the fluid reads it from the environment variable
TQ_COUPLING_TOKEN (`tokenEnv`), see fluid_env().
"""
from __future__ import annotations

import functools
import math
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from . import paths
from .case import (
    WATER_BULK_MODULUS,
    WATER_LOG_INTERVAL,
    closed_section,
    coupling_defect_correction,
    coupling_predictor,
    coupling_window_force_weight,
    coupling_window_problem,
    fluid_ranks_problem,
    half_block,
    water_end_kinds,
)
from .coupling_scales import absolute_tolerances
from .foam_dict import Quoted, foam_file
from .solver_input_schema import group_attrs
from .water_case import WaterCase, patch_types
from .water_case import write as write_dictionaries

TOKEN_ENV = "TQ_COUPLING_TOKEN"
#: what the solid writes by default (tq-solid's CouplingInput::writeFields), in order
SOLID_WRITE_FIELDS = ("velocity", "displacement")


#: Pa: the bulk modulus of the water OpenFOAM solves for the inertial remainder of incompressible water
#: (the volume change is the solid's constraint; in 3D the remainder's
#: redistribution of volume along the axis meets this stiffness, not an infinite one)
REMAINDER_BULK_MODULUS = WATER_BULK_MODULUS


@dataclass(frozen=True)
class WaterSplit:
    """Which part of the water's pressure each side carries: decided for a case by `water_split`, the
    one place (docs/coupler.md "Volume law in the solid"). tq-solid's part is written to solid_input.h5's
    /coupling (coupling_settings); OpenFOAM's is written into the water case (water_case: its water
    model and K). Whether the water sends its wall pressure less its mean concerns both sides: it
    travels in the settings, to /coupling subtract_mean_pressure and to tqInterface's
    `subtractMeanPressure` (which tqInterface reads and never decides)."""

    volume_law: str  # carried by tq-solid: compressible | incompressible | none (the water sends it all)
    bulk_modulus: float  # Pa: tq-solid's K for a compressible volume law, else 0
    water_density: float  # kg/m³: tq-solid carries the water's rigid translation (0: the water does)
    water_ends: str  # closed (one station) | open (one per plane of wet nodes, joined by the axial flow)
    axial_density: float  # kg/m³: the density of that axial flow
    foam_model: str  # the water OpenFOAM solves: compressible | incompressible
    foam_bulk_modulus: float  # Pa: OpenFOAM's K (its perfectFluid; unused by pimpleFoam)
    subtract_mean_pressure: bool  # tqInterface sends its wall pressure less its area mean
    #: open ends: what closes each end (y_min, y_max): reservoir | valve | surge_tank, and a tank's area (m²)
    end_kinds: tuple[str, str] = ("reservoir", "reservoir")
    surge_tank_areas: tuple[float, float] = (0.0, 0.0)


def water_split(case) -> WaterSplit:
    """What each water model means for the two sides (the case's `water` and `coupling.volume_law`,
    `coupling.water_translation`):

    - coupling.volume_law `solid` (the default): tq-solid carries the volumetric part, K =
      water.bulk_modulus for compressible water, the volume held for incompressible water; in a closed
      section (a slice, or 3D with closed ends) one uniform pressure, with open ends one pressure per
      plane of wet nodes joined by the axial plug flow. OpenFOAM solves the inertial remainder with
      compressible water of K at most REMAINDER_BULK_MODULUS (exactly it for incompressible water), and
      in a closed section sends its wall pressure less its area mean (the uniform part is the solid's).
    - coupling.volume_law `water`: OpenFOAM solves the case's water (its model and K) and sends its whole
      pressure; tq-solid carries nothing."""
    d = case.data
    water, cs = d["water"], d["coupling"]
    rho, k_case = float(water["density"]), float(water["bulk_modulus"])
    ends = "closed" if closed_section(d) else "open"
    kinds = water_end_kinds(d) if ends == "open" else ("reservoir", "reservoir")
    areas = tuple(float((water.get(e) or {}).get("area") or 0.0) if k == "surge_tank" else 0.0
                  for e, k in zip(("end_ymin", "end_ymax"), kinds, strict=True))
    if ends == "open" and half_block(d):
        # the half's ymax end is the plane of symmetry: by symmetry no water flows through it
        kinds, areas = (kinds[0], "valve"), (areas[0], 0.0)
    if cs.get("volume_law", "solid") == "water":
        return WaterSplit("none", 0.0, 0.0, ends, rho, water["model"], k_case, False, kinds, areas)
    translation = rho if cs.get("water_translation", "solid") == "solid" else 0.0
    if water["model"] == "incompressible":
        # the volume change is the solid's constraint; OpenFOAM's stiffness only makes a closed domain's
        # pressure well posed
        law, k_solid, k_foam = "incompressible", 0.0, REMAINDER_BULK_MODULUS
    else:
        # The remainder hardly depends on K (it is the water's inertia), but OpenFOAM's own uniform
        # pressure, subtracted from it, grows with K and brings its solver noise along
        # (docs/coupler.md "Volume law in the solid": K = 2200 GPa in OpenFOAM stopped at 1.2 s).
        law, k_solid, k_foam = "compressible", k_case, min(k_case, REMAINDER_BULK_MODULUS)
    return WaterSplit(law, k_solid, translation, ends, rho, "compressible", k_foam, ends == "closed", kinds, areas)


def volume_law(case) -> tuple[str, float]:
    """Who carries the volumetric part of the water pressure (water_split): ("compressible", K) or
    ("incompressible", 0) when the solid does, ("none", 0) when the water solver sends its whole pressure."""
    w = water_split(case)
    return w.volume_law, w.bulk_modulus


class FluidCaseError(RuntimeError):
    """The water case cannot be built; the message says why and what to do."""


@dataclass
class FluidCase:
    path: Path
    solver: str  # pimpleFoam | rhoPimpleFoam
    mode: str  # slice | 3d
    model: str  # incompressible | compressible
    end_time: float
    delta_t: float


def coupling_window_size(window: int, solid_dt: float) -> float:
    """The coupling window both sides are given, s: `window` solid steps of tq-solid's step `solid_dt`
    (solid_input.solid_step) rounded down to 5 significant digits, a short number in the water's
    controlDict, its time names and the run's summary, and never above the solid's stable step."""
    if not (solid_dt > 0 and math.isfinite(solid_dt)):
        raise FluidCaseError(f"solid step {solid_dt!r} s is not positive")
    q = 10.0 ** (math.floor(math.log10(solid_dt)) - 4)
    return int(window) * (math.floor(solid_dt / q) * q)


def coupling_windows(t_end: float, window_size: float) -> int:
    """The number of coupling windows: ceil(t_end / window_size), at least 1 (the run ends on whole
    windows). Both sides are given it (/coupling windows, the water's `windows`)."""
    return max(1, math.ceil(t_end / window_size - 1e-9))


def checkpoint_windows(interval: float, window_size: float) -> int:
    """Coupled with the water: the windows between two restart checkpoints for a checkpoint every
    `interval` s (output.checkpoint_interval), max(1, round(interval / window_size)); 0 for none.
    Both sides are given the answer (/coupling checkpoint_windows, the water's restart_windows)."""
    if interval <= 0:
        return 0
    return max(1, int(math.floor(interval / window_size + 0.5)))


def coupling_settings(case, window_size: float, address_file: Path, token: str,
                      t_end: float | None = None) -> dict:
    """Everything both sides must agree on, from the case's coupling section and the window: one
    object, written once as solid_input.h5's /coupling (solid_coupling_attrs) and given to the water
    (exchange_dict, water_case).

    window_size: the coupling window in s (coupling_window_size); windows: coupling_windows;
    checkpoint_windows: the windows between two restart checkpoints (checkpoint_windows)."""
    d = case.data
    cs = d["coupling"]
    if t_end is None:
        t_end = d["time"]["end_time"]
    if t_end is None:
        raise FluidCaseError("coupling_settings needs the seismic duration (time.end_time or the motion's)")
    if not window_size > 0:
        raise FluidCaseError(f"coupling window size {window_size!r} s is not positive")
    if (why := coupling_window_problem(cs["scheme"], cs["window"])) is not None:
        raise FluidCaseError(f"coupling.window = {cs['window']}: {why}; use window: 1")
    split = water_split(case)
    return {
        "scheme": cs["scheme"],
        "window": int(cs["window"]),
        "window_size": float(window_size),
        "windows": coupling_windows(t_end, window_size),
        "checkpoint_windows": checkpoint_windows(float(d["output"]["checkpoint_interval"]), window_size),
        "window_force_weight": coupling_window_force_weight(cs),
        "defect_correction": coupling_defect_correction(cs),
        "energy_limit": float(cs.get("energy_limit", 0)),
        "tolerance": float(cs["tolerance"]),
        # absolute floors per field (coupling_scales.py)
        "absolute_tolerance": absolute_tolerances(case, window_size, float(cs["tolerance"])),
        "max_iterations": int(cs["max_iterations"]),
        "acceleration": cs["acceleration"],
        "initial_relaxation": 0.5,
        "predictor": coupling_predictor(cs),
        "residual_scale": cs.get("residual_scale", "current"),
        "reuse": int(cs.get("reuse", 0)),
        "transport": cs["transport"],
        "address_file": str(address_file),
        "token": token,
        "timeout": float(cs["timeout"]),
        "connect_timeout": float(cs["timeout"]),
        "face": "lining_inner",
        "mesh": "wall",
        "map": "coincident",
        "map_tolerance": 1e-6,
        "write_fields": list(SOLID_WRITE_FIELDS),
        "participant": "solid",
        "partner": "fluid",
        # tq-solid's part of the water (water_split)
        "volume_law": split.volume_law,
        "bulk_modulus": split.bulk_modulus,
        "water_density": split.water_density,
        "water_ends": split.water_ends,
        "axial_density": split.axial_density,
        "end_ymin": split.end_kinds[0],
        "end_ymax": split.end_kinds[1],
        "surge_tank_area_ymin": split.surge_tank_areas[0],
        "surge_tank_area_ymax": split.surge_tank_areas[1],
        # OpenFOAM's part that tq-solid must know of: the water sends its wall pressure less its mean
        # (the water case's tqInterface and tq-solid's /coupling both read it from here)
        "subtract_mean_pressure": split.subtract_mean_pressure,
        # a half block's wet face ends at its plane of symmetry (its nodes' area vectors there are half
        # the whole face's)
        "symmetry_ymax": split.volume_law != "none" and half_block(case.data),
    }


def solid_coupling_attrs(s: dict) -> dict:
    """The /coupling attributes of solid_input.h5 (docs/formats.md) for these settings: each setting as
    the table stores it, less those the table's /coupling rows leave out (solver_input_schema.group_attrs)."""
    return group_attrs("/coupling", s)


def exchange_dict(s: dict) -> dict:
    """The fluid's `exchange` dictionary (couplerExchange, docs/water.md §2) for these settings.
    The fluid is the second participant; the solid (first) maps, so mappingSide is the solid."""
    if s["transport"] != "tcp":
        raise FluidCaseError(f"coupling.transport {s['transport']!r}: the OpenFOAM side speaks tcp only "
                             "(docs/water.md §11); use transport: tcp")
    return {
        "type": "coupler",
        "participant": s["partner"],
        "partner": s["participant"],
        "tokenEnv": TOKEN_ENV,
        "addressFile": Quoted(s["address_file"]),
        "transport": s["transport"],
        "timeout": s["timeout"],
        "connectTimeout": s["connect_timeout"],
        "scheme": s["scheme"],
        "windowSize": s["window_size"],
        "windows": s["windows"],
        "maxIterations": s["max_iterations"],
        "tolerance": s["tolerance"],
        "acceleration": s["acceleration"],
        "initialRelaxation": s["initial_relaxation"],
        "predictor": s["predictor"],
        "residualScale": s["residual_scale"],
        "reuse": s.get("reuse", 0),
        "absoluteTolerance": dict(s["absolute_tolerance"]),
        "mesh": s["mesh"],
        "map": s["map"],
        "mapTolerance": s["map_tolerance"],
        "mappingSide": Quoted(s["participant"]),
        "readFields": list(s["write_fields"]),
        "writeFields": ["force"],
    }


def _boundary_types(folder: Path, types: dict[str, str]) -> None:
    """Set the patch types gmshToFoam left as 'patch'."""
    boundary = folder / "constant" / "polyMesh" / "boundary"
    for patch, typ in types.items():
        if typ == "patch":
            continue
        _foam(folder, "foamDictionary", str(boundary), "-entry", f"entry0/{patch}/type", "-set", typ,
              log=f"foamDictionary.{patch}", case=False)


def fluid_env() -> dict[str, str]:
    """OpenFOAM's environment (WM_PROJECT_DIR) with libtqFoam.so (and through it libmpi) loadable."""
    env = paths.openfoam_env()
    lib = paths.openfoam_library()
    if lib is None:
        raise FluidCaseError("libtqFoam.so is not built (cmake --build build --target tqFoam)")
    env.setdefault("WM_PROJECT_DIR", "/usr/share/openfoam")
    dirs = [str(lib.parent)]
    mpi = Path("/usr/lib/x86_64-linux-gnu/openmpi/lib")
    if mpi.is_dir():
        dirs.append(str(mpi))
    if env.get("LD_LIBRARY_PATH"):
        dirs.append(env["LD_LIBRARY_PATH"])
    env["LD_LIBRARY_PATH"] = os.pathsep.join(dirs)
    env.setdefault("FOAM_SIGFPE", "true")
    return env


def _foam(folder: Path, *cmd: str, log: str, case: bool = True) -> None:
    exe = shutil.which(cmd[0])
    if exe is None:
        raise FluidCaseError(f"OpenFOAM's {cmd[0]} is not on PATH (Debian package openfoam, v1912)")
    proc = subprocess.run([exe, *cmd[1:], *(["-case", str(folder)] if case else [])], env=fluid_env(),
                          capture_output=True, text=True, timeout=600)
    (folder / f"log.{log}").write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0 or "FOAM FATAL" in proc.stdout + proc.stderr:
        raise FluidCaseError(f"{cmd[0]} failed on the water case; see {folder / f'log.{log}'}")


def water_case(case, settings: dict, slice_mode: bool, write_interval: float | None = None,
               restart: dict | None = None) -> WaterCase:
    """The water case of condition dynamic_water (water_case.WaterCase) for `case` and the coupling
    `settings`: one water step a coupling window. `restart`: the restart checkpoints' entries of
    water_case.WaterCase (restart_dir, restart_windows, restart_from; docs/formats.md "Restart
    checkpoints"), none by default."""
    d = case.data
    water = d["water"]
    split = water_split(case)
    if settings.get("volume_law", "none") != split.volume_law:
        raise FluidCaseError(f"the coupling settings give tq-solid volume_law {settings.get('volume_law')!r}, "
                             f"but this case's water gives {split.volume_law!r}: make the settings from the "
                             "same case (coupling_settings)")
    if water["model"] == "incompressible" and slice_mode and split.volume_law != "incompressible":
        raise FluidCaseError("incompressible water in a closed slice needs the volume law in the solid "
                             "(coupling.volume_law: solid, the default); the water alone cannot change its "
                             "cross-section (docs/coupler.md \"Volume law in the solid\")")
    model = split.foam_model
    if slice_mode:
        ends = ("empty", "empty")
    elif water["ends"] == "closed":
        ends = ("wall", "wall") if model == "compressible" else ("open", "open")
    else:
        # a valve is a wall; the reservoir's p = 0 is an open patch, and so is a surge tank's (its level is
        # tq-solid's: the water solver's remainder meets p = 0 there)
        ends = tuple("wall" if k == "valve" else "open" for k in split.end_kinds)
    if not slice_mode and half_block(d):
        ends = (ends[0], "symmetry")  # the half block's ymax end: its plane of symmetry
    dt = settings["window_size"]
    end_time = settings["windows"] * dt
    brief = water.get("log", "brief") == "brief"
    return WaterCase(
        model=model, ends=ends, density=float(water["density"]), viscosity=float(water["viscosity"]),
        bulk_modulus=split.foam_bulk_modulus, delta_t=dt, end_time=end_time,
        write_interval=write_interval if write_interval else max(end_time, 0.1),
        free_surface_level=float(d["geometry"]["tunnel_centre_z"]) + float(water["head"]),
        exchange=exchange_dict(settings),
        subtract_mean_pressure=bool(settings.get("subtract_mean_pressure", False)),
        log_interval=float(water.get("log_interval", WATER_LOG_INTERVAL)) if brief else None,
        **(restart or {}))


def write_water_case(w: WaterCase, water_msh: Path, folder: Path) -> FluidCase:
    """Make `folder` (emptied first) the OpenFOAM case `w` on the gmsh 2.2 mesh `water_msh` (physical
    groups water, interface, end_ymin, end_ymax): the dictionaries, the mesh converted (gmshToFoam,
    the patch types of water_case.patch_types) and checked (checkMesh). Not run."""
    water_msh = Path(water_msh)
    if not water_msh.is_file():
        raise FluidCaseError(f"water mesh {water_msh} not found; run `tunnelquake mesh`")
    folder = Path(folder)
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    write_dictionaries(w, folder)
    shutil.copy(water_msh, folder / "water.msh")
    _foam(folder, "gmshToFoam", str(folder / "water.msh"), log="gmshToFoam")
    _boundary_types(folder, patch_types(w))
    _foam(folder, "checkMesh", log="checkMesh")
    return FluidCase(folder, w.solver, w.mode, w.model, w.end_time, w.delta_t)


def build_fluid_case(case, water_msh: Path, folder: Path, settings: dict, slice_mode: bool,
                     write_interval: float | None = None, restart: dict | None = None) -> FluidCase:
    """Make `folder` an OpenFOAM case of the water of `case`, ready to run coupled (not run)."""
    return write_water_case(water_case(case, settings, slice_mode, write_interval, restart), water_msh, folder)


# ----------------------------------------------------------------------------------------------
# Decomposed water (parallel.fluid_ranks > 1): decomposePar, mpirun, reconstructPar
# ----------------------------------------------------------------------------------------------
#: The key every decomposition error names.
RANKS_KEY = "parallel.fluid_ranks"


def water_cells(folder: Path) -> int:
    """The number of cells of the water case's mesh (the `nCells:` note gmshToFoam writes in the
    header of constant/polyMesh/owner, ASCII or binary)."""
    owner = Path(folder) / "constant" / "polyMesh" / "owner"
    with open(owner, "rb") as f:
        head = f.read(4096).decode("latin-1")
    m = re.search(r"nCells:\s*(\d+)", head)
    if not m:
        raise FluidCaseError(f"no 'nCells' note in {owner}: cannot size the decomposition of {RANKS_KEY}")
    return int(m.group(1))


def _factor_triples(n: int):
    for a in range(1, n + 1):
        if n % a:
            continue
        for b in range(1, n // a + 1):
            if (n // a) % b == 0:
                yield a, b, n // (a * b)


def simple_split(ranks: int, extents: tuple[float, float, float], slice_mode: bool) -> tuple[int, int, int]:
    """Subdomains along (x, y, z) for the `simple` method: the product is `ranks` and the cut area
    is least, the water taken as the box of its `extents` (a cut normal to x costs Ly Lz, ...).

    Slice: never along y (one cell thick, `empty` ends); the section is cut in x and z, x first on
    a tie. 3D: the tunnel's axis y is cut first as long as a cross-section (4 R^2 for the box) is
    smaller than an axial cut (2 R L): for the paper's 80 m tunnel, (1 N 1). Measured with
    decomposePar on 2 ranks: the 3D paper water (14,784 cells) has 336 processor faces cut along y
    against 880 cut along x; the slice (336 cells) 20 either way (docs/coupler.md)."""
    lx, ly, lz = (max(float(v), 1e-12) for v in extents)
    best = None
    for nx, ny, nz in _factor_triples(ranks):
        if slice_mode and ny != 1:
            continue
        cut = (nx - 1) * ly * lz + (ny - 1) * lx * lz + (nz - 1) * lx * ly
        # tie-break: fewer slabs in the direction listed later (x before z, y before x)
        key = (round(cut, 9), nz, nx)
        if best is None or key < best[0]:
            best = (key, (nx, ny, nz))
    return best[1]


def write_decompose_dict(folder: Path, ranks: int, split: tuple[int, int, int]) -> Path:
    """system/decomposeParDict: `ranks` subdomains, method simple with n = split. (scotch would
    need the real libscotchDecomp: Debian's openfoam v1912 ships only its stub, and on these
    structured cylinders the simple cut along the axis is already the least.)"""
    path = Path(folder) / "system" / "decomposeParDict"
    path.write_text(foam_file({"numberOfSubdomains": ranks, "method": "simple",
                               "coeffs": {"n": list(split), "delta": 0.001}},
                              "decomposeParDict", note=f"written by tunnelquake ({RANKS_KEY}: {ranks})"))
    return path


def decompose(folder: Path, ranks: int, extents: tuple[float, float, float], slice_mode: bool) -> dict:
    """Split the water case into `ranks` processor folders (decomposeParDict + decomposePar, its log
    in log.decomposePar). Returns {'split': (nx, ny, nz), 'cells': [per rank], 'processor_faces': n}.
    Errors name parallel.fluid_ranks and the fix."""
    folder = Path(folder)
    cells = water_cells(folder)
    bad = fluid_ranks_problem(cells, ranks)  # the rule `check` applies to the mesh's counts
    if bad is not None:
        raise FluidCaseError(f"{RANKS_KEY} = {ranks} {bad[0]}; {bad[1]}")
    split = simple_split(ranks, extents, slice_mode)
    write_decompose_dict(folder, ranks, split)
    for old in folder.glob("processor*"):
        shutil.rmtree(old)
    try:
        _foam(folder, "decomposePar", "-force", log="decomposePar")
    except FluidCaseError as e:
        raise FluidCaseError(f"{RANKS_KEY} = {ranks}: {e}; use fluid_ranks: 1, or fewer ranks") from None
    log = (folder / "log.decomposePar").read_text()
    per = [int(x) for x in re.findall(r"^Processor \d+\s*\n\s*Number of cells = (\d+)", log, flags=re.M)]
    if len(per) != ranks or min(per) < 1:
        raise FluidCaseError(f"{RANKS_KEY} = {ranks}: decomposePar gave cells per rank {per} (split n = "
                             f"{split}); a rank without water cells cannot run: use fewer ranks "
                             f"(see {folder / 'log.decomposePar'})")
    m = re.search(r"^Number of processor faces = (\d+)", log, flags=re.M)
    return {"split": split, "cells": per, "processor_faces": int(m.group(1)) if m else None}



#: TQ_WATER_BATCH=0 in the environment runs the water under the scheduling policy it inherits
BATCH_ENV = "TQ_WATER_BATCH"


@functools.lru_cache(maxsize=1)
def _chrt_batch() -> str | None:
    """`chrt` where it can start a program under the batch policy here (util-linux, Linux), else None."""
    exe = shutil.which("chrt")
    if exe is None or not sys.platform.startswith("linux"):
        return None
    try:
        ok = subprocess.run([exe, "--batch", "0", "true"], capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return None
    return exe if ok else None


def batch_scheduled(cmd: list[str]) -> list[str]:
    """The water's ranks (`mpirun ...`, whose ranks inherit the policy) under Linux's batch scheduling
    policy (SCHED_BATCH, `chrt --batch 0`): a batch task that the solid wakes with the wall's motion
    does not preempt the solid's thread that woke it, which then sends to the next rank and waits,
    instead of standing aside while the first rank starts its pass. The 3D example's first second on
    2 ranks: tq-solid's exchange work 0.54-0.69 s of wall (its CPU) against 1.88-3.02 s, the coupled
    wall 0.969x (median of 6 alternated rounds); the slice's water on one rank gains nothing (1.010x),
    so a single water process keeps its policy (docs/benchmarks.md "Against the time goals").
    Unchanged where chrt cannot (not Linux, no util-linux) or with TQ_WATER_BATCH=0."""
    if os.environ.get(BATCH_ENV) == "0":
        return cmd
    exe = _chrt_batch()
    return [exe, "--batch", "0", *cmd] if exe else cmd


def mpirun_executable() -> str:
    exe = shutil.which("mpirun")
    if exe is None:
        raise FluidCaseError(f"{RANKS_KEY} > 1 needs mpirun (Debian package openmpi-bin, which "
                             "scripts/bootstrap.sh installs); install it or use fluid_ranks: 1")
    return exe


def mpirun_command(ranks: int, solver: str, folder: Path, env: dict) -> list[str]:
    """`mpirun -np N ... <solver> -parallel -case <folder>` with the environment the ranks need
    (-x) and the ranks yielding the core while they wait (mpi_yield_when_idle: OpenMPI 4.1 spins in
    MPI_Recv otherwise; the ranks wait for rank 0, which waits for the solid on TCP). Not bound to
    cores (--bind-to none): tq-solid and the ranks take turns on the same cores."""
    cmd = [mpirun_executable(), "-np", str(ranks)]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    cmd += ["--oversubscribe", "--bind-to", "none", "--mca", "mpi_yield_when_idle", "1"]
    for var in (TOKEN_ENV, "LD_LIBRARY_PATH", "WM_PROJECT_DIR", "FOAM_SIGFPE", "PATH", "TQ_WATER_GATHER"):
        if var in env:
            cmd += ["-x", var]
    return cmd + [solver, "-parallel", "-case", str(folder)]


def reconstruct(folder: Path) -> str:
    """reconstructPar of every time a processor folder holds (log in log.reconstructPar); the
    processor folders stay. Returns what happened, in words (never raises: the run's results do
    not depend on it)."""
    folder = Path(folder)
    times = [p.name for p in (folder / "processor0").iterdir() if p.is_dir() and _is_time(p.name)] \
        if (folder / "processor0").is_dir() else []
    if not [t for t in times if float(t) > 0]:
        return f"no water time written beyond 0 (processor folders in {folder})"
    try:
        _foam(folder, "reconstructPar", "-newTimes", log="reconstructPar")
    except FluidCaseError as e:
        return f"reconstructPar failed ({e}); the water's fields are in {folder}/processor*/"
    return (f"water fields reconstructed into {folder} (times {', '.join(sorted(times, key=float))}; log "
            f"{folder / 'log.reconstructPar'}; the processor folders stay)")


def _is_time(name: str) -> bool:
    try:
        float(name)
    except ValueError:
        return False
    return True
