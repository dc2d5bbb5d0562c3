"""Running a case: mesh, motion, then each condition with only the solvers it needs, then post.

  no_water       solid only (rock + lining), no fluid process, no coupling
  static_water   solid only, with the hydrostatic pressure on the lining's inner face
  dynamic_water  solid + OpenFOAM water, coupled every step

run_held takes the results folder and runs the job (run_case) under the supervisor (supervise.py);
`resume` continues each condition from its restart checkpoint (restart.resume_plan).
"""
from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

from . import children, paths, supervise
from .case_report import OutputsNotWritten, post_case
from .children import Side, lost_its_partner, say, watch_pair
from .cores import concurrent_conditions, solid_env
from .files import DiskFull, is_no_space
from .fingerprint import condition_inputs
from .prepare import make_mesh, mesh_dir, motion_and_figure
from .rates import WATER_RANK_CELLS
from .restart import (
    checkpoint_dir,
    coupled_resume_point,
    fluid_ranks_problem,
    forget_resume_source,
    keep_resume_source,
    resume_args,
    resume_plan,
)
from .scene import plan
from .solid_input import solid_threads
from .supervise import progress, started


def solver_status() -> dict[str, str | None]:
    """Which participants can run today; None means ready, else the reason it cannot."""
    solid = paths.solid_executable()
    fluid = paths.openfoam_library()
    caps = _solid_capabilities(solid) if solid else set()
    return {
        "solid": None if "staged-seismic" in caps else
        "the solid solver does not run staged seismic cases yet (rebuild tq-solid)",
        "fluid": None if fluid and "water-coupling" in caps else
        ("the OpenFOAM-side library is not built (run scripts/bootstrap.sh)" if not fluid else
         "tq-solid does not report the water-coupling capability (rebuild it)"),
    }


def _solid_capabilities(exe) -> set[str]:
    """What this tq-solid build can run (`tq-solid --capabilities`); empty if it cannot say."""
    import subprocess

    try:
        out = children.run([str(exe), "--capabilities"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return set()
    return set(out.stdout.split()) if out.returncode == 0 else set()


def run_solid_condition(case, cond: str, motion_file, prefix: bool = False,
                        resume: bool | dict = False, ranks: int = 1) -> tuple[int, object]:
    """Write this condition's solid input and run tq-solid on it; results_<cond>.h5 beside the
    report. tq-solid exits 0 when completed, 2 on bad input, 3 when it stopped (unstable...), 4 when
    the water coupling stopped (dynamic_water: partner lost, timeout, handshake, divergence).
    With `resume`, tq-solid continues from the condition's last restart checkpoint (a manifest:
    from that one, restart.condition_choice's newest intact checkpoint)."""
    import subprocess

    from .solid_input import SolidInputError, write_solid_input

    work = case.output_dir / cond
    res = case.output_dir / f"results_{cond}.h5"
    with children.FORK_LOCK:  # no child may be created while these HDF5 files are open
        try:
            inp = write_solid_input(case, mesh_dir(case) / "mesh.h5", motion_file, cond, work / "solid_input.h5")
        except SolidInputError as e:  # (e.g. an incident wave's within record that cannot be deconvolved)
            say(f"condition {cond}: no solid input: {e}")
            return 2, res
        threads = solid_threads(case, mesh_dir(case) / "mesh.h5", 2 if prefix else 1)
    if ranks > 1:  # on MPI ranks (solid_ranks): one thread a rank unless the cores allow more
        from .solid_ranks import solid_command

        threads = max(1, threads // ranks)
        cmd = solid_command(paths.solid_executable(), inp, res, threads, ranks)
    else:
        cmd = [str(paths.solid_executable()), str(inp), "-o", str(res), "--threads", str(threads)]
    if float(case.data["output"]["checkpoint_interval"]) > 0 or resume:
        cmd += ["--checkpoint-dir", str(checkpoint_dir(case, cond))]
    if isinstance(resume, dict):
        resume = keep_resume_source(case, cond, resume)
    elif not resume:
        forget_resume_source(case, cond)
    if resume:
        cmd += resume_args(resume) if isinstance(resume, dict) else ["--resume"]
    started(cond, res)
    say(f"condition {cond}: running the solid{f' on {ranks} ranks' if ranks > 1 else ''} ({' '.join(cmd)})")
    if not prefix:
        return children.run(cmd, env=solid_env()).returncode, res
    # beside another condition: each line of tq-solid's progress says which condition it is
    with children.popen(cmd, env=solid_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                        bufsize=1) as proc:
        for line in proc.stdout:
            progress(cond, line)
            say(f"[{cond}] {line.rstrip()}")
    return proc.returncode, res


def _fluid_echo():
    """Which OpenFOAM lines reach the terminal: errors, the library's messages, the end, and the
    simulated time every 5 s of wall time."""
    import time as _time

    last = [0.0]
    # OpenFOAM's error block (its FATAL line to "FOAM exiting") is echoed whole, unless it only
    # repeats the solid's error ("'solid' stopped on an error while ...", within its first lines):
    # the solid's own line says that, once.
    state = ["idle"]  # idle, held (the block's first lines, waiting), relay, fatal
    held: list[str] = []

    def echo(line: str) -> bool:
        if line.startswith("tqInterface interface: t ="):  # one per pass: to the log only
            return False
        if state[0] == "held":  # the block's first lines, until one says whose error it is
            if "stopped on an error while" in line:
                state[0] = "relay"
                held.clear()
            elif len(held) < 4 and not line.lstrip().startswith(("From function", "FOAM exiting")):
                held.append(line)
                return False
            else:
                for h in held:
                    if h.strip():
                        say(f"  [water] {h.rstrip()}")
                held.clear()
                state[0] = "fatal"
        if state[0] in ("relay", "fatal"):
            shown = state[0] == "fatal" and bool(line.strip())
            if "FOAM exiting" in line:
                state[0] = "idle"
            return shown
        if "FATAL" in line and "ERROR" in line:
            state[0] = "held"
            held.append(line)
            return False
        if "FATAL" in line or "tqInterface" in line or "coupler" in line.lower() or line.startswith("End"):
            return True
        if "MPI_ABORT" in line or line.startswith(("mpirun", "Primary job", "nProcs")):  # parallel runs, mpirun
            return True
        if line.startswith("Time = ") and _time.monotonic() - last[0] > 5.0:
            last[0] = _time.monotonic()
            return True
        return False

    return echo


def _water_extents(case, mesh_h5) -> tuple[float, float, float]:
    """The water's box (x, y, z extents, m): the lining's inner diameter across, the mesh's length
    along the axis y (the slice's thickness in slice mode)."""
    import h5py

    g = case.data["geometry"]
    d = 2.0 * (float(g["excavated_radius"]) - float(g["lining_thickness"]))
    with h5py.File(mesh_h5, "r") as f:
        y = f["nodes/coordinates"][:, 1]
    return d, float(y.max() - y.min()), d


#: tq-solid's exit code when the file system refused its results (a full disk, a quota, an I/O error)
SOLID_OUTPUT_ERROR = 5


def _ran_out_of_space(folder, sides) -> bool:
    """Whether a failed condition met a full disk: tq-solid said so (exit 5 with the reason), a
    solver's last lines or its log's writing met ENOSPC, or the disk holding `folder` is full now."""
    from .files import free_bytes

    for side in sides:
        if side.log_error is not None and is_no_space(side.log_error):
            return True
        if any("No space left on device" in line for line in side.lines):
            return True
    return free_bytes(folder) < 65536


def _disk_full_note(folder) -> str:
    from .files import free_bytes, human_bytes

    return (f"no space left on the disk holding {folder} ({human_bytes(free_bytes(folder))} free). Fix: free space "
            f"there, or set output.directory to a disk with room, and run again")


def run_coupled_condition(case, cond: str, motion_file, share: int = 1,
                          resume: bool = False, solid_ranks: int = 1) -> tuple[int, object, str]:
    """Condition dynamic_water: tq-solid (listener, first participant) + OpenFOAM (second), joined
    by the coupler over TCP; `share`: the solvers running at once (solid_threads). Returns (exit code, results path, what happened). Exit code: 0 both
    completed; else the failing side's (tq-solid: 2 input, 3 unstable, 4 coupling; OpenFOAM: 1).

    parallel.fluid_ranks N > 1: the water case is decomposed (fluid_case.decompose: decomposePar,
    method simple) and the water runs as `mpirun -np N <solver> -parallel` (each rank a part of the
    coupler's participant with its own face points; fluid_case.mpirun_command); its fields are
    reconstructed at the end (reconstructPar; the processor folders stay in <fluid>/processor*).

    `solid_ranks` > 1: tq-solid runs on that many MPI ranks (solid_ranks.solid_command), each rank
    exchanging the wet nodes it owns with the water over its own connection (a part of the coupler's
    first participant).

    Restart checkpoints (output.checkpoint_interval > 0): both sides write theirs into
    <condition>/checkpoint at every K-th completed window (settings' checkpoint_windows; the solid
    on ranks gathers its ranks' parts into one, and so does the water on ranks (fluid-<window>.bin),
    each resumed on the same rank count only: run_case refuses another fluid_ranks beforehand);
    with `resume` both start from the last window both wrote (restart.coupled_resume_point), with
    the interrupted run's token (the solid's input, and so its fingerprint, is then the same)."""
    import secrets
    import time as _time

    import h5py

    from . import fluid_case as fc
    from .solid_input import solid_step, write_solid_input

    work = case.output_dir / cond
    work.mkdir(parents=True, exist_ok=True)
    res = case.output_dir / f"results_{cond}.h5"
    exe = paths.solid_executable()
    token = secrets.token_hex(16)
    point = coupled_resume_point(case, cond) if resume else None
    if point is not None:
        point = keep_resume_source(case, cond, point)
    else:
        forget_resume_source(case, cond)
    if point is not None:
        with h5py.File(work / "solid_input.h5", "r") as f:
            token = str(f["coupling"].attrs["token"])
    addr = work / "wall.addr"
    addr.unlink(missing_ok=True)
    for stale in work.glob("wall.addr.part*"):  # the solid's parts on ranks (a stopped run's)
        stale.unlink(missing_ok=True)
    mesh_h5 = mesh_dir(case) / "mesh.h5"
    # The whole set-up holds FORK_LOCK: it writes and reads back HDF5 files and starts children
    # (tq-solid --check, OpenFOAM's utilities) while other conditions may be starting theirs.
    children.FORK_LOCK.acquire()
    try:
        # the solid's input without the coupling first, for tq-solid's step; then the one coupling
        # settings object both sides are given, in the input written again with its /coupling group
        inp = write_solid_input(case, mesh_h5, motion_file, cond, work / "solid_input.h5")
        with h5py.File(inp, "r") as f:
            t_end = float(f["solver"].attrs["t_end"])
        with h5py.File(mesh_h5, "r") as f:
            slice_mode = int(f.attrs.get("slice", 0)) == 1
        window = fc.coupling_window_size(case.data["coupling"]["window"], solid_step(exe, inp))
        settings = fc.coupling_settings(case, window, addr, token, t_end=t_end)
        inp = write_solid_input(case, mesh_h5, motion_file, cond, inp, coupling=settings)
        ranks = int(case.data["parallel"]["fluid_ranks"])
        every = settings["checkpoint_windows"]
        restart = None
        if every > 0:
            restart = {"restart_dir": str(checkpoint_dir(case, cond)), "restart_windows": every,
                       "restart_from": str(point["fluid"]) if point is not None else None,
                       "input_fingerprint": condition_inputs(case, cond)["digest"]}
        fluid = fc.build_fluid_case(case, mesh_dir(case) / "water.msh", work / "fluid", settings, slice_mode,
                                    restart=restart)
        env = fc.fluid_env()
        env[fc.TOKEN_ENV] = token
        fluid_cmd = [fluid.solver, "-case", str(fluid.path)]
        if ranks > 1:
            dec = fc.decompose(fluid.path, ranks, _water_extents(case, mesh_h5), slice_mode)
            fluid_cmd = fc.batch_scheduled(fc.mpirun_command(ranks, fluid.solver, fluid.path, env))
            say(f"condition {cond}: water decomposed on {ranks} ranks (simple, n = {dec['split']}): cells "
                f"{', '.join(map(str, dec['cells']))}, {dec['processor_faces']} processor faces; log "
                f"{fluid.path / 'log.decomposePar'}")
            if min(dec["cells"]) < WATER_RANK_CELLS:
                say(f"condition {cond}: note: {min(dec['cells'])} water cells a rank is below "
                    f"{WATER_RANK_CELLS}: the exchange and the ranks' communication outweigh the split "
                    f"solve, expect no speed-up over parallel.fluid_ranks: 1 (docs/coupler.md)")
    except (fc.FluidCaseError, RuntimeError, ValueError, OSError) as e:
        if is_no_space(e):
            e = f"{e}; {_disk_full_note(case.output_dir)}"
        say(f"condition {cond}: cannot set up the coupled run: {e}")
        return 2, res, f"not started: {e}"
    finally:
        children.FORK_LOCK.release()
    say(f"condition {cond}: {settings['windows']} coupling windows of {settings['window_size']:.6g} s "
        f"({settings['scheme']}, {settings['acceleration']}); water: {fluid.solver} ({fluid.model}, {fluid.mode}) "
        f"in {fluid.path}")

    solid_env_ = solid_env()
    with children.FORK_LOCK:
        threads = solid_threads(case, mesh_h5, share)
    solid_cmd = [str(exe), str(inp), "-o", str(res), "--threads", str(threads)]
    if solid_ranks > 1:
        from .solid_ranks import solid_command

        solid_cmd = solid_command(exe, inp, res, max(1, threads // solid_ranks), solid_ranks)
    if restart is not None:
        solid_cmd += ["--checkpoint-dir", restart["restart_dir"]]
        if point is not None:
            solid_cmd += resume_args(point)
    started(cond, res)
    t0 = _time.perf_counter()
    say(f"condition {cond}: running the solid ({' '.join(solid_cmd)}); log {work / 'solid.log'}")
    solid = Side("solid", solid_cmd, work / "solid.log", solid_env_, lambda line: progress(cond, line))
    fluid_side = None
    timeout = settings["timeout"]
    # the solid publishes its address after its static stages (relaxation: no time limit known)
    while fluid_side is None:
        if addr.exists():
            say(f"condition {cond}: solid listening; running the water ({' '.join(fluid_cmd)}); "
                f"log {work / 'fluid.log'}")
            fluid_side = Side("water", fluid_cmd, work / "fluid.log", env, _fluid_echo())
            break
        if solid.proc.poll() is not None or children.stopping.is_set():
            break
        _time.sleep(0.05)

    failed = None
    if fluid_side is not None:
        failed = watch_pair(solid, fluid_side, timeout)
        fluid_side.close()
    else:  # the solid ended before publishing its address: it never coupled
        solid.proc.wait()
        failed = solid
    solid.close()
    wall = _time.perf_counter() - t0
    if children.stopping.is_set():  # stopped by a signal: the supervisor says what and why
        return 130, res, "interrupted"
    on = ""
    if ranks > 1:
        on = f" on {ranks} ranks"
        if fluid_side is not None:
            with children.FORK_LOCK:  # reconstructPar is a child too
                say(f"condition {cond}: {fc.reconstruct(fluid.path)}")
    if failed is not None:
        rc = failed.proc.returncode or 1
        side = "tq-solid (solid)" if failed is solid else f"{fluid.solver}{on} (water)"
        unseen = failed.tail()
        say(f"condition {cond}: {side} failed with exit code {rc}; its log: {failed.log}" + (f"\n{unseen}" if unseen
                                                                                           else ""))
        why = f"{side} failed (exit {rc}) after {wall:.1f} s; see {failed.log}"
        partner = fluid_side if failed is solid else solid
        if partner is not None and lost_its_partner(partner):
            say(f"condition {cond}: the {partner.name} stopped because the {failed.name} did (its log: {partner.log})")
        elif partner is not None and partner.ended_after is not None:
            say(f"condition {cond}: the {partner.name} was ended by run {partner.ended_after:.0f} s after the "
                f"{failed.name} failed: it had not met the loss by itself (its log: {partner.log})")
        if _ran_out_of_space(case.output_dir, [x for x in (solid, fluid_side) if x is not None]):
            note = _disk_full_note(case.output_dir)
            say(f"condition {cond}: stopped by a full disk: {note}")
            why = f"stopped by a full disk after {wall:.1f} s ({side} first, exit {rc}): {note}"
        return (rc if failed is solid else 1), res, f"{why}; {what_was_written(res)}"
    return 0, res, f"coupled with {fluid.solver}{on} in {wall:.1f} s (logs: {work / 'solid.log'}, {work / 'fluid.log'})"


def what_was_written(res: Path) -> str:
    """Where a stopped condition's results are, said only of a file that exists and opens."""
    if not res.is_file():
        return f"no results file was written ({res.name} does not exist)"
    try:
        import h5py

        with h5py.File(res, "r") as f:
            status = f.attrs.get("status", "unknown")
            status = status.decode() if isinstance(status, bytes) else str(status)
    except OSError:
        return f"{res.name} is there but does not open as HDF5 (the solver stopped while writing it)"
    if status == "running":  # its solver has ended: the file is cut off, never still running
        if not supervise.rewritten(res):
            return (f"{res.name} is as an earlier run left it, cut off where that run was stopped (this run's solver "
                    "did not write to it; `tunnelquake post` reports it up to its last sample)")
        return (f"what the solid wrote is in {res.name}, cut off: its solver ended without writing a status "
                "(`tunnelquake post` reports it up to its last sample)")
    if len(status) > 120:  # the solver's own message above says the whole of it, once
        cut = status.find(". ")
        status = (status[:cut] if 0 < cut <= 160 else status[:120].rsplit(" ", 1)[0]) + " ... (in full above)"
    return f"what the solid wrote is in {res.name} (status {status})"


def run_case(case, resume: bool = False, post: bool = True, ranks: int = 1) -> int:
    """The run itself: mesh, motion, the conditions (`resume`: from their restart checkpoints,
    restart.resume_plan; `ranks`: every condition's solid on that many MPI ranks), post.
    Raises children.Interrupted when a signal stops it between steps."""
    t0 = time.perf_counter()
    which = f" (variant {case.variant})" if case.variant else ""
    resuming: dict[str, str] = {}
    if resume:
        resuming, nothing, afresh = resume_plan(case)
        if nothing is not None and afresh:
            say(f"resume: {nothing}")
            resuming = {}
        elif nothing is not None:
            say(nothing)
            return 0
        for cond, what in resuming.items():
            for note in getattr(what, "notes", ()):
                say(f"resume: {cond}: {note}")
            if what == "checkpoint":
                m = what.point
                say(f"resume: {cond} continues from its checkpoint at t = {float(m['time']):.6g} s")
            elif what == "completed":
                say(f"resume: {cond} completed earlier: kept")
            else:
                say(f"resume: {cond} runs from the start" if getattr(what, "notes", None) else
                    f"resume: {cond} has no restart checkpoint: it runs from the start")
        refused = [fluid_ranks_problem(case, cond, what.point) for cond, what in resuming.items()
                   if what == "checkpoint"]
        refused = [why for why in refused if why is not None]
        for why in refused:
            print(f"error: cannot resume {why}", file=sys.stderr)
        if refused:
            return 1
    say(f"case '{case.data['name']}'{which} valid; results go to {case.output_dir}")
    done: list[str] = []
    skipped: list[str] = []
    failed: list[str] = []

    supervise.PHASE[0] = "meshing"
    try:
        summary = make_mesh(case)
    except DiskFull as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    c = summary["counts"]
    done.append(f"mesh: {c['rock']} rock, {c['lining']} lining, {c['water']} water hexahedra "
                f"({summary['mode']})")

    children.check()
    supervise.PHASE[0] = "preparing the motion"
    later: list = []  # a new motion's figure: drawn beside the conditions, not before them
    made = motion_and_figure(case, reuse=True, later=later)
    if made is None:
        return 1
    source, motion_file, fig = made
    done.append(f"motion: {source} -> {motion_file.name}, {fig.name}")
    if later:
        later[:] = [_motion_figure(later[0], failed)]
    try:
        return _conditions_and_post(case, resuming, post, ranks, motion_file, later, done, skipped, failed, t0)
    finally:
        if later:  # left by a stop or an error: drawn as if before the conditions
            later.pop()()


def _motion_figure(draw, failed: list[str]):
    """`draw` (the motion's figure and motion.json, prepare.motion_and_figure's `later`), its error
    (a full disk) said and added to `failed` instead of raised: the conditions' results stay, and
    post goes on without the figure."""
    def figure() -> None:
        try:
            draw()
        except Exception as e:  # noqa: BLE001 - said; the next run makes the motion again (no motion.json)
            say(f"error: the motion's figure not drawn: {e}")
            failed.append(f"motion figure: {type(e).__name__}: {e}")

    return figure


def _keep_rates(case, cond: str, res: Path, resumed: bool, ranks: int) -> None:
    """A completed condition's measured time against check's estimate of it, kept for later
    estimates on this machine (scene.record_run_rates); said in one line. Not for a condition
    continued from a checkpoint (its time covers the part after it) nor for a solid on several ranks (the
    estimate is of one process)."""
    from .scene import record_run_rates

    if resumed or ranks != 1:
        return
    kept = record_run_rates(case, cond, res)
    if kept:
        said = ", ".join(f"{k} x{r:.2f}" for k, r in kept.items())
        say(f"condition {cond}: measured against check's estimate: {said} (kept for this machine's next estimates)")


def _conditions_and_post(case, resuming, post, ranks, motion_file, later, done, skipped, failed, t0) -> int:
    """run_case's conditions and post (`later`: the motion's figure still to draw, drawn by the first
    path of conditions to end while another runs, else after them)."""
    from .post_early import EarlyPost

    early = EarlyPost(case) if post else None
    completed: list[str] = []  # conditions whose solver exited 0 (their results files whole)

    def idle_work(other_running: bool) -> None:
        """A path of conditions has ended: with another still running, the motion's figure and
        post's per-condition work of the completed conditions on the core it leaves idle."""
        if not other_running:
            return
        if early is None:
            while later:
                later.pop(0)()
            return
        try:
            early.idle(list(completed), later)
        except children.Interrupted:
            raise
        except Exception as e:  # noqa: BLE001 - post does what is left, and meets the error itself
            say(f"post's work beside the running condition(s) stopped ({type(e).__name__}: {e}); post does it")

    children.check()
    supervise.PHASE[0] = "running the conditions"
    status = solver_status()
    runnable: list[tuple[str, tuple]] = []
    for cond, parts in plan(case):
        if resuming.get(cond) == "completed":
            done.append(f"{cond} ({' + '.join(parts)}): completed earlier, kept")
            continue
        missing = [status[p] for p in parts if status[p] is not None]
        runs = " + ".join(parts)
        if missing:
            say(f"condition {cond}: would run {runs}; not run: {'; '.join(missing)}")
            skipped.append(f"{cond} ({runs}): {'; '.join(missing)}")
        else:
            runnable.append((cond, parts))

    def coupled(cond, parts, share=1):
        runs = " + ".join(parts)
        rc, res, why = run_coupled_condition(case, cond, motion_file, share,
                                             resume=resuming.get(cond) == "checkpoint", solid_ranks=ranks)
        if children.stopping.is_set():
            return
        if rc == 0:
            forget_resume_source(case, cond)
            done.append(f"{cond} ({runs}): completed -> {res.name}; {why}")
            completed.append(cond)
            _keep_rates(case, cond, res, resuming.get(cond) == "checkpoint", ranks)
        else:
            failed.append(f"{cond} ({runs}): {why}")

    def solid_only(cond, parts, prefix):
        runs = " + ".join(parts)
        t1 = time.perf_counter()
        choice = resuming.get(cond)
        rc, res = run_solid_condition(case, cond, motion_file, prefix=prefix,
                                      resume=choice.point if choice == "checkpoint" else False, ranks=ranks)
        children.check()
        if rc == 0:
            forget_resume_source(case, cond)
            done.append(f"{cond} ({runs}): completed -> {res.name} in {time.perf_counter() - t1:.1f} s")
            completed.append(cond)
            _keep_rates(case, cond, res, choice == "checkpoint", ranks)
        elif rc == SOLID_OUTPUT_ERROR:
            from .files import free_bytes, human_bytes

            kept = f"what was written is in {res.name}" if res.is_file() else f"{res.name} was not started"
            failed.append(f"{cond} ({runs}): tq-solid could not write its results (exit {rc}; its message above says "
                          f"why; {human_bytes(free_bytes(case.output_dir))} free now on the disk holding "
                          f"{case.output_dir}); {kept}")
        else:
            failed.append(f"{cond} ({runs}): tq-solid stopped (exit {rc}); see the message above; "
                          f"{what_was_written(res)}")

    # The coupled condition (solid and water take turns: about one core) runs beside the solid-only
    # ones (one core) when the machine has two cores or more; otherwise one after the other.
    water = [(c, p) for c, p in runnable if "fluid" in p]
    alone = [(c, p) for c, p in runnable if "fluid" not in p]
    side_by_side = bool(water) and bool(alone) and concurrent_conditions() > 1
    thread = None
    beside_error: list[BaseException] = []
    alone_done, water_done = threading.Event(), threading.Event()
    if side_by_side:
        say(f"running {', '.join(c for c, _ in water)} beside {', '.join(c for c, _ in alone)} "
            f"({concurrent_conditions()} cores)")
        def beside():
            try:
                for c, p in water:
                    coupled(c, p, 2)
                water_done.set()
                idle_work(not alone_done.is_set())
            except children.Interrupted:
                pass
            except BaseException as e:  # noqa: BLE001 - raised by the job once the solid-only path is done
                beside_error.append(e)

        thread = threading.Thread(target=beside, daemon=True)
        thread.start()
    else:
        for c, p in water:
            coupled(c, p)
    try:
        for c, p in alone:
            solid_only(c, p, side_by_side)
        alone_done.set()
        if thread is not None:
            idle_work(not water_done.is_set())
    except children.Interrupted:
        # the job ends only with the thread beside it: that thread may be inside h5py (writing its
        # condition's input), and a process finalized beside it never ends; the supervisor bounds
        # this wait (supervise.JOB_WIND_DOWN_S) and ends the process at once when it runs over
        if thread is not None:
            thread.join()
        raise
    if thread is not None:
        thread.join()
        if beside_error:
            raise beside_error[0]
    while later:  # not drawn beside a condition: drawn now, as before the conditions
        later.pop(0)()

    children.check()
    supervise.PHASE[0] = "post-processing"
    if post:
        try:
            report = post_case(case, early)
        except OutputsNotWritten as e:
            failed.append(f"post: {e}")
        except Exception as e:  # noqa: BLE001 - the conditions' results stay; say why the report is missing
            failed.append(f"post: {type(e).__name__}: {e} (the results files are kept; `tunnelquake post` retries)")
        else:
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


def run_held(case, command: str, resume: bool = False, post: bool = True, ranks: int = 1) -> int:
    """Take the case's results folder (one run at a time; `command` says who holds it), then run the
    job under the supervisor that turns SIGINT, SIGTERM and SIGHUP into an orderly stop."""
    import contextlib

    from .runlock import RunLockBusy, run_lock

    with contextlib.ExitStack() as stack:
        try:
            note = stack.enter_context(run_lock(case.output_dir, command))
        except RunLockBusy as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        if note:
            say(f"note: {note}")
        return supervise.supervised(case, lambda: run_case(case, resume, post, ranks) if ranks > 1
                                    else run_case(case, resume, post))
