"""Restart checkpoints of the water coupling on MPI ranks (docs/architecture.md "The water coupling on
ranks", docs/reliability.md "Restart"): tq-solid on 2 and 3 ranks coupled to the fake water
(tunnelquake.coupling.fakes replaying a pressure history, saving its coupler state at the same windows
as the solid), a rank killed mid-run (SIGKILL, the test hook TQ_RANK_FAULT: a lost node) and the run
resumed from the last window both sides wrote, on the same ranks.

Reference: the same coupled run on the same ranks, never stopped, with the same checkpoints. Every
dataset and attribute of the results file but the wall-clock figures must be equal byte for byte
(tolerance 0): the solid's sums on ranks run in a fixed order, the coupler's iterations are
deterministic, so any state the checkpoint misses (a rank's part, the coupling's windows done on every
rank, each rank's adapter and its carried volume law, its part of the coupler participant's secant
columns and predictor) shows up as a difference. The case is test_coupled_ranks's: the lining ring with the volume
law and the water's translation carried, implicit windows of 4 steps stepped again whole, so a window
restored from a checkpoint is a window the run iterated.

A resume on another rank count is refused by name with the fix, before the solid listens for the
water.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_coupled_ranks import ENV, EXE, K_STEPS, TOKEN, WINDOWS, half_held_ring, pressure_history, solid_input
from test_solid_coupling import N_THETA

from tunnelquake.compare import results_differences
from tunnelquake.solid_ranks import solid_command

h5py = pytest.importorskip("h5py")

pytestmark = [pytest.mark.skipif(EXE is None, reason="tq-solid is not built (set TQ_BUILD_DIR)"),
              pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")]

#: a checkpoint at the end of every EVERY-th window (both sides), of the run's WINDOWS
EVERY = 15


def prepare(folder: Path) -> Path:
    """The coupled ring case of test_coupled_ranks in `folder`, with restart checkpoints every EVERY windows."""
    folder.mkdir(parents=True, exist_ok=True)
    half_held_ring(folder / "mesh.h5")
    solid_input(folder / "solid_input.h5", folder / "wall.addr")
    with h5py.File(folder / "solid_input.h5", "a") as f:
        f["output"].attrs["checkpoint_interval"] = EVERY * K_STEPS * 2e-5
        f["coupling"].attrs["checkpoint_windows"] = EVERY
    pressure_history(folder / "force.npz")
    (folder / "checkpoint").mkdir(exist_ok=True)
    (folder / "water").mkdir(exist_ok=True)
    return folder


def run(folder: Path, ranks: int, resume_window: int | None = None, fault: str | None = None):
    """The solid on `ranks` ranks and the fake water, both with their checkpoints; `resume_window`: both
    resumed from that window's; `fault`: TQ_RANK_FAULT. Returns (solid, water) completed processes."""
    for addr in folder.glob("wall.addr*"):  # part 0's and the other parts' (.part<r>) of a run before
        addr.unlink()
    water_cmd = [sys.executable, "-m", "tunnelquake.coupling.fakes", "--role", "fluid", "--token", TOKEN,
                 "--address-file", str(folder / "wall.addr"), "--scheme", "implicit", "--windows", str(WINDOWS),
                 "--window-size", repr(K_STEPS * 2e-5), "--n-theta", str(N_THETA), "--n-layers", "2",
                 "--timeout", "30", "--connect-timeout", "30", "--history", str(folder / "force.npz"),
                 "--checkpoint-dir", str(folder / "water"), "--checkpoint-windows", str(EVERY)]
    solid_cmd = solid_command(EXE, folder / "solid_input.h5", folder / "results.h5", 1, ranks)
    solid_cmd += ["--checkpoint-dir", str(folder / "checkpoint")]
    if resume_window is not None:
        water_cmd += ["--resume-from", str(folder / "water" / f"fake-{resume_window:09d}.bin")]
        solid_cmd += ["--resume"]
    water = subprocess.Popen(water_cmd, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    env = {**ENV, "TQ_RANK_FAULT": fault} if fault else ENV
    solid = subprocess.run(solid_cmd, env=env, capture_output=True, text=True, timeout=240)
    try:
        out, err = water.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # a hung fake: end it (it is ours)
        water.kill()
        out, err = water.communicate(timeout=10)
    return solid, subprocess.CompletedProcess(water_cmd, water.returncode, out, err)


def status(path: Path) -> str:
    with h5py.File(path, "r") as f:
        s = f.attrs["status"]
    return s.decode() if isinstance(s, bytes) else str(s)


@pytest.mark.parametrize("ranks", [2, 3])
def test_coupled_run_on_ranks_with_a_rank_killed_resumes_bitwise_equal(tmp_path, ranks):
    ref = prepare(tmp_path / "reference")
    solid, water = run(ref, ranks)
    assert solid.returncode == 0, solid.stdout + solid.stderr
    assert water.returncode == 0, water.stdout + water.stderr
    assert status(ref / "results.h5") == "completed"
    with h5py.File(ref / "results.h5", "r") as f:
        steps = int(f["timings"].attrs["steps"])
        assert int(f["timings"].attrs["checkpoints"]) == WINDOWS // EVERY - 1  # none after the last window
        assert int(f["coupling"].attrs["passes"]) >= 2 * WINDOWS  # every window stepped again

    # the last rank killed at 60 % of the run's steps: the checkpoints of windows 15 and 30 written
    case = prepare(tmp_path / "case")
    solid, water = run(case, ranks, fault=f"{ranks - 1}:{int(0.6 * steps)}")
    assert solid.returncode != 0, solid.stdout + solid.stderr
    assert water.returncode != 0  # its partner lost
    said = status(case / "results.h5")
    assert said.startswith("stopped: the run on ranks was ended by signal"), said
    m = json.loads((case / "checkpoint" / "checkpoint.json").read_text())
    assert int(m["window"]) == 2 * EVERY, m
    assert (case / "water" / f"fake-{2 * EVERY:09d}.bin").is_file()

    # resumed on another rank count: refused by name, with the fix, before it listens for the water
    other = ranks + 1
    cmd = solid_command(EXE, case / "solid_input.h5", case / "results.h5", 1, other)
    refused = subprocess.run(cmd + ["--checkpoint-dir", str(case / "checkpoint"), "--resume"], env=ENV,
                             capture_output=True, text=True, timeout=60)
    assert refused.returncode == 2, refused.stdout + refused.stderr
    assert (f"was written by the run on {ranks} ranks; resume it on {ranks} ranks (--ranks {ranks})"
            in refused.stderr), refused.stderr
    assert not (case / "wall.addr").exists()
    assert status(case / "results.h5") == said  # the results file as the stopped run left it

    solid, water = run(case, ranks, resume_window=int(m["window"]))
    assert solid.returncode == 0, solid.stdout + solid.stderr
    assert water.returncode == 0, water.stdout + water.stderr
    assert (f"resumed from checkpoint {m['sequence']} at t = " in solid.stdout
            and f"coupling window {2 * EVERY}) on {ranks} rank(s)" in solid.stdout), solid.stdout
    assert status(case / "results.h5") == "completed"
    assert results_differences(ref / "results.h5", case / "results.h5") == []
    assert not (case / "checkpoint" / "checkpoint.json").exists()  # a completed run leaves none to resume


#: the OpenFOAM case: shaking simulated, s, and a checkpoint every INTERVAL s of it (both sides)
END, INTERVAL = 0.1, 0.025


@pytest.fixture(scope="module")
def openfoam_reference(tmp_path_factory):
    """The example's dynamic_water (OpenFOAM's water) run on 2 ranks, never stopped: its folder and
    the solid's steps."""
    from case_edits import with_time
    from test_restart import _case_text

    from conftest import ran_case

    ref = tmp_path_factory.mktemp("reference")
    # single-rate: the example's subcycling of dynamic_water does not run on ranks
    text = with_time(_case_text("dynamic_water", END, INTERVAL), subcycling=0)
    ran_case(ref, text, "--ranks", "2", "--no-post")
    with h5py.File(ref / "results" / "results_dynamic_water.h5", "r") as f:
        steps = int(f["timings"].attrs["steps"])
        assert int(f["timings"].attrs["checkpoints"]) == 3  # at 0.025, 0.05 and 0.075 s; none at the end
        assert int(f["ranks"].attrs["ranks"]) == 2
    return ref, steps


@pytest.mark.parametrize("how", ["rank killed", "ctrl-c"])
def test_run_on_ranks_with_openfoams_water_stopped_and_resumed_is_bitwise_equal(openfoam_reference, tmp_path, capsys,
                                                                                monkeypatch, how):
    """`tunnelquake run --ranks 2` of the example's dynamic_water (OpenFOAM's water), stopped after both
    sides wrote a checkpoint: `rank killed`, rank 1 killed (SIGKILL) at 85 % of the shaking, after the
    checkpoint pair of 0.075 s; `ctrl-c`, SIGINT to the run's process group (a terminal's Ctrl-C) once
    the pair of 0.05 s is written, after which `run` exits 130 and no rank, mpirun or water is left.
    `run --ranks 3 --resume` is refused by name with the fix, before the water starts; `run --ranks 2
    --resume` starts both sides from the last window both wrote, the water as the one-process resume
    does (its fluid-<window>.bin), and ends with every dataset and attribute of the results (all but
    the wall-clock figures) byte for byte those of the run on 2 ranks never stopped."""
    from test_restart import _pids, _start, _stop
    from test_restart_coupled import _wait_for_pair

    from tunnelquake.case import load_case
    from tunnelquake.cli import main
    from tunnelquake.restart import coupled_resume_point

    ref, steps = openfoam_reference
    case = tmp_path / "case"
    (case / "results").mkdir(parents=True)
    shutil.copy(ref / "case.yaml", case / "case.yaml")
    shutil.copytree(ref / "results" / "mesh", case / "results" / "mesh")
    shutil.copy(ref / "results" / "motion.h5", case / "results" / "motion.h5")

    if how == "rank killed":
        monkeypatch.setenv("TQ_RANK_FAULT", f"1:{int(0.85 * steps)}")
        assert main(["run", str(case / "case.yaml"), "--ranks", "2", "--no-post"]) != 0
        monkeypatch.delenv("TQ_RANK_FAULT")
    else:
        proc = _start(case / "case.yaml", "--ranks", "2")
        try:
            _wait_for_pair(case / "case.yaml", proc, 2)
        finally:
            out = _stop(proc, case, "SIGINT")
        assert proc.returncode == 130, out[-2000:]
        left = [pid for program in (b"tq-solid", b"mpirun", b"PimpleFoam") for pid in _pids(case, program)]
        assert not left, out[-2000:]
    res = case / "results" / "results_dynamic_water.h5"
    stopped = status(res)
    assert stopped.startswith("stopped"), stopped
    if how == "rank killed":
        assert stopped.startswith("stopped: the run on ranks was ended by signal"), stopped
    m = coupled_resume_point(load_case(case / "case.yaml"), "dynamic_water")
    assert m is not None, stopped
    if how == "rank killed":
        assert float(m["time"]) == pytest.approx(3 * INTERVAL, rel=0.02), m
    else:
        assert int(m["sequence"]) >= 2, m
    capsys.readouterr()

    assert main(["run", str(case / "case.yaml"), "--ranks", "3", "--resume", "--no-post"]) != 0
    said = capsys.readouterr().out
    assert "was written by the run on 2 ranks; resume it on 2 ranks (--ranks 2)" in said, said[-3000:]
    assert "running the water" not in said, said[-3000:]
    assert status(res) == stopped

    assert main(["run", str(case / "case.yaml"), "--ranks", "2", "--resume", "--no-post"]) == 0
    said = capsys.readouterr().out
    assert f"resume: dynamic_water continues from its checkpoint at t = {float(m['time']):.6g} s" in said, said[-3000:]
    assert status(res) == "completed"
    assert results_differences(ref / "results" / "results_dynamic_water.h5", res) == []
    assert not list((case / "results" / "dynamic_water" / "checkpoint").glob("*-*"))
