"""The child processes of `tunnelquake run`, and the one rule that keeps them from holding the
parent's files.

HDF5 takes an advisory lock (flock) on every file it opens and opens it without close-on-exec. A
child forked while a thread of this process has an HDF5 file open holds a copy of that descriptor,
and with it the lock, until it closes its descriptors just before exec. When the writer closes its
file and opens it again within that window (write, then read back), the reopen fails with
`[Errno 11] Unable to synchronously open file (unable to lock file ...)`. Close-on-exec would not
help: the copy lives from fork to exec either way.

So FORK_LOCK is held while this process has an HDF5 file open and while it creates a child:
`popen` and `run` below take it around the fork (Popen returns once the child has exec'd, i.e.
after it closed what it inherited), and the code that reads or writes HDF5 files beside running
conditions holds it for the time the files are open (`with FORK_LOCK:`).

Every child started here leads a session of its own (a terminal's Ctrl-C reaches `tunnelquake`
only, which then stops its children in order), reads nothing from the terminal, and is recorded,
so that `stop_all` ends them all, with whatever they started (mpirun's ranks), in bounded time:
SIGTERM to each child's process group, SIGKILL STOP_GRACE_S later to what is left.
"""
from __future__ import annotations

import os
import signal
import subprocess
import threading
import time

#: held while an HDF5 file of this process is open and while a child is being created (re-entrant:
#: a writer may start a child, e.g. `tq-solid --check`, while it holds its files)
FORK_LOCK = threading.RLock()


#: s a child has to end after SIGTERM before SIGKILL
STOP_GRACE_S = 5.0
#: s to wait for the process groups to vanish after SIGKILL
KILL_WAIT_S = 2.0

#: set once the run is being stopped: no new child starts (popen raises Interrupted)
stopping = threading.Event()
_started: list[subprocess.Popen] = []


class Interrupted(Exception):
    """The run is being stopped: raised where a new child would start or a new phase begin."""


def check() -> None:
    """Raise Interrupted once the run is being stopped (called between phases)."""
    if stopping.is_set():
        raise Interrupted


def popen(cmd, **kw) -> subprocess.Popen:
    """subprocess.Popen under FORK_LOCK, in a session of its own, stdin from /dev/null, recorded
    for stop_all. Raises Interrupted once the run is being stopped."""
    kw.setdefault("start_new_session", True)
    kw.setdefault("stdin", subprocess.DEVNULL)
    with FORK_LOCK:
        check()
        proc = subprocess.Popen(cmd, **kw)
        _started.append(proc)
    return proc


def run(cmd, *, timeout: float | None = None, capture_output: bool = False, text: bool = False,
        **kw) -> subprocess.CompletedProcess:
    """subprocess.run, the child created under FORK_LOCK (the wait is outside it)."""
    if capture_output:
        kw["stdout"] = kw["stderr"] = subprocess.PIPE
    with popen(cmd, text=text, **kw) as proc:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def _direct_children() -> list[int]:
    """PIDs whose parent is this process (also those started by other modules' subprocess calls)."""
    return children_of(os.getpid())


def children_of(parent: int) -> list[int]:
    """The live (not zombie) processes whose parent is `parent`, from /proc."""
    me, out = parent, []
    try:
        names = os.listdir("/proc")
    except OSError:
        return out
    for name in names:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rfind(")") + 2:].split()
        if len(fields) > 1 and fields[0] != "Z" and int(fields[1]) == me:
            out.append(int(name))
    return out


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _pid_alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            stat = fh.read()
    except OSError:
        return False
    return stat[stat.rfind(")") + 2:][:1] != "Z"


def _send(groups, pids, sig) -> None:
    """`sig` to each process group in `groups` and each process in `pids`; gone ones are skipped."""
    for target, kill in [(g, os.killpg) for g in groups] + [(p, os.kill) for p in pids]:
        try:
            kill(target, sig)
        except ProcessLookupError:
            pass


def stop_all(grace: float = STOP_GRACE_S) -> dict:
    """Stop every child: SIGTERM to the process group of each recorded child (its own, so that
    mpirun's ranks get it too) and to any other direct child, SIGKILL to what is left after
    `grace` s, then wait up to KILL_WAIT_S s. Returns {"terminated": n, "killed": n, "left": [pids]}."""
    stopping.set()
    with FORK_LOCK:  # no child is half-created while the list is read
        groups = {p.pid for p in _started if p.poll() is None}
    others = [pid for pid in _direct_children() if pid not in groups]
    _send(groups, others, signal.SIGTERM)

    def reap() -> None:
        for p in _started:
            p.poll()

    def alive() -> tuple[list[int], list[int]]:
        reap()
        return [g for g in groups if _group_alive(g)], [pid for pid in others if _pid_alive(pid)]

    deadline = time.monotonic() + grace
    left_groups, left_others = alive()
    while (left_groups or left_others) and time.monotonic() < deadline:
        time.sleep(0.02)
        left_groups, left_others = alive()
    killed = len(left_groups) + len(left_others)
    _send(left_groups, left_others, signal.SIGKILL)
    deadline = time.monotonic() + KILL_WAIT_S
    while (left_groups or left_others) and time.monotonic() < deadline:
        time.sleep(0.02)
        left_groups, left_others = alive()
    return {"terminated": len(groups) + len(others) - killed, "killed": killed, "left": left_groups + left_others}
