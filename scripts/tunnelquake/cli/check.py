"""tunnelquake check: validate a case file without running anything."""
from __future__ import annotations

import sys

from ..units import STANDARD_GRAVITY
from .common import add_ranks_argument, load_for_ranks, parser, say


def mesh_estimate(d: dict, case=None) -> str:
    """One line: the hexahedra the mesh will have and the memory meshing and the run need
    (estimated from the division counts, and with `case` a DRM layer's free field: scene.with_drm_memory;
    the case's checks warn when that exceeds the machine's)."""
    from ..case import case_geology, ground_layers
    from ..meshing.params import element_counts, machine_memory, memory_estimate, resolve

    mesh_plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    counts = element_counts(mesh_plan)
    need = memory_estimate(counts, d["conditions"])
    if case is not None:
        from ..scene import with_drm_memory

        need = with_drm_memory(need, case, mesh_plan)
    have = machine_memory()
    mib = 2.0**20
    machine = f" (machine: {have['total'] / mib:,.0f} MiB)" if have else ""
    ground = "rock" if len(counts["regions"]) < 2 else (
        "ground (" + ", ".join(f"{k} {v:,}" for k, v in counts["regions"].items()) + ")")
    drm = (f" (a DRM field of {need['drm_field'] / mib:,.0f} MiB in it)" if need.get("drm_field") else "")
    return (f"mesh: {counts['rock']:,} {ground} + {counts['lining']:,} lining + {counts['water']:,} water hexahedra; "
            f"about {need['meshing'] / mib:,.0f} MiB to mesh, {need['run'] / mib:,.0f} MiB to run{drm}{machine}")


def ranks_memory(d: dict, ranks: int) -> str:
    """One line: the estimated peak memory of rank 0 and of each other rank of the solid on `ranks` ranks
    (tunnelquake.solid_ranks.memory_per_rank, measured on a 2-million-element model)."""
    from ..case import case_geology, ground_layers
    from ..meshing.params import element_counts, resolve
    from ..solid_ranks import memory_per_rank

    counts = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    first, other = memory_per_rank(counts["rock"] + counts["lining"], ranks)
    mib = 2.0**20
    return (f"memory on {ranks} ranks: about {first / mib:,.0f} MiB on rank 0 (its part and the whole model the "
            f"results are gathered into), {other / mib:,.0f} MiB on each other rank (docs/benchmarks.md \"A "
            "2-million-element model on ranks\")")


def main(argv: list[str]) -> int:
    p = parser("check", __doc__)
    add_ranks_argument(p)
    args = p.parse_args(argv)
    case = load_for_ranks(args)
    if case is None:
        return 1
    d = case.data
    g = d["geometry"]
    gm = d["ground_motion"]
    src = {"file": gm["file"], "none": "no horizontal motion"}.get(gm["source"], f"synthetic (seed {gm['synthetic']['seed']})")
    if gm["azimuth"]:
        src += f" at azimuth {gm['azimuth']:g} deg from x towards y"
    if gm["second_horizontal"]["file"] is not None:
        src += f"; second horizontal record {gm['second_horizontal']['file']} at 90 deg to it"
    if gm["vertical"]["file"] is not None:
        src += f"; vertical record {gm['vertical']['file']}"
    from ..scene import added_mass_diagnostic, assess_slice, mesh_step_problem, plan, runtime_estimate

    estimate = runtime_estimate(case)  # its look at the mesh gives the step time.dt is held to
    step = mesh_step_problem(case, estimate.frequencies)
    if step is not None:
        print(f"error: {case.path}: {step}", file=sys.stderr)
        return 1
    which = f", variant {case.variant}" if case.variant else ""
    say(f"case '{d['name']}' is valid ({case.path}{which}); results go to {case.output_dir}")
    say(f"  block x {g['x_range']} y {g['y_range']} z {g['z_range']} m; tunnel r={g['excavated_radius']:g} m "
        f"at z={g['tunnel_centre_z']:g} m, lining {g['lining_thickness']:g} m; mesh mode {d['mesh']['mode']}")
    say(f"  materials: {', '.join(d['materials'])}; conditions: {', '.join(d['conditions'])}")
    if args.ranks > 1:
        say(f"  the solid on {args.ranks} MPI ranks (mpirun, the model partitioned between them; restart "
            f"checkpoints resume on {args.ranks} ranks only: docs/architecture.md \"The solid on ranks\")")
        say(f"  {ranks_memory(d, args.ranks)}")
        if "dynamic_water" in d["conditions"]:
            say("  dynamic_water on ranks: each rank exchanges the wet nodes it owns with the water, over its "
                "own connection")
    from ..case import ground_layers

    if ground_layers(d):
        say("  ground layers from the surface: " + ", ".join(f"{m} down to z = {z:g} m" for m, z in ground_layers(d))
            + "; below: rock")
    from ..case import fault_offset_slip

    slip = fault_offset_slip(d)
    if slip is not None:
        fo = d["fault_offset"]
        when = (f"in {fo['increments']} increment(s), before the shaking" if fo["rise_time"] is None else
                f"from t = {fo['start_time'] or 0.0:g} s over {fo['rise_time']:g} s of the run (cosine ramp), the "
                "faces held to it so that no record enters")
        say(f"  fault offset: the hanging wall moved by [{slip[0]:.4g}, {slip[1]:.4g}, {slip[2]:.4g}] m "
            f"({float((slip ** 2).sum()) ** 0.5:.4g} m) relative to the footwall on the block's faces but the top, "
            f"{when}")
    window = "the whole record" if gm["duration"] is None else f"{gm['duration']:g} s"
    pga = "the record's own" if gm["pga"] is None else f"{gm['pga']:g} m/s^2 ({gm['pga'] / STANDARD_GRAVITY:.3g} g)"
    say(f"  ground motion: {src}; window {window}; PGA {pga}; cut-off {gm['cutoff_frequency']:g} Hz; convention "
        f"{gm['convention']}")
    say(f"  {mesh_estimate(d, case)}")
    say(f"  {estimate.line()}")

    from ..restart import checkpoint_dir, coupled_resume_point, fluid_ranks_problem

    for cond, parts in plan(case):
        say(f"  condition {cond}: runs {' + '.join(parts)}")
        # a fresh run is fine; `run --resume` refuses to continue from a checkpoint of another fluid rank count
        point = coupled_resume_point(case, cond) if "fluid" in parts and checkpoint_dir(case, cond).is_dir() else None
        why = fluid_ranks_problem(case, cond, point) if point is not None else None
        if why is not None:
            print(f"warning: `tunnelquake run --resume` refuses {why}")
    if "dynamic_water" in d["conditions"]:
        am = added_mass_diagnostic(case, estimate.frequencies)
        if am.stable:
            say(f"  {am.message}")
        else:
            print(f"warning: {am.message}")
    sl = assess_slice(case)
    if d["mesh"]["mode"] == "slice" and not sl.valid:
        for r in sl.reasons:
            print(f"warning: slice mode is not equivalent to the 3D model here: {r}")
    for a in sl.advice:
        say(f"  advice: {a}")
    if d["suite"]["records"] is not None:
        from ..motion import MotionError
        from ..suite_members import combination_rule, plan_members

        try:
            members = plan_members(case)
        except (MotionError, ValueError) as e:  # the suite's checks say each record's problem first
            print(f"error: the suite's members cannot be planned: {e}", file=sys.stderr)
            return 1
        rule = combination_rule(d["suite"]["combine"], len(members))
        say(f"  suite: {len(members)} members (scaling {d['suite']['scaling']}, combined by {rule}), each in "
            f"{case.output_dir / 'members'}/<name>:")
        for m in members:
            say(f"    {m.name}: {m.record.path} ({m.record.units}, {m.record.direction}) x {m.factor:.5g}, "
                f"PGA {m.pga:.4g} m/s^2")
    if case.warnings:
        say(f"  {len(case.warnings)} warning(s) above")
    return 0
