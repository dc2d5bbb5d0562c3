"""Faults of `tunnelquake run` and `post` and what the user gets from each (docs/reliability.md):
each test is named after the fault, forces it, and asserts the clean outcome."""
from __future__ import annotations

import shutil
import threading
import time

import pytest

from conftest import EXAMPLE
from tunnelquake.cli import main

RECORD = "../../../shared/data/ground_motions/elCentro_1940_NS_Peknold_dt0.02.AT2"


def _case_text(end_time: str = "0.02 s") -> str:
    """The example with its record path made absolute and a short shaking."""
    rec = (EXAMPLE.parent / RECORD).resolve()
    return EXAMPLE.read_text().replace(RECORD, str(rec)) + f"\ntime:\n  end_time: {end_time}\n"


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    """The example (0.02 s of shaking) meshed and its motion written, once for this module."""
    folder = tmp_path_factory.mktemp("prepared")
    (folder / "case.yaml").write_text(_case_text())
    assert main(["mesh", str(folder / "case.yaml")]) == 0
    assert main(["motion", str(folder / "case.yaml")]) == 0
    return folder


def _copy(prepared, tmp_path):
    dst = tmp_path / "case"
    shutil.copytree(prepared, dst)
    return dst / "case.yaml"


def test_race_coupled_setup_beside_a_starting_solid_never_forks_with_an_hdf5_file_open(prepared, tmp_path,
                                                                                    monkeypatch):
    """The coupled condition writes dynamic_water/solid_input.h5 and reads it back while the
    solid-only conditions start tq-solid beside it. A child forked while an HDF5 file of the parent
    is open inherits the descriptor and its lock until it execs; a reopen inside that window fails
    with `[Errno 11] ... unable to lock file`. The window is a fraction of a millisecond, so the
    interleaving is forced: every HDF5 file opened for writing is held open 20 ms longer (a slow
    disk), and every fork records the HDF5 files open in the parent at that instant, which must be
    none. Both run in a tight loop, the solver replaced by a script (only the parent's writes and
    forks matter), the water's set-up cut short after the solid side's HDF5 work."""
    import subprocess

    import h5py

    from tunnelquake import fluid_case as fc
    from tunnelquake import paths
    from tunnelquake.case import load_case
    from tunnelquake.cli import run

    p = _copy(prepared, tmp_path)
    fake = tmp_path / "fake-tq-solid"
    fake.write_text('#!/bin/sh\necho "dt = 1e-05 s"\n')
    fake.chmod(0o755)
    monkeypatch.setattr(paths, "solid_executable", lambda: fake)

    def water_setup_stub(*args, **kwargs):
        raise fc.FluidCaseError("set-up of the solid side done")

    monkeypatch.setattr(fc, "build_fluid_case", water_setup_stub)
    monkeypatch.setattr(run, "say", lambda msg: None)

    open_now: dict[int, str] = {}
    guard = threading.Lock()
    forks_with_open_files: list[list[str]] = []

    class SlowFile(h5py.File):
        def __init__(self, name, mode="r", *args, **kwargs):
            super().__init__(name, mode, *args, **kwargs)
            with guard:
                open_now[id(self)] = f"{name} ({mode})"

        def close(self):
            if self.id.valid and self.mode == "r+":
                time.sleep(0.02)
            super().close()
            with guard:
                open_now.pop(id(self), None)

    monkeypatch.setattr(h5py, "File", SlowFile)
    execute_child = subprocess.Popen._execute_child

    def recording_execute_child(self, *args, **kwargs):
        with guard:
            if open_now:
                forks_with_open_files.append(sorted(open_now.values()))
        return execute_child(self, *args, **kwargs)

    monkeypatch.setattr(subprocess.Popen, "_execute_child", recording_execute_child)

    case = load_case(p)
    motion = case.output_dir / "motion.h5"
    stop = threading.Event()
    outcomes: list[str] = []

    def coupled():
        while not stop.is_set():
            outcomes.append(run.run_coupled_condition(case, "dynamic_water", motion)[2])

    th = threading.Thread(target=coupled)
    th.start()
    spawned = 0
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < 5.0 and not forks_with_open_files:
            rc, _ = run.run_solid_condition(case, "no_water", motion)
            assert rc == 0
            spawned += 1
    finally:
        stop.set()
        th.join(timeout=30)
    assert not forks_with_open_files, (f"{len(forks_with_open_files)} child(ren) forked while HDF5 files were open: "
                                       f"{forks_with_open_files[0]}")
    failed = [o for o in outcomes if "set-up of the solid side done" not in o]
    assert not failed, f"{len(failed)} of {len(outcomes)} coupled set-ups failed: {failed[0]}"
    assert len(outcomes) >= 10 and spawned >= 10, (len(outcomes), spawned)


def _killed_in_stage(case_yaml, cond: str, stage_line: str):
    """Run tq-solid on `cond` of the case and SIGKILL it as soon as it prints `stage_line`:
    a results file left by a run stopped there (status still 'running'); "never printed" lets
    it complete."""
    import subprocess

    from tunnelquake import paths
    from tunnelquake.case import load_case
    from tunnelquake.solid_input import write_solid_input

    case = load_case(case_yaml)
    out = case.output_dir
    inp = write_solid_input(case, out / "mesh" / "mesh.h5", out / "motion.h5", cond, out / cond / "solid_input.h5")
    res = out / f"results_{cond}.h5"
    with subprocess.Popen([str(paths.solid_executable()), str(inp), "-o", str(res), "--threads", "1"],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) as proc:
        for line in proc.stdout:
            if line.startswith(stage_line):
                proc.kill()
                break
        proc.wait(timeout=30)
    if stage_line != "never printed":
        assert proc.returncode == -9, "tq-solid ended before the stage to stop in"
    return res


def test_post_on_a_run_stopped_before_shaking_reports_the_stage_and_the_missing_conditions(prepared, tmp_path,
                                                                                         capsys):
    """tq-solid killed inside the static stages, and a run stopped at the start of the seismic
    stage: their results files have monitors with no row (which `_rows` could not reshape).
    `post` exits 0 and reports where each stopped, and the condition with no results file."""
    import h5py

    p = _copy(prepared, tmp_path)
    _killed_in_stage(p, "static_water", "tq-solid: stage excavation")
    # tq-solid records its stages once all have ended and then appends rows as it shakes, with no
    # line printed in between to stop it at: the state "stages recorded, no row yet" is made from
    # a completed file with its rows cut and its status put back
    res = _killed_in_stage(p, "no_water", "never printed")
    with h5py.File(res, "a") as f:
        f.attrs["status"] = "running"
        for g in f["monitors"].values():
            for ds in g.values():
                ds.resize(0, axis=0)
        assert f["monitors/top_arch/time"].shape[0] == 0 and "stages/3_switch" in f
    assert main(["post", str(p)]) == 0
    out = capsys.readouterr().out
    report = (p.parent / "results" / "report.md").read_text()
    assert ("(1) no water: status **running**, no monitor sample: the run stopped before the shaking (static "
            "stages finished: in_situ, excavation, lining; stopped at the start of the seismic stage, before its "
            "first sample)") in report
    assert ("(2) static water: status **running**, no monitor sample: the run stopped before the shaking (in the "
            "static stages, none recorded as finished; planned: in_situ, excavation, lining, hydrostatic, seismic)"
            ) in report
    assert "(3) dynamic water: no results (`results_dynamic_water.h5` was not written" in report
    assert "No condition has monitor samples yet" in report
    assert "no_water: status 'running', no monitor sample: stopped before the shaking (static stages" in out
    assert "dynamic_water: no results file (results_dynamic_water.h5)" in out
    csv_rows = (p.parent / "results" / "monitors_no_water.csv").read_text().splitlines()
    assert len(csv_rows) == 1 and csv_rows[0].startswith("time_s,")


def test_post_on_an_unreadable_results_file_names_it_and_reports_the_rest(prepared, tmp_path, capsys):
    """A results file that is not HDF5 (a crash before its superblock, a foreign file): named as
    unreadable in the report and on the terminal; the other conditions are still reported."""
    p = _copy(prepared, tmp_path)
    _killed_in_stage(p, "no_water", "tq-solid: stage excavation")
    (p.parent / "results" / "results_static_water.h5").write_bytes(b"not an HDF5 file\n" * 10)
    assert main(["post", str(p)]) == 0
    out = capsys.readouterr().out
    report = (p.parent / "results" / "report.md").read_text()
    assert "(2) static water: `results_static_water.h5` cannot be read (" in report
    assert "static_water: results_static_water.h5 cannot be read (" in out
    assert "(1) no water: status **running**, no monitor sample" in report
