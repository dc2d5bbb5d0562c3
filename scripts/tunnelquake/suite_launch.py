"""Running a case with a `suite:`: every member x condition, members in parallel on a process pool
(this machine's cores) or on MPI ranks (mpi4py.futures), or a Slurm job array; then suite_report.md.

Each member is a case of its own (<results>/members/<name>/case.yaml, see suite.py) run by the
single-run machinery (launch.run_held) inside a worker, its output in members/<name>/run.log and
its state in members/<name>/member.json. A member whose case file is unchanged and whose every
condition completed is never run again; a member that fails is reported and the others go on.

Stopping: SIGINT, SIGTERM or SIGHUP to `tunnelquake run` (a terminal's Ctrl-C reaches the pool's
workers too) cancels the members not started and sends SIGINT to each running member's worker,
whose run stops its solvers (children.stop_all) and marks its conditions interrupted; a worker
still there STOP_BOUND_S later is killed with what it started. `--resume` then runs what is left.

`python -m tunnelquake.suite_launch <member case> [--resume] [--no-post]` runs one member, as a Slurm
array task does; a task that Slurm requeued (SLURM_RESTART_COUNT > 0) resumes from its checkpoint
(with none, it runs from the start).
"""
from __future__ import annotations

import json
import math
import os
import re
import shlex
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from . import children
from .case_file import load_or_report
from .children import QUIET, say
from .launch import run_held
from .prepare import make_mesh, mesh_dir
from .suite_members import STATE, read_state
from .supervise import Signalled

#: s between progress lines while no member ends
PROGRESS_S = float(os.environ.get("TQ_SUITE_PROGRESS_S", "30"))
#: s the running members have, after the stop signal, to end by themselves (their own bound is
#: children.STOP_GRACE_S + KILL_WAIT_S, then supervise.JOB_WIND_DOWN_S) before their workers are killed
STOP_BOUND_S = 15.0
#: written in the suite's folder when it is being stopped: a member handed out does not start
STOP_FILE = ".suite-stop"


@dataclass(frozen=True)
class SuiteOptions:
    """What `tunnelquake run` was asked of a suite."""

    case_arg: str  # the case as given on the command line (the messages quote it)
    workers: int | None = None  # members at once (None: suite.workers, or the cores // a member's)
    executor: str | None = None  # "local" or "mpi" (None: mpi under mpi4py.futures, else local)
    resume: bool = False  # run only the members not finished
    slurm: bool = False  # write the members and a Slurm job-array script, run nothing
    no_post: bool = False  # no suite report


# ----------------------------------------------------------------------------------------------
# In the worker
# ----------------------------------------------------------------------------------------------
def _write_state(folder: Path, state: dict) -> None:
    tmp = folder / f".{STATE}.{os.getpid()}"
    tmp.write_text(json.dumps(state, indent=1) + "\n")
    os.replace(tmp, folder / STATE)


def _ignore_sigint() -> None:
    """Pool worker start: an idle worker ignores the terminal's Ctrl-C (a member's run installs its
    own handlers while it runs)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _has_checkpoint(case_file: str) -> bool:
    """Whether a condition of this member left a restart checkpoint (docs/user_guide.md "Resuming a run")."""
    from .case import load_case
    from .restart import checkpoint_manifest
    from .scene import plan

    try:
        case = load_case(Path(case_file))
    except Exception:  # noqa: BLE001 - the member's own run reports a case it cannot read
        return False
    return any(checkpoint_manifest(case, cond) is not None for cond, _ in plan(case))


def run_member(case_file: str, no_post: bool = False, stop_file: str | None = None, resume: bool = False) -> dict:
    """Run one member (as `tunnelquake run <member case>` does) in this process, its output to run.log
    beside it; returns {name, rc, status, wall_s}. A member whose turn comes once `stop_file`
    exists (the suite is being stopped; a pool may have handed it out already) does not start.
    With `resume`, a member that left a restart checkpoint continues from it (`run --resume`; its
    run.log is appended to); one without runs from the start."""
    import traceback

    # members share the machine with one another: their times are not this machine's measure of a
    # lone run, and check's later estimates do not learn from them (rates.record_run)
    os.environ["TQ_RATES_RECORD"] = "0"
    folder = Path(case_file).parent
    name = folder.name
    if stop_file is not None and Path(stop_file).exists():
        return {"name": name, "rc": None, "status": "not started", "wall_s": 0.0}
    t0 = time.time()
    state = {"name": name, "status": "running", "pid": os.getpid(), "host": os.uname().nodename, "started": t0}
    _write_state(folder, state)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    rc = 1
    again = resume and _has_checkpoint(case_file)
    with open(folder / "run.log", "a" if again else "w") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            argv = [case_file, *(["--no-post"] if no_post else []), *(["--resume"] if again else [])]
            if again:
                say(f"--- {time.strftime('%Y-%m-%d %H:%M:%S')}: tunnelquake run {shlex.join(argv)}")
            case = load_or_report(Path(case_file))
            rc = 1 if case is None else run_held(case, "tunnelquake run " + shlex.join(argv), resume=again,
                                                 post=not no_post)
        except BaseException:  # noqa: BLE001 - a member's crash is its own; the suite goes on
            traceback.print_exc()
            rc = 1
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
    status = "completed" if rc == 0 else ("interrupted" if rc > 128 else "failed")
    state.update(status=status, rc=rc, wall_s=time.time() - t0, ended=time.time())
    _write_state(folder, state)
    return {"name": name, "rc": rc, "status": status, "wall_s": state["wall_s"]}


# ----------------------------------------------------------------------------------------------
# The driver
# ----------------------------------------------------------------------------------------------
def member_need(case, mesh_h5) -> int:
    """Cores one member uses: its solid's threads, and the water's ranks beside them for
    dynamic_water."""
    from .solid_input import solid_threads
    from .suite_members import member_conditions

    threads = solid_threads(case, mesh_h5)
    conds = member_conditions(case)
    if "dynamic_water" not in conds:
        return threads
    ranks = int(case.data["parallel"]["fluid_ranks"])
    return max(threads, ranks) + (threads if len(conds) > 1 else 0)


_SIMULATED = re.compile(r"t = ([0-9.eE+-]+) s / ([0-9.eE+-]+) s")


def member_fraction(folder: Path, conditions: int) -> float | None:
    """How far a running member is, from its run.log: the conditions whose solver completed and the
    simulated time of the last progress line of tq-solid (`t = 8.9 s / 20 s ...`); None before one."""
    try:
        text = (Path(folder) / "run.log").read_text(errors="replace")
    except OSError:
        return None
    done = text.count("tq-solid: completed")
    matches = list(_SIMULATED.finditer(text[-4096:]))
    last = matches[-1] if matches else None
    if last is None and not done:
        return None
    part = float(last.group(1)) / float(last.group(2)) if last is not None and float(last.group(2)) > 0 else 0.0
    return min(1.0, (done + (part if done < conditions else 0.0)) / max(conditions, 1))


def _progress(members, todo, results: dict, workers: int, t0: float, conditions: int = 1) -> str:
    now = time.time()
    done = [n for n in results]
    running, elapsed, totals = [], [], []
    for m in todo:
        if m.name in results:
            continue
        st = read_state(m.folder)
        if st.get("status") == "running" and st.get("started", 0) >= t0 - 1:
            running.append(m.name)
            elapsed.append(now - st["started"])
            f = member_fraction(m.folder, conditions)
            if f is not None and f > 0.02:
                totals.append(elapsed[-1] / f)
    left = len(todo) - len(done) - len(running)
    failed = sum(1 for r in results.values() if r["status"] != "completed")
    walls = [r["wall_s"] for r in results.values() if r["status"] == "completed"] or totals
    if walls:
        mean = sum(walls) / len(walls)
        eta_s = (left * mean + sum(max(mean - e, 0.0) for e in elapsed)) / max(workers, 1)
        eta = f"ETA {_dur(eta_s)}"
    else:
        eta = "ETA once a member has started shaking"
    kept = len(members) - len(todo)
    return (f"suite: {len(done) + kept} done{f' ({kept} earlier)' if kept else ''}, {len(running)} running, "
            f"{left} left of {len(members)}; {failed} failed; {_dur(now - t0)} elapsed, {eta}")


def _dur(s: float) -> str:
    s = max(0.0, s)
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


def _executor(kind: str, workers: int):
    if kind == "mpi":
        from mpi4py.futures import MPIPoolExecutor

        ex = MPIPoolExecutor(max_workers=workers)
        n = getattr(ex, "num_workers", None) or workers
        return ex, int(n)
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    ctx = multiprocessing.get_context("spawn")
    return ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_ignore_sigint), workers


def _under_mpi4py_futures() -> bool:
    if "mpi4py.futures" not in sys.modules:
        return False
    from mpi4py import MPI

    return MPI.COMM_WORLD.Get_size() > 1


def _stop_members(todo, pool) -> dict:
    """SIGINT to each running member's worker on this host, wait up to STOP_BOUND_S for them to
    end, then SIGKILL what is left (with the process groups of its children)."""
    host = os.uname().nodename
    pids = set()
    for m in todo:
        st = read_state(m.folder)
        if st.get("status") == "running" and st.get("host") == host and st.get("pid"):
            pids.add(int(st["pid"]))
    procs = getattr(pool, "_processes", None) or {}
    pids |= {p for p in procs}
    for pid in pids:
        try:
            os.kill(pid, signal.SIGINT)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + STOP_BOUND_S
    busy = [m for m in todo if read_state(m.folder).get("status") == "running"]
    while busy and time.monotonic() < deadline:
        time.sleep(0.1)
        busy = [m for m in busy if read_state(m.folder).get("status") == "running"]
    killed = []
    for m in busy:
        st = read_state(m.folder)
        pid = int(st.get("pid", 0))
        if st.get("host") != host or not pid:
            continue
        for child in children.children_of(pid):
            try:
                os.killpg(child, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        st.update(status="interrupted", rc=-9, ended=time.time())
        _write_state(m.folder, st)
        killed.append(m.name)
    return {"killed": killed}


#: a Slurm task's time limit from `check`'s run-time estimate of one member (scene.runtime_estimate):
#: SLURM_TIME_FACTOR x the estimate + SLURM_TIME_EXTRA_S (static stages, start, post). The estimate is
#: at the speed measured on the machine that writes the script (within 6 % of the slice's conditions
#: where measured; the 3D whole not checked: docs/benchmarks.md "check's run-time estimate"); the factor
#: covers slower or busier compute nodes
SLURM_TIME_FACTOR = 2.0
SLURM_TIME_EXTRA_S = 600.0
#: minutes of a member's task when check cannot estimate its run (no probe of this machine)
SLURM_TIME_UNKNOWN_MIN = 24 * 60


def slurm_time(case, need: int) -> tuple[int, str]:
    """Minutes of a member's array task (#SBATCH --time) and where they come from: suite.slurm_time,
    or `check`'s estimate of one member's run (its conditions as `run` schedules them on `need`
    cores) x SLURM_TIME_FACTOR + SLURM_TIME_EXTRA_S."""
    from .scene import runtime_estimate

    given = case.data["suite"].get("slurm_time")
    if given is not None:
        return max(1, math.ceil(float(given) / 60.0)), "suite.slurm_time"
    est = runtime_estimate(case)
    if not est.seconds:  # this machine's speed could not be measured: a day, and why
        return SLURM_TIME_UNKNOWN_MIN, (f"no run-time estimate ({est.basis}): {SLURM_TIME_UNKNOWN_MIN // 60} h; "
                                        "suite.slurm_time sets it")
    wall = est.wall if need > 1 else sum(est.seconds.values())
    minutes = max(1, math.ceil((SLURM_TIME_FACTOR * wall + SLURM_TIME_EXTRA_S) / 60.0))
    return minutes, (f"{SLURM_TIME_FACTOR:g} x check's estimate of a member ({wall:.0f} s of shaking) + "
                     f"{SLURM_TIME_EXTRA_S / 60:g} min; suite.slurm_time sets it")


def _slurm_duration(minutes: int) -> str:
    """Minutes as Slurm's --time reads them: [days-]hours:minutes:seconds."""
    days, rest = divmod(int(minutes), 24 * 60)
    return (f"{days}-" if days else "") + f"{rest // 60:02d}:{rest % 60:02d}:00"


def _sbatch_word(text: str) -> str:
    """A value of an #SBATCH line, quoted as sbatch reads one: in double quotes, a backslash or a
    double quote escaped by a backslash (sbatch splits the line at blanks outside quotes and takes
    an unquoted # as the start of a comment)."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def write_slurm(case, members, need: int, argv_case: str, resume: bool = False, no_post: bool = False) -> Path:
    """A Slurm job array of the members (one task each), and the report's command to run after it.
    Every path is quoted for bash and for sbatch; each task runs in members/ (its output there too);
    a requeued task (SLURM_RESTART_COUNT > 0) continues from its member's restart checkpoint."""
    from .suite_members import suite_dir

    folder = suite_dir(case)
    where = folder / "members"
    for what, path in (("the results folder", str(folder)), ("the case file", str(case.path)),
                       ("the case as given", argv_case)):
        if "\n" in path or "\r" in path:
            raise ValueError(f"{what} {path!r} has a line break in its path, which a line of a Slurm script cannot "
                             "hold. Fix: rename the folder (or set output.directory) to a path without one")
    names = " ".join(shlex.quote(m.name) for m in members)
    env = "".join(f"export {k}={shlex.quote(os.environ[k])}\n" for k in ("PYTHONPATH", "TQ_BUILD_DIR")
                  if k in os.environ)
    minutes, why = slurm_time(case, need)
    script = folder / "suite.slurm"
    variant = f" --variant {shlex.quote(case.variant)}" if case.variant else ""
    flags = "".join(f" {f}" for f, on in (("--resume", resume), ("--no-post", no_post)) if on)
    text = (
        "#!/bin/bash\n"
        f"# Record suite of {shlex.quote(str(case.path))}: one array task a member. Submit: sbatch {shlex.quote(str(script))}\n"
        f"# Then the suite report: tunnelquake post {shlex.quote(argv_case)}{variant}\n"
        f"# --time: {why}.\n"
        "# A task Slurm requeues (node failure, preemption; SLURM_RESTART_COUNT > 0) continues from its\n"
        "# member's restart checkpoint (docs/user_guide.md \"Record suites\").\n"
        f"#SBATCH --job-name={_sbatch_word('tq-' + str(case.data['name']))}\n"
        f"#SBATCH --array=0-{len(members) - 1}\n"
        f"#SBATCH --cpus-per-task={need}\n"
        "#SBATCH --ntasks=1\n"
        f"#SBATCH --time={_slurm_duration(minutes)}\n"
        "#SBATCH --requeue\n"
        "#SBATCH --open-mode=append\n"
        f"#SBATCH --chdir={_sbatch_word(str(where))}\n"
        "#SBATCH --output=slurm-%A_%a.out\n"
        "set -euo pipefail\n" + env +
        f"members=({names})\n"
        'member=${members[$SLURM_ARRAY_TASK_ID]}\n'
        f'exec {shlex.quote(sys.executable)} -m tunnelquake.suite_launch {shlex.quote(str(where))}/"$member"/case.yaml'
        f"{flags}\n")
    tmp = folder / f".suite.slurm.{os.getpid()}"
    tmp.write_text(text)
    os.replace(tmp, script)
    return script


def run_suite(case, command: str, opts: SuiteOptions) -> int:
    """Run the suite of `case` holding its folder (`command` says who holds it)."""
    from .runlock import RunLockBusy, run_lock
    from .suite_members import suite_dir

    folder = suite_dir(case)
    try:
        lock = run_lock(folder, command)
        note = lock.__enter__()
    except RunLockBusy as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    try:
        return _suite(case, opts, note)
    except KeyboardInterrupt:  # before the members start (planning, meshing): nothing to stop
        print("tunnelquake run: suite interrupted by SIGINT before any member started", file=sys.stderr)
        return 130
    finally:
        lock.__exit__(None, None, None)


def _suite(case, opts: SuiteOptions, note) -> int:
    import shutil

    from .motion import MotionError
    from .suite_members import member_conditions, member_finished, plan_members, suite_dir, write_member, write_report

    folder = suite_dir(case)
    if note:
        say(f"note: {note}")
    try:
        members = plan_members(case)
    except (MotionError, ValueError) as e:
        print(f"error: suite: {e}", file=sys.stderr)
        return 1
    conds = member_conditions(case)
    say(f"suite '{case.data['name']}': {len(members)} members x {len(conds)} condition(s) "
        f"({', '.join(conds)}); results in {folder}")
    finished = [m for m in members if member_finished(m, conds)]
    todo = [m for m in members if m not in finished]
    if finished:
        say(f"suite: finished earlier, kept: {', '.join(m.name for m in finished)}")
    if opts.resume:
        say(f"suite: resuming: {len(todo)} member(s) left: {', '.join(m.name for m in todo) or 'none'}")
    make_mesh(case)  # once for all members: each gets a copy
    for m in todo:
        write_member(m)
        shutil.copytree(mesh_dir(case), m.folder / "mesh", dirs_exist_ok=True)
    need = member_need(case, mesh_dir(case) / "mesh.h5")
    if opts.slurm:
        if not todo:
            say("suite: every member finished: no job array to submit")
            return 0
        try:
            script = write_slurm(case, todo, need, opts.case_arg, resume=opts.resume, no_post=opts.no_post)
        except ValueError as e:
            print(f"error: suite: {e}", file=sys.stderr)
            return 1
        variant = f" --variant {shlex.quote(case.variant)}" if case.variant else ""
        say(f"suite: Slurm job array of {len(todo)} member(s) written: {script} (`sbatch {shlex.quote(str(script))}`); "
            f"then `tunnelquake post {shlex.quote(opts.case_arg)}{variant}` writes the suite report")
        return 0
    results: dict[str, dict] = {}
    rc = 0
    if todo:
        rc = _run_pool(case, opts, members, todo, need, results)
        if rc is not None and rc > 128:
            return rc
    states = {m.name: read_state(m.folder) for m in members}
    failed = [r for r in results.values() if r["status"] != "completed"]
    if opts.no_post:
        say("suite: report skipped (--no-post); `tunnelquake post` writes it")
    else:
        report = write_report(case, members, states)
        say(f"suite: report {report}")
    for r in failed:
        say(f"suite: member {r['name']} FAILED (exit {r['rc']}); its log: "
            f"{folder / 'members' / r['name'] / 'run.log'}")
    return 1 if failed else 0


def _run_pool(case, opts: SuiteOptions, members, todo, need, results) -> int | None:
    from concurrent.futures import FIRST_COMPLETED, wait

    from .suite_members import member_conditions, suite_dir

    kind = opts.executor or ("mpi" if _under_mpi4py_futures() else "local")
    cores = len(os.sched_getaffinity(0))
    workers = opts.workers or int(case.data["suite"]["workers"]) or max(1, cores // max(need, 1))
    workers = max(1, min(workers, len(todo))) if kind == "local" else workers
    names = {"SIGINT": signal.SIGINT, "SIGTERM": signal.SIGTERM, "SIGHUP": signal.SIGHUP}

    def on_signal(signum, frame):
        for sig in names.values():
            signal.signal(sig, lambda *_: None)
        raise Signalled(signum)

    before = {sig: signal.getsignal(sig) for sig in names.values()}
    t0 = time.time()
    pool = None
    stop_file = suite_dir(case) / STOP_FILE
    try:
        for sig in names.values():
            signal.signal(sig, on_signal)
        pool, workers = _executor(kind, workers)
        say(f"suite: running {len(todo)} member(s) on {workers} {'MPI worker(s)' if kind == 'mpi' else 'worker(s)'}"
            f" ({need} core(s) a member, {cores} core(s) here); logs in members/<name>/run.log")
        stop_file.unlink(missing_ok=True)
        futures = {pool.submit(run_member, str(m.case_file), opts.no_post, str(stop_file), opts.resume): m
                   for m in todo}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=PROGRESS_S, return_when=FIRST_COMPLETED)
            for f in done:
                m = futures[f]
                try:
                    r = f.result()
                except Exception as e:  # noqa: BLE001 - a worker that died: that member failed
                    r = {"name": m.name, "rc": 1, "status": "failed", "wall_s": time.time() - t0,
                         "error": f"{type(e).__name__}: {e}"}
                results[m.name] = r
                what = r["status"]
                if what == "failed":
                    what = f"FAILED (exit {r['rc']}{', ' + r['error'] if 'error' in r else ''})"
                say(f"suite: member {m.name} {what} in {r['wall_s']:.1f} s")
            say(_progress(members, todo, results, workers, t0, len(member_conditions(case))))
        pool.shutdown(wait=True)
        return 0
    except Signalled as e:
        QUIET.set()
        signame = {v: k for k, v in names.items()}[e.signum]
        stop_file.touch()
        for f in list(locals().get("futures", {})):
            f.cancel()
        stopped = _stop_members(todo, pool) if pool is not None else {"killed": []}
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)
        states = {m.name: read_state(m.folder).get("status", "not started") for m in todo}
        done = [n for n, s in states.items() if s == "completed"]
        stopped_names = [n for n, s in states.items() if s == "interrupted"]
        left = [n for n, s in states.items() if s not in ("completed", "interrupted", "failed")]
        killed = f" ({', '.join(stopped['killed'])} killed after {STOP_BOUND_S:.0f} s)" if stopped["killed"] else ""
        QUIET.clear()
        print(f"tunnelquake run: suite interrupted by {signame} after {time.time() - t0:.1f} s: completed "
              f"{', '.join(done) or 'none'}; stopped {', '.join(stopped_names) or 'none'}{killed}; not started "
              f"{', '.join(left) or 'none'}. `tunnelquake run {opts.case_arg} --resume` runs the members left",
              file=sys.stderr, flush=True)
        return 128 + e.signum
    finally:
        for sig, handler in before.items():
            signal.signal(sig, handler)
        children.stopping.clear()


def requeued() -> int:
    """How many times Slurm has restarted this job (SLURM_RESTART_COUNT; 0 when not set)."""
    try:
        return max(0, int(os.environ.get("SLURM_RESTART_COUNT", "0") or 0))
    except ValueError:
        return 0


def main(argv: list[str]) -> int:
    """One member, as a Slurm array task runs it: from its restart checkpoint with --resume or when
    Slurm requeued the task."""
    import argparse

    p = argparse.ArgumentParser(prog="python -m tunnelquake.suite_launch",
                                description="run one member of a record suite (a Slurm array task)")
    p.add_argument("case", help="the member's case.yaml (<results>/members/<name>/case.yaml)")
    p.add_argument("--resume", action="store_true", help="continue from the member's restart checkpoints")
    p.add_argument("--no-post", action="store_true", help="skip the member's post-processing")
    args = p.parse_args(argv)
    again = requeued()
    if again and not args.resume:
        say(f"Slurm requeued this task (SLURM_RESTART_COUNT={again}): the member resumes from its restart "
            "checkpoint, if it has one")
    out = run_member(str(Path(args.case).resolve()), no_post=args.no_post, resume=args.resume or again > 0)
    print(f"member {out['name']}: {out['status']} (exit {out['rc']}) in {out['wall_s']:.1f} s", flush=True)
    return 0 if out["rc"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
