"""One tunnelquake command that writes a results folder at a time (run, and mesh, motion and post
run by hand).

The lock is an flock on `<results folder>/.tunnelquake-run.lock`, which also holds who took it
(PID, start time, command). The kernel drops an flock when its holder dies however it dies, so a
lock is never stale in effect; the file's text of a run that ended without clearing it is what
makes the next run say that it takes over. The descriptor is close-on-exec: the solvers a run
starts do not hold the lock.
"""
from __future__ import annotations

import contextlib
import datetime
import fcntl
import json
import os
import sys
from pathlib import Path

LOCK_NAME = ".tunnelquake-run.lock"


class RunLockBusy(Exception):
    """Another run holds the folder; the message names it."""


def describe(info: dict) -> str:
    """Who holds a folder, from its lock record: pid, start, host, command."""
    parts = [f"pid {info.get('pid', '?')}"]
    if info.get("started"):
        parts.append(f"started {info['started']}")
    if info.get("host"):
        parts.append(f"on {info['host']}")
    if info.get("command"):
        parts.append(f"command `{info['command']}`")
    return ", ".join(parts)


def _read(fd: int) -> dict:
    os.lseek(fd, 0, os.SEEK_SET)
    text = os.read(fd, 65536).decode("utf-8", "replace").strip()
    if not text:
        return {}
    try:
        info = json.loads(text)
    except ValueError:
        return {"pid": "?", "command": text[:200]}
    return info if isinstance(info, dict) else {}


def _alive(pid) -> bool:
    try:
        os.kill(int(pid), 0)
    except (ValueError, TypeError, ProcessLookupError):
        return False
    except PermissionError:
        return True
    return True


def holder(folder: Path) -> dict | None:
    """Who runs in `folder` now (the lock file's record), or None when no run holds it."""
    path = Path(folder) / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except FileNotFoundError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return _read(fd) or {"pid": "?"}
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


@contextlib.contextmanager
def run_lock(folder: Path, command: str | None = None):
    """Hold the results folder for this run. Raises RunLockBusy naming the run that holds it.
    Yields a note (or None) when it took over the record of a run that ended without clearing it."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        info = _read(fd)
        os.close(fd)
        words = str(info.get("command", "")).split()
        who = " ".join(words[:2]) if words[:1] == ["tunnelquake"] and len(words) > 1 else "tunnelquake command"
        raise RunLockBusy(f"another `{who}` is using {folder} ({describe(info or {'pid': '?'})}); "
                          f"wait for it to end, or stop it (kill {info.get('pid', '<pid>')}), then run again") from None
    try:
        previous = _read(fd)
        note = None
        if previous:
            why = "is no longer running" if not _alive(previous.get("pid")) else "no longer holds it"
            note = (f"taking over the lock of an earlier run ({describe(previous)}): pid {previous.get('pid', '?')} "
                    f"{why}, it ended without releasing the folder")
        record = {"pid": os.getpid(), "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
                  "host": os.uname().nodename, "command": command or " ".join(sys.argv)}
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, (json.dumps(record) + "\n").encode(), 0)
        except OSError:  # a full disk: the flock still holds the folder; only its record is missing
            pass
        yield note
    finally:
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)  # a cleared record: the run ended and released the folder
        os.close(fd)  # drops the flock
