"""Figures drawn in two processes (tunnelquake.drawing): every job's outcome comes back as if it
had run here (its value, or its exception with type and message, a full disk still a full disk),
half of the jobs run in the helper, a helper that dies leaves its jobs failed with the
reason instead of a lost report, and a helper that hangs is stopped and its jobs drawn here."""
from __future__ import annotations

import os
import signal
import time

import pytest

from tunnelquake import drawing
from tunnelquake.drawing import DrawingProcessEnded, Jobs, draw_all
from tunnelquake.files import DiskFull, is_no_space


def _write(path, text):
    path.write_text(text)
    return (path, os.getpid())


def _fail(kind, path):
    if kind == "value":
        raise ValueError(f"nothing to draw at {path.name}")
    raise DiskFull(path, 4096)


def _die(_path):
    os.kill(os.getpid(), signal.SIGKILL)


def _hang_unless_in(parent, path):
    """Writes `path` in the process `parent`; in any other it hangs (as a fork that copied a held
    lock would)."""
    if os.getpid() != parent:
        time.sleep(3600)
    return _write(path, "drawn")


@pytest.fixture
def two(monkeypatch):
    monkeypatch.setenv("TQ_DRAW_PROCESSES", "2")


def test_outcomes_are_those_of_a_run_here_and_the_work_is_split(tmp_path, two):
    jobs = Jobs()
    for i in range(4):
        jobs.add(f"w{i}", _write, tmp_path / f"w{i}.txt", f"figure {i}")
    jobs.add("bad", _fail, "value", tmp_path / "bad.png")
    jobs.add("full", _fail, "disk", tmp_path / "full.png")
    out = draw_all(jobs)
    assert list(out) == ["w0", "w1", "w2", "w3", "bad", "full"]
    pids = set()
    for i in range(4):
        path, pid = out[f"w{i}"].value
        assert out[f"w{i}"].error is None and path.read_text() == f"figure {i}"
        pids.add(pid)
    assert os.getpid() in pids and len(pids) == 2  # this process and one helper
    e = out["bad"].error
    assert type(e) is ValueError and str(e) == "nothing to draw at bad.png"
    e = out["full"].error
    assert type(e) is DiskFull and is_no_space(e) and e.path == tmp_path / "full.png" and e.needed == 4096
    assert str(e) == str(DiskFull(tmp_path / "full.png", 4096))


def test_a_helper_that_dies_leaves_its_jobs_failed_and_this_process_s_done(tmp_path, two):
    jobs = Jobs()
    jobs.add("dies", _die, tmp_path / "a.png")  # the first job: the helper's
    jobs.add("here", _write, tmp_path / "b.txt", "kept")
    out = draw_all(jobs)
    assert isinstance(out["dies"].error, DrawingProcessEnded)
    assert "ended without its figures" in str(out["dies"].error)
    assert out["here"].value == (tmp_path / "b.txt", os.getpid())


def test_one_process_draws_everything_here_in_order(tmp_path, monkeypatch):
    monkeypatch.setenv("TQ_DRAW_PROCESSES", "1")
    jobs = Jobs()
    for i in range(3):
        jobs.add(f"w{i}", _write, tmp_path / f"w{i}.txt", str(i))
    out = draw_all(jobs)
    assert [o.value[1] for o in out.values()] == [os.getpid()] * 3


def test_a_helper_that_hangs_is_stopped_and_its_jobs_drawn_here(tmp_path, two, monkeypatch, capfd):
    monkeypatch.setattr(drawing, "HELPER_WAIT_S", 1.0)
    jobs = Jobs()
    jobs.add("hangs there", _hang_unless_in, os.getpid(), tmp_path / "a.txt")  # the helper's
    jobs.add("here", _write, tmp_path / "b.txt", "kept")
    t0 = time.monotonic()
    out = draw_all(jobs)
    assert time.monotonic() - t0 < 30
    assert out["hangs there"].error is None and out["hangs there"].value == (tmp_path / "a.txt", os.getpid())
    assert (tmp_path / "a.txt").read_text() == "drawn" and out["here"].value[1] == os.getpid()
    assert "had not sent its figures 1 s after" in capfd.readouterr().err
    with pytest.raises(ChildProcessError):  # the helper was reaped: no child left behind
        os.waitpid(-1, os.WNOHANG)
