"""The rows of solid_input.h5's table (data only: no import of the case schema, so that the case's
checks can ask it which parameters a model needs). Everything made from it is in
`tunnelquake.solver_input_schema`, which resolves the rows linked to case keys."""
from __future__ import annotations

from dataclasses import dataclass

FORMAT = "tunnelquake-solid-input"
VERSION = 2
MATERIALS = "/materials/*"
# The material models tq-solid registers (solid_solver/src/materials/registry.cpp; a C++ test checks
# the two lists agree). The case schema's `materials.<name>.model` takes its choices from here.
MODELS = ("elastic", "mohr_coulomb_damage", "kelvin_voigt", "reinforced_concrete")

_UNSET = object()


@dataclass(frozen=True)
class Entry:
    """One attribute (or dataset) of a group. ``group`` is a path; ``*`` stands for a free name
    (a mesh region, a face group, a load). Bounds are inclusive unless ``lo_open``/``hi_open``.
    An entry whose ``doc`` is empty shares the row of the entry before it in the docs.

    Which attributes the writer puts in the file (``solver_input_schema.group_attrs``): with
    ``omit_default`` a value equal to the default is left out (tq-solid reads the default); with
    ``written_with`` the attribute is left out unless that attribute of the group is written."""

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
    omit_default: bool = False  # writer: the default is not written
    written_with: str = ""  # writer: only together with this attribute of the group


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
                "hydrostatic", "fault_offset", "interfaces", "boundaries", "motion", "drm", "coupling",
                "schema")),
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
    Group("/fault_offset", doc="the fault_offset stage's prescribed displacement (docs/solid_solver.md "
                               "\"Fault offset\")"),
    Group("/interfaces", ("rock_lining", "lining_joints")),
    Group("/interfaces/rock_lining"),
    Group("/interfaces/lining_joints", doc="the joint law of the lining's joints, whose node pairs mesh.h5 "
                                           "holds (docs/theory.md \"Lining joints\")"),
    Group("/boundaries", ("bottom", "free_field", "periodic")),
    Group("/boundaries/bottom"),
    Group("/boundaries/free_field"),
    Group("/boundaries/periodic"),
    Group("/motion"),
    Group("/drm", doc="the free field on a domain-reduction layer (docs/solid_solver.md \"Domain reduction\")"),
    Group("/coupling"),
)

_MC = ("mohr_coulomb_damage",)
_KV = ("kelvin_voigt",)
_RC = ("reinforced_concrete",)

ENTRIES: tuple[Entry, ...] = (
    _e("/", "format", "str", f'`"{FORMAT}"`', required=True, choices=(FORMAT,)),
    _e("/", "version", "int", f"`{VERSION}`", required=True, lo=VERSION, hi=VERSION),
    _e("/", "condition", "str", "informational", choices=("no_water", "static_water", "dynamic_water")),
    _e("/", "mesh", "str", "path of `mesh.h5`, relative to this file's folder or absolute", required=True),
    _e("/", "input_fingerprint", "str", "the case keys that shaped this condition's results, by group, as JSON "
                                        "(`tunnelquake.fingerprint`; docs/formats.md \"Input fingerprint\"): copied into "
                                        "the results file's root attribute of that name, its `digest` into each "
                                        "checkpoint manifest (`inputs`)"),
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
    _e(MATERIALS, "retardation_time", "float", "τ of `kelvin_voigt` (σ = C:ε + τ C:ε̇; damping ratio ξ = ωτ/2 at "
       "angular frequency ω, e.g. ξ = 5 % at 5 Hz is τ = 3.2e-3 s; docs/solid_solver.md \"Kelvin–Voigt rock\"); "
       "shortens the stable step like Rayleigh β", unit="s", case="materials.retardation_time", models=_KV,
       required_by=_KV),
    # reinforced_concrete (docs/solid_solver.md "Reinforced concrete lining"): the concrete and bars
    # of the case's design block, the ring's geometry from geometry and mesh (solid_input.py).
    _e(MATERIALS, "fc", "float", "`reinforced_concrete`: compressive strength of the parabola–rectangle (the "
       "design block's fck)", unit="Pa", case="design.concrete.fck", models=_RC, lo=0.0, lo_open=True),
    _e(MATERIALS, "fct", "float", "`reinforced_concrete`: tensile strength (fctm; EN 1992-1-1 Table 3.1 from fck "
       "when not given)", unit="Pa", case="design.concrete.fctm", models=_RC, lo=0.0, lo_open=True),
    _e(MATERIALS, "eps_c2", "float", "`reinforced_concrete`: strain at the parabola's top (written from fck, "
       "EN 1992-1-1 Table 3.1)", models=_RC, default=2.0e-3, lo=0.0, lo_open=True),
    _e(MATERIALS, "eps_cu2", "float", "`reinforced_concrete`: ultimate compressive strain; beyond it the concrete "
       "has crushed (written from fck, Table 3.1)", models=_RC, default=3.5e-3, lo=0.0,
       lo_open=True),
    _e(MATERIALS, "tension_stiffening_beta", "float", "`reinforced_concrete`: β of EN 1992-1-1 eq. (7.19) in the "
       "tension-stiffening law (1 short-term, 0.5 sustained or repeated)", case="materials.tension_stiffening_beta",
       models=_RC, default=1.0, lo=0.0, hi=1.0),
    _e(MATERIALS, "Es", "float", "`reinforced_concrete`: steel modulus", unit="Pa", case="design.reinforcement.Es",
       models=_RC, default=200e9, lo=0.0, lo_open=True),
    _e(MATERIALS, "fy", "float", "`reinforced_concrete`: steel yield strength (elastic–perfectly plastic)",
       unit="Pa", case="design.reinforcement.fyk", models=_RC, default=500e6, lo=0.0, lo_open=True),
    _e(MATERIALS, "As_inner_hoop", "float", "`reinforced_concrete`: hoop bars at the inner face, area per metre "
       "of tunnel", unit="m²/m", case="design.reinforcement.As_inner", models=_RC, default=0.0, lo=0.0),
    _e(MATERIALS, "As_outer_hoop", "float", "`reinforced_concrete`: hoop bars at the outer face", unit="m²/m",
       case="design.reinforcement.As_outer", models=_RC, default=0.0, lo=0.0),
    _e(MATERIALS, "As_inner_axial", "float", "`reinforced_concrete`: axial bars at the inner face, area per metre "
       "of circumference", unit="m²/m", case="design.reinforcement.As_inner_axial", models=_RC, default=0.0,
       lo=0.0),
    _e(MATERIALS, "As_outer_axial", "float", "`reinforced_concrete`: axial bars at the outer face", unit="m²/m",
       case="design.reinforcement.As_outer_axial", models=_RC, default=0.0, lo=0.0),
    _e(MATERIALS, "axis_distance", "float", "`reinforced_concrete`: face to bar centroid, both faces", unit="m",
       case="design.reinforcement.axis_distance", models=_RC, default=0.05, lo=0.0, lo_open=True),
    _e(MATERIALS, "ring_centre_x", "float", "`reinforced_concrete`: x of the tunnel axis (the hoop direction is "
       "about it)", unit="m", case="geometry.tunnel_centre_x", models=_RC),
    _e(MATERIALS, "ring_centre_z", "float", "`reinforced_concrete`: z of the tunnel axis", unit="m",
       case="geometry.tunnel_centre_z", models=_RC),
    _e(MATERIALS, "ring_inner_radius", "float", "`reinforced_concrete`: the lining's inner radius "
       "(written as geometry.excavated_radius − lining_thickness)", unit="m", models=_RC,
       lo=0.0, lo_open=True),
    _e(MATERIALS, "ring_thickness", "float", "`reinforced_concrete`: the lining's thickness", unit="m",
       case="geometry.lining_thickness", models=_RC, lo=0.0, lo_open=True),
    _e(MATERIALS, "ring_layers", "float", "`reinforced_concrete`: the mesh's element rows through the lining's "
       "thickness, the bars' rows (written as mesh.lining_elements_through x mesh.refinement_factor)",
       case="mesh.lining_elements_through", models=_RC, lo=1.0),
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
    _e("/stages", "sequence", "names", "a subset of `in_situ,excavation,lining,hydrostatic,fault_offset,seismic` in that "
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
    _e("/fault_offset", "nodes", "data", "the nodes moved [N] (mesh node indices), each held in x, y, z from the "
       "fault_offset stage to the seismic stage's switch, where its reactions are held as forces", required=True),
    _e("/fault_offset", "displacement", "data", "[N, 3] each node's displacement, added to the state before the "
       "stage", unit="m", required=True),
    _e("/fault_offset", "increments", "int", "equal steps the displacement is imposed in, each relaxed to "
       "equilibrium", default=1, lo=1),
    _e("/fault_offset", "rise_time", "float", "T > 0: no fault_offset stage; from the seismic stage's switch the "
       "nodes are held and moved by the displacement times ½(1 − cos(π (t − t0)/T)) over [t0, t0 + T], t0 = "
       "start_time; 0: the static offset of the fault_offset stage", unit="s", default=0.0, lo=0.0),
    _e("/fault_offset", "start_time", "float", unit="s", default=0.0, lo=0.0),
    _e("/interfaces/rock_lining", "model", "str", "`bonded`: the pairs tied; `dynamic_contact`: eqs. 9–13",
       default="bonded", choices=("bonded", "dynamic_contact"), case="interface.model"),
    _e("/interfaces/rock_lining", "static_friction", "float", "μs, μd, f_c, and what a failed pair keeps "
       "(`cohesion_lost` or `cohesion_kept`)", default=0.6, lo=0.0, case="interface.static_friction"),
    _e("/interfaces/rock_lining", "dynamic_friction", "float", default=0.6, lo=0.0, case="interface.dynamic_friction"),
    _e("/interfaces/rock_lining", "cohesion", "float", unit="Pa", default=0.0, lo=0.0, case="interface.cohesion"),
    _e("/interfaces/rock_lining", "after_failure", "str", default="cohesion_lost", case="interface.after_failure"),
    _e("/interfaces/lining_joints", "normal_stiffness", "float", "k_n and k_s: the joint's normal and shear "
       "stiffness per unit area", unit="Pa/m", required=True, lo=0.0, lo_open=True,
       case="lining_joints.normal_stiffness"),
    _e("/interfaces/lining_joints", "shear_stiffness", "float", unit="Pa/m", required=True, lo=0.0, lo_open=True,
       case="lining_joints.shear_stiffness"),
    _e("/interfaces/lining_joints", "tensile_strength", "float", "f_t: the tension a joint carries before it "
       "opens (0: none)", unit="Pa", default=0.0, lo=0.0, case="lining_joints.tensile_strength"),
    _e("/interfaces/lining_joints", "friction", "float", "μ: the shear capped at μ × compression; negative: "
       "the shear spring without a cap", default=-1.0),
    _e("/boundaries/bottom", "face", "str", "viscoelastic base on that face group", default="bottom"),
    _e("/boundaries/bottom", "type", "str", default="viscoelastic", choices=("viscoelastic",)),
    _e("/boundaries/bottom", "distance", "float", "R in K = αG/R (0: tunnel axis to base, else the model "
       "height)", unit="m", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "alpha_n", "float", "α_N, α_T (0: 4/3, 2/3; slice meshes 1, 1/2)", default=0.0,
       lo=0.0),
    _e("/boundaries/bottom", "alpha_t", "float", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "rho", "float", "the half-space below the base, all three or none (0: each base "
       "node's column's lowest layer, the nearest free-field face's)", unit="kg/m³", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "cp", "float", unit="m/s", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "cs", "float", unit="m/s", default=0.0, lo=0.0),
    _e("/boundaries/bottom", "column_face", "str", "vertical face whose layers define the base's column "
       "(empty: the first free-field face, else `xmin`)", default=""),
    _e("/boundaries/free_field", "faces", "names", "vertical face groups driven by 1D free-field columns; each "
       "horizontally layered (quads in rows of one material), or with rows that lean but as many nodes on every "
       "vertical line of it (a strip under a slope along the axis: the column on the lines' mean heights, each "
       "quad at its centroid's height)", required=True),
    _e("/boundaries/free_field", "shared_column_faces", "names", "vertical face groups whose quads are not in "
       "horizontal rows (a tunnel's cross-section, its ends plugged with ground), driven by the first face's "
       "column: each node at its height, each quad by the column's layer at its centroid, whose material it "
       "must have", default=""),
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
    _e("/drm", "nodes", "data", "the DRM layer's nodes [N] (mesh node indices): the layer is every element whose "
       "eight nodes are among them with inner and outer ones; it must be linear elastic", required=True),
    _e("/drm", "internal", "data", "[N] 1 for an inner node (b, the region's side), 0 for an outer one (e)",
       required=True),
    _e("/drm", "time", "data", "free-field sample times [T] from the seismic stage's start, strictly increasing; "
       "linear in time between them, "
       "the end values held outside", unit="s", required=True),
    _e("/drm", "u", "data", "free field at the nodes [T, N, 3]: displacement, velocity (used where "
       "Rayleigh β acts), acceleration (read; a lumped mass has no b–e coupling)", unit="m", required=True),
    _e("/drm", "v", "data", unit="m/s", required=True),
    _e("/drm", "a", "data", unit="m/s²", required=True),
    _e("/coupling", "scheme", "str", "`dynamic_water` through the coupler (docs/coupler.md \"Solid adapter\")",
       default="implicit", choices=("explicit", "paper", "implicit")),
    _e("/coupling", "window", "int", "solid steps per window k (k > 1 not with `paper`); window length (0 = k "
       "steps; tq-solid's seismic step is window_size / k); number of windows (both sides run this many: "
       "`tunnelquake run` gives ⌈t_end / window_size⌉)", default=1, lo=1),
    _e("/coupling", "window_size", "float", unit="s", default=0.0, lo=0.0),
    _e("/coupling", "windows", "int", lo=1, required=True),
    _e("/coupling", "checkpoint_windows", "int", "with /output checkpoint_interval and `--checkpoint-dir`: a restart "
       "checkpoint at the end of every K-th accepted window (0 = every window; `tunnelquake run` gives "
       "round(checkpoint_interval / window_size), at least 1)", default=0, lo=0, omit_default=True),
    _e("/coupling", "tolerance", "float", "implicit: relative residual, passes per window, acceleration, first "
       "relaxation factor, windows of IQN-ILS columns kept, predictor (`linear` and `damped` need implicit)",
       default=1e-4, lo=0.0),
    _e("/coupling", "max_iterations", "int", default=20, lo=1),
    _e("/coupling", "acceleration", "str", default="iqn-ils", choices=("none", "constant", "aitken", "iqn-ils")),
    _e("/coupling", "initial_relaxation", "float", default=0.5, lo=0.0),
    _e("/coupling", "reuse", "int", default=0, lo=0, omit_default=True),
    _e("/coupling", "predictor", "str", default="constant", choices=("constant", "linear", "damped"),
       omit_default=True),
    _e("/coupling", "residual_scale", "str", "implicit: each field's relative residual against its pass's own "
       "norm (`current`) or the largest norm it had in an accepted window (`largest`; docs/coupler.md "
       "\"Convergence test\")", case="coupling.residual_scale", default="current",
       choices=("current", "largest"), omit_default=True),
    _e("/coupling", "absolute_tolerance_velocity", "float", "implicit: absolute floors on each field's RMS "
       "residual (0 = none); `tunnelquake run` derives them (docs/coupler.md \"Convergence test\")",
       unit="m/s", default=0.0, lo=0.0),
    _e("/coupling", "absolute_tolerance_displacement", "float", unit="m", default=0.0, lo=0.0),
    _e("/coupling", "absolute_tolerance_force", "float", unit="N", default=0.0, lo=0.0),
    _e("/coupling", "window_force_weight", "float", "implicit windows of k > 1 steps: weight of the window-end "
       "force (0.5 linear ramp, 1 end force held; docs/coupler.md \"Window force weight\")",
       case="coupling.window_force_weight", default=0.5, omit_default=True),
    _e("/coupling", "defect_correction", "float", "implicit windows of k > 1 steps: the share of the defect not "
       "yet repaid (the accepted windows' water answers less the forces stepped with) added to the next window's "
       "force; 0 = off (docs/coupler.md \"Defect correction\")", case="coupling.defect_correction", default=0.0,
       lo=0.0, hi=1.0, omit_default=True),
    _e("/coupling", "energy_limit", "float", "stop (exit 3) when the coupling's energy exceeds energy_limit × "
       "max(largest \\|interface work\\|, energy_floor) (docs/coupler.md \"Energy guard\"); 0 = no stop",
       default=0.0, lo=0.0, omit_default=True),
    _e("/coupling", "energy_floor", "float", unit="J", default=0.0, lo=0.0),
    _e("/coupling", "volume_law", "str", "the water's volumetric pressure in tq-solid's step (docs/coupler.md "
       "\"Volume law in the solid\", \"Open ends\")", default="none",
       choices=("none", "compressible", "incompressible"), omit_default=True),
    _e("/coupling", "bulk_modulus", "float", unit="Pa", default=0.0, lo=0.0, written_with="volume_law"),
    _e("/coupling", "water_density", "float", unit="kg/m³", default=0.0, lo=0.0, omit_default=True,
       written_with="volume_law"),
    _e("/coupling", "water_ends", "str", default="closed", choices=("closed", "open"), omit_default=True,
       written_with="volume_law"),
    _e("/coupling", "axial_density", "float", unit="kg/m³", default=0.0, lo=0.0, written_with="water_ends"),
    _e("/coupling", "end_ymin", "str", "water_ends open: what closes each end of the column (docs/theory.md "
       "\"The water column along the tunnel\"): reservoir (p = 0), valve (no flow), surge_tank (a free surface "
       "of the area surge_tank_area_*)", default="reservoir", choices=("reservoir", "valve", "surge_tank"),
       omit_default=True, written_with="water_ends"),
    _e("/coupling", "end_ymax", "str", default="reservoir", choices=("reservoir", "valve", "surge_tank"),
       omit_default=True, written_with="water_ends"),
    _e("/coupling", "surge_tank_area_ymin", "float", unit="m²", default=0.0, lo=0.0, omit_default=True,
       written_with="water_ends"),
    _e("/coupling", "surge_tank_area_ymax", "float", unit="m²", default=0.0, lo=0.0, omit_default=True,
       written_with="water_ends"),
    _e("/coupling", "subtract_mean_pressure", "flag", "1: the water sends its wall pressure less its area mean "
       "(OpenFOAM's tqInterface `subtractMeanPressure`, written from the same setting): the uniform part is "
       "tq-solid's volume law, so it needs a volume_law with water_ends closed", default=0.0,
       omit_default=True),
    _e("/coupling", "symmetry_ymax", "flag", "1: the wetted face's nodes at its largest y lie on a plane of "
       "symmetry (a half block, mesh.symmetry mid_length): the carried modes' projection counts their area "
       "vectors as the whole face's, twice the half's", default=0.0, omit_default=True, written_with="volume_law"),
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


def required_by(model: str) -> list[str]:
    """The case keys of the material parameters a model needs."""
    return [e.case.rsplit(".", 1)[1] for e in ENTRIES if e.group == MATERIALS and model in e.required_by]
