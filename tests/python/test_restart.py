"""Restart of a single run (docs/user_guide.md "Resuming a run", docs/reliability.md "Restart"):
a run stopped in any way after a restart checkpoint and continued with `tunnelquake run --resume`
ends with results bitwise equal to those of a run that was never stopped.

Reference: the same case run without interruption, with the same checkpoint interval and thread
count. Every dataset of the results file (monitor histories, energy balance, lining section
forces and envelopes, damage, snapshots) and every attribute except wall-clock figures must be
equal byte for byte (tolerance 0): the solid's time step is deterministic, so any state the
checkpoint misses shows up as a difference."""
from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time

import h5py
import pytest
from case_edits import with_time

from conftest import EXAMPLE
from tunnelquake.cli import main
from tunnelquake.compare import results_differences as _differences

RECORD = "../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2"

#: shaking simulated, s; a checkpoint every INTERVAL s of it
END, INTERVAL = 0.6, 0.15


def _case_text(condition: str = "no_water", end: float = END, interval: float = INTERVAL) -> str:
    """The example with one condition, its record path made absolute, `end` s of shaking and a
    checkpoint every `interval` s."""
    rec = (EXAMPLE.parent / RECORD).resolve()
    text = EXAMPLE.read_text().replace(RECORD, str(rec))
    lines = []
    for line in text.splitlines():
        if line.startswith("conditions:"):
            line = f"conditions: [{condition}]"
        lines.append(line)
        if line.startswith("output:"):
            lines.append(f"  checkpoint_interval: {interval} s")
    return with_time("\n".join(lines), end_time=f"{end} s")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The case meshed, its motion written, and run once without interruption."""
    folder = tmp_path_factory.mktemp("reference")
    (folder / "case.yaml").write_text(_case_text())
    assert main(["run", str(folder / "case.yaml"), "--no-post"]) == 0
    return folder


def _copy(reference, tmp_path):
    """A fresh folder with the reference's mesh and motion (not its results)."""
    import shutil

    dst = tmp_path / "case"
    (dst / "results").mkdir(parents=True)
    shutil.copy(reference / "case.yaml", dst / "case.yaml")
    shutil.copytree(reference / "results" / "mesh", dst / "results" / "mesh")
    shutil.copy(reference / "results" / "motion.h5", dst / "results" / "motion.h5")
    return dst / "case.yaml"


def _start(case_yaml, *extra, env=None):
    """`tunnelquake run` as a user starts it: its own process group, as a terminal's job."""
    return subprocess.Popen([sys.executable, "-m", "tunnelquake", "run", str(case_yaml), "--no-post", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            env={**os.environ, **(env or {})})


def _wait_for_checkpoint(case_yaml, proc, at_least: float, timeout: float = 120.0) -> float:
    """Wait until the condition's last checkpoint is at `at_least` s or later; its time."""
    manifest = case_yaml.parent / "results" / "no_water" / "checkpoint" / "checkpoint.json"
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            t = float(json.loads(manifest.read_text())["time"])
            if t >= at_least:
                return t
        except (OSError, ValueError, KeyError):
            pass
        assert proc.poll() is None, proc.communicate()[0][-3000:]
        time.sleep(0.02)
    raise AssertionError(f"no checkpoint at t >= {at_least} s within {timeout} s")


def _pids(folder, program: bytes) -> list[int]:
    """The PIDs of the processes whose executable name ends with `program` working in `folder`."""
    out = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                with open(f"/proc/{name}/cmdline", "rb") as fh:
                    cmd = fh.read().split(b"\0")
            except OSError:
                continue
            if cmd and cmd[0].endswith(program) and any(str(folder).encode() in c for c in cmd):
                out.append(int(name))
    return out


def _solid_pid(folder) -> int:
    """The PID of the tq-solid working in `folder`."""
    pids = _pids(folder, b"tq-solid")
    assert pids, f"no tq-solid running in {folder}"
    return pids[0]


def _wait_gone(pids: list[int], timeout: float = 60.0) -> None:
    """Wait until each process in `pids` has exited (gone, or a zombie: its files are closed)."""
    deadline = time.monotonic() + timeout
    for pid in pids:
        while time.monotonic() < deadline:
            try:
                with open(f"/proc/{pid}/stat", "rb") as fh:
                    if fh.read().rsplit(b")", 1)[1].split()[0] == b"Z":
                        break
            except OSError:
                break
            time.sleep(0.01)
        else:
            raise AssertionError(f"process {pid} still running {timeout} s after SIGKILL")


def _stop(proc, folder, how: str, programs: tuple[bytes, ...] = (b"tq-solid",)) -> str:
    """Stop a running `tunnelquake run` (`_start`) in `folder` as `how` says: "SIGINT" to its
    process group (Ctrl-C), "SIGKILL tq-solid" or "SIGKILL water" (OpenFOAM's solver) alone (a
    crash), or "SIGKILL all": tunnelquake and
    the solvers named by `programs` together (a lost node). Whatever happens, nothing of it is
    left running; returns its output."""
    out = ""
    try:
        if proc.poll() is None:
            if how == "SIGINT":
                os.killpg(proc.pid, signal.SIGINT)
            elif how == "SIGKILL tq-solid":
                os.kill(_solid_pid(folder), signal.SIGKILL)
            elif how == "SIGKILL water":
                for pid in _pids(folder, b"PimpleFoam"):
                    os.kill(pid, signal.SIGKILL)
            else:
                pids = [pid for program in programs for pid in _pids(folder, program)]
                os.kill(proc.pid, signal.SIGKILL)
                for pid in pids:
                    os.kill(pid, signal.SIGKILL)
                _wait_gone(pids)  # a killed solver holds its files' locks until it has exited
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return out


def _resume_and_compare(case_yaml, reference, capsys):
    assert main(["run", str(case_yaml), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert "resume: no_water continues from its checkpoint at t = " in out, out[-2000:]
    res = case_yaml.parent / "results" / "results_no_water.h5"
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed"
        assert f["monitors/top_arch/time"][-1, 0] == pytest.approx(END, abs=1e-4)
    assert _differences(reference / "results" / "results_no_water.h5", res) == []
    # a completed run leaves no checkpoint behind
    assert not (case_yaml.parent / "results" / "no_water" / "checkpoint" / "checkpoint.json").exists()
    return out


@pytest.mark.parametrize("how", ["SIGINT", "SIGKILL tq-solid", "SIGKILL all"])
def test_run_stopped_after_a_checkpoint_resumes_bitwise_equal_to_an_uninterrupted_run(reference, tmp_path,
                                                                                    capsys, how):
    """Stopped after its second checkpoint: by Ctrl-C (SIGINT to the process group: tunnelquake
    stops tq-solid and exits 130), by SIGKILL of tq-solid alone (a crash: tunnelquake reports the
    failure and ends), or by SIGKILL of tunnelquake and tq-solid together (a lost node). The resumed
    run continues from the checkpoint and ends bitwise equal to the uninterrupted one."""
    p = _copy(reference, tmp_path)
    proc = _start(p)
    try:
        t_ck = _wait_for_checkpoint(p, proc, 2 * INTERVAL - 1e-9)
    finally:
        out = _stop(proc, p.parent, how)
    assert proc.returncode == {"SIGINT": 130, "SIGKILL tq-solid": 1, "SIGKILL all": -9}[how], out[-2000:]
    assert t_ck < END - 1e-6  # stopped before the end
    with h5py.File(p.parent / "results" / "results_no_water.h5", "r") as f:
        assert f.attrs["status"] != "completed"
    _resume_and_compare(p, reference, capsys)


@pytest.mark.parametrize("part", ["solid", "results"])
def test_crash_while_writing_a_checkpoint_leaves_the_previous_one(reference, tmp_path, capsys, part):
    """tq-solid killed (SIGKILL) while it writes its third checkpoint, after the state file
    (`solid`) or also the results copy (`results`) but before the manifest
    (TQ_CHECKPOINT_FAULT): the manifest still names the second, whose files are whole, and the
    resumed run ends bitwise equal to the uninterrupted one."""
    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": f"3:{part}"})
    out, _ = proc.communicate(timeout=180)
    assert proc.returncode == 1, out[-2000:]
    assert "tq-solid stopped (exit -9)" in out, out[-2000:]
    folder = p.parent / "results" / "no_water" / "checkpoint"
    manifest = json.loads((folder / "checkpoint.json").read_text())
    assert manifest["sequence"] == 2 and manifest["time"] == pytest.approx(2 * INTERVAL, abs=1e-3)
    assert (folder / "solid-000003.bin").is_file()  # the interrupted write was under way
    resumed = _resume_and_compare(p, reference, capsys)
    assert f"at t = {manifest['time']:.6g} s" in resumed


def test_resume_of_a_finished_run_keeps_it_and_with_nothing_to_resume_starts_afresh(reference, tmp_path, capsys):
    """--resume of a run that completed changes nothing and says so (exit 0). --resume of a run
    killed before its first checkpoint was written (tq-solid killed inside it: no manifest), as a
    requeued batch job runs it, starts afresh, says so, and ends equal to the uninterrupted run."""
    res = reference / "results" / "results_no_water.h5"
    before = res.stat().st_mtime_ns
    assert main(["run", str(reference / "case.yaml"), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert "nothing to resume: every condition in " in out and "completed (no_water)" in out, out
    assert res.stat().st_mtime_ns == before

    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": "1:solid"})
    out, _ = proc.communicate(timeout=180)
    assert proc.returncode == 1 and "tq-solid stopped (exit -9)" in out, out[-2000:]
    assert not (p.parent / "results" / "no_water" / "checkpoint" / "checkpoint.json").exists()
    assert main(["run", str(p), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert "resume: nothing to resume in " in out and "no condition has a restart checkpoint" in out, out[-2000:]
    assert "starting afresh" in out and "continues from its checkpoint" not in out, out[-2000:]
    assert _differences(res, p.parent / "results" / "results_no_water.h5") == []


def test_resume_after_the_case_changed_runs_again_naming_the_key(reference, tmp_path):
    """A checkpoint belongs to the inputs it was written for (its manifest's `inputs`, the digest of
    the condition's input fingerprint): after an edit of the case that shapes the condition (here
    the lining's cohesion), `--resume` does not continue from it but runs the condition from the
    start, naming the key with its old and new value, and the results then carry the new inputs.
    tq-solid alone, given the old checkpoint, still refuses it (its own fingerprint of its input)."""
    from tunnelquake import fingerprint as F
    from tunnelquake import paths
    from tunnelquake.case import load_case

    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": "2:solid"})
    out, _ = proc.communicate(timeout=180)
    assert proc.returncode == 1 and "tq-solid stopped (exit -9)" in out, out[-2000:]
    text = p.read_text()
    assert text.count("cohesion: 1.80 MPa") == 1
    p.write_text(text.replace("cohesion: 1.80 MPa", "cohesion: 1.90 MPa"))
    work = p.parent / "results" / "no_water"
    old_input = work / "solid_input.h5"
    again = _start(p, "--resume")
    out, _ = again.communicate(timeout=180)
    assert again.returncode == 0, out[-2000:]
    assert ("resume: no_water: its checkpoint was written with other inputs: materials.lining.cohesion 1.8e+06 -> "
            "1.9e+06 (solid material); it runs from the start") in out, out[-2000:]
    assert "continues from its checkpoint" not in out, out[-2000:]
    res = p.parent / "results" / "results_no_water.h5"
    assert F.read_results(res)["digest"] == F.condition_inputs(load_case(p), "no_water")["digest"]
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed"
    # tq-solid's own check: a checkpoint of the old input refused by the new solver input
    stale = _copy(reference, tmp_path / "stale")
    proc = _start(stale, env={"TQ_CHECKPOINT_FAULT": "2:solid"})
    proc.communicate(timeout=180)
    assert old_input.is_file()
    got = subprocess.run([str(paths.solid_executable()), str(old_input), "-o", str(tmp_path / "x.h5"),
                          "--checkpoint-dir", str(stale.parent / "results" / "no_water" / "checkpoint"), "--resume"],
                         capture_output=True, text=True, timeout=120)
    assert got.returncode == 2 and "was written for another input" in got.stderr, got.stderr[-2000:]


def test_suite_member_resumed_continues_from_its_checkpoint(reference, tmp_path):
    """A record suite's `--resume` runs a member that did not finish with `run --resume` when it
    left a restart checkpoint (suite_launch.run_member): here a member killed inside its third
    checkpoint continues from its second and ends bitwise equal to the uninterrupted run."""
    from tunnelquake.suite_launch import run_member

    p = _copy(reference, tmp_path)
    proc = _start(p, env={"TQ_CHECKPOINT_FAULT": "3:solid"})
    out, _ = proc.communicate(timeout=180)
    assert proc.returncode == 1 and "tq-solid stopped (exit -9)" in out, out[-2000:]
    got = run_member(str(p), no_post=True, resume=True)
    log = (p.parent / "run.log").read_text()
    assert got["status"] == "completed", log[-2000:]
    assert f"tq-solid: resumed from checkpoint 2 at t = {2 * INTERVAL:g} s" in log, log[-2000:]
    assert _differences(reference / "results" / "results_no_water.h5",
                        p.parent / "results" / "results_no_water.h5") == []


def _resume_beside_the_orphaned_solver(case_yaml, proc, wait) -> tuple[int, int, str]:
    """Once `wait()` returns: tq-solid of the running `proc` held with SIGSTOP (so that what follows
    does not depend on the machine's speed), `tunnelquake` alone killed (SIGKILL), and a
    `--resume` of the same case run while the orphaned solver lives; the solver is let go on
    (SIGCONT) whatever happens. Returns the solver's PID, the resume's exit code and output."""
    solid = None
    try:
        wait()
        solid = _solid_pid(case_yaml.parent)
        os.kill(solid, signal.SIGSTOP)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        again = _start(case_yaml, "--resume")
        out, _ = again.communicate(timeout=180)
        return solid, again.returncode, out
    finally:
        if solid is not None:
            os.kill(solid, signal.SIGCONT)


def test_resume_while_the_solver_of_a_killed_supervisor_still_runs_is_refused(reference, tmp_path, capsys):
    """SIGKILL of `tunnelquake` alone: its tq-solid (a session of its own) runs on. A `--resume`
    meanwhile must not start a second solver on the same files: tq-solid finds the checkpoints
    locked, names the running one's PID and exits 2 before touching anything. Once the first has
    finished, `--resume` finds the condition completed, and its results are those of the
    uninterrupted run. (The running solver is held with SIGSTOP so that the refusal is tested
    whatever the machine's speed.)"""
    p = _copy(reference, tmp_path)
    proc = _start(p)
    try:
        solid, rc, out = _resume_beside_the_orphaned_solver(p, proc, lambda: _wait_for_checkpoint(
            p, proc, INTERVAL - 1e-9))
        assert rc == 1, out[-2000:]
        assert f"another tq-solid (pid {solid}) is running with the checkpoints in " in out, out[-2000:]
        assert "tq-solid stopped (exit 2)" in out, out[-2000:]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        rest, _ = proc.communicate(timeout=180)  # ends when the orphaned solver closes the pipe
    assert "tq-solid: completed" in rest, rest[-2000:]
    assert main(["run", str(p), "--resume", "--no-post"]) == 0
    assert "nothing to resume: every condition in " in capsys.readouterr().out
    assert _differences(reference / "results" / "results_no_water.h5",
                        p.parent / "results" / "results_no_water.h5") == []


def test_run_on_ranks_stopped_by_ctrl_c_after_a_checkpoint_resumes_bitwise_equal(reference, tmp_path, capsys):
    """The solid on 2 MPI ranks (`--ranks 2`: mpirun puts each rank in a process group of its own)
    stopped by Ctrl-C (SIGINT to the run's process group) after its first checkpoint: `run` sends
    SIGTERM to the ranks too, so they stop within a second (rank 0 writes the status with the time
    its results reach), not after mpirun's own wait (odls_base_sigkill_timeout, 5 s, during which they
    stepped on, and which `run`'s SIGKILL of mpirun at the end of its grace could cut short, leaving
    them running). `run` exits 130, nothing of the run is left; `run --resume --ranks 2` continues
    from the checkpoint and ends bitwise equal to the same run on 2 ranks never stopped (against one
    process the motion is bitwise equal; the energies' sums differ by round-off, 5e-15)."""
    from tunnelquake.children import STOP_GRACE_S

    whole = _copy(reference, tmp_path / "whole")
    assert main(["run", str(whole), "--ranks", "2", "--no-post"]) == 0
    p = _copy(reference, tmp_path)
    proc = _start(p, "--ranks", "2")
    ranks_s = math.inf
    try:
        _wait_for_checkpoint(p, proc, INTERVAL - 1e-9)
        ranks = _pids(p.parent, b"tq-solid")
        assert len(ranks) == 2, ranks  # both ranks running
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        while time.monotonic() - t0 < 3 * STOP_GRACE_S and _pids(p.parent, b"tq-solid"):
            time.sleep(0.01)
        ranks_s = time.monotonic() - t0
    finally:
        out = _stop(proc, p.parent, "SIGINT")
    stopped_s = time.monotonic() - t0
    assert proc.returncode == 130, out[-2000:]
    assert ranks_s < 2.0 and stopped_s < STOP_GRACE_S + 3.0, (ranks_s, stopped_s, out[-2000:])
    assert not _pids(p.parent, b"tq-solid") and not _pids(p.parent, b"mpirun"), out[-2000:]
    with h5py.File(p.parent / "results" / "results_no_water.h5", "r") as f:
        status = f.attrs["status"]
        status = status.decode() if isinstance(status, bytes) else str(status)
        assert status.startswith("stopped: the run on ranks was ended by signal 15"), (status, out[-2000:])
        assert INTERVAL - 1e-9 <= f["monitors/top_arch/time"][-1, 0] < END - 1e-6  # rows past the checkpoint
    assert main(["run", str(p), "--resume", "--ranks", "2", "--no-post"]) == 0
    resumed = capsys.readouterr().out
    assert "resume: no_water continues from its checkpoint at t = " in resumed, resumed[-2000:]
    assert _differences(whole.parent / "results" / "results_no_water.h5",
                        p.parent / "results" / "results_no_water.h5") == []
