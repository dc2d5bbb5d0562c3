"""Restart of the condition coupled with the water (docs/user_guide.md "Resuming a run",
docs/reliability.md "Restart"): a `dynamic_water` run stopped after a restart checkpoint and continued
with `tunnelquake run --resume` ends with results bitwise equal to those of a run never stopped.

Reference: the same case run without interruption, with the same checkpoint interval. Every
dataset and attribute of results_dynamic_water.h5 except wall-clock figures must be equal byte
for byte (tolerance 0): the solid's step, the water's step and the coupling's iterations are
deterministic, so any state either side's checkpoint misses (the water's fields and old-time
levels, its solver's projection basis, the coupler's secant columns, the adapter's predictor and
energy bookkeeping, the defect carried into the next window) shows up as a difference. The case
carries a quarter of the unpaid defect a window (coupling.defect_correction 0.25, docs/coupler.md
"Defect correction"), so that its state is among what must come back."""
from __future__ import annotations

import json
import subprocess
import sys
import time

import h5py
import pytest
from test_restart import _case_text, _copy, _start, _stop

from conftest import ran_case
from tunnelquake.cli import main
from tunnelquake.compare import results_differences as _differences

#: shaking simulated, s; a checkpoint every INTERVAL s of it (every 99 coupling windows of 1.008 ms)
END, INTERVAL = 0.3, 0.1


def _coupled_case_text() -> str:
    text = _case_text("dynamic_water", END, INTERVAL)
    assert "\n  tolerance: 1e-3\n" in text  # the example's coupling section
    return text.replace("\n  tolerance: 1e-3\n", "\n  tolerance: 1e-3\n  defect_correction: 0.25\n", 1)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return ran_case(tmp_path_factory.mktemp("reference"), _coupled_case_text(), "--no-post")


def _wait_for_pair(case_yaml, proc, sequence: int, timeout: float = 240.0) -> dict:
    """Wait until both sides have written checkpoint `sequence` or a later one."""
    from tunnelquake.case import load_case
    from tunnelquake.restart import coupled_resume_point

    case = load_case(case_yaml)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = coupled_resume_point(case, "dynamic_water")
        if m is not None and int(m["sequence"]) >= sequence:
            return m
        assert proc.poll() is None, proc.communicate()[0][-3000:]
        time.sleep(0.02)
    raise AssertionError(f"no checkpoint pair {sequence} or later within {timeout} s")


@pytest.mark.parametrize("how", ["SIGINT", "SIGKILL tq-solid", "SIGKILL water", "SIGKILL all"])
def test_coupled_run_stopped_after_a_checkpoint_resumes_bitwise_equal(reference, tmp_path, capsys, how):
    """Stopped after both sides wrote their second checkpoint: by Ctrl-C (SIGINT to
    the process group, exit 130), by SIGKILL of tq-solid alone or of the water alone (a crash:
    tunnelquake stops the other side and reports the failure, exit 1) or by SIGKILL of tunnelquake, tq-solid and the water
    together (a lost node). `--resume` starts both from the last window both wrote and ends bitwise equal to
    the uninterrupted run."""
    p = _copy(reference, tmp_path)
    proc = _start(p)
    try:
        m = _wait_for_pair(p, proc, 2)
    finally:
        out = _stop(proc, p.parent, how, (b"tq-solid", b"PimpleFoam"))
    assert proc.returncode == {"SIGINT": 130, "SIGKILL tq-solid": 1, "SIGKILL water": 1, "SIGKILL all": -9}[how], \
        out[-2000:]
    _resume_and_compare(p, reference, tmp_path, capsys, m)


@pytest.mark.parametrize("part", ["solid", "results"])
def test_coupled_crash_inside_a_checkpoint_resumes_from_the_one_before(reference, tmp_path, capsys, part):
    """tq-solid killed (SIGKILL) inside its third checkpoint, after its state file (`solid`) or also
    its results copy (`results`), before its manifest (TQ_CHECKPOINT_FAULT): tunnelquake stops the
    water, which has not written a third; `--resume` continues both from the second and ends
    bitwise equal to the uninterrupted run."""
    from tunnelquake.case import load_case
    from tunnelquake.restart import coupled_resume_point

    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": f"3:{part}"})
    out, _ = proc.communicate(timeout=240)
    assert proc.returncode == 1 and "tq-solid (solid) failed with exit code -9" in out, out[-2000:]
    m = coupled_resume_point(load_case(p), "dynamic_water")
    assert m is not None and int(m["sequence"]) == 2, m
    _resume_and_compare(p, reference, tmp_path, capsys, m)


def test_water_killed_inside_its_checkpoint_resumes_from_the_one_before(reference, tmp_path, capsys):
    """The water killed (SIGKILL) inside its third checkpoint, the file written under its temporary
    name and not yet renamed (TQ_CHECKPOINT_FAULT=<window>:water): tq-solid wrote its third before
    (the water writes after the solid), so the last pair both wrote is the second; tunnelquake stops
    tq-solid and says the water failed; `--resume` continues both from the second and ends bitwise
    equal to the uninterrupted run, the temporary file gone with the other checkpoints."""
    from tunnelquake.case import load_case
    from tunnelquake.restart import coupled_resume_point

    with h5py.File(reference / "results" / "results_dynamic_water.h5", "r") as f:
        every = round(INTERVAL / float(f["coupling"].attrs["window_size"]))
    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": f"{3 * every}:water"})
    out, _ = proc.communicate(timeout=240)
    assert proc.returncode == 1 and "(water) failed with exit code -9" in out, out[-2000:]
    left = list((p.parent / "results" / "dynamic_water").rglob("fluid-*"))
    assert [f.name for f in left if f.name.endswith(".tmp")] == [f"fluid-{3 * every:09d}.bin.tmp"], left
    m = coupled_resume_point(load_case(p), "dynamic_water")
    assert m is not None and int(m["sequence"]) == 2, m
    _resume_and_compare(p, reference, tmp_path, capsys, m)
    assert not list((p.parent / "results" / "dynamic_water").rglob("fluid-*"))


def test_coupled_suite_member_resumed_continues_from_its_checkpoint_pair(reference, tmp_path):
    """A record suite's `--resume` runs a coupled member that did not finish with `run --resume` when it
    left a restart checkpoint (suite_launch.run_member): tq-solid killed inside its third checkpoint
    (TQ_CHECKPOINT_FAULT=3:solid), the member continues both sides from the second pair, says so in its
    run.log, and ends bitwise equal to the uninterrupted run."""
    from tunnelquake.case import load_case
    from tunnelquake.restart import coupled_resume_point

    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": "3:solid"})
    out, _ = proc.communicate(timeout=240)
    assert proc.returncode == 1 and "tq-solid (solid) failed with exit code -9" in out, out[-2000:]
    m = coupled_resume_point(load_case(p), "dynamic_water")
    assert m is not None and int(m["sequence"]) == 2, m
    # in a process of its own, as a suite's pool runs it: its output (the supervisor's lines too) to run.log
    member = subprocess.run([sys.executable, "-c", "import json, sys; from tunnelquake.suite_launch import "
                             "run_member; print(json.dumps(run_member(sys.argv[1], no_post=True, resume=True)))",
                             str(p)], capture_output=True, text=True, timeout=240)
    log = (p.parent / "run.log").read_text()
    assert member.returncode == 0 and json.loads(member.stdout)["status"] == "completed", log[-2000:]
    assert f"resume: dynamic_water continues from its checkpoint at t = {float(m['time']):.6g} s" in log, log[-2000:]
    assert f"resumed from \"{m['fluid']}\"" in log, log[-2000:]  # the water from its file of that pair
    assert _differences(reference / "results" / "results_dynamic_water.h5",
                        p.parent / "results" / "results_dynamic_water.h5") == []


def _resume_and_compare(p, reference, tmp_path, capsys, m):
    """`--resume` of the stopped run in `p` (whose checkpoint pair `m` is the second) ends completed
    and bitwise equal to the uninterrupted `reference`, its checkpoints removed."""
    res = p.parent / "results" / "results_dynamic_water.h5"
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] != "completed"
    assert main(["run", str(p), "--resume", "--no-post"]) == 0
    said = capsys.readouterr().out
    assert "resume: dynamic_water continues from its checkpoint at t = " in said, said[-2000:]
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed"
        assert f["monitors/top_arch/time"][-1, 0] == pytest.approx(END, abs=1e-4)
        windows = int(f["coupling"].attrs["windows"])
        every = round(INTERVAL / float(f["coupling"].attrs["window_size"]))
    assert int(m["window"]) == 2 * every < windows  # the second of the checkpoints every INTERVAL
    assert _differences(reference / "results" / "results_dynamic_water.h5", res) == []
    # the monitors as `tunnelquake post` writes them (monitors_dynamic_water.csv), byte for byte
    from tunnelquake import post as P

    csv = [P.monitors_csv(P.read_condition(f, "dynamic_water"), tmp_path / f"monitors_{k}.csv").read_bytes()
           for k, f in (("reference", reference / "results" / "results_dynamic_water.h5"), ("resumed", res))]
    assert len(csv[0]) > 0 and csv[0] == csv[1]
    assert not list((p.parent / "results" / "dynamic_water" / "checkpoint").glob("*-*"))


def test_coupled_resume_while_the_solvers_of_a_killed_supervisor_still_run_is_refused(reference, tmp_path, capsys):
    """SIGKILL of `tunnelquake` alone: its tq-solid and its water, coupled to each other, outlive it.
    A `--resume` meanwhile must not start a second pair on the same files: tq-solid finds the
    checkpoints locked and names the running one's PID. Once the orphans have ended (at the end of
    the run, or when their output to the dead supervisor fails), `--resume` ends with the results
    of the uninterrupted run. (The running solid is held with SIGSTOP so that the refusal is tested
    whatever the machine's speed.)"""
    import os
    import signal

    from test_restart import _resume_beside_the_orphaned_solver

    p = _copy(reference, tmp_path)
    proc = _start(p)
    solid = None
    try:
        solid, rc, out = _resume_beside_the_orphaned_solver(p, proc, lambda: _wait_for_pair(p, proc, 1))
        assert rc == 1, out[-2000:]
        assert f"another tq-solid (pid {solid}) is running with the checkpoints in " in out, out[-2000:]
    finally:
        deadline = time.monotonic() + 240
        while solid is not None and os.path.exists(f"/proc/{solid}") and time.monotonic() < deadline:
            time.sleep(0.1)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=60)
    assert not os.path.exists(f"/proc/{solid}"), "the orphaned tq-solid did not end"
    assert main(["run", str(p), "--resume", "--no-post"]) == 0
    assert _differences(reference / "results" / "results_dynamic_water.h5",
                        p.parent / "results" / "results_dynamic_water.h5") == []
