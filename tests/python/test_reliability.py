"""Faults of `tunnelquake run` and `post` and what the user gets from each (docs/reliability.md):
each test is named after the fault, forces it, and asserts the clean outcome."""
from __future__ import annotations

import contextlib
import re
import shutil
import threading
import time

import pytest
from case_edits import with_time

from conftest import EXAMPLE
from tunnelquake.cli import main

RECORD = "../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2"


def _case_text(end_time: str = "0.02 s") -> str:
    """The example with its record path made absolute and a short shaking."""
    rec = (EXAMPLE.parent / RECORD).resolve()
    return with_time(EXAMPLE.read_text().replace(RECORD, str(rec)), end_time=end_time)


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
    from tunnelquake import launch, paths
    from tunnelquake.case import load_case

    p = _copy(prepared, tmp_path)
    fake = tmp_path / "fake-tq-solid"
    # tq-solid --check --json FILE writes its step to FILE; any other call only has to succeed
    fake.write_text('#!/bin/sh\nwhile [ $# -gt 0 ]; do\n  if [ "$1" = --json ]; then echo \'{"dt": 1e-05}\' > "$2"; fi\n'
                    '  shift\ndone\n')
    fake.chmod(0o755)
    monkeypatch.setattr(paths, "solid_executable", lambda: fake)

    def water_setup_stub(*args, **kwargs):
        raise fc.FluidCaseError("set-up of the solid side done")

    monkeypatch.setattr(fc, "build_fluid_case", water_setup_stub)
    monkeypatch.setattr(launch, "say", lambda msg: None)

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
            outcomes.append(launch.run_coupled_condition(case, "dynamic_water", motion)[2])

    th = threading.Thread(target=coupled)
    th.start()
    spawned = 0
    t0 = time.monotonic()
    try:
        # at least 5 s and at least 10 rounds of each side (a loaded machine takes longer for them)
        while ((time.monotonic() - t0 < 5.0 or spawned < 10 or len(outcomes) < 10)
               and time.monotonic() - t0 < 120.0 and not forks_with_open_files):
            rc, _ = launch.run_solid_condition(case, "no_water", motion)
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


def _start_run(case_yaml, *extra):
    """`tunnelquake run` as a user starts it: its own process group, as a terminal's job."""
    import subprocess
    import sys

    return subprocess.Popen([sys.executable, "-m", "tunnelquake", "run", str(case_yaml), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)


def _read_until(proc, marker: str, timeout: float = 60.0) -> list[str]:
    """Lines of `proc` up to the first holding `marker` (fails if it ends or times out first). The
    pipe's bytes are read here, not by a buffered readline: that may take in several lines at once,
    and select then has nothing to wake on while the marker waits in its buffer. What came after
    the marker's line is kept for the next read (`_read_until` or `_signalled`)."""
    import os
    import selectors

    lines: list[str] = []
    got = getattr(proc, "unread", b"")
    deadline = time.monotonic() + timeout
    with selectors.DefaultSelector() as sel:
        sel.register(proc.stdout, selectors.EVENT_READ)
        while True:
            while b"\n" in got:
                raw, got = got.split(b"\n", 1)
                lines.append(raw.decode(errors="replace") + "\n")
                if marker in lines[-1]:
                    proc.unread = got
                    return lines
            left = deadline - time.monotonic()
            chunk = os.read(proc.stdout.fileno(), 65536) if left > 0 and sel.select(timeout=left) else b""
            if not chunk:
                break
            got += chunk
    proc.unread = got
    raise AssertionError(f"no line with {marker!r}; last lines:\n{''.join(lines[-15:])}")


def _processes_naming(folder) -> list[str]:
    """Processes whose command line names `folder` (the solvers of a run get its paths)."""
    import os

    found = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/cmdline", "rb") as fh:
                cmd = fh.read().replace(b"\0", b" ").decode(errors="replace")
            with open(f"/proc/{name}/stat") as fh:
                state = fh.read().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if str(folder) in cmd and state != "Z":
            found.append(f"{name}: {cmd[:200]}")
    return found


@contextlib.contextmanager
def _killed_at_end(proc):
    """`proc` (a process group of its own), killed with its group if it is still there when the block ends."""
    import os
    import signal

    try:
        yield proc
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _signalled(proc, send) -> tuple[str, float]:
    """`send()` (a signal to `proc`), then the rest of its output and the seconds it took to end."""
    t_sig = time.monotonic()
    send()
    rest, _ = proc.communicate(timeout=30)
    return getattr(proc, "unread", b"").decode(errors="replace") + rest, time.monotonic() - t_sig


def _longer(prepared, tmp_path, end_time: str = "2 s"):
    p = _copy(prepared, tmp_path)
    p.write_text(p.read_text().replace("end_time: 0.02 s", f"end_time: {end_time}"))
    return p


@pytest.mark.parametrize("signame, to_group, code", [("SIGINT", True, 130), ("SIGTERM", False, 143)])
def test_signal_stops_every_child_marks_the_conditions_interrupted_and_prints_one_line(prepared, tmp_path,
                                                                                     signame, to_group, code):
    """SIGINT as a terminal's Ctrl-C sends it (to the whole process group), SIGTERM as `kill`
    sends it (to tunnelquake only), while the conditions run side by side (coupled: tq-solid and
    the water). Within the stated bound (children.STOP_GRACE_S + KILL_WAIT_S +
    supervise.JOB_WIND_DOWN_S = 10 s) the command exits 128 + the signal number, its last line says
    what was stopped at which simulated time, no traceback, no process of the run is left, each
    running condition's results file reads status 'interrupted', the folder's lock is released,
    and `post` reports the interrupted conditions."""
    import os
    import signal

    import h5py

    from tunnelquake import runlock
    from tunnelquake.launch import solver_status
    from tunnelquake.supervise import JOB_WIND_DOWN_S

    p = _longer(prepared, tmp_path)
    res = p.parent / "results"
    coupled = solver_status()["fluid"] is None
    with _killed_at_end(_start_run(p, "--no-post")) as proc:
        before = _read_until(proc, "running the water" if coupled else "[no_water] tq-solid: stage")
        time.sleep(1.5)
        sig = getattr(signal, signame)
        rest, took = _signalled(proc, lambda: os.killpg(proc.pid, sig) if to_group else os.kill(proc.pid, sig))
    from tunnelquake import children

    assert proc.returncode == code, rest[-2000:]
    assert took < children.STOP_GRACE_S + children.KILL_WAIT_S + JOB_WIND_DOWN_S, took
    out = "".join(before) + rest
    assert "Traceback" not in out and "KeyboardInterrupt" not in out, out[-3000:]
    last = rest.strip().splitlines()[-1]
    assert last.startswith(f"tunnelquake run: interrupted by {signame} after "), last
    assert "every child process ended" in last and "(`tunnelquake post " in last, last
    assert _processes_naming(p.parent) == []
    assert runlock.holder(res) is None
    marked = ["no_water", "dynamic_water"] if coupled else ["no_water"]
    labels = {"no_water": "(1) no water", "dynamic_water": "(3) dynamic water"}
    assert main(["post", str(p)]) == 0
    report = (res / "report.md").read_text()
    for cond in marked:
        # the simulated time where tq-solid's rows or progress lines give it
        assert re.search(rf"(stopped|,) {cond} (at t = [0-9.e+-]+ s of 2 s|in the shaking, no row written yet)", last), last
        with h5py.File(res / f"results_{cond}.h5", "r") as f:
            assert f.attrs["status"] == "interrupted", cond
            assert f.attrs["interrupted_by"] == f"{signame} to tunnelquake run (pid {proc.pid})"
        assert f"{labels[cond]}: status **interrupted**" in report


def test_second_run_of_the_same_case_folder_refuses_naming_the_first(prepared, tmp_path, capsys):
    """A second `tunnelquake run` of a case folder while one runs exits 1 before touching
    anything, naming the first run's PID and start time; the first goes on undisturbed."""
    import os
    import signal

    p = _longer(prepared, tmp_path)
    first = _start_run(p, "--no-post")
    try:
        _read_until(first, "condition no_water: running the solid")
        assert main(["run", str(p)]) == 1
        err = capsys.readouterr().err
        assert f"error: another `tunnelquake run` is using {p.parent / 'results'} (pid {first.pid}, started 20" in err
        assert f"wait for it to end, or stop it (kill {first.pid}), then run again" in err
        # the subcommands that write the same folder by hand refuse the same way, touching nothing
        mesh_stamp = (p.parent / "results" / "mesh" / "fingerprint.json").stat().st_mtime_ns
        for sub in ("mesh", "motion", "post"):
            assert main([sub, str(p)]) == 1, sub
            err = capsys.readouterr().err
            assert f"error: another `tunnelquake run` is using {p.parent / 'results'} (pid {first.pid}" in err, sub
        assert (p.parent / "results" / "mesh" / "fingerprint.json").stat().st_mtime_ns == mesh_stamp
        assert first.poll() is None, "the first run must go on"
    finally:
        os.kill(first.pid, signal.SIGTERM)
        first.communicate(timeout=30)
    assert first.returncode == 143


def _ended_by_sigterm_within_the_bound(proc, rest: str, took: float, case_file) -> None:
    """`tunnelquake run`, sent SIGTERM while a thread of its job held h5py's lock, exited 128 + 15 within
    supervise.JOB_WIND_DOWN_S (+ 5 s), its last line the interruption's, the results folder released."""
    from tunnelquake import runlock, supervise

    assert proc.returncode == 143, rest
    assert took < supervise.JOB_WIND_DOWN_S + 5.0, took
    assert rest.strip().splitlines()[-1].startswith("tunnelquake run: interrupted by SIGTERM after "), rest
    assert runlock.holder(case_file.parent / "results") is None


def test_signal_while_the_job_thread_holds_h5pys_lock_still_ends_the_process(prepared, tmp_path):
    """A signal reaches `tunnelquake run` while its job's thread is inside h5py (h5py's global lock
    held: writing a condition's input beside a running solver). The thread does not end within
    supervise.JOB_WIND_DOWN_S; the interpreter's teardown frees h5py objects, which takes that lock,
    so a normal exit never ends. The command must still exit 128 + 15 within the stated bound,
    with its one line, and release the folder. The job is replaced by one that holds the lock."""
    import os
    import signal
    import subprocess
    import sys
    import textwrap

    p = _copy(prepared, tmp_path)
    script = tmp_path / "held.py"
    script.write_text(textwrap.dedent(f"""
        import sys, time
        import h5py
        from tunnelquake import launch
        from tunnelquake.cli import main
        kept = h5py.File({str(tmp_path / "open.h5")!r}, "w").create_group("g")  # freed at teardown
        def job(case, resume, post):
            print("job: holding h5py's lock", flush=True)
            with h5py._objects.phil:
                time.sleep(120)
        launch.run_case = job
        sys.argv = ["tunnelquake", "run", {str(p)!r}, "--no-post"]
        sys.exit(main())
    """))
    with _killed_at_end(subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                                         stderr=subprocess.STDOUT, text=True, start_new_session=True)) as proc:
        _read_until(proc, "job: holding h5py's lock")
        rest, took = _signalled(proc, lambda: os.kill(proc.pid, signal.SIGTERM))
    _ended_by_sigterm_within_the_bound(proc, rest, took, p)


def test_signal_while_the_thread_beside_holds_h5pys_lock_still_ends_the_process(prepared, tmp_path):
    """The coupled condition runs in a thread beside the solid-only ones. A signal stops the
    solid-only path at once while the thread beside is inside h5py (writing its condition's input:
    h5py's global lock held). The job must not end before that thread: a process finalized beside
    it never ends. The command exits 128 + 15 within the stated bound, with its one line, and
    releases the folder. Both paths are replaced: the one beside holds the lock, the solid-only one
    waits for the stop."""
    import os
    import signal
    import subprocess
    import sys
    import textwrap

    p = _copy(prepared, tmp_path)
    script = tmp_path / "beside.py"
    script.write_text(textwrap.dedent(f"""
        import sys, time
        import h5py
        from tunnelquake import children, launch
        from tunnelquake.cli import main
        kept = h5py.File({str(tmp_path / "open.h5")!r}, "w").create_group("g")  # freed at teardown
        def coupled(*args, **kwargs):
            with h5py._objects.phil:
                print("beside: holding h5py's lock", flush=True)
                time.sleep(120)
        def solid(*args, **kwargs):
            print("solid: running", flush=True)
            children.stopping.wait(120)
            raise children.Interrupted()
        launch.run_coupled_condition = coupled
        launch.run_solid_condition = solid
        sys.argv = ["tunnelquake", "run", {str(p)!r}, "--no-post"]
        sys.exit(main())
    """))
    env = dict(os.environ, TQ_CONDITIONS_AT_ONCE="2")
    with _killed_at_end(subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, env=env,
                                         stderr=subprocess.STDOUT, text=True, start_new_session=True)) as proc:
        seen = _read_until(proc, "beside: holding h5py's lock")
        if not any("solid: running" in line for line in seen):
            _read_until(proc, "solid: running")
        rest, took = _signalled(proc, lambda: os.kill(proc.pid, signal.SIGTERM))
    _ended_by_sigterm_within_the_bound(proc, rest, took, p)


def test_an_error_in_the_coupled_condition_beside_the_solid_only_ones_is_raised_not_lost(prepared, tmp_path,
                                                                                          monkeypatch):
    """An unexpected error in the coupled condition's thread (beside the solid-only conditions)
    reaches the command as an error once the solid-only conditions are done; the run never ends
    as if the condition had not been planned."""
    from tunnelquake import launch

    def coupled(*args, **kwargs):
        raise RuntimeError("the coupled path failed")

    ran = []

    def solid(case, cond, *args, **kwargs):
        ran.append(cond)
        return 1, case.output_dir / f"results_{cond}.h5"

    monkeypatch.setenv("TQ_CONDITIONS_AT_ONCE", "2")
    monkeypatch.setattr(launch, "run_coupled_condition", coupled)
    monkeypatch.setattr(launch, "run_solid_condition", solid)
    with pytest.raises(RuntimeError, match="the coupled path failed"):
        main(["run", str(_copy(prepared, tmp_path)), "--no-post"])
    assert ran == ["no_water", "static_water"]  # the solid-only conditions all ran first


def test_stale_lock_of_a_dead_run_is_taken_over_saying_so(prepared, tmp_path, capsys):
    """The lock file still names a run that died (SIGKILL leaves its record): the next run takes
    the folder over, says so naming the dead PID, runs, and clears the record at its end."""
    import json
    import subprocess

    from tunnelquake import runlock

    p = _copy(prepared, tmp_path)
    dead = subprocess.Popen(["true"])
    dead.wait()
    lock = p.parent / "results" / runlock.LOCK_NAME
    lock.write_text(json.dumps({"pid": dead.pid, "started": "2026-01-02T03:04:05+00:00", "host": "h",
                                "command": "tunnelquake run case.yaml"}))
    assert main(["run", str(p), "--no-post"]) == 0
    out = capsys.readouterr().out
    assert (f"note: taking over the lock of an earlier run (pid {dead.pid}, started 2026-01-02T03:04:05+00:00, "
            f"on h, command `tunnelquake run case.yaml`): pid {dead.pid} is no longer running") in out
    assert lock.read_text() == "" and runlock.holder(lock.parent) is None


def test_summary_of_a_stopped_condition_names_only_a_results_file_that_was_written(tmp_path):
    """The run's summary names a stopped condition's results file only when it exists and opens,
    with the status the solver recorded."""
    import h5py

    from tunnelquake.launch import what_was_written

    res = tmp_path / "results_no_water.h5"
    assert what_was_written(res) == "no results file was written (results_no_water.h5 does not exist)"
    res.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 40)  # a signature and nothing after it
    assert what_was_written(res) == ("results_no_water.h5 is there but does not open as HDF5 (the solver stopped "
                                     "while writing it)")
    res.unlink()
    with h5py.File(res, "w") as f:
        f.attrs["status"] = "failed"
    assert what_was_written(res) == "what the solid wrote is in results_no_water.h5 (status failed)"
