"""The layout of solid_input.h5, tq-solid's input: the one table of its groups, attributes and datasets.

Everything else is made from this table:

* `tunnelquake.solid_input` writes the file through :func:`put` (a key not in the table is refused);
* ``python -m tunnelquake.solver_input_schema --write`` generates tq-solid's table
  (solid_solver/src/io/input_schema.inc), whose reader checks every group, attribute, default and
  bound from it, and the reference in docs/formats.md "## solid_input.h5"; tests check both are
  up to date (tests/python/test_solver_input_schema.py).

An entry linked to a case key (``case="stages.relaxation_tolerance"``) takes its bounds and its
default from the case schema (case.py), unless it states them itself (where tq-solid's default for
an absent attribute is not the case's default).

Material parameters travel with the file: the writer adds the material rows of this table to
``/schema`` and tq-solid checks the material attributes against them, after checking that each
row it was built with is the same in the file. A parameter added here thus reaches tq-solid's
per-region parameter map (``tq-solid --print-input``) without rebuilding it; the other rows are
fixed at build time and their hash (``/schema`` attribute ``hash``) must equal tq-solid's.
"""
from __future__ import annotations

import functools
import hashlib
import json
import math
import sys
from dataclasses import dataclass, replace

from .paths import ROOT

FORMAT = "tunnelquake-solid-input"
VERSION = 2
MATERIALS = "/materials/*"
MODELS = ("elastic", "mohr_coulomb_damage")

_UNSET = object()


@dataclass(frozen=True)
class Entry:
    """One attribute (or dataset) of a group. ``group`` is a path; ``*`` stands for a free name
    (a mesh region, a face group, a load). Bounds are inclusive unless ``lo_open``/``hi_open``.
    An entry whose ``doc`` is empty shares the row of the entry before it in the docs."""

    group: str
    name: str
    kind: str  # float | int | whole | flag | str | names | data
    unit: str = ""
    default: object = None  # None: no default (absent is absent)
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    required: bool = False
    choices: tuple = ()
    doc: str = ""
    case: str | None = None
    models: tuple = ()  # materials: the models that read it (empty: all)
    required_by: tuple = ()  # materials: the models that need it


@dataclass(frozen=True)
class Group:
    path: str
    members: tuple = ()  # subgroups (and dataset entries are added from the table)
    required: bool = False
    doc: str = ""


def _e(group, name, kind, doc="", **kw):
    return Entry(group, name, kind, doc=doc, **kw)


GROUPS = (
    Group("/", ("solver", "damping", "materials", "boundary", "loads", "monitors", "output", "stages", "in_situ",
                "hydrostatic", "interfaces", "boundaries", "motion", "coupling", "schema")),
    Group("/schema", doc="the material rows of this table and the hash of the others (written by the writer)"),
    Group("/solver", required=True, doc="at least attribute t_end"),
    Group("/damping"),
    Group("/materials", ("*",), required=True, doc="one subgroup per mesh region"),
    Group(MATERIALS),
    Group("/boundary", ("fixed",)),
    Group("/boundary/fixed", ("*",)),
    Group("/boundary/fixed/*"),
    Group("/loads", ("*",)),
    Group("/loads/*"),
    Group("/monitors"),
    Group("/output"),
    Group("/stages"),
    Group("/in_situ"),
    Group("/hydrostatic"),
    Group("/interfaces", ("rock_lining",)),
    Group("/interfaces/rock_lining"),
    Group("/boundaries", ("bottom", "free_field", "periodic")),
    Group("/boundaries/bottom"),
    Group("/boundaries/free_field"),
    Group("/boundaries/periodic"),
    Group("/motion"),
    Group("/coupling"),
)

_MC = ("mohr_coulomb_damage",)

ENTRIES: tuple[Entry, ...] = (
    _e("/", "format", "str", f'`"{FORMAT}"`', required=True, choices=(FORMAT,)),
    _e("/", "version", "int", f"`{VERSION}`", required=True, lo=VERSION, hi=VERSION),
    _e("/", "condition", "str", "informational", choices=("no_water", "static_water", "dynamic_water")),
    _e("/", "mesh", "str", "path of `mesh.h5`, relative to this file's folder or absolute", required=True),
    _e("/schema", "hash", "str", "hash of the rows other than the material ones; tq-solid refuses a file whose "
                                 "hash is not its own (written by another version of the table)"),
    _e("/schema", "material_parameters", "data", "the material rows of this table, one string each (fields "
                                                 "of `MATERIAL_ROW_FIELDS` joined by vertical bars): tq-solid reads the "
                                                 "material attributes against them"),
    _e("/solver", "t_end", "float", "end time", unit="s", required=True, lo=0.0, lo_open=True),
    _e("/solver", "dt", "float", "time step; `0` = safety × critical. A step above safety × critical is refused",
       unit="s", default=0.0),
    _e("/solver", "safety", "float", "stable-step safety factor", default=0.9),
    _e("/solver", "integrator", "str", "`paper_eq3_4`: the paper's eqs. 3–4 literally; unstable, for study",
       default="central_difference", choices=("central_difference", "paper_eq3_4")),
    _e("/solver", "formulation", "str", "`full_integration`: elastic reference, locks",
       default="one_point_assumed_strain",
       choices=("one_point_assumed_strain", "one_point_assumed_strain_no_poisson", "full_integration")),
    _e("/solver", "velocity_limit", "float", "\\|v\\| above this stops the run as exploding", unit="m/s",
       default=1e3),
    _e("/solver", "gravity_z", "float", "vertical body acceleration (e.g. −9.81)", unit="m/s²", default=0.0),
    _e("/solver", "subcycling_levels", "whole", "elements step up to 2^n times the finest step where their own "
       "stable step allows (docs/solid_solver.md \"Subcycling\"); 0 = off. Not with stiffness-proportional "
       "damping", default=0.0, case="time.subcycling"),
    _e("/damping", "ratio", "float", "Rayleigh damping ratio ξ at f1, f2: α = 2ξω1ω2/(ω1+ω2), β = 2ξ/(ω1+ω2)",
       default=0.0),
    _e("/damping", "f1", "float", unit="Hz"),
    _e("/damping", "f2", "float", unit="Hz"),
    _e("/damping", "alpha", "float", "or the coefficients directly; not together with `ratio` (none: undamped)",
       unit="1/s", default=0.0, lo=0.0),
    _e("/damping", "beta", "float", unit="s", default=0.0, lo=0.0),
    _e(MATERIALS, "model", "str", "docs/theory.md §3", default="elastic", choices=MODELS, case="materials.model"),
    _e(MATERIALS, "E", "float", "Young's modulus, Poisson's ratio, density", unit="Pa", required=True,
       case="materials.youngs_modulus"),
    _e(MATERIALS, "nu", "float", required=True, case="materials.poisson_ratio"),
    _e(MATERIALS, "rho", "float", unit="kg/m³", required=True, case="materials.density"),
    _e(MATERIALS, "cohesion", "float", "c, φ, σt (capped at the apex c cot φ); required by "
       "`mohr_coulomb_damage`, ignored by `elastic`", unit="Pa", case="materials.cohesion", models=_MC,
       required_by=_MC),
    _e(MATERIALS, "friction_angle", "float", unit="°", case="materials.friction_angle", models=_MC,
       required_by=_MC),
    _e(MATERIALS, "tensile_strength", "float", unit="Pa", case="materials.tensile_strength", models=_MC,
       required_by=_MC),
    _e(MATERIALS, "dilation_angle", "float", "ψ ≤ φ", unit="°", case="materials.dilation_angle", models=_MC),
    _e(MATERIALS, "damage_constant", "float", "R of eq. (18) (0 = no damage, perfect plasticity)",
       case="materials.damage_constant", models=_MC),
    _e(MATERIALS, "damage_effect", "str", "`cohesion` (eq. 16: damage reduces c only) or "
       "`cohesion_and_stiffness` (σ = (1 − D) C:(ε − ε^p): c, σt and the stiffness scaled by 1 − D)",
       default="cohesion", choices=("cohesion", "cohesion_and_stiffness"), models=_MC),
    _e("/boundary/fixed/*", "directions", "str", "fixed displacement directions of that face group's nodes, "
       "letters from `xyz` (e.g. `\"xyz\"` base, `\"x\"` roller). A slice mesh gets u_y = 0 everywhere",
       required=True),
    _e("/loads/*", "target", "str", "face group (force shared by tributary area) or node set (equal shares)",
       required=True),
    _e("/loads/*", "direction", "str", required=True, choices=("x", "y", "z")),
    _e("/loads/*", "force", "float", "total force, times the time function", unit="N", required=True),
    _e("/loads/*", "time", "data", "piecewise-linear time function [K], end values held (none: constant 1)",
       unit="s"),
    _e("/loads/*", "value", "data"),
    _e("/monitors", "names", "data", "monitor names [M] (no `/`); positions [M, 3]: nearest node for u, v, a, "
       "element with the nearest centroid for stresses. `tunnelquake` adds `@base` (the base under the axis) "
       "and `@free_field` (xmin side, axis depth), the references of `output.displacement_reference`"),
    _e("/monitors", "points", "data", unit="m"),
    _e("/output", "monitor_dt", "float", "interval of the histories (monitors, energies, ring forces): rows at "
       "k·monitor_dt, interpolated between the solver states around each", unit="s", default=0.005, lo=0.0,
       lo_open=True),
    _e("/output", "progress_s", "float", "wall seconds between progress lines", unit="s", default=5.0),
    _e("/output", "ring_forces", "flag", "1: the lining's section forces and diameter changes at every sample",
       default=1.0),
    _e("/output", "checkpoint_interval", "float", "simulated time between restart checkpoints, written with "
       "`--checkpoint-dir` (\"Restart checkpoints\" below); 0 = none", unit="s", default=0.0, lo=0.0),
    _e("/output", "snapshot_times", "data", "times of full-field snapshots [S]; `tunnelquake` writes "
       "`output.snapshot_times`, or when empty every 1 s of the seismic stage and its end", unit="s"),
    _e("/stages", "sequence", "names", "a subset of `in_situ,excavation,lining,hydrostatic,seismic` in that "
       "order; without `/stages` one dynamic stage from rest", required=True),
    _e("/stages", "relaxation_tolerance", "float", "static stages end when \\|f_ext − f_int\\|₂ / max(the "
       "stage's initial out-of-balance force, 1e-6 × the model's force norm) is below this",
       case="stages.relaxation_tolerance", hi_open=True),
    _e("/stages", "relaxation_max_steps", "int", "per static stage; beyond it the run stops (exit 3)",
       case="stages.relaxation_max_steps"),
    _e("/stages", "mass_scaling", "flag", "1: relax with element masses scaled to one common step (statics "
       "only)", default=1.0),
    _e("/stages", "equilibrium_correction", "flag", "1: at the switch hold the relaxation's residual "
       "out-of-balance force, so the model starts at rest", default=1.0),
    _e("/stages", "lining_region", "str", "region installed by the `lining` stage", default="lining"),
    _e("/stages", "release_fraction", "float", "λ: the `excavation` stage relaxes λ of the excavation load "
       "with the rock alone, the `lining` stage the rest on rock and lining (docs/theory.md §2); λ < 1 needs "
       "both stages", case="stages.release_fraction"),
    _e("/in_situ", "kx", "float", "σx = kx σv, σy = ky σv, σz = kz σv, σv = −(q + g ∫_z^{z_top} ρ dζ) at each "
       "centroid of every region but the lining (docs/solid_solver.md \"Staged initial state\")", default=1.0,
       lo=0.0, case="in_situ.kx"),
    _e("/in_situ", "ky", "float", default=1.0, lo=0.0, case="in_situ.ky"),
    _e("/in_situ", "kz", "float", default=1.0, lo=0.0, case="in_situ.kz"),
    _e("/in_situ", "gravity", "float", "g: the overburden's and the whole run's body force −g ẑ; not with a "
       "different `/solver` `gravity_z`", unit="m/s²", default=0.0, lo=0.0, case="in_situ.gravity"),
    _e("/in_situ", "density", "float", "overburden ρ (0 = each element's own), ground surface (default the "
       "mesh's top), surcharge q", unit="kg/m³", default=0.0, lo=0.0),
    _e("/in_situ", "z_top", "float", unit="m"),
    _e("/in_situ", "surcharge", "float", unit="Pa", default=0.0, lo=0.0),
    _e("/hydrostatic", "pressure_at_axis", "float", "p(z) = max(0, p_axis − γw (z − z_axis)); the writer uses "
       "ρw g H, ρw g; `z_axis` required with γw > 0", unit="Pa", required=True, lo=0.0),
    _e("/hydrostatic", "unit_weight", "float", unit="N/m³", default=0.0, lo=0.0),
    _e("/hydrostatic", "z_axis", "float", unit="m", default=0.0),
    _e("/hydrostatic", "face", "str", "face group loaded (consistent nodal forces, 2×2 Gauss points a quad)",
       default="lining_inner"),
    _e("/interfaces/rock_lining", "model", "str", "`bonded`: the pairs tied; `dynamic_contact`: eqs. 9–13",
       default="bonded", choices=("bonded", "dynamic_contact"), case="interface.model"),
    _e("/interfaces/rock_lining", "static_friction", "float", "μs, μd, f_c, and what a failed pair keeps "
       "(`cohesion_lost` or `cohesion_kept`)", default=0.6, lo=0.0, case="interface.static_friction"),
    _e("/interfaces/rock_lining", "dynamic_friction", "float", default=0.6, lo=0.0, case="interface.dynamic_friction"),
    _e("/interfaces/rock_lining", "cohesion", "float", unit="Pa", default=0.0, lo=0.0, case="interface.cohesion"),
    _e("/interfaces/rock_lining", "after_failure", "str", default="cohesion_lost", case="interface.after_failure"),
    _e("/boundaries/bottom", "face", "str", "viscoelastic base on that face group", default="bottom"),
    _e("/boundaries/bottom", "type", "str", default="viscoelastic", choices=("viscoelastic",)),
    _e("/boundaries/bottom", "distance", "float", "R in K = αG/R (0: tunnel axis to base, else the model "
       "height)", unit="m", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "alpha_n", "float", "α_N, α_T (0: 4/3, 2/3; slice meshes 1, 1/2)", default=0.0,
       lo=0.0),
    _e("/boundaries/bottom", "alpha_t", "float", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "rho", "float", "the half-space below the base, all three or none (0: the base "
       "column's lowest layer)", unit="kg/m³", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "cp", "float", unit="m/s", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "cs", "float", unit="m/s", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "column_face", "str", "vertical face whose layers define the base's column "
       "(empty: the first free-field face, else `xmin`)", default=""),
    _e("/boundaries/free_field", "faces", "names", "vertical face groups driven by 1D free-field columns; each "
       "horizontally layered", required=True),
    _e("/boundaries/periodic", "faces", "names", "two opposite face groups tied node by node from the seismic "
       "stage on; written for a slice whose motion has a component along the axis", required=True),
    _e("/motion", "time", "data", "incident (up-going) accelerations [K] at the base, x, y: SH, z: P; linear "
       "between samples; a missing component is zero", unit="s"),
    _e("/motion", "ax", "data", unit="m/s²"),
    _e("/motion", "ay", "data", unit="m/s²"),
    _e("/motion", "az", "data", unit="m/s²"),
    _e("/motion", "cutoff_frequency", "float", "for the λ_min/8 element-size warning; the record's convention "
       "(informational)", unit="Hz", default=0.0, lo=0.0),
    _e("/motion", "convention", "str", default=""),
    _e("/coupling", "scheme", "str", "`dynamic_water` through the coupler (docs/coupler.md \"Solid adapter\")",
       default="implicit", choices=("explicit", "paper", "implicit")),
    _e("/coupling", "window", "int", "solid steps per window k (k > 1 not with `paper`); window length (0 = k "
       "steps); number of windows (0 = ⌈t_end / window⌉)", default=1, lo=1),
    _e("/coupling", "window_size", "float", unit="s", default=0.0, lo=0.0),
    _e("/coupling", "windows", "int", default=0, lo=0),
    _e("/coupling", "tolerance", "float", "implicit: relative residual, passes per window, acceleration, first "
       "relaxation factor, windows of IQN-ILS columns kept, predictor (`linear` needs implicit)", default=1e-4,
       lo=0.0),
    _e("/coupling", "max_iterations", "int", default=20, lo=1),
    _e("/coupling", "acceleration", "str", default="iqn-ils", choices=("none", "constant", "aitken", "iqn-ils")),
    _e("/coupling", "initial_relaxation", "float", default=0.5, lo=0.0),
    _e("/coupling", "reuse", "int", default=0, lo=0),
    _e("/coupling", "predictor", "str", default="constant", choices=("constant", "linear")),
    _e("/coupling", "absolute_tolerance_velocity", "float", "implicit: absolute floors on each field's RMS "
       "residual (0 = none); `tunnelquake run` derives them (docs/coupler.md \"Convergence test\")",
       unit="m/s", default=0.0, lo=0.0),
    _e("/coupling", "absolute_tolerance_displacement", "float", unit="m", default=0.0, lo=0.0),
    _e("/coupling", "absolute_tolerance_force", "float", unit="N", default=0.0, lo=0.0),
    _e("/coupling", "window_force_weight", "float", "implicit windows of k > 1 steps: weight of the window-end "
       "force (0.5 linear ramp, 1 end force held; docs/coupler.md \"Window force weight\")",
       case="coupling.window_force_weight", default=0.5),
    _e("/coupling", "energy_limit", "float", "stop (exit 3) when the coupling's energy exceeds energy_limit × "
       "max(largest \\|interface work\\|, energy_floor) (docs/coupler.md \"Energy guard\"); 0 = no stop",
       default=0.0, lo=0.0),
    _e("/coupling", "energy_floor", "float", unit="J", default=0.0, lo=0.0),
    _e("/coupling", "volume_law", "str", "the water's volumetric pressure in tq-solid's step (docs/coupler.md "
       "\"Volume law in the solid\", \"Open ends\")", default="none",
       choices=("none", "compressible", "incompressible")),
    _e("/coupling", "bulk_modulus", "float", unit="Pa", default=0.0, lo=0.0),
    _e("/coupling", "water_density", "float", unit="kg/m³", default=0.0, lo=0.0),
    _e("/coupling", "water_ends", "str", default="closed", choices=("closed", "open")),
    _e("/coupling", "axial_density", "float", unit="kg/m³", default=0.0, lo=0.0),
    _e("/coupling", "transport", "str", "`mpi`: docs/coupler.md \"tq-solid under mpirun\"; the port file (tcp); "
       "the run's secret; a silent fluid's limit; wait for the fluid (0 = timeout)", default="tcp",
       choices=("tcp", "mpi")),
    _e("/coupling", "address_file", "str", default=""),
    _e("/coupling", "token", "str", default=""),
    _e("/coupling", "timeout", "float", unit="s", default=120.0, lo=0.0, lo_open=True),
    _e("/coupling", "connect_timeout", "float", unit="s", default=0.0, lo=0.0),
    _e("/coupling", "face", "str", "wetted face group, interface name on the wire, the solid's map, fields the "
       "solid writes in the fluid's order, participant names", default="lining_inner"),
    _e("/coupling", "mesh", "str", default="wall"),
    _e("/coupling", "map", "str", default="coincident", choices=("coincident", "projection")),
    _e("/coupling", "map_tolerance", "float", unit="m", default=1e-6, lo=0.0),
    _e("/coupling", "write_fields", "names", default="velocity,displacement"),
    _e("/coupling", "participant", "str", default="solid"),
    _e("/coupling", "partner", "str", default="fluid"),
)


# ------------------------------------------------------------------------------------------------
# The table, resolved: links to the case schema filled in
# ------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def _case_schema():
    from .case import schema

    return schema()


def _case_spec(dotted: str):
    from .schema import MapOf, Section

    spec = _case_schema()
    for part in dotted.split("."):
        spec = spec.fields[part]
        if isinstance(spec, MapOf):
            spec = spec.item
    assert not isinstance(spec, Section), dotted
    return spec


def _resolve(e: Entry) -> Entry:
    if e.case is None:
        return e
    s = _case_spec(e.case)
    kw = {}
    for mine, theirs in (("lo", "min"), ("hi", "max")):
        if getattr(e, mine) is None:
            kw[mine] = getattr(s, theirs, None)
            kw[f"{mine}_open"] = getattr(e, f"{mine}_open") or getattr(s, f"{theirs}_open", False)
    if e.default is None and s.default not in (None, _case_missing()) and not e.choices:
        kw["default"] = float(s.default) if e.kind in ("float", "whole") else s.default
    return replace(e, **kw)


def _case_missing():
    from .schema import _MISSING

    return _MISSING


def entries() -> list[Entry]:
    """The table with the case links resolved (what the writer, tq-solid and the docs use)."""
    return [_resolve(e) for e in ENTRIES]


def required_by(model: str) -> list[str]:
    """The case keys of the material parameters a model needs."""
    return [e.case.rsplit(".", 1)[1] for e in entries() if e.group == MATERIALS and model in e.required_by]


def linked(group: str, table: list[Entry] | None = None) -> list[Entry]:
    """A group's rows written from a case key (the writer takes them from the case section)."""
    return [e for e in (table or entries()) if e.group == group and e.case]


def lookup(group: str, name: str, table: list[Entry] | None = None) -> Entry:
    for e in table or entries():
        if e.group == group and e.name == name:
            return e
    raise KeyError(f"{group} {name!r} is not in the solid_input.h5 table (scripts/tunnelquake/solver_input_schema.py)")


def _row(e: Entry) -> dict:
    d = {k: getattr(e, k) for k in ("group", "name", "kind", "unit", "default", "lo", "hi", "lo_open", "hi_open",
                                    "required", "choices", "models", "required_by")}
    d["choices"], d["models"], d["required_by"] = list(e.choices), list(e.models), list(e.required_by)
    return d


def schema_hash(table: list[Entry] | None = None) -> str:
    """Hash of every row but the material ones (those travel in the file): 16 hex digits."""
    rows = [_row(e) for e in (table or entries()) if e.group != MATERIALS]
    rows += [{"group": g.path, "members": list(g.members), "required": g.required} for g in GROUPS]
    return hashlib.sha256(json.dumps(rows, sort_keys=True).encode()).hexdigest()[:16]


#: the fields of a material row in /schema material_parameters, in order, joined by "|"
MATERIAL_ROW_FIELDS = ("name", "kind", "unit", "default", "lo", "hi", "lo_open", "hi_open", "required",
                       "choices", "models", "required_by", "case")


def _field_text(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int | float):
        return repr(float(v))
    if isinstance(v, tuple):
        return ",".join(v)
    return str(v)


def material_rows(table: list[Entry] | None = None) -> list[str]:
    """The material rows as tq-solid reads them from /schema material_parameters: one string a row,
    the fields of MATERIAL_ROW_FIELDS joined by "|" (numbers as Python's repr, flags 0/1, lists by ",")."""
    return ["|".join(_field_text(getattr(e, k)) for k in MATERIAL_ROW_FIELDS)
            for e in (table or entries()) if e.group == MATERIALS]


# ------------------------------------------------------------------------------------------------
# The writer's one entry point
# ------------------------------------------------------------------------------------------------
class SchemaError(ValueError):
    """A value the table refuses (the writer's bug, or a case value outside the solver's range)."""


def put(obj, group: str, name: str, value, table: list[Entry] | None = None) -> None:
    """Write ``value`` as attribute (or dataset) ``name`` of the open h5py group ``obj``, whose
    table group is ``group``; the entry's kind decides the stored type and its bounds are checked."""
    import numpy as np

    e = lookup(group, name, table)
    where = f"solid_input.h5 {group} {name}"
    if e.kind == "data":
        obj[name] = value
        return
    if e.kind in ("str", "names"):
        if not isinstance(value, str):
            raise SchemaError(f"{where}: {value!r} is not a text")
        if e.choices and value not in e.choices:
            raise SchemaError(f"{where}: {value!r} is not one of {', '.join(e.choices)}")
        obj.attrs[name] = value
        return
    x = float(value)
    if not math.isfinite(x):
        raise SchemaError(f"{where}: {value!r} is not finite")
    if (e.lo is not None and (x < e.lo or (e.lo_open and x == e.lo))) or \
            (e.hi is not None and (x > e.hi or (e.hi_open and x == e.hi))):
        raise SchemaError(f"{where}: {value!r} lies outside {_range_text(e)}")
    obj.attrs[name] = np.int64(int(value)) if e.kind == "int" else x


def write_schema(f, table: list[Entry] | None = None) -> None:
    """The /schema group: the hash of the fixed rows and the material rows (tq-solid reads them)."""
    import h5py
    import numpy as np

    g = f.create_group("schema")
    put(g, "/schema", "hash", schema_hash(table), table)
    put(g, "/schema", "material_parameters", np.array(material_rows(table), dtype=h5py.string_dtype()), table)


# ------------------------------------------------------------------------------------------------
# Generated files
# ------------------------------------------------------------------------------------------------
INC = ROOT / "solid_solver" / "src" / "io" / "input_schema.inc"
DOC = ROOT / "docs" / "formats.md"
BEGIN = "<!-- solid_input:begin (generated by python -m tunnelquake.solver_input_schema --write) -->"
END = "<!-- solid_input:end -->"


def _range_text(e: Entry) -> str:
    from .schema import Number

    if e.choices:
        return ", ".join(f"`{c}`" for c in e.choices) if e.kind != "str" or len(e.choices) > 1 else ""
    return Number(min=e.lo, max=e.hi, min_open=e.lo_open, max_open=e.hi_open)._range_text()


def _c_str(s) -> str:
    return json.dumps("" if s is None else str(s), ensure_ascii=False)


def _c_num(x) -> str:
    if x is None:
        return "0"
    return repr(float(x)) if math.isfinite(float(x)) else "0"


_KIND = {"float": "Float", "int": "Int", "whole": "Whole", "flag": "Flag", "str": "Text", "names": "Names",
         "data": "Data"}


def _ident(s: str) -> str:
    return "root" if s == "/" else s.strip("/").replace("/*", "").replace("/", "_")


def cpp_table(table: list[Entry] | None = None) -> str:
    table = table or entries()
    out = ["// solid_input.h5's table for tq-solid: GENERATED by `python -m tunnelquake.solver_input_schema --write`",
           "// from scripts/tunnelquake/solver_input_schema.py; do not edit (a test checks it is up to date).",
           "// Included by input_schema.hpp.", "",
           f"inline constexpr const char* kFormat = {_c_str(FORMAT)};",
           f"inline constexpr int kVersion = {VERSION};",
           f"inline constexpr const char* kHash = {_c_str(schema_hash(table))};",
           f"inline constexpr const char* kMaterials = {_c_str(MATERIALS)};", "",
           "inline constexpr Group kGroups[] = {"]
    for g in GROUPS:
        members = [m for m in g.members] + [e.name for e in table if e.group == g.path and e.kind == "data"]
        out.append(f"    {{{_c_str(g.path)}, {_c_str(','.join(members))}, {'true' if g.required else 'false'}, "
                   f"{_c_str(g.doc)}}},")
    out += ["};", "", "inline constexpr Attr kAttrs[] = {"]
    for e in table:
        d = e.default
        num = isinstance(d, int | float) and not isinstance(d, bool)
        out.append(
            f"    {{{_c_str(e.group)}, {_c_str(e.name)}, Kind::{_KIND[e.kind]}, {_c_str(e.unit)}, "
            f"{'true' if d is not None else 'false'}, {_c_num(d) if num else '0'}, {_c_str(d if not num else '')}, "
            f"{'true' if e.lo is not None else 'false'}, {_c_num(e.lo)}, {'true' if e.lo_open else 'false'}, "
            f"{'true' if e.hi is not None else 'false'}, {_c_num(e.hi)}, {'true' if e.hi_open else 'false'}, "
            f"{'true' if e.required else 'false'}, {_c_str(','.join(e.choices))}, {_c_str(','.join(e.models))}, "
            f"{_c_str(','.join(e.required_by))}, {_c_str(e.case)}}},")
    out += ["};", "", "// One constant per row: the reader names a row by these, never by a string of its own.",
            "namespace key {"]
    groups: dict[str, list[tuple[int, Entry]]] = {}
    for i, e in enumerate(table):
        groups.setdefault(e.group, []).append((i, e))
    for g, rows in groups.items():
        out.append(f"namespace {_ident(g)} {{")
        for i, e in rows:
            out.append(f"inline constexpr const Attr& {e.name} = kAttrs[{i}];")
        out.append(f"}}  // namespace {_ident(g)}")
    out += ["}  // namespace key", ""]
    return "\n".join(out)


def _per_row(texts: list[str]) -> str:
    """One text for a row of several entries: once when all agree, else each, by '/'."""
    return texts[0] if len(set(texts)) == 1 else " / ".join(t or "–" for t in texts)


def _type(e: Entry) -> str:
    k = {"whole": "float (whole)", "flag": "int 0/1", "names": "str (comma-separated)", "data": "dataset"}
    return k.get(e.kind, e.kind) + (f" ({e.unit})" if e.unit else "")


def _default_text(e: Entry) -> str:
    if e.required:
        return "**required**"
    if e.required_by:
        return f"required by {', '.join(e.required_by)}"
    if e.default is None or e.default == "":
        return ""
    return f"`{e.default:g}`" if isinstance(e.default, float) else f"`{e.default}`"


def doc_rows(table: list[Entry] | None = None) -> list[str]:
    table = table or entries()
    rows: list[list[Entry]] = []
    for e in table:
        if e.doc or not rows or rows[-1][0].group != e.group:
            rows.append([e])
        else:
            rows[-1].append(e)
    out = ["| group | attribute (dataset) | type (unit) | default | allowed | meaning |", "|---|---|---|---|---|---|"]
    for r in rows:
        g = r[0].group.replace("*", "<name>") if r[0].group != MATERIALS else "/materials/<region>"
        names = ", ".join(f"`{e.name}`" if e.kind != "data" else f"`{e.name}` (dataset)" for e in r)
        case = ", ".join(f"`{e.case}`" for e in r if e.case)
        doc = r[0].doc + (f" (case key {case})" if case else "")
        cells = [_per_row([f(e) for e in r]) for f in (_type, _default_text, _range_text)]
        out.append(f"| `{g}` | {names} | {' | '.join(cells)} | {doc} |")
    return out


def doc_section(table: list[Entry] | None = None) -> str:
    head = ("The run parameters of `tq-solid`, written by `tunnelquake.solid_input.write_solid_input` (details of "
            "the solver in `docs/solid_solver.md`). SI units. This table is generated from "
            "`scripts/tunnelquake/solver_input_schema.py`, the one table the writer and tq-solid's reader are "
            "made from: a group, attribute or dataset not listed is refused with its path and the allowed names; "
            "a missing required one, a non-finite or out-of-range number or a choice not listed is refused "
            "naming it (exit 2). `/boundary/fixed` holds the supports of the static stages; at the seismic "
            "stage those on the base and the free-field faces become their reactions and the dynamic "
            "boundaries. `tq-solid --print-input FILE` prints what it read, with each region's parameters.")
    import textwrap

    return "\n".join(textwrap.wrap(head, 100) + [""] + doc_rows(table))


def _replace_between(text: str, body: str) -> str:
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    return text[:start] + "\n" + body + "\n" + text[end:]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "--write" not in argv:
        print(cpp_table())
        print(doc_section())
        return 0
    INC.write_text(cpp_table())
    DOC.write_text(_replace_between(DOC.read_text(), doc_section()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
