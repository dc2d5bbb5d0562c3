"""Figures drawn in two processes: this one and one forked beside it.

Drawing a figure (matplotlib's layout and PNG encoding) is pure Python work on data already in
memory, and post-processing draws a dozen of them one after the other on one core while the
second core of the machine is idle. `draw_all` forks one helper process that draws the first,
third, ... figure while this process draws the others; each outcome (the drawing function's return value, or
the exception it raised) comes back to this process, so the caller treats a figure drawn beside it
as one drawn here. The figures are the same files either way (each is written whole by its own
drawing function through files.atomic_path).

The fork is made under children.FORK_LOCK (no HDF5 file of this process is open then: see
children.py), the helper resets the stop signals to their defaults (a stopped run's SIGTERM to its
direct children, or a terminal's Ctrl-C, ends it) and leaves by os._exit, running no exit handler
of this process. Where fork is unavailable, fails, or only one core may be used, or when
TQ_DRAW_PROCESSES=1, everything is drawn here, in order. A helper that has not sent its figures
HELPER_WAIT_S seconds (or ten times this process's own drawing time, if longer) after this process
finished its share is taken to hang (a lock copied by the fork in the held state): it is killed and
its share drawn here, so a report is never lost to it nor waits for ever.
"""
from __future__ import annotations

import os
import pickle
import select
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

#: seconds the helper may take past this process's own share (at least; see the module's text)
HELPER_WAIT_S = 120.0


@dataclass
class Outcome:
    """One figure's outcome: the drawing function's value, or the exception it raised."""

    value: Any = None
    error: BaseException | None = None


@dataclass
class Jobs:
    """Figures to draw: key -> (function, args, kwargs), in the order added."""

    items: list[tuple[str, Callable, tuple, dict]] = field(default_factory=list)

    def add(self, key: str, draw: Callable, *args, **kw) -> None:
        self.items.append((key, draw, args, kw))


class DrawingProcessEnded(RuntimeError):
    """The helper process ended before it said how its figures went (a signal, the memory)."""


def processes() -> int:
    """How many processes draw: 2 where this process may use two cores or more, else 1
    (TQ_DRAW_PROCESSES overrides)."""
    env = os.environ.get("TQ_DRAW_PROCESSES")
    if env:
        return max(1, int(env))
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return 2 if cores > 1 and hasattr(os, "fork") else 1


def _run(item) -> Outcome:
    _, draw, args, kw = item
    try:
        return Outcome(value=draw(*args, **kw))
    except Exception as e:  # noqa: BLE001 - handed to the caller, as if raised there
        return Outcome(error=e)


def _portable(o: Outcome) -> Outcome:
    """The outcome as it can cross to the parent: an exception that does not pickle becomes a
    RuntimeError carrying its type's name and its message."""
    try:
        pickle.loads(pickle.dumps(o))
        return o
    except Exception:  # noqa: BLE001 - any pickling failure
        e = o.error
        if isinstance(e, OSError):  # its errno kept (a full disk is told by it)
            return Outcome(error=OSError(e.errno, str(e)))
        text = f"{type(e).__name__}: {e}" if e is not None else f"unpicklable result {type(o.value).__name__}"
        return Outcome(error=RuntimeError(text))


def _read_until(fd: int, deadline: float) -> tuple[bytes, bool]:
    """Everything written to the pipe `fd` until its writer closes it (then closes `fd`), and
    whether `deadline` (time.monotonic) passed first."""
    chunks = []
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                return b"".join(chunks), True
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                return b"".join(chunks), False
            chunks.append(chunk)
    finally:
        os.close(fd)


def draw_all(jobs: Jobs) -> dict[str, Outcome]:
    """Draw every job; their outcomes by key (the order of `jobs`)."""
    items = jobs.items
    if len(items) < 2 or processes() < 2:
        return {it[0]: _run(it) for it in items}
    from . import children

    theirs, mine = items[0::2], items[1::2]  # the helper takes the first: this process has the rest of its job after
    with children.FORK_LOCK:
        for stream in (sys.stdout, sys.stderr):  # nothing buffered that the helper would write again
            stream.flush()
        read_fd, write_fd = os.pipe()
        try:
            pid = os.fork()
        except OSError:
            os.close(read_fd)
            os.close(write_fd)
            return {it[0]: _run(it) for it in items}
        if pid == 0:  # the helper: draw its share, send the outcomes, leave without exit handlers
            code = 0
            try:
                os.close(read_fd)
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                    signal.signal(sig, signal.SIG_DFL)
                data = pickle.dumps({it[0]: _portable(_run(it)) for it in theirs})
                with os.fdopen(write_fd, "wb") as w:
                    w.write(data)
                for stream in (sys.stdout, sys.stderr):
                    stream.flush()
            except BaseException:  # noqa: BLE001 - the parent says the figures were not drawn
                code = 1
            os._exit(code)
    os.close(write_fd)
    out: dict[str, Outcome] = {}
    started = time.monotonic()
    try:
        here = {it[0]: _run(it) for it in mine}
    except BaseException:  # interrupted here: the helper's figures are not waited for
        os.close(read_fd)
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise
    wait_s = max(HELPER_WAIT_S, 10 * (time.monotonic() - started))
    data, hung = _read_until(read_fd, time.monotonic() + wait_s)
    if hung:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    if hung:
        print(f"tunnelquake: the drawing process had not sent its figures {wait_s:.0f} s after this one drew its own's figures; "
              "it was stopped and its figures are drawn here", file=sys.stderr)
        there = {it[0]: _run(it) for it in theirs}
    else:
        try:
            there = pickle.loads(data) if data else None
        except Exception:  # noqa: BLE001 - a cut-off message: the helper ended mid-write
            there = None
    if there is None:
        why = DrawingProcessEnded(f"the drawing process ended without its figures (exit status "
                                  f"{os.waitstatus_to_exitcode(status)})")
        there = {it[0]: Outcome(error=why) for it in theirs}
    for it in items:
        out[it[0]] = here[it[0]] if it[0] in here else there[it[0]]
    return out
