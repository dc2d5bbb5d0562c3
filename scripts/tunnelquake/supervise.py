"""The supervisor of `tunnelquake run`: the job runs in a thread while the main thread waits for it
and for SIGINT, SIGTERM or SIGHUP; on one it stops every child (children.stop_all), marks each
condition whose solver was running as interrupted in its results file and says where each stopped.
The conditions' runners (launch.py) record here what they started and how far it got."""
from __future__ import annotations

import re
import threading
import time

from . import children
from .children import QUIET

#: The conditions whose solver was started in this process: condition -> (results file, the
#: file's (inode, mtime, size) before the start or None), for the status written when a signal
#: stops the run (a results file the solver never rewrote is left alone).
STARTED: dict[str, tuple] = {}


def _signature(path):
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


def started(cond: str, res) -> None:
    """The solver of `cond` is started on its results file `res`."""
    STARTED[cond] = (res, _signature(res))
    PROGRESS.pop(cond, None)


def rewritten(res) -> bool:
    """Whether a solver this run started has written `res` (it changed since the start); True
    for a file no solver of this run was started on."""
    for path, before in STARTED.values():
        if path == res:
            return _signature(res) != before
    return True


#: condition -> the simulated time of tq-solid's last progress line seen (`  t = 0.5 s / 2 s ...`);
#: its results file may lag by up to its flush interval (2 s of wall time)
PROGRESS: dict[str, float] = {}
_PROGRESS_LINE = re.compile(r"^\s*t = ([0-9.eE+-]+) s / ")


def progress(cond: str, line: str) -> bool:
    """Note the simulated time of a progress line of the solver of `cond`; True: the line is shown."""
    m = _PROGRESS_LINE.match(line)
    if m:
        PROGRESS[cond] = float(m.group(1))
    return True


#: s the supervisor waits, after the children have ended, for the job's thread to wind down before
#: it writes the statuses (a thread inside gmsh or the post-processing is left to the exit)
JOB_WIND_DOWN_S = 3.0

SIGNAL_NAMES = {2: "SIGINT", 15: "SIGTERM", 1: "SIGHUP"}


class Signalled(BaseException):
    """Raised in the main thread by the signal handler of a supervisor."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: the phase the job is in, for the line printed when a signal stops it
PHASE = ["starting"]

#: set when a signal stopped the run and the job's thread had not ended within JOB_WIND_DOWN_S
LEFT_RUNNING = threading.Event()


def exit_now_if_left_running(rc: int) -> None:
    """End the process at once (stdout and stderr flushed, the interpreter not finalized) when a
    stopped run's job thread is still running. Finalizing beside it can hang for good: a thread
    left inside h5py holds h5py's global lock, and the interpreter's teardown frees h5py objects,
    which takes that lock (a daemon thread holding it at exit: the process never ended)."""
    import os
    import sys

    if LEFT_RUNNING.is_set():
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(rc)


def supervised(case, job) -> int:
    """Run `job` (no argument, returns the exit code; children.Interrupted when stopped between
    steps) in a thread while this (main) thread waits for it and for signals. On SIGINT,
    SIGTERM or SIGHUP: stop every child (children.stop_all), mark each condition whose solver was
    running as interrupted in its results file, print one line, return 128 + the signal number."""
    import signal
    import sys

    if threading.current_thread() is not threading.main_thread():  # signals reach the main thread only
        return job()
    box: dict = {}

    # the job's end is told by an Event of its own, never by Thread.is_alive or join: a signal
    # raised while join waits makes Python 3.11 take the thread for ended (join releases the
    # thread's own lock when interrupted) while it still runs
    done = threading.Event()

    def body() -> None:
        try:
            box["rc"] = job()
        except children.Interrupted:
            box["rc"] = None
        except BaseException as e:  # noqa: BLE001 - handed to the main thread, raised there
            box["exc"] = e
        finally:
            done.set()

    def on_signal(signum, frame):
        for sig in SIGNAL_NAMES:  # a second signal while stopping changes nothing
            signal.signal(sig, lambda *_: None)
        raise Signalled(signum)

    t0 = time.monotonic()
    before = {sig: signal.getsignal(sig) for sig in SIGNAL_NAMES}
    children.stopping.clear()
    LEFT_RUNNING.clear()
    QUIET.clear()
    STARTED.clear()
    PHASE[0] = "starting"
    worker = threading.Thread(target=body, name="tunnelquake-run", daemon=True)
    try:
        for sig in SIGNAL_NAMES:
            signal.signal(sig, on_signal)
        worker.start()
        while not done.wait(0.2):
            pass
    except Signalled as e:
        QUIET.set()
        stopped = children.stop_all()
        if not done.wait(JOB_WIND_DOWN_S):
            LEFT_RUNNING.set()
        name = SIGNAL_NAMES[e.signum]
        print(_interrupted_line(name, PHASE[0], _mark_interrupted(name), stopped, time.monotonic() - t0, case),
              file=sys.stderr, flush=True)
        return 128 + e.signum
    finally:
        for sig, handler in before.items():
            signal.signal(sig, handler)
        QUIET.clear()
    if "exc" in box:
        raise box["exc"]
    return box["rc"] if box.get("rc") is not None else 1


def _simulated_time(f) -> float | None:
    """The last time all monitors of an open results file reached (None without a row)."""
    from .post import _advancing

    ends = []
    for g in f.get("monitors", {}).values():
        if "time" not in g:
            continue
        t = g["time"][...].reshape(-1)
        n = _advancing(t)
        if n == 0:
            return None
        ends.append(float(t[n - 1]))
    return min(ends) if ends else None


def _mark_interrupted(signame: str) -> list[str]:
    """Write status 'interrupted' into the results file of each condition whose solver this run
    started and that did not finish; return "<condition> at t = <s> s" for each."""
    import os

    import h5py

    from .post import _planned_end

    out = []
    for cond, (res, before) in STARTED.items():
        sig = _signature(res)
        if sig is None or sig == before:
            out.append(f"{cond} (its solver had not written {res.name} yet)")
            continue
        got = children.FORK_LOCK.acquire(timeout=2.0)
        try:
            with h5py.File(res, "a") as f:
                status = f.attrs.get("status", b"")
                status = status.decode() if isinstance(status, bytes) else str(status)
                if status != "running":
                    continue  # it ended by itself (completed, or stopped with its own reason)
                rows_to = _simulated_time(f)
                stages = len(f.get("stages", {}))
                known = [x for x in (rows_to, PROGRESS.get(cond)) if x is not None]
                t = max(known) if known else None
                f.attrs["status"] = "interrupted"
                f.attrs["interrupted_by"] = f"{signame} to tunnelquake run (pid {os.getpid()})"
                if t is not None:
                    f.attrs["interrupted_at"] = t
        except (OSError, KeyError, ValueError) as e:
            out.append(f"{cond} ({res.name} not marked: {e})")
            continue
        finally:
            if got:
                children.FORK_LOCK.release()
        inp = res.parent / cond / "solid_input.h5"
        planned = _planned_end(inp) if inp.is_file() else None
        of = f" of {planned:g} s" if planned is not None else ""
        if t is None:
            out.append(f"{cond} {'in the shaking, no row written yet' if stages else 'in its static stages'}")
        elif rows_to is None or rows_to < t:
            rows = f"rows written to t = {rows_to:.4g} s" if rows_to is not None else "no row written yet"
            out.append(f"{cond} at t = {t:.4g} s{of} ({rows})")
        else:
            out.append(f"{cond} at t = {t:.4g} s{of}")
    return out


def _interrupted_line(signame: str, phase: str, conds: list[str], stopped: dict, wall: float, case) -> str:
    what = f"stopped {', '.join(conds)}" if conds else f"stopped while {phase}"
    procs = ("every child process ended" if not stopped["left"] else
             f"process group(s) {', '.join(map(str, stopped['left']))} still there after SIGKILL")
    if stopped["killed"]:
        procs += f" ({stopped['killed']} needed SIGKILL)"
    variant = f" --variant {case.variant}" if case.variant else ""
    kept = (f"; results so far kept with status 'interrupted' (`tunnelquake post {case.path}{variant}` reports them)"
            if any(" at t = " in c or c.endswith((" no row written yet", " static stages")) for c in conds) else "")
    return f"tunnelquake run: interrupted by {signame} after {wall:.1f} s: {what}; {procs}{kept}"
