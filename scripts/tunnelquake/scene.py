"""What a scene needs: which solvers each condition runs, and whether a plane-strain slice is
equivalent to the 3D model (ARCHITECTURE.md §6).

A slice (one element thick along the tunnel axis y, u_y = 0, a one-cell-thick water mesh) gives
the 3D answer when nothing varies along y: one straight tunnel along y, materials and interface
uniform along y, and a vertically incident motion with no y component — which every TunnelQuake
case satisfies by construction (the geometry is an extruded section, the motion has x and z
components only). What can break the equivalence is the water: in a slice the water cannot flow
along the axis, so a motion that changes the lining's cross-sectional area (the vertical P wave
squeezes the ring) meets water that cannot leave. Incompressible water then makes the problem
ill-posed (and the fluid side refuses it); compressible water (bulk modulus K) resists the area
change with p = -K dA/A, which is the long-tunnel limit of the 3D model and the right slice model.
It equals the 3D model whose water has closed ends; with open ends (p = 0 at y = 0 and L) the 3D
water relieves its pressure through the ends (paper case, L = 80 m: the hydrodynamic pressure at
mid-length 4x lower than the slice's; docs/benchmarks.md "Slice against 3D").
"""
from __future__ import annotations

import contextlib
import math
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from .case import closed_section, coupling_window_force_weight, critical_step, lining_layer_step, subcycling_levels

PARTICIPANTS = {
    "no_water": ("solid",),  # rock + lining only: no fluid process, no coupling
    "static_water": ("solid",),  # hydrostatic pressure as a static load: still no fluid process
    "dynamic_water": ("solid", "fluid"),  # OpenFOAM water coupled every window
}


@dataclass
class SliceAssessment:
    valid: bool
    reasons: list[str] = field(default_factory=list)  # why not (empty when valid)
    advice: list[str] = field(default_factory=list)  # what the user may want to change


def plan(case) -> list[tuple[str, tuple[str, ...]]]:
    """The participants each requested condition runs, in the case's order."""
    return [(c, PARTICIPANTS[c]) for c in case.data["conditions"]]


def assess_slice(case) -> SliceAssessment:
    d = case.data
    reasons: list[str] = []
    advice: list[str] = []
    dynamic = "dynamic_water" in d["conditions"]
    water = d["water"]
    from .case import case_geology

    geology = case_geology(d)
    varying = []  # what changes along the tunnel axis
    if geology is not None:
        if geology.fault is not None:
            varying.append(f"geology.fault_zone ({geology.fault.material}) crosses the tunnel")
        varying += [f"geology.dipping_layers[{i}] ({layer.material}) dips along the axis (its bottom's normal has a "
                    "y component)" for i, layer in enumerate(geology.dipping) if abs(layer.bottom.normal[1]) > 1e-9]
        if geology.slope is not None and abs(math.cos(math.radians(geology.slope.dip_direction))) > 1e-9:
            varying.append(f"geology.slope descends towards azimuth {geology.slope.dip_direction:g} deg, along the "
                           "axis, so the cover changes along it")
        if geology.portal is not None:
            varying.append(f"geology.portal: the tunnel leaves a {geology.portal.angle:g} deg slope through a face at "
                           f"y = {geology.portal.station:g} m, and ends there")
    wave = d.get("incident_wave") or {}
    if wave.get("type", "none") != "none":
        varying.append(f"incident_wave: a {wave['type']} wave {wave['angle']:g} deg from the vertical through a domain-"
                       "reduction layer, which a slice has no room for")
    if d["mesh"]["mode"] == "slice" and varying:
        reasons += [f"{v}: the ground changes along y, and a slice holds its section at mid-length only" for v in varying]
    if d["mesh"]["mode"] == "3d" and varying:
        what = "the motion or the ground" if wave.get("type", "none") != "none" else "the ground"
        advice.append(f"{what} changes along the tunnel axis (" + "; ".join(varying) + "): a slice cannot "
                      "represent it, keep mesh.mode: 3d")
    elif d["mesh"]["mode"] == "3d" and not reasons:
        if dynamic and water.get("ends", "open") == "open":
            # Measured on the paper case (docs/benchmarks.md "Slice against 3D"): open ends let the water
            # breathe along the 80 m tunnel, the slice cannot.
            advice.append("water.ends: open lets the water flow out of the tunnel's ends, which a slice (no axial "
                          "flow: the long-tunnel limit) cannot: a slice reproduces this 3D model with water.ends: "
                          "closed (paper case: every monitored peak within 0.05 %), not with open ends (paper case, "
                          "80 m: hydrodynamic pressure at mid-length 4x lower, lining compression up to 8 % apart, "
                          "displacements within 0.14 %)")
        else:
            advice.append("the scene is uniform along the tunnel axis: mesh.mode: slice gives the same answer for "
                          f"about 1/{d['mesh'].get('elements_along_axis', 44)} of the solid's cost (paper case: "
                          "every monitored peak within 0.05 % of the 3D run)")
        cs = d["coupling"]
        if dynamic and cs["scheme"] == "implicit" and int(cs["window"]) > 1:
            # Measured on the paper case in 3D (docs/stability.md "The paper case in 3D"): the linear ramp of
            # the window's force lets a period-two mode grow even in converged windows; 1e-3 let the closed
            # water column's axial breathing mode grow on energy the coupling created from 13.5 s.
            if coupling_window_force_weight(cs) < 0.75:
                advice.append("coupling.window_force_weight: 0.75 damps the period-two mode of the water's added "
                              "mass that the linear ramp (0.5) lets grow in 3D even in converged windows (paper case: "
                              "stopped at 0.066 s incompressible, at 4.8 s compressible with closed ends; with 0.75 "
                              "and tolerance 1e-4 the 20 s record ran through, within 0.17 % of the slice; "
                              "docs/coupler.md \"Window force weight\")")
            if float(cs["tolerance"]) > 1e-4:
                advice.append(f"coupling.tolerance: 1e-4 (here {float(cs['tolerance']):g}): the relative residual is of "
                              "the whole force, the water's head included, so 1e-3 accepts errors of about 1 % of the "
                              "hydrodynamic force; in 3D they fed the closed water column's axial breathing mode (paper "
                              "case: energy created from 13.5 s, the run wrong by 16 s; docs/coupler.md \"Energy guard\")")
        single = [c for c in d["conditions"] if not subcycling_levels(d, c)]
        if single:
            # Measured on the paper mesh (docs/benchmarks.md "Solid subcycling and element order"): the
            # lining's 0.25 m layers set the step; the rock may take up to 8 times it.
            advice.append(f"time.subcycling: 3 (here single-rate: {', '.join(single)}) lets the rock step up to 8 "
                          "times the lining's step (paper mesh in 3D: 0.29 of the element evaluations, about 1.9x "
                          "fewer solid seconds a step; docs/solid_solver.md \"Subcycling\")")
    return SliceAssessment(valid=not reasons, reasons=reasons, advice=advice)


#: the exchanged added-mass ratio from which ramped windows (weight below 3/4) are predicted unstable
#: (measured bracket on the example slice: 14.4 ran, 36 did not; docs/stability.md "Water stiffness")
PERIOD_TWO_RATIO = 20.0


@dataclass
class AddedMassDiagnostic:
    """Added-mass estimate for partitioned coupling (ARCHITECTURE.md §5, VERIFICATION.md)."""

    interface_mass: float  # kg/m^2: lumped mass of the lining's wetted nodes per wall area
    ratios: dict[str, float]  # name -> ratio (incompressible: per mode; compressible: impedance)
    stable: bool  # the case's scheme is expected to be stable with the case's water model
    message: str


def added_mass_diagnostic(case, frequencies: dict | None = None) -> AddedMassDiagnostic:
    """Estimate whether the case's coupling scheme is stable before running it.

    The explicit solid resists the water within one step only with the lumped mass of the lining's
    wetted nodes, m_G = rho_l h_1 / 2 per wall area (h_1 the first element layer). Water adds
    rho_w R / n per area to ovaling mode n: a staggered exchange (explicit, or the paper's
    predictor-corrector) amplifies interface errors by about rho_w R / (n m_G) each step, unstable
    above 1 (Causin et al. 2005). Compressible water also acts within a window like a dashpot of
    impedance rho_w c (stable while rho_w c dt_c / m_G < 2, dt_c = window x the solid's step,
    planned_step: from the mesh's hexahedra where `frequencies` are given, as check gives them from
    runtime_estimate, else from the mesh plan) — but measured on the water-filled ring and on the
    paper's slice (docs/stability.md) the added-mass bound decides for compressible water too (the
    structure's frequencies are far below the water's acoustic ones), so both are checked."""
    import math

    d = case.data
    g, w, lin = d["geometry"], d["water"], d["materials"]["lining"]
    h1 = lining_layer_step(d)[0]
    m_g = lin["density"] * h1 / 2
    R = g["excavated_radius"] - g["lining_thickness"]
    scheme = d["coupling"]["scheme"]
    ratios = {f"mode {n}": w["density"] * R / (n * m_g) for n in (1, 2)}
    if w["model"] == "compressible":
        dt_c = d["coupling"]["window"] * planned_step(case, frequencies)
        c_w = math.sqrt(w["bulk_modulus"] / w["density"])
        ratios["impedance"] = w["density"] * c_w * dt_c / m_g
    # The enclosed water's volumetric stiffness 2K/R per wall area (p = -K dA/A, dA/A = 2u/R) against
    # the wet nodes' mass: exchanged once a window it is a spring integrated with the window's step,
    # stable while omega_v dt_c < 2 (measured on the example slice with the linear ramp: K 2.2 GPa, 1.84,
    # ran the record; 22 GPa, 5.8, stopped at 3.3 s; 220 GPa diverged at 0.08 s; with window force weight
    # 0.75 the bound is conservative: 22 GPa ran 5 s, docs/stability.md). The volume law in the solid
    # takes it out of the exchange (docs/coupler.md "Volume law in the solid").
    from .fluid_case import volume_law
    law = volume_law(case)[0]
    if law == "none" and closed_section(d) and w["model"] == "compressible" and "impedance" in ratios:
        ratios["volume stiffness"] = math.sqrt(2 * w["bulk_modulus"] / (R * m_g)) * dt_c
    # with the water's translation carried by the solid, the exchange keeps the modes from n = 2 on
    worst = ratios["mode 2" if law != "none" and d["coupling"]["water_translation"] == "solid" else "mode 1"]
    staggered_ok = worst < 1 and ratios.get("impedance", 0.0) < 2
    stable = scheme == "implicit" or staggered_ok
    # Implicit windows of several steps whose force is ramped (window force weight below 3/4) let a mode of
    # period two windows grow on a large exchanged added mass, converged or not (docs/coupler.md "Window
    # force weight"). Measured: 14.4 times the wet nodes' mass ran the example slice's record, 36 (water
    # as dense as the lining) stopped at 4.4 s, the open 3D tube's breathing (32) and the ring's 107 too.
    ramped = scheme == "implicit" and int(d["coupling"]["window"]) > 1 and coupling_window_force_weight(
        d["coupling"]) < 0.75
    if ramped and worst >= PERIOD_TWO_RATIO:
        verdict = (f"the ramped window force (window_force_weight {coupling_window_force_weight(d['coupling'])}) "
                   f"with an exchanged added-mass ratio {worst:.1f} >= {PERIOD_TWO_RATIO} will let a mode of period "
                   "two windows grow: use coupling.window_force_weight: 0.75 (the default)")
        stable = False
    elif ratios.get("volume stiffness", 0.0) >= 2:
        verdict = (f"the water's volumetric stiffness exchanged once a window (omega_v dt_c = "
                   f"{ratios['volume stiffness']:.1f} >= 2) will make the coupling create energy or diverge: use "
                   "coupling.volume_law: solid (the default), which carries it inside the solid's step")
        stable = False
    elif law != "none" and scheme == "implicit":
        carried = ("volume law and its translation (mode 1) are" if d["coupling"]["water_translation"] == "solid"
                   else "volume law is")
        where = "" if closed_section(d) else (", per plane of wet nodes along the axis, joined by the water's "
                                              "axial flow to the open ends")
        verdict = (f"the water's {carried} in the solid ({law}, any bulk modulus{where}); the 'implicit' scheme "
                   "iterates the remaining added mass each window: stable")
    elif scheme == "implicit" and w["model"] == "incompressible" and worst >= 1:
        # measured on the paper case in 3D (docs/stability.md "The paper case in 3D with incompressible water")
        verdict = (f"the 'implicit' scheme iterates each window, but with incompressible water at added-mass "
                   f"ratio {worst:.1f} expect many passes (the paper case: 12 a step with one-step windows, and "
                   "windows of several steps diverged): prefer water.model: compressible, or coupling.window: 1")
        stable = d["coupling"]["window"] == 1
    elif scheme == "implicit":
        verdict = "the 'implicit' scheme iterates each window to convergence: stable (a few passes a step)"
    elif stable:
        verdict = f"the '{scheme}' scheme is stable (added-mass ratio {worst:.2f} < 1)"
    else:
        why = (f"added-mass ratio {worst:.1f} > 1" if worst >= 1 else
               f"impedance ratio {ratios['impedance']:.2f} >= 2: shorten coupling.window")
        verdict = (f"the '{scheme}' scheme will diverge ({why}, docs/stability.md): use scheme: implicit "
                   "(acceleration iqn-ils)")
    detail = ", ".join(f"{k} {v:.2f}" for k, v in ratios.items())
    return AddedMassDiagnostic(m_g, ratios, stable,
                               f"added mass: wetted lining nodes {m_g:.0f} kg/m^2; {w['model']} water: {detail}; "
                               f"{verdict}")


#: water passes a window: explicit 1, the paper's predictor-corrector 2; the implicit scheme's at
#: tolerance 1e-3 (the example slice: 1.398 over the record, 1.516 over its first 2 s), times
#: IMPLICIT_PASSES_PER_DECADE for each tenfold tighter tolerance (measured: the first 1 s of the slice,
#: windows of 16 with reuse, 2.44 passes at 1e-4 against 1.77 at 1e-3, 1.38x; the 3D variant's record
#: at 1e-4, 1.89, against the slice's 1.398 at 1e-3, 1.35x; docs/benchmarks.md)
PASSES_PER_WINDOW = {"implicit": 1.45, "explicit": 1.0, "paper": 2.0}
IMPLICIT_PASSES_PER_DECADE = 1.37
#: implicit with `coupling.residual_scale: largest`: the passes against `current`'s (the example's 3D
#: variant's record at 1e-4: 33,541 against 37,603, 0.892; its slice at 1e-3 with the damped predictor
#: 0.990; docs/benchmarks.md "The residual against the largest norm")
LARGEST_SCALE_PASSES = 0.892


def passes_per_window(coupling: dict) -> float:
    """The water passes a coupling window is expected to take (PASSES_PER_WINDOW; the implicit
    scheme's at its tolerance), in a slice and in 3D alike, wherever the water's volume law is
    carried. The first tenths of a second take more where the exchange carries the law
    (the example's 3D variant at 1e-4: 2.80 a window over its first 0.2 s), but over a run of
    seconds the rule holds: 1.97 over its first 2 s against the rule's 1.99, 2.07 over 2.5 s; the
    slice 1.97 over 2 s against 1.95 with the law in the solid (docs/benchmarks.md "check's
    estimates on the 3D cases")."""
    import math

    scheme = coupling["scheme"]
    passes = PASSES_PER_WINDOW[scheme]
    if scheme == "implicit":
        passes *= IMPLICIT_PASSES_PER_DECADE ** math.log10(1e-3 / float(coupling["tolerance"]))
        if coupling.get("residual_scale") == "largest":
            passes *= LARGEST_SCALE_PASSES
    return max(1.0, passes)


#: the most hexahedra (solid and water) `check` meshes itself to count a subcycled condition's levels:
#: the example's 3D variant (79,200) takes 1.2 CPU s; a larger case's mesh is counted when
#: `tunnelquake mesh` has made it
CHECK_MESH_MAX_ELEMENTS = 250_000


class MeshNotMade(ValueError):
    """check does not mesh a case this large itself (CHECK_MESH_MAX_ELEMENTS)."""


@contextmanager
def current_solid_mesh(case):
    """The path of the case's solid mesh (mesh.h5): the one in its results folder when it is up to
    date (prepare.current_mesh), else one meshed now in a temporary folder (the mesher
    takes about 0.1 CPU s for the example's slice, 1.2 s for its 3D variant). Raises MeshNotMade for
    a case of more than CHECK_MESH_MAX_ELEMENTS hexahedra without a current mesh."""
    import tempfile

    from .case import case_geology, ground_layers
    from .meshing.params import element_counts, resolve
    from .prepare import build_case_mesh, current_mesh, mesh_dir

    if current_mesh(case) is not None:
        yield mesh_dir(case) / "mesh.h5"
        return
    d = case.data
    counts = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    total = counts["rock"] + counts["lining"] + counts["water"]
    if total > CHECK_MESH_MAX_ELEMENTS:
        raise MeshNotMade(f"its {total:,} hexahedra are more than check meshes itself ({CHECK_MESH_MAX_ELEMENTS:,}); "
                          "`tunnelquake mesh` makes the mesh check then counts")
    with tempfile.TemporaryDirectory(prefix="tq-check-mesh-") as tmp:
        build_case_mesh(case, Path(tmp))
        yield Path(tmp) / "mesh.h5"


def subcycled_levels(case, conditions=None) -> dict:
    """condition -> the subcycling levels tq-solid will give its solid (subcycle_levels.Levels), for
    each subcycled condition among `conditions` (default the case's): from the case's mesh, the
    materials, the time step's safety factor (and time.dt where given), the rock-lining interface's
    model, and for a condition with water coupled its wet wall held at the finest level."""
    return mesh_figures(case, conditions or case.data["conditions"])[0]


def repass_reach(case, conditions) -> dict:
    """condition -> the fraction of a window's element evaluations that a re-pass steps again
    (subcycle_levels.window_reach, tq-solid's Solver::planRepasses), for each condition among
    `conditions` with the water coupled in implicit windows of several steps; 1 where tq-solid steps
    every re-pass whole (a reinforced concrete lining's block pass, a fault offset's prescribed slip)."""
    return mesh_figures(case, conditions)[1]


def solid_frequencies(case, mesh_h5) -> dict:
    """Each region of the case's solid mesh `mesh_h5` -> its hexahedra's largest 2 c_p / L, tq-solid's
    frequency bound (subcycle_levels.mesh_frequencies, a reinforced lining stiffened by its bars as
    tq-solid stiffens it: case.reinforced_lining_step_scale; case.critical_step takes them for its
    step)."""
    from .case import reinforced_lining_step_scale
    from .subcycle_levels import mesh_frequencies

    return mesh_frequencies(mesh_h5, case.data["materials"], {"lining": reinforced_lining_step_scale(case.data)})


def stable_step(case, frequencies: dict | None = None, mesh_plan=None) -> float:
    """safety_factor x case.critical_step, s: the longest step tq-solid takes for the case (from the
    mesh's hexahedra's `frequencies` where given: solid_frequencies; `mesh_plan` the case's
    meshing.params.resolve, made here when not given)."""
    from .case import case_geology, ground_layers
    from .meshing.params import resolve

    d = case.data
    if mesh_plan is None:
        mesh_plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    return float(d["time"]["safety_factor"]) * critical_step(d, mesh_plan, frequencies)


def planned_step(case, frequencies: dict | None = None, mesh_plan=None) -> float:
    """The solid's time step, s, as tq-solid will take it: time.dt where given, else stable_step (what
    solid_input.solid_step reads from tq-solid itself once the input is written)."""
    dt = case.data["time"].get("dt")
    return float(dt) if dt is not None else stable_step(case, frequencies, mesh_plan)


def mesh_step_problem(case, frequencies: dict | None) -> str | None:
    """time.dt above the stable step of the case's own mesh, safety_factor x case.critical_step with its
    hexahedra's `frequencies` (solid_frequencies; runtime_estimate keeps them), which tq-solid refuses
    when it builds its solver: the message naming the key, the value, the limit, the region whose
    elements set it and the fix; None when time.dt is not given, is within it, or the case was not
    meshed (`frequencies` None: the case's own check against the mesh plan's estimate stands then)."""
    d = case.data
    dt = d["time"].get("dt")
    if dt is None or not frequencies:
        return None
    safety = float(d["time"]["safety_factor"])
    limit = stable_step(case, frequencies)
    if dt <= limit:
        return None
    region = max(frequencies, key=frequencies.get)
    return (f"time.dt = {dt:g} s is above the solid's stable step on this mesh, {limit:.4g} s (safety_factor "
            f"{safety:g} x the critical step of its hexahedra, the smallest volume / largest face against its "
            f"material's P-wave speed, in region '{region}', and the damping): tq-solid refuses a step above "
            f"safety_factor x its critical step. Fix: leave time.dt out (the stable step x safety_factor), or give "
            f"at most {limit:.4g} s")


def mesh_figures(case, conditions, mesh_h5=None) -> tuple[dict, dict]:
    """(subcycled_levels, repass_reach) of `conditions`, from one look at the case's mesh (`mesh_h5`, else
    current_solid_mesh): the levels of each subcycling and wet wall computed once for both."""
    from .case import fault_offset_slip
    from .subcycle_levels import level_counts, mesh_level_arrays, mesh_window_reach

    d = case.data
    c = d["coupling"]
    sub = [x for x in conditions if subcycling_levels(d, x)]
    again = [x for x in conditions if "fluid" in PARTICIPANTS[x] and c["scheme"] == "implicit" and int(c["window"]) > 1]
    if fault_offset_slip(d) is not None or any(m.get("model") == "reinforced_concrete" for m in d["materials"].values()):
        reach, again = {x: 1.0 for x in again}, []
    else:
        reach = {}
    if not sub and not again:
        return {}, reach
    levels, arrays, reached = {}, {}, {}
    with contextlib.nullcontext(mesh_h5) if mesh_h5 is not None else current_solid_mesh(case) as mesh_h5:
        for x in dict.fromkeys(sub + again):
            key = (subcycling_levels(d, x), "fluid" in PARTICIPANTS[x])
            if key not in arrays:
                arrays[key] = mesh_level_arrays(mesh_h5, d["materials"], key[0], float(d["time"]["safety_factor"]),
                                                float(d["time"].get("dt") or 0.0), d["interface"]["model"], wet=key[1])
            if x in sub:
                levels[x] = level_counts(arrays[key])
            if x in again:
                if key not in reached:
                    r = mesh_window_reach(mesh_h5, arrays[key], int(c["window"]))
                    reached[key] = r["evals_by_chunk"] / r["evals_whole"] if r["evals_whole"] else 1.0
                reach[x] = reached[key]
    return levels, reach


@dataclass
class RuntimeEstimate:
    dt: float  # the solid's step, s (the mesh's critical step x safety: case.critical_step)
    steps: int  # solid steps of the shaking
    seconds: dict[str, float]  # condition -> s of its shaking on an otherwise idle machine
    wall: float  # s, the conditions as `run` schedules them (the coupled one beside the others), statics included
    basis: str = ""  # where the rates come from (rates.MachineRates), or why there are none
    statics: float = 0.0  # s of each condition's fault-offset static stage (0 without one)
    statics_steps: int = 0  # its relaxation steps (rates.RELAX_STEPS_PER_INCREMENT a increment)
    threads: dict[str, int] = field(default_factory=dict)  # condition -> tq-solid's OpenMP threads
    speedup: dict[str, float] = field(default_factory=dict)  # condition -> their speed-up (1 on one thread)
    cpu: dict[str, float] = field(default_factory=dict)  # condition -> CPU s of its shaking on one thread
    subcycled: dict[str, tuple[float, float]] = field(default_factory=dict)  # condition -> (cost fraction, CPU factor)
    repass: dict[str, tuple[float, float]] = field(default_factory=dict)  # condition -> (re-pass evaluations, CPU factor)
    water_ranks: tuple[int, float] = (1, 1.0)  # the water's ranks and its share of the wall against one rank's
    frequencies: dict | None = None  # region -> its hexahedra's largest 2 c_p / L (None: not meshed)
    #: condition -> its kind (rates.part_key) and its seconds before any correction
    kinds: dict[str, tuple[str, float]] = field(default_factory=dict)
    #: part_key -> (factor, runs) of the corrections taken from this machine's recorded runs
    corrections: dict[str, tuple[float, int]] = field(default_factory=dict)
    probes_complete: bool = True  # every probe it needs was measured and the mesh counted (basis says what is not)

    def line(self) -> str:
        if not self.seconds and self.basis:
            return f"run time: not estimated ({self.basis})"
        per = ", ".join(f"{c} {_minutes(s)}" for c, s in self.seconds.items())
        offset = (f", each after about {_minutes(self.statics)} of the fault offset's static stage "
                  f"({self.statics_steps:,} relaxation steps)" if self.statics else "")
        rest = "the other static stages come on top" if self.statics else "the static stages come on top"
        many = sorted({(n, self.speedup.get(c, 1.0)) for c, n in self.threads.items() if n > 1})
        threads = "".join(f"; the solid on {n} threads, {x:.2f}x one thread's speed" for n, x in many)
        by = {}
        for c, (f, x) in self.subcycled.items():
            by.setdefault((round(f, 3), round(x, 2)), []).append(c)
        sub = "".join(f"; {' and '.join(cs)} subcycled: {f:.3g} of the element evaluations a step, {x:.2f}x "
                      "one rate's CPU" for (f, x), cs in by.items())
        again = "".join(f"; {c}'s windows stepped again over the water's reach: {r:.2f} of a pass's element "
                        f"evaluations, {x:.2f}x its CPU" for c, (r, x) in self.repass.items() if r < 1)
        n, f = self.water_ranks
        water = f"; the water on {n} ranks, {f:.2f}x one rank's share of the time" if n > 1 else ""
        runs = ", ".join(f"{k} x{x:.2f} ({m} run{'s' if m > 1 else ''})" for k, (x, m) in self.corrections.items())
        learnt = f"; corrected by this machine's earlier runs of its kind: {runs}" if runs else ""
        return (f"run time: about {_minutes(self.wall)} ({per} of shaking; {self.steps:,} solid steps of "
                f"{self.dt:.2g} s{offset}{threads}{sub}{again}{water}) on an otherwise idle machine, from "
                f"{self.basis}{learnt}; "
                f"{rest}")


def _minutes(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.0f} min" if s < 7200 else f"{s / 3600:.1f} h"


def water_ranks_factor(ranks: int, cells: int) -> float:
    """The water's share of the wall on `ranks` ranks (parallel.fluid_ranks, as many as the cores the
    coupled condition has) against one rank's: rates.WATER_RANKS_FACTOR on two ranks or more with
    rates.WATER_RANK_CELLS cells a rank or more, else 1."""
    from . import rates as R

    return R.WATER_RANKS_FACTOR if ranks >= 2 and cells // ranks >= R.WATER_RANK_CELLS else 1.0


def runtime_estimate(case, counts: dict | None = None, rates=None, actual: dict | None = None,
                     corrected: bool = True, measure_if_missing: bool = True) -> RuntimeEstimate:
    """The CPU time of each condition's shaking from the element and cell counts, the stable step
    and the coupling scheme, at this machine's measured rates (`rates`: a rates.MachineRates; by
    default rates.machine_rates(), the cached probe of this processor and build, run once). The step is tq-solid's own:
    2 / w_max of the case's mesh (its hexahedra's largest 2 c_p / L, L their volume / largest face:
    solid_frequencies; where check does not mesh the case, the mesh plan's estimate from the lining's
    hexahedra and a fault zone's shortest axial element) times the safety factor, cut by
    stiffness-proportional damping and a Kelvin-Voigt material's viscosity as tq-solid cuts it
    (case.critical_step). A fault offset imposed before the shaking adds its static stage's relaxation
    steps to each condition and makes the shaking after it dearer in ground that yields (rates.py
    RELAX_STEPS_PER_INCREMENT, RELAX_STEP_FACTOR, YIELDED_SHAKING_FACTOR); the other static stages
    are not counted. A subcycled condition (time.subcycling) takes its one-rate CPU times
    rates.MachineRates.subcycled_factor of the fraction of the element evaluations a fine step makes
    with the levels tq-solid will give the case's mesh (subcycled_levels). The solid's part is its
    CPU time on one thread divided by the measured speed-up
    of the OpenMP threads `run` gives it (cores.solid_thread_count: the cores divided among the
    conditions running at once, one on a small mesh; rates.MachineRates.speedup). The water's passes
    on parallel.fluid_ranks take water_ranks_factor of one rank's share. Each condition's time is then
    multiplied by the median ratio of measured to estimated time of this machine's recorded runs of
    its kind (rates.part_key: a solid-only condition, or a coupled one, its solid and water together;
    rates.MachineRates.correction; not with `corrected` False). `actual` (condition -> {'steps', 'passes_per_window'}) takes a run's own
    counts instead of the estimated ones (record_run_rates); `measure_if_missing` False runs no probe."""
    import math

    from .case import case_geology, ground_layers
    from .cores import available, side_by_side, solid_thread_count
    from .meshing.params import element_counts, resolve

    d = case.data
    mesh_plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    counts = counts or element_counts(mesh_plan)
    conditions = plan(case)
    # one look at the case's mesh (meshed now in a temporary folder where not current): the stable step
    # of its hexahedra as tq-solid takes it, each subcycled condition's levels, the re-passes' reach
    try:  # no mesh: the step from the mesh plan, subcycled conditions counted at one rate, re-passes whole
        with current_solid_mesh(case) as mesh_h5:
            frequencies = solid_frequencies(case, mesh_h5)
            levels, reach = mesh_figures(case, [c for c, _ in conditions], mesh_h5)
    except (ValueError, RuntimeError, OSError, ImportError, KeyError) as e:
        frequencies, levels, reach = None, {}, {}
        unmeshed = f"; the step from the mesh plan, subcycled conditions counted at one rate (no mesh: {e})"
    else:
        unmeshed = ""
    dt = planned_step(case, frequencies, mesh_plan)
    duration = d["time"].get("end_time")
    if duration is None:
        from .motion import window_seconds

        duration = window_seconds(d["ground_motion"], case.dir) or 0.0
    steps = int(math.ceil(duration / dt))
    from . import rates as R

    share = 2 if side_by_side(conditions) else 1
    elements = counts["rock"] + counts["lining"]
    threads = {c: solid_thread_count(int(d["parallel"]["threads"]), elements, share) for c, _ in conditions}
    # more threads than cores run no faster than one a core
    on_cores = {c: min(n, available()) for c, n in threads.items()}
    if rates is None:
        try:
            rates = R.machine_rates(threads=max(on_cores.values(), default=1), elements=elements,
                                    subcycled=any(subcycling_levels(d, c) for c, _ in conditions),
                                    measure_if_missing=measure_if_missing)
        except (R.ProbeFailed, OSError) as e:
            return RuntimeEstimate(dt=dt, steps=steps, seconds={}, wall=0.0,
                                   basis=f"this machine's speed could not be measured: {e}", frequencies=frequencies)
    speedup = {c: rates.speedup(n) for c, n in on_cores.items()}
    # each condition's solid at its own subcycling (time.subcycling, given once or per condition): a
    # fine step evaluates the fraction of the elements its levels give and moves every node
    solid_of = {c: elements * steps * rates.solid_element_step
                * (rates.subcycled_factor(levels[c].cost_fraction) if c in levels else 1.0) for c, _ in conditions}
    statics, statics_steps = 0.0, 0
    fo = d.get("fault_offset") or {}
    from .case import fault_offset_slip

    if fault_offset_slip(d) is not None and fo.get("rise_time") is None:
        # the offset imposed by a static stage before the shaking: its relaxation steps, and the
        # shaking after it dearer where the ground it yielded is plastic (rates.py)
        statics_steps = int(fo["increments"]) * R.RELAX_STEPS_PER_INCREMENT
        statics = (counts["rock"] + counts["lining"]) * statics_steps * rates.solid_element_step * R.RELAX_STEP_FACTOR
        if any(m["model"] not in R.LINEAR_MODELS for m in d["materials"].values()):
            solid_of = {c: s * R.YIELDED_SHAKING_FACTOR for c, s in solid_of.items()}
    seconds, cpu = {}, {}
    # the water's ranks have the cores to themselves only when the coupled condition runs alone
    ranks = min(int(d["parallel"]["fluid_ranks"]), max(1, available() // share))
    water_ranks = (ranks, water_ranks_factor(ranks, counts["water"]))
    kinds, used = {}, {}
    length = {"seconds": duration}
    for cond, parts in conditions:
        x = speedup[cond]
        run = (actual or {}).get(cond, {})
        n_steps = int(run.get("steps") or steps)
        solid = solid_of[cond] * (n_steps / steps if steps else 1.0)
        solid_key = (cond in levels, rates.size_side)
        if "fluid" not in parts:
            cpu[cond] = solid
            kinds[cond] = (R.part_key("solid", on_cores[cond], *solid_key, **length), solid / x)
        else:
            c = d["coupling"]
            per_window = float(run.get("passes_per_window") or passes_per_window(c))
            passes = per_window * n_steps / c["window"]
            water = passes * (rates.water_pass + counts["water"] * rates.water_cell_pass)
            # a window's first pass, then its re-passes over the water's reach (Solver::planRepasses)
            again = rates.repass_factor(levels[cond].cost_fraction if cond in levels else 1.0, reach.get(cond, 1.0))
            solid_passes = 1.0 + max(0.0, per_window - 1.0) * again
            # staggered: the water's passes in series with the solid's (its threads wait meanwhile)
            cpu[cond] = solid * R.COUPLED_SOLID_FACTOR * solid_passes + water
            kinds[cond] = (R.part_key("coupled", on_cores[cond], *solid_key, ranks=water_ranks[0], **length),
                           solid * R.COUPLED_SOLID_FACTOR * solid_passes / x + water * water_ranks[1])
        key, alone_s = kinds[cond]
        factor, n = rates.correction(key) if corrected else (1.0, 0)
        if n:
            used[key] = (factor, n)
        seconds[cond] = alone_s * factor
    coupled = [s + statics / speedup[c] for c, s in seconds.items() if c == "dynamic_water"]
    alone = [s + statics / speedup[c] for c, s in seconds.items() if c != "dynamic_water"]
    wall = max(sum(coupled), sum(alone)) if coupled and alone else sum(coupled) + sum(alone)
    size = (f"; {elements:,} solid elements: the {rates.size_side}^3 box's CPU an element-step "
            f"{rates.size_factor:.2f}x the probe's" if rates.size_side else "")
    basis = (f"{rates.processor}'s speed (tq-solid-bench probe {rates.probe_s:.3g} CPU s, {rates.source}{size}"
             + (f"; {rates.speedup_note}" if rates.speedup_note else "") + unmeshed
             + "; docs/benchmarks.md \"check's run-time estimate\")")
    return RuntimeEstimate(dt=dt, steps=steps, seconds=seconds, wall=wall, basis=basis, statics=statics,
                           statics_steps=statics_steps, threads=threads, speedup=speedup, cpu=cpu,
                           subcycled={c: (lv.cost_fraction, rates.subcycled_factor(lv.cost_fraction))
                                      for c, lv in levels.items()},
                           repass={c: (r, rates.repass_factor(levels[c].cost_fraction if c in levels else 1.0, r))
                                   for c, r in reach.items()},
                           water_ranks=water_ranks if any("fluid" in p for _, p in conditions) else (1, 1.0),
                           kinds=kinds, corrections=used,
                           probes_complete=not (rates.speedup_note or unmeshed), frequencies=frequencies)


def record_run_rates(case, cond: str, results) -> dict[str, float]:
    """After condition `cond` of `case` completed in one go (not resumed, the solid in one
    process): the measured / estimated ratio of its shaking's time, estimated at the run's own steps
    and passes with this machine's cached probes (none run now), kept for later estimates
    (rates.record_run): a solid-only condition's shaking (/timings wall_s), a coupled one's coupled
    wall (/coupling coupled_wall_s: the solid and the water in series). Nothing is kept for
    a run shorter than rates.RUN_RECORD_MIN_S or when a probe is missing. Returns what was kept."""
    import h5py

    from . import rates as R

    if not R.records_runs():  # nothing would be kept: no estimate either
        return {}
    try:
        with h5py.File(results, "r") as f:
            t = dict(f["timings"].attrs) if "timings" in f else {}
            c = dict(f["coupling"].attrs) if "coupling" in f else None
    except OSError:
        return {}
    steps = int(t.get("steps", 0))
    if c is not None:
        wall = float(c.get("coupled_wall_s", 0))
        windows = float(c.get("windows", 0))
        run = {"steps": steps, "passes_per_window": float(c.get("passes", 0)) / windows if windows else 0}
    else:
        wall = float(t.get("wall_s", 0))
        run = {"steps": steps}
    if not (wall >= R.RUN_RECORD_MIN_S and steps > 0):
        return {}
    try:
        est = runtime_estimate(case, actual={cond: run}, corrected=False, measure_if_missing=False)
    except (ValueError, OSError, KeyError):
        return {}
    if cond not in est.kinds or not est.probes_complete or not est.kinds[cond][1] > 0:
        return {}
    key, estimated = est.kinds[cond]
    ratios = {key: wall / estimated}
    return ratios if R.record_run(ratios) else {}


# ------------------------------------------------------------------------------------------------
# The memory of a domain-reduction field (incident_wave): counted in check's "MiB to run"
# ------------------------------------------------------------------------------------------------
#: Copies of a DRM field (u, v and a at the layer's nodes, 8 bytes a value) `tunnelquake run`'s own
#: process holds at its peak: the field from freefield.free_field (computed in chunks of
#: drm_input.FREE_FIELD_CHUNK nodes, whose work arrays come on top) and one of its three arrays
#: transposed for the file (drm_input.write_drm). Measured on cases/axial_wave (42.9 MiB field):
#: free_field's traced peak 51.1 MiB, writing the input 65 MiB (docs/benchmarks.md "check's
#: estimates on the 3D cases").
DRIVER_DRM_COPIES = 4.0 / 3.0
#: Copies tq-solid holds: the input's /drm it read and the layer's own (boundaries/drm.cpp copies the
#: field into DomainReduction); cases/axial_wave: 111.7 MiB peak RSS against 30.9 MiB without it.
SOLID_DRM_COPIES = 2.0


def drm_layer_nodes(plan, offset: int) -> int:
    """The nodes of the DRM layer `offset` element rings in from the block's sides and base
    (incident_wave.drm_layer), counted on the mesh plan without meshing: the section's outer grid is
    structured (nx x nz elements: the side zones' divisions and the near-field box's side, which has
    quarter.count), so its nodes at distance k from x_min, x_max and the base number
    (nx + 1 - 2k)(nz + 1 - k) minus those at k + 1; the two node planes of the layer across the
    block's ends (y) take every section node at distance >= offset (the plugged section: the ends are
    rock), the planes between them the section's two rings at offset and offset + 1. A filled section
    of F quadrilaterals and B boundary nodes has F + 1 + B / 2 nodes (Euler). Exact on
    cases/axial_wave (1,558) and the joint test's case (1,610)."""
    from .meshing.params import element_counts

    nx = sum(dv.count for _, dv in plan.left) + plan.quarter.count + sum(dv.count for _, dv in plan.right)
    nz = sum(dv.count for _, dv in plan.bottom) + plan.quarter.count + sum(dv.count for _, dv in plan.top)
    ny = len(plan.y_levels) - 1

    def at_least(k):  # section nodes at distance >= k from x_min, x_max and the base (outer grid)
        return max(nx + 1 - 2 * k, 0) * max(nz + 1 - k, 0)

    counts = element_counts(plan)
    section = (counts["rock"] + counts["lining"] + counts["water"]) / max(ny, 1) + 1 + (nx + nz)
    outer = (nx + 1) * (nz + 1) - at_least(offset)  # the rows outside the layer
    ends = 4 * (section - outer)
    sides = max(ny - 2 * offset - 3, 0) * (at_least(offset) - at_least(offset + 2))
    return int(round(ends + sides))


def drm_field_bytes(case, plan=None) -> float:
    """Bytes of the free field a DRM layer is given (u, v, a: layer nodes x time samples x 3 x 8
    bytes each); 0 without an incident wave. The samples: the processed record's (its window over
    the record's step, which free_field keeps), or an H5DRM file's own."""
    from .case import case_geology, ground_layers
    from .incident_wave import active
    from .meshing.params import resolve

    d = case.data
    if not active(d):
        return 0.0
    plan = plan or resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    nodes = drm_layer_nodes(plan, int(d["incident_wave"]["drm_offset"]))
    samples = _field_samples(case)
    return 3 * nodes * samples * 3 * 8.0 if samples else 0.0


def _field_samples(case) -> int:
    """The DRM field's time samples (0 where the record cannot be read: check says why)."""
    from .motion import MotionError, read_record, resolve_path, window_seconds

    d = case.data
    w = d["incident_wave"]
    if w["type"] == "h5drm":
        import h5py

        try:
            with h5py.File(resolve_path(w["h5drm"]["file"], case.dir), "r") as f:
                return int(f["DRM_Data/displacement"].shape[1])
        except (OSError, KeyError):
            return 0
    gm = d["ground_motion"]
    window = window_seconds(gm, case.dir)
    if not window:
        return 0
    if gm["source"] == "file":
        try:
            dt = read_record(resolve_path(gm["file"], case.dir), gm["format"], gm["units"]).dt
        except MotionError:
            dt = gm["synthetic"]["dt"] if gm["if_missing"] == "synthetic" else 0.0
    else:
        dt = gm["synthetic"]["dt"]
    return int(round(window / dt)) + 1 if dt > 0 else 0


def with_drm_memory(need: dict, case, plan=None) -> dict:
    """meshing.params.memory_estimate's `need` with the DRM field added to 'run' (the driver's copies
    and each tq-solid's: two at once beside the coupled condition, as memory_estimate counts them),
    and 'drm_field' the field's own bytes."""
    field_bytes = drm_field_bytes(case, plan)
    conds = list(case.data["conditions"])
    solids = 2 if "dynamic_water" in conds and len(conds) > 1 else 1
    out = dict(need)
    out["run"] = need["run"] + (DRIVER_DRM_COPIES + solids * SOLID_DRM_COPIES) * field_bytes
    out["drm_field"] = field_bytes
    return out
