"""tunnelquake run: the main job. Validates the case, meshes it, prepares the motion, then runs each
condition with only the solvers it needs, and post-processes.

  no_water       solid only (rock + lining), no fluid process, no coupling
  static_water   solid only, with the hydrostatic pressure on the lining's inner face
  dynamic_water  solid + OpenFOAM water, coupled every step
"""
from __future__ import annotations

import time

from .. import paths
from ..motion import MotionError
from ..scene import plan
from .common import load_or_report, parser, say


def solver_status() -> dict[str, str | None]:
    """Which participants can run today; None means ready, else the reason it cannot."""
    solid = paths.solid_executable()
    fluid = paths.openfoam_library()
    return {
        "solid": None if solid and _solid_runs_cases(solid) else
        "the solid solver does not run staged seismic cases yet (issue 3: tq-solid)",
        # The OpenFOAM library may be built, but the coupler that joins it to the solid is not yet.
        "fluid": "the coupled water side is not in place yet (issues 5 and 6)"
        if fluid else "the OpenFOAM-side library is not built (run scripts/bootstrap.sh)",
    }


def _solid_runs_cases(exe) -> bool:
    import subprocess

    try:
        out = subprocess.run([str(exe), "--capabilities"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return out.returncode == 0 and "staged-seismic" in out.stdout


def run_solid_condition(case, cond: str, motion_file) -> tuple[int, object]:
    """Write this condition's solid input and run tq-solid on it; results_<cond>.h5 beside the
    report. tq-solid exits 0 when completed, 2 on bad input, 3 when it stopped (unstable...)."""
    import subprocess

    from ..solid_input import write_solid_input
    from .mesh import mesh_dir

    work = case.output_dir / cond
    inp = write_solid_input(case, mesh_dir(case) / "mesh.h5", motion_file, cond, work / "solid_input.h5")
    res = case.output_dir / f"results_{cond}.h5"
    cmd = [str(paths.solid_executable()), str(inp), "-o", str(res)]
    threads = case.data["parallel"]["threads"]
    if threads:
        cmd += ["--threads", str(threads)]
    say(f"condition {cond}: running the solid ({' '.join(cmd)})")
    return subprocess.run(cmd).returncode, res


def main(argv: list[str]) -> int:
    p = parser("run", __doc__)
    p.add_argument("--no-post", action="store_true", help="skip post-processing")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    case = load_or_report(args.case)
    if case is None:
        return 1
    say(f"case '{case.data['name']}' valid; results go to {case.output_dir}")
    done: list[str] = []
    skipped: list[str] = []
    failed: list[str] = []

    from .mesh import make_mesh

    summary = make_mesh(case)
    c = summary["counts"]
    done.append(f"mesh: {c['rock']} rock, {c['lining']} lining, {c['water']} water hexahedra "
                f"({summary['mode']})")

    from .motion import make_motion, plot_motion

    try:
        motion, motion_file = make_motion(case)
    except MotionError as e:
        print(f"error: {e}")
        return 1
    fig = case.output_dir / "figures" / "fig03_input_motion.png"
    plot_motion(motion, fig)
    done.append(f"motion: {motion.record.source} -> {motion_file.name}, {fig.name}")

    status = solver_status()
    for cond, parts in plan(case):
        missing = [status[p] for p in parts if status[p] is not None]
        runs = " + ".join(parts)
        if missing:
            say(f"condition {cond}: would run {runs}; not run: {'; '.join(missing)}")
            skipped.append(f"{cond} ({runs}): {'; '.join(missing)}")
            continue
        rc, res = run_solid_condition(case, cond, motion_file)
        if rc == 0:
            done.append(f"{cond} ({runs}): completed -> {res.name}")
        else:
            failed.append(f"{cond} ({runs}): tq-solid stopped (exit {rc}); see the message above; "
                          f"what was written is in {res.name}")

    if not args.no_post:
        from .post import post_case

        report = post_case(case)
        done.append(f"post: {report}")

    say(f"finished in {time.perf_counter() - t0:.1f} s")
    say("done:")
    for d in done:
        say(f"  + {d}")
    if skipped:
        say("not run (the solver pieces are still being built):")
        for s in skipped:
            say(f"  - {s}")
    if failed:
        say("FAILED:")
        for s in failed:
            say(f"  ! {s}")
        return 1
    return 0
