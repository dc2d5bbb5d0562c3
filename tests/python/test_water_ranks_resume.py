"""Restart checkpoints of the water on MPI ranks (docs/formats.md "Restart checkpoints",
docs/coupler.md "Water on several MPI ranks"): `parallel.fluid_ranks: 2`, the solid on 1 rank and on
2 (`--ranks 2`), stopped inside a checkpoint and continued with `tunnelquake run --resume`.

The case is test_water_parts's soft-rock slice (rock E = 1.5 GPa, elastic lining, one cycle of a 4 Hz
sine, dynamic_water only) over END_S of shaking with a checkpoint every INTERVAL_S: tq-solid is killed
(SIGKILL, the test hook TQ_CHECKPOINT_FAULT) inside its third checkpoint, after its state file and
before its manifest, so the resume continues both sides from the second; or the water's master rank
kills itself inside its third (TQ_CHECKPOINT_FAULT=<window>:water: the one file of both ranks' parts
written under its temporary name, not renamed), which leaves the second pair the last one whole; or
one water rank is killed
(SIGKILL, a lost node) right after the water wrote its first, so the resume continues from the last
pair both sides wrote whole (the first, in every run so far). Each water rank's part of
that checkpoint (its cells' fields with their old-time levels and projection basis, its points'
motion, its part of the coupler participant: its nodes' values and rows of the scheme's secant
columns, the scheme's counters) is in the one fluid-<window>.bin the master wrote.

Reference: the same case, same ranks, never stopped. Every dataset and attribute of the results file
but the wall-clock figures must be equal byte for byte (tolerance 0), and the water's own load
history (interface.dat) too: both solvers and the coupler's iterations are deterministic on a fixed
rank count, so any rank's state the checkpoint misses shows up as a difference.

A resume with another water rank count than the checkpoint's is refused by name, both counts and the
fix said, before anything runs (and `tunnelquake check` warns of it).
"""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
yaml = pytest.importorskip("yaml")
from test_coupled_ranks_resume import status as _status  # noqa: E402
from test_water_parts import _write_case  # noqa: E402

from conftest import coupled_run_missing  # noqa: E402
from tunnelquake.cli import main  # noqa: E402
from tunnelquake.compare import results_differences  # noqa: E402

needs_coupled_run = pytest.mark.skipif(coupled_run_missing(mpirun=True) is not None,
                                       reason=str(coupled_run_missing(mpirun=True)))

#: shaking simulated and the checkpoint interval, s: checkpoints every 9 windows of 2.87 ms (about 0.026,
#: 0.052 and 0.077 s)
END_S, INTERVAL_S = 0.1, 0.025


def _case(folder: Path, fluid_ranks: int = 2) -> Path:
    p = _write_case(folder)
    data = yaml.safe_load(p.read_text())
    data["time"]["end_time"] = f"{END_S} s"
    data["output"]["checkpoint_interval"] = f"{INTERVAL_S} s"
    data["parallel"]["fluid_ranks"] = fluid_ranks
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def _interface_rows(folder: Path) -> bytes:
    """The water's interface.dat (its load history, one row a pass), written by its master."""
    (path,) = (folder / "results" / "dynamic_water" / "fluid" / "postProcessing").rglob("interface.dat")
    return path.read_bytes()


def _kill_a_water_rank(case: Path, ranks: list[str], window: int) -> str:
    """`tunnelquake run` started as a user starts it; as soon as the water wrote its checkpoint of
    `window` (the whole run takes about a second here: the folder is polled every 2 ms), one water
    rank (the newest of the solver's processes in the case's folder) is killed (SIGKILL: its node
    lost). Returns what `tunnelquake run` printed."""
    import os
    import signal
    import time

    from test_restart import _pids, _start, _wait_gone

    import tunnelquake

    # this tree's package in the child too (not another checkout's installed one)
    proc = _start(case, *ranks, env={"PYTHONPATH": str(Path(tunnelquake.__file__).parents[1])})
    fluid = case.parent / "results" / "dynamic_water" / "checkpoint" / f"fluid-{window:09d}.bin"
    try:
        deadline = time.monotonic() + 240
        while not fluid.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        pids = _pids(case.parent, b"PimpleFoam")
        assert len(pids) == 2, (pids, fluid.exists())  # the water's two ranks, still running
        os.kill(max(pids), signal.SIGKILL)
        _wait_gone([max(pids)])
        out, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 1 and "(water) failed" in out, out[-3000:]
    return out


@needs_coupled_run
@pytest.mark.parametrize(("solid_ranks", "how"), [(1, "fault"), (2, "fault"), (1, "water fault"), (1, "kill")])
def test_water_on_ranks_stopped_in_a_checkpoint_resumes_bitwise_equal(tmp_path, capsys, monkeypatch, solid_ranks,
                                                                      how):
    """`fault`: tq-solid killed inside its third checkpoint (TQ_CHECKPOINT_FAULT=3:solid); `water fault`:
    the water's master rank killed inside its third, the file of both ranks' parts written under its
    temporary name and not yet renamed (TQ_CHECKPOINT_FAULT=<window>:water); `kill`: a water rank
    killed (SIGKILL) once the water wrote its first."""
    from tunnelquake.case import load_case
    from tunnelquake.restart import coupled_resume_point, fluid_ranks_of

    ranks = ["--ranks", str(solid_ranks)] if solid_ranks > 1 else []
    ref = _case(tmp_path / "reference")
    assert main(["run", str(ref), *ranks, "--no-post"]) == 0
    said = capsys.readouterr().out
    assert "water decomposed on 2 ranks" in said and "--checkpoint-dir" in said, said[-3000:]
    ref_res = tmp_path / "reference" / "results" / "results_dynamic_water.h5"
    with h5py.File(ref_res, "r") as f:
        assert int(f["timings"].attrs["checkpoints"]) == 3  # windows 9, 18 and 27; none at the end
        window_size = float(f["coupling"].attrs["window_size"])

    case = _case(tmp_path / "case")
    shutil.copytree(tmp_path / "reference" / "results" / "mesh", case.parent / "results" / "mesh")
    shutil.copy(tmp_path / "reference" / "results" / "motion.h5", case.parent / "results" / "motion.h5")
    every = round(INTERVAL_S / window_size)
    if how == "kill":
        _kill_a_water_rank(case, ranks, every)
    else:
        monkeypatch.setenv("TQ_CHECKPOINT_FAULT", "3:solid" if how == "fault" else f"{3 * every}:water")
        assert main(["run", str(case), *ranks, "--no-post"]) != 0
        monkeypatch.delenv("TQ_CHECKPOINT_FAULT")
        if how == "water fault":
            said = capsys.readouterr().out
            assert "(water) failed" in said and "the solid stopped because the water did" in said, said[-3000:]
            left = [f.name for f in (case.parent / "results" / "dynamic_water").rglob("fluid-*.tmp")]
            assert left == [f"fluid-{3 * every:09d}.bin.tmp"], left
    res = case.parent / "results" / "results_dynamic_water.h5"
    stopped = _status(res)
    assert stopped != "completed", stopped
    m = coupled_resume_point(load_case(case), "dynamic_water")
    if how != "kill":
        assert m is not None and int(m["sequence"]) == 2, m
    else:  # the first pair, or a later one the run wrote before the rank died
        assert m is not None and 1 <= int(m["sequence"]) < 4, m
    assert int(m["window"]) == int(m["sequence"]) * every, m
    assert fluid_ranks_of(Path(m["fluid"])) == 2  # one file, both water ranks' parts in it
    capsys.readouterr()

    # the case now with the water on 3 ranks: refused by name with both counts and the fix
    data = yaml.safe_load(case.read_text())
    data["parallel"]["fluid_ranks"] = 3
    case.write_text(yaml.safe_dump(data, sort_keys=False))
    assert main(["check", str(case), *ranks]) == 0
    warned = capsys.readouterr().out
    assert "warning: `tunnelquake run --resume` refuses dynamic_water" in warned, warned[-3000:]
    assert main(["run", str(case), *ranks, "--resume", "--no-post"]) == 1
    out, err = capsys.readouterr()
    assert ("holds the water on 2 rank(s), and the case has parallel.fluid_ranks: 3" in err
            and "Fix: set parallel.fluid_ranks: 2 to resume it, or run without --resume" in err), err
    assert "running the solid" not in out and "water decomposed" not in out, out[-3000:]
    assert _status(res) == stopped  # nothing was written
    assert coupled_resume_point(load_case(case), "dynamic_water")["sequence"] == m["sequence"]

    data["parallel"]["fluid_ranks"] = 2
    case.write_text(yaml.safe_dump(data, sort_keys=False))
    assert main(["run", str(case), *ranks, "--resume", "--no-post"]) == 0
    said = capsys.readouterr().out
    assert f"resume: dynamic_water continues from its checkpoint at t = {float(m['time']):.6g} s" in said, \
        said[-3000:]
    log = (case.parent / "results" / "dynamic_water" / "fluid.log").read_text()
    assert f"(coupling window {int(m['window'])}, the water on 2 ranks)" in log, log[-3000:]
    assert _status(res) == "completed"
    assert results_differences(ref_res, res) == []
    assert _interface_rows(case.parent) == _interface_rows(tmp_path / "reference")
    assert not list((case.parent / "results" / "dynamic_water" / "checkpoint").glob("*-*"))
    assert not list((case.parent / "results" / "dynamic_water").rglob("fluid-*"))


@pytest.fixture(scope="module")
def reference_2x2(tmp_path_factory):
    """The case with the solid on 2 ranks and the water on 2, never stopped: its folder, the solid's
    steps and the windows between two checkpoints."""
    folder = tmp_path_factory.mktemp("reference")
    assert main(["run", str(_case(folder)), "--ranks", "2", "--no-post"]) == 0
    with h5py.File(folder / "results" / "results_dynamic_water.h5", "r") as f:
        assert f.attrs["status"] == "completed" and int(f["ranks"].attrs["ranks"]) == 2
        assert int(f["timings"].attrs["checkpoints"]) == 3  # windows 9, 18 and 27; none at the end
        steps = int(f["timings"].attrs["steps"])
        every = round(INTERVAL_S / float(f["coupling"].attrs["window_size"]))
    return folder, steps, every


#: s within which the loss of one rank must have stopped the whole run (both sides) and `tunnelquake
#: run` returned: mpirun waits its grace (children.STOP_GRACE_S) before it sends the other ranks
#: SIGTERM and as long again before SIGKILL; anything near this bound is a hang
STOP_BOUND_S = 90


def _whole_up_to_its_status(stopped: Path, reference: Path) -> tuple[float, float]:
    """The stopped run's results file opened and read whole, its status saying to when results are
    kept: "the results up to t = T s are kept" (a rank of the solid lost: its last sample, at the end of
    the last window the water accepted), or "exchange with 'fluid' failed at t = T s ... window W of"
    (the water lost while the solid waited for its answer to window W: the state at T, inside that
    window, was never accepted and is not sampled). The last row of every time history is at or
    before the end of the last window accepted, and every row is the reference's byte for byte (as is
    every dataset that is not a history: the model, the snapshots), but the lining's envelopes (the
    extremes of the rows kept). Returns T and the end of the last window accepted."""
    import re

    with h5py.File(stopped, "r") as s, h5py.File(reference, "r") as r:
        status = s.attrs["status"]
        status = status.decode() if isinstance(status, bytes) else str(status)
        times = s["monitors/top_arch/time"][:, 0]
        rows, rows_ref = len(times), len(r["monitors/top_arch/time"])
        if kept := re.search(r"the results up to t = ([0-9.eE+-]+) s are kept", status):
            t_kept = t_accepted = float(kept.group(1))
            assert times[-1] == pytest.approx(t_kept, rel=1e-5), (times[-1], status)
        else:
            lost = re.search(r"exchange with 'fluid' failed at t = ([0-9.eE+-]+) s .* window (\d+) of", status)
            assert lost, status
            t_kept = float(lost.group(1))
            t_accepted = (int(lost.group(2)) - 1) * float(r["coupling"].attrs["window_size"])
            # no row from the window the water never accepted
            assert t_accepted < t_kept and times[-1] <= t_accepted * (1 + 1e-9), (times[-1], t_accepted, status)
        same = int(np.searchsorted(times, t_accepted * (1 + 1e-9), side="right"))  # rows up to the accepted end
        assert 0 < same <= rows < rows_ref, (same, rows, rows_ref)
        names: list[str] = []
        s.visit(names.append)
        checked = 0
        for name in names:
            x = s[name]
            if not isinstance(x, h5py.Dataset) or name.startswith("timings") or "/envelope/" in name:
                continue
            y = r[name]
            if x.shape[:1] == (rows,) and y.shape[:1] == (rows_ref,):
                assert x[:same].tobytes() == y[:same].tobytes(), name
            else:
                assert x.shape == y.shape and x[()].tobytes() == y[()].tobytes(), name
            checked += 1
        assert checked > 50, checked
    return t_kept, t_accepted


@needs_coupled_run
@pytest.mark.parametrize("lost", ["solid rank 1", "a water rank"])
def test_solid_and_water_on_2_ranks_each_a_rank_lost_stops_whole_and_resumes_bitwise_equal(tmp_path, capsys,
                                                                                            reference_2x2, lost):
    """m:n, the solid on 2 ranks (`--ranks 2`) and the water on 2 (`parallel.fluid_ranks: 2`): one rank
    of one side killed (SIGKILL, a lost node) mid-run: solid rank 1 once it has taken 60 % of the
    reference's steps (TQ_RANK_FAULT, at the end of window 21: after the checkpoints of windows 9 and
    18), or a water rank right after the water wrote its checkpoint of window 9. The whole run stops
    within STOP_BOUND_S with a non-zero exit, the side that lost the rank blamed and its partner said to
    have stopped because of it; the results file opens, says where it stopped, and is the reference's up
    to there; `run --resume` continues from the last pair of checkpoints both sides wrote whole and ends
    with every dataset and attribute the reference's, byte for byte, and the water's interface.dat too."""
    import os
    import signal
    import subprocess
    import time

    from test_restart import _start

    import tunnelquake
    from tunnelquake.case import load_case
    from tunnelquake.restart import coupled_resume_point

    ref, steps, every = reference_2x2
    ref_res = ref / "results" / "results_dynamic_water.h5"
    case = _case(tmp_path / "case")
    shutil.copytree(ref / "results" / "mesh", case.parent / "results" / "mesh")
    shutil.copy(ref / "results" / "motion.h5", case.parent / "results" / "motion.h5")
    res = case.parent / "results" / "results_dynamic_water.h5"
    child = {"PYTHONPATH": str(Path(tunnelquake.__file__).parents[1])}  # this tree's package in the child

    t0 = time.monotonic()
    if lost == "solid rank 1":
        proc = _start(case, "--ranks", "2", env={**child, "TQ_RANK_FAULT": f"1:{int(0.6 * steps)}"})
        try:
            out, _ = proc.communicate(timeout=STOP_BOUND_S)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, _ = proc.communicate()
            raise AssertionError(f"the run did not stop within {STOP_BOUND_S} s of its start: {out[-3000:]}") from None
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        assert proc.returncode == 1, out[-3000:]
        assert "mpirun noticed that process rank 1" in out and "exited on signal 9 (Killed)" in out, out[-3000:]
        blamed, partner = "tq-solid (solid) failed with exit code 137", "the water stopped because the solid did"
        wrong = "(water) failed"
    else:
        out = _kill_a_water_rank(case, ["--ranks", "2"], every)
        blamed, partner = "rhoPimpleFoam on 2 ranks (water) failed", "the solid stopped because the water did"
        wrong = "tq-solid (solid) failed"
    stop_s = time.monotonic() - t0
    assert stop_s < STOP_BOUND_S, stop_s
    assert blamed in out and partner in out and wrong not in out, out[-3000:]
    assert not _pids_in(case.parent)  # nothing of either side is left running

    status = _status(res)
    assert status.startswith("stopped: "), status
    t_kept, t_accepted = _whole_up_to_its_status(res, ref_res)
    m = coupled_resume_point(load_case(case), "dynamic_water")
    if lost == "solid rank 1":
        assert status.startswith("stopped: the run on ranks was ended by signal 15"), status
        assert m is not None and int(m["sequence"]) == 2, m  # window 18's; window 27's never written
    else:  # the first pair, or a later one the run wrote before the rank died
        assert m is not None and 1 <= int(m["sequence"]) < 4, m
    assert int(m["window"]) == int(m["sequence"]) * every and float(m["time"]) <= t_accepted * (1 + 1e-9), \
        (m, t_accepted)
    capsys.readouterr()

    assert main(["run", str(case), "--ranks", "2", "--resume", "--no-post"]) == 0
    said = capsys.readouterr().out
    assert f"resume: dynamic_water continues from its checkpoint at t = {float(m['time']):.6g} s" in said, \
        said[-3000:]
    assert f"coupling window {int(m['window'])}) on 2 rank(s)" in said, said[-3000:]
    log = (case.parent / "results" / "dynamic_water" / "fluid.log").read_text()
    assert f"(coupling window {int(m['window'])}, the water on 2 ranks)" in log, log[-3000:]
    assert _status(res) == "completed"
    assert results_differences(ref_res, res) == []
    assert _interface_rows(case.parent) == _interface_rows(ref)
    assert not list((case.parent / "results" / "dynamic_water" / "checkpoint").glob("*-*"))
    print(f"\n{lost} lost: the run stopped {stop_s:.1f} s after its start; results kept to t = {t_kept:.6g} s, "
          f"the reference's to t = {t_accepted:.6g} s; resumed from window {m['window']}, bitwise equal")


def _pids_in(folder: Path) -> list[int]:
    """The solvers (tq-solid, the water's solver) and mpirun processes still working in `folder`."""
    from test_restart import _pids

    return [p for prog in (b"tq-solid", b"PimpleFoam", b"mpirun") for p in _pids(folder, prog)]


def _fluid_file(path: Path, parts: list[bytes] | None, digest: str = "d" * 64) -> Path:
    """A water checkpoint as tqInterface writes it (docs/formats.md "Restart checkpoints"): one rank's
    body after TQFLUID1 (`parts` None), or TQFLUIDR, the rank count and each part; then the trailer."""
    import struct
    import sys
    import zlib

    if parts is None:
        body = b"TQFLUID1" + b"state of the one rank" + b"TQFLEND1"
    else:
        body = b"TQFLUIDR" + struct.pack("=q", len(parts))
        body += b"".join(struct.pack("=q", len(p)) + p for p in parts)
    body += digest.ljust(64).encode() + b"TQFLSUM1"
    path.write_bytes(body + zlib.crc32(body).to_bytes(4, sys.byteorder))
    return path


def test_a_water_checkpoint_on_ranks_is_checked_whole_and_says_its_rank_count(tmp_path):
    """The supervisor's checks of fluid-<window>.bin (restart.fluid_problem: its trailer, CRC-32 and
    digest) take the file of a water on ranks as they take one rank's, and read the rank count that
    wrote it; a file cut anywhere, or with a bit flipped in a rank's part, is damaged."""
    from tunnelquake.restart import fluid_problem, fluid_ranks_of

    parts = [b"rank 0: its cells, its points, interface.dat" * 40, b"rank 1" * 50, b"rank 2" * 30]
    good = _fluid_file(tmp_path / "fluid-000000018.bin", parts)
    assert fluid_problem(good) == (None, "d" * 64)
    assert fluid_ranks_of(good) == 3
    assert fluid_ranks_of(_fluid_file(tmp_path / "one.bin", None)) == 1
    data = good.read_bytes()
    for cut in (16, len(data) // 2, len(data) - 1):
        bad = tmp_path / f"cut{cut}.bin"
        bad.write_bytes(data[:cut])
        assert fluid_problem(bad)[0] is not None, cut
    flipped = bytearray(data)
    flipped[16 + 8 + len(parts[0]) + 8 + 3] ^= 0x10  # a bit of rank 1's part
    (tmp_path / "flipped.bin").write_bytes(bytes(flipped))
    problem, _ = fluid_problem(tmp_path / "flipped.bin")
    assert problem is not None and "CRC-32" in problem and "damaged" in problem, problem


@pytest.mark.parametrize(("written", "now"), [(1, 2), (2, 1), (2, 3), (3, 3)])
def test_a_resume_on_another_water_rank_count_is_refused_naming_both_and_the_fix(tmp_path, written, now):
    """restart.fluid_ranks_problem, what `run --resume` refuses with before anything runs: the
    checkpoint's count and the case's both named, and the fix; None on the same count."""
    from types import SimpleNamespace

    from tunnelquake.restart import fluid_ranks_problem

    f = _fluid_file(tmp_path / "fluid-000000018.bin", None if written == 1 else [b"x"] * written)
    case = SimpleNamespace(data={"parallel": {"fluid_ranks": now}})
    why = fluid_ranks_problem(case, "dynamic_water", {"time": "0.0516", "fluid": str(f)})
    if written == now:
        assert why is None
        return
    assert why is not None
    assert f"holds the water on {written} rank(s), and the case has parallel.fluid_ranks: {now}" in why, why
    assert f"Fix: set parallel.fluid_ranks: {written} to resume it, or run without --resume" in why, why
