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
so that `stop_all` ends them all, with whatever they started (mpirun's ranks, in process groups of
their own), in bounded time: SIGTERM to each child's process group and to each process below it in
another group, SIGKILL STOP_GRACE_S later to what is left.
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


def _live_parents() -> dict[int, list[int]]:
    """parent PID -> the live (not zombie) processes it is the parent of, from one scan of /proc."""
    below: dict[int, list[int]] = {}
    try:
        names = os.listdir("/proc")
    except OSError:
        return below
    for name in names:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rfind(")") + 2:].split()
        if len(fields) > 1 and fields[0] != "Z":
            below.setdefault(int(fields[1]), []).append(int(name))
    return below


def children_of(parent: int) -> list[int]:
    """The live (not zombie) processes whose parent is `parent`, from /proc."""
    return _live_parents().get(parent, [])


def _below(roots) -> list[int]:
    """Every live process below the processes `roots` (children, their children, ...; one scan of
    /proc)."""
    below = _live_parents()
    found, todo = [], list(roots)
    while todo:
        for child in below.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def outside_below(roots, groups) -> list[int]:
    """Every live process below the processes `roots` (children, their children, ...; one scan of
    /proc) whose process group is none of `groups`: those that left their parent's group (mpirun puts
    each rank in a group of its own), which a signal to the groups does not reach."""
    out = []
    for pid in _below(roots):
        try:
            if os.getpgid(pid) not in groups:
                out.append(pid)
        except ProcessLookupError:  # gone meanwhile
            pass
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
    now = process_state(pid)
    return now is not None and now[1] != "Z"


def _send(groups, pids, sig) -> None:
    """`sig` to each process group in `groups` and each process in `pids`; gone ones are skipped."""
    for target, kill in [(g, os.killpg) for g in groups] + [(p, os.kill) for p in pids]:
        try:
            kill(target, sig)
        except ProcessLookupError:
            pass


def stop_all(grace: float = STOP_GRACE_S) -> dict:
    """Stop every child: SIGTERM to the process group of each recorded child (its own), to any other
    direct child, and to every process below them outside those groups (mpirun's ranks, each in a
    group of its own: SIGTERM to mpirun alone reaches them only after its odls_base_sigkill_timeout,
    and a SIGKILL of mpirun before that would leave them running); SIGKILL to what is left after
    `grace` s, then wait up to KILL_WAIT_S s. Returns {"terminated": n, "killed": n, "left": [pids]}."""
    stopping.set()
    with FORK_LOCK:  # no child is half-created while the list is read
        groups = {p.pid for p in _started if p.poll() is None}
    others = [pid for pid in _direct_children() if pid not in groups]
    # found before any is signalled: a rank whose mpirun has gone is no longer below it
    others += outside_below(list(groups) + others, groups)
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


#: set while a run is being stopped by a signal: its threads' progress lines are dropped, so that
#: the one line saying what was stopped is the last thing printed
QUIET = threading.Event()


def say(msg: str) -> None:
    """One line to stdout, written whole in one call: print() writes the text and its newline
    apart, so two threads' lines (the solid's and the water's echo) could run together."""
    if QUIET.is_set():
        return
    import sys

    sys.stdout.write(f"[tunnelquake] {msg}\n")
    sys.stdout.flush()


class Side:
    """One participant's process, its log streamed to a file and echoed (filtered) to the terminal."""

    #: s between flushes of the log file (a flush per line cost the water's verbose log, ~20 lines a
    #: pass, a write call each on the cores the solvers share)
    FLUSH_S = 1.0

    def __init__(self, name: str, cmd: list[str], log, env, echo):
        import collections
        import subprocess
        import threading

        self.name, self.log, self.lines = name, log, collections.deque(maxlen=40)
        #: the same last lines, each with whether it was echoed to the terminal
        self.echoed = collections.deque(maxlen=40)
        self.log_error: OSError | None = None
        #: whether it said it coupled with its partner (COUPLED_SIGNS): it will meet a lost partner at
        #: its next exchange, once the step or checkpoint it is in is done
        self.coupled = False
        #: s `run` waited before ending it (stop_side), None while it ended by itself
        self.ended_after: float | None = None
        self.fh = open(log, "w")
        self.proc = popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   bufsize=1)
        self.thread = threading.Thread(target=self._pump, args=(echo,), daemon=True)
        self.thread.start()

    def _pump(self, echo) -> None:
        """Copy the child's output to its log and the terminal until it ends. A log the disk has no
        room for stops being written (said once); the output is still read, so the child never
        blocks on a full pipe, and its last lines still reach the terminal."""
        import time as _time

        flushed = _time.monotonic()

        def logged(write, *args) -> None:
            if self.log_error is None:
                try:
                    write(*args)
                except OSError as e:
                    self.log_error = e
                    say(f"  [{self.name}] its log {self.log} is cut here: {e.strerror or e}")

        for line in self.proc.stdout:
            logged(self.fh.write, line)
            if not self.coupled and any(sign in line for sign in COUPLED_SIGNS):
                self.coupled = True
            self.lines.append(line)
            shown = bool(echo(line))
            self.echoed.append(shown)
            if shown:
                logged(self.fh.flush)
                say(f"  [{self.name}] {line.rstrip()}")
                flushed = _time.monotonic()
            elif _time.monotonic() - flushed > self.FLUSH_S:
                logged(self.fh.flush)
                flushed = _time.monotonic()
        logged(self.fh.flush)

    def close(self) -> None:
        import contextlib

        self.thread.join(timeout=10)
        with contextlib.suppress(OSError):  # a log the disk had no room for: said by _pump
            self.fh.close()

    def tail(self, n: int = 6) -> str:
        """The last `n` lines of the output that the terminal has not seen (a line echoed as it
        came is not printed again), indented; empty when it saw them all."""
        unseen = [x for x, shown in zip(list(self.lines), list(self.echoed), strict=True) if not shown]
        return "\n".join(f"      {x.rstrip()}" for x in unseen[-n:])


def process_tree(root: int) -> list[int]:
    """`root` and every live process below it."""
    return [root, *_below([root])]


#: /proc/PID/stat's state letters, in words
_STATES = {"R": "running", "S": "sleeping", "D": "in uninterruptible I/O wait", "T": "stopped", "t": "traced",
           "Z": "a zombie", "I": "idle"}


def process_state(pid: int | str) -> tuple[str, str, float] | None:
    """(executable name, state letter, CPU seconds used so far) of `pid` from /proc/PID/stat (a
    thread's: "PID/task/TID"), or None once it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            stat = fh.read()
    except OSError:
        return None
    name = stat[stat.find("(") + 1:stat.rfind(")")]
    fields = stat[stat.rfind(")") + 2:].split()
    # fields from the state on: utime and stime are /proc/PID/stat's 14th and 15th (clock ticks)
    return name, fields[0], (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _wchan(pid: int | str) -> str:
    """The kernel function `pid` (a thread's: "PID/task/TID") sleeps in ("" when running or unknown)."""
    try:
        with open(f"/proc/{pid}/wchan") as fh:
            w = fh.read().strip()
    except OSError:
        return ""
    return "" if w in ("0", "") else w


def describe_processes(pids, cpu_before: dict[int, float], seconds: float) -> str:
    """Each process of `pids` as it is now: its name and PID, its state (and the kernel function it
    sleeps in), and the CPU seconds it used over the last `seconds` s (from `cpu_before`, its CPU
    seconds then): a process running with about `seconds` of CPU is busy (a long step, or a busy
    wait in an MPI call), one asleep with none waits (a message, a lock), one in I/O wait writes."""
    parts = []
    for pid in pids:
        now = process_state(pid)
        if now is None:
            continue
        name, state, cpu = now
        where = _wchan(pid) if state != "R" else ""
        used = cpu - cpu_before.get(pid, cpu)
        parts.append(f"{name} (pid {pid}) {_STATES.get(state, state)}{f' in {where}' if where else ''}, "
                     f"{used:.1f} s of CPU in the last {seconds:.1f} s")
    return "; ".join(parts) or "none left"


def in_disk_wait(pids, over_s: float = 0.5, every_s: float = 0.05) -> dict[int, str]:
    """The processes of `pids` with a thread seen in uninterruptible I/O wait (state D: a write to
    disk, an fsync) at any of the samples taken every `every_s` s over `over_s` s (a restart
    checkpoint's several fsyncs leave gaps between them): PID -> the kernel function that thread
    waits in."""
    seen: dict[int, str] = {}
    deadline = time.monotonic() + over_s
    while True:
        for pid in pids:
            try:  # any of its threads (a writer thread's fsync leaves the main thread asleep)
                threads = os.listdir(f"/proc/{pid}/task")
            except OSError:
                continue
            for tid in threads:
                now = process_state(f"{pid}/task/{tid}")
                if now is not None and now[1] == "D":
                    seen[pid] = _wchan(f"{pid}/task/{tid}") or "a write"
                    break
        if seen or time.monotonic() >= deadline:
            return seen
        time.sleep(every_s)


#: s more a partner is left past its grace while one of its processes is in uninterruptible I/O wait
#: (state D: a restart checkpoint's fsync on a disk busy with other writes, which on a loaded disk can
#: take longer than any grace): it is writing, not hung, and ended in that write its checkpoint is lost
PARTNER_DISK_GRACE_S = 60.0


def stop_side(side: Side, grace: float) -> None:
    """Let a partner that lost its peer stop by itself within `grace` s (it is told at once, or
    after its coupling timeout), longer while it is writing to disk (PARTNER_DISK_GRACE_S), then end
    it: SIGTERM first, to mpirun and to its ranks (each in a process group of its own: mpirun would
    pass it on only after its odls timeout, and a SIGKILL of mpirun would orphan them), SIGKILL 10 s
    later. Ending it, `run` says what each of its processes was doing (describe_processes): where a
    partner that did not meet the loss by itself spent the grace."""
    import subprocess

    t0 = time.monotonic()
    cpu_before = {pid: st[2] for pid in process_tree(side.proc.pid) if (st := process_state(pid))}
    try:
        side.proc.wait(timeout=grace)
        return
    except subprocess.TimeoutExpired:
        pass
    told = False
    while time.monotonic() - t0 < grace + PARTNER_DISK_GRACE_S and not stopping.is_set():
        writing = in_disk_wait(process_tree(side.proc.pid))
        if not writing:
            break
        if not told:
            waits = ", ".join(f"pid {pid} in {where}" for pid, where in writing.items())
            say(f"  {side.name} did not stop within {grace:.0f} s, but is writing to disk ({waits}, uninterruptible "
                f"I/O wait): left up to {PARTNER_DISK_GRACE_S:.0f} s more to end by itself")
            told = True
        try:
            side.proc.wait(timeout=1.0)
            return
        except subprocess.TimeoutExpired:
            pass
    if stopping.is_set():
        return  # stop_all ends it
    waited = time.monotonic() - t0
    tree = process_tree(side.proc.pid)
    more = f" and {waited - grace:.0f} s more while it wrote to disk" if told else ""
    say(f"  {side.name} did not stop within {grace:.0f} s{more}: ending it (pid {side.proc.pid}); its processes: "
        f"{describe_processes(tree, cpu_before, waited)}")
    side.ended_after = waited
    # mpirun's ranks, each in a process group of its own, told at once too (stop_all)
    below = outside_below([side.proc.pid], {side.proc.pid})
    side.proc.terminate()
    _send([], below, signal.SIGTERM)
    try:
        side.proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        side.proc.kill()
        _send([], [pid for pid in below if _pid_alive(pid)], signal.SIGKILL)
        side.proc.wait(timeout=30)


#: s a side that failed leaves a partner still waiting for its connection (the failed side stopped at
#: its start), which would otherwise wait its whole coupling timeout and blame the partner for not
#: connecting
PARTNER_GRACE_S = 5.0

#: s a side that failed leaves a partner that had coupled with it: the partner meets the closed
#: connection at its next exchange, after the step or the restart checkpoint it is in (a checkpoint's
#: fsyncs on a disk busy with other writes can take seconds); ended sooner, it would stop on `run`'s
#: SIGTERM without saying why
PARTNER_COUPLED_GRACE_S = 15.0

#: s a side that failed saying it lost its partner leaves that partner, the cause, to end by itself: a
#: solid on MPI ranks whose rank died is ended by mpirun (OpenMPI 4.1) in two waits of its
#: odls_base_sigkill_timeout (solid_ranks.solid_command: STOP_GRACE_S): SIGCONT, a wait, SIGTERM (rank 0
#: writes the results file's status, and the water sees the connection close), a wait, SIGKILL. Measured
#: (solid and water on 2 ranks, solid rank 1 killed): the water ended 5.0 s after the rank's death and
#: the solid's mpirun 4.0 s after the water, 1.0 s inside PARTNER_GRACE_S, which a slower mpirun would
#: overrun (stop_side then ends it: "did not stop within 5 s", and its exit status is not its own)
PARTNER_CAUSE_GRACE_S = 2 * STOP_GRACE_S + 5.0


#: what the coupler's PartnerLostError says (coupler/src/endpoint.cpp, participant.cpp,
#: transport_tcp.cpp): a side whose last lines hold one of these stopped because its partner went
#: first, by a lost connection, an ABORT or a BYE
PARTNER_LOST_SIGNS = ("The partner process has probably stopped", "stopped on an error while",
                      "ended the coupling (BYE) while", "connection closed by the partner")


#: what each side prints once it has coupled with its partner (tq-solid's app.cpp and ranked_run.cpp,
#: the water's couplerExchange.C)
COUPLED_SIGNS = ("tq-solid: coupled with the fluid", "' coupled with '")


def lost_its_partner(side: Side) -> bool:
    """Whether the side's last output lines say its coupling partner went first."""
    return any(sign in line for line in list(side.lines) for sign in PARTNER_LOST_SIGNS)


def partner_grace(failed: Side, partner: Side) -> float:
    """s `failed`'s partner is left to end by itself: PARTNER_CAUSE_GRACE_S when the failed side says
    it lost its partner (the partner, the cause, is ending), PARTNER_COUPLED_GRACE_S when the partner
    had coupled (it is told at its next exchange), else PARTNER_GRACE_S."""
    if lost_its_partner(failed):
        return PARTNER_CAUSE_GRACE_S
    return PARTNER_COUPLED_GRACE_S if partner.coupled else PARTNER_GRACE_S


def root_failure(failed: Side, other: Side) -> Side:
    """The side to blame for a coupled run's failure, given the one `watch_pair` saw fail first and
    its partner (both ended). The first to exit is not always the cause: a solid on MPI ranks whose
    rank is killed is ended by mpirun only after the water, which saw the connection close at once,
    has stopped. When the first failed side says it lost its partner and the partner failed too
    (without saying the same), the partner is the cause."""
    rc = other.proc.returncode
    if rc not in (0, None) and lost_its_partner(failed) and not lost_its_partner(other):
        return other
    return failed


def watch_pair(first: Side, second: Side, grace: float, poll_s: float = 0.1) -> Side | None:
    """Wait until both coupled sides have ended. A side that fails (non-zero exit) has its partner
    stopped (stop_side) after at most partner_grace s; a side that ends cleanly leaves its
    partner `grace` s to follow (it was told the end) before it is ended. Returns the side to blame
    (root_failure: the first to fail, unless it only lost its partner), or None when both ended
    cleanly."""
    import time as _time

    while True:
        r1, r2 = first.proc.poll(), second.proc.poll()
        for side, rc, other in ((first, r1, second), (second, r2, first)):
            if rc is not None and rc != 0:
                side.thread.join(timeout=2)  # its last lines read: did it only lose its partner?
                stop_side(other, min(grace, partner_grace(side, other)))
                if other.proc.poll() is not None:  # both ended: their last lines read in full
                    for s in (side, other):
                        s.thread.join(timeout=10)
                return root_failure(side, other)
        if r1 == 0 and r2 == 0:
            return None
        if r1 == 0 or r2 == 0:
            other = second if r1 == 0 else first
            stop_side(other, grace)
            return other if other.proc.returncode != 0 else None
        _time.sleep(poll_s)
