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
"""
from __future__ import annotations

import subprocess
import threading

#: held while an HDF5 file of this process is open and while a child is being created (re-entrant:
#: a writer may start a child, e.g. `tq-solid --check`, while it holds its files)
FORK_LOCK = threading.RLock()


def popen(cmd, **kw) -> subprocess.Popen:
    """subprocess.Popen under FORK_LOCK."""
    with FORK_LOCK:
        return subprocess.Popen(cmd, **kw)


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
