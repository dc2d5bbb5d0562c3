"""A full disk under a run, the mesher, the motion and post (docs/reliability.md "A full disk"):
each test puts the case on a small tmpfs, forces the fault, and asserts what the user gets: the
message, the exit code, files that open, nothing partial under a final name, no process left.
Skipped where a tmpfs cannot be mounted (not root, or no mount permission)."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

import pytest
from test_reliability import _case_text, _processes_naming

from conftest import ROOT
from tunnelquake import runlock
from tunnelquake.cli import main


def _mount_tmpfs(where, size: str) -> None:
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    where.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], capture_output=True,
                       text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")


@pytest.fixture
def disk(tmp_path):
    """A tmpfs at tmp_path/disk (1 MB at first; `resize` it, `fill` it up to `leave` bytes free)."""
    where = tmp_path / "disk"
    _mount_tmpfs(where, "1M")

    class Disk:
        path = where

        @staticmethod
        def resize(size: str) -> None:
            subprocess.run(["mount", "-o", f"remount,size={size}", str(where)], check=True)

        @staticmethod
        def used() -> int:
            st = os.statvfs(where)
            return (st.f_blocks - st.f_bfree) * st.f_frsize

        @staticmethod
        def fill(leave: int) -> None:
            st = os.statvfs(where)
            free = st.f_bavail * st.f_frsize
            if free <= leave:
                return
            fd = os.open(where / "filler", os.O_WRONLY | os.O_CREAT, 0o600)
            try:
                os.posix_fallocate(fd, 0, free - leave)
            finally:
                os.close(fd)

    yield Disk
    subprocess.run(["umount", "-l", str(where)], check=False)


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    """The example, condition 3 only, meshed and its motion written, once for this module."""
    folder = tmp_path_factory.mktemp("prepared")
    text = _case_text("0.02 s").replace("conditions: [no_water, static_water, dynamic_water]",
                                        "conditions: [dynamic_water]")
    (folder / "case.yaml").write_text(text)
    assert main(["mesh", str(folder / "case.yaml")]) == 0
    assert main(["motion", str(folder / "case.yaml")]) == 0
    return folder


def _copy_to(prepared, disk, end_time: str | None = None):
    dst = disk.path / "case"
    shutil.copytree(prepared, dst)
    p = dst / "case.yaml"
    if end_time:
        p.write_text(p.read_text().replace("end_time: 0.02 s", f"end_time: {end_time}"))
    return p


def _tq(*args, env_extra=None):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "scripts"), env.get("PYTHONPATH", "")])
    env.update(env_extra or {})
    return subprocess.run([sys.executable, "-m", "tunnelquake", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=600)


def _rows(path, monitor: str = "top_arch"):
    """Status and monitor times of a results file (it must open)."""
    import h5py
    import numpy as np

    with h5py.File(path, "r") as f:
        status = f.attrs["status"]
        status = status.decode() if isinstance(status, bytes) else str(status)
        t = np.asarray(f[f"monitors/{monitor}/time"][...]).reshape(-1)
    return status, t


def _errors(stderr: str) -> list[str]:
    """The lines of stderr that are not the case's warnings (e.g. the record is absent and the
    synthetic motion is used, as on a machine without the shared data)."""
    return [ln for ln in stderr.strip().splitlines() if not ln.startswith("warning: ")]


def test_tq_solid_on_a_full_disk_stops_between_samples_with_exit_5_and_a_whole_results_file(prepared, disk):
    """tq-solid alone (condition 3's solid input, no water) writing to a disk that fills at
    different points: it exits 5 (never a crash), names the file, the reason and the space, and
    its results file opens with every sample it says it wrote and status 'stopped: ...'. A disk
    with no room for even the start leaves no file."""
    from tunnelquake import paths
    from tunnelquake.case import load_case
    from tunnelquake.solid_input import write_solid_input

    if paths.solid_executable() is None:
        pytest.skip("tq-solid is not built")
    disk.resize("4M")
    p = _copy_to(prepared, disk, "1 s")
    case = load_case(p)
    out = case.output_dir
    shutil.rmtree(out / "figures")
    (out / "mesh" / "model.msh").unlink()
    inp = write_solid_input(case, out / "mesh" / "mesh.h5", out / "motion.h5", "no_water", out / "no_water" / "in.h5")
    # The rooms below are sized on the monitors' (the case's three and the two displacement
    # references), energy and interface histories (the first sample
    # holds room for the first chunk of each); the lining's ring forces (written through the same
    # space ledger, and on in the coupled test below) are left out here so that a sample still fits.
    import h5py

    with h5py.File(inp, "a") as f:
        f["output"].attrs["ring_forces"] = 0
    res = out / "results_no_water.h5"
    base = disk.used()
    for room, stops in ((100_000, "start"), (680_000, "run"), (800_000, "run")):
        res.unlink(missing_ok=True)
        disk.resize(f"{(base + room) // 1024}k")
        r = subprocess.run([str(paths.solid_executable()), str(inp), "-o", str(res), "--threads", "1"],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 5, (room, r.returncode, r.stderr[-2000:])
        assert f"tq-solid: cannot write '{res}': No space left on device (" in r.stderr, r.stderr
        assert re.search(r"\([^)]*need[^)]*, [0-9.]+ [kM]?B free on its file system\)", r.stderr), r.stderr
        if stops == "start":
            assert "no results written" in r.stderr and not res.exists()
            continue
        m = re.search(r"results up to t = ([0-9.e+-]+) s \((\d+) samples\) are in", r.stderr)
        assert m, r.stderr
        status, t = _rows(res)
        assert status.startswith(f"stopped: cannot write '{res}': No space left on device"), status
        assert t.size == int(m.group(2)) and t.size > 0
        assert abs(t[-1] - float(m.group(1))) < 1e-5 and (t.size < 2 or (t[1:] > t[:-1]).all())


def test_coupled_run_on_a_full_disk_ends_with_a_clear_message_and_post_reports_it_up_to_the_last_sample(prepared,
                                                                                                         disk):
    """`tunnelquake run` of condition 3 (tq-solid and the water) on a tmpfs that fills during
    the shaking: the run ends (exit 1) saying the disk is full, where and how much is free, with
    no traceback and no process left; the results file opens with status 'stopped: ...'.
    `post` on the full disk says up to which time the run is reported and that its outputs did
    not fit (exit 1, one error line); once space is freed, `post` writes the report of the run up
    to its last sample."""
    from tunnelquake.launch import solver_status

    if solver_status()["fluid"] is not None:
        pytest.skip(f"the coupled condition cannot run here: {solver_status()['fluid']}")
    disk.resize("8M")
    p = _copy_to(prepared, disk, "1 s")
    (p.parent / "results" / "mesh" / "model.msh").unlink()  # 0.4 MB the run does not need
    # room for the run's start, its snapshot at the seismic start and its first samples, the first
    # chunks of the lining's ring forces included (design and diameter histories float32, free-body
    # forces float64: 3 x 98 kB); 1.2 and 1.5 MB leave no room for a sample, 1.8 MB stops in the shaking
    disk.resize(f"{(disk.used() + 1_800_000) // 1024}k")
    r = _tq("run", p)
    out = r.stdout + r.stderr
    assert r.returncode == 1, out[-3000:]
    assert "Traceback" not in out, out[-3000:]
    assert "No space left on device" in out
    assert re.search(r"! dynamic_water \(solid \+ fluid\): stopped by a full disk after [0-9.]+ s \(.*\): no space "
                     rf"left on the disk holding {re.escape(str(p.parent / 'results'))} \([0-9.]+ [kMG]?B free\)\. Fix: "
                     "free space there", out), out[-3000:]
    assert _processes_naming(p.parent) == []
    res = p.parent / "results" / "results_dynamic_water.h5"
    status, t = _rows(res)
    assert status.startswith("stopped: "), status
    assert t.size > 0 and t[-1] < 1.0
    last = f"{t[-1]:.4g}"

    disk.fill(0)  # post on the disk with nothing free
    r = _tq("post", p)
    out = r.stdout + r.stderr
    assert r.returncode == 1 and "Traceback" not in out, out[-3000:]
    assert "dynamic_water: status 'stopped: " in out
    assert f"post-processed up to the last written step, t = {last} s" in out, out[-3000:]
    err = _errors(r.stderr)
    assert len(err) == 1 and err[0].startswith("error: cannot write ") and "no space left on device" in err[0], err
    assert "(not written: " in err[0] and "report.md" in err[0] and "the results files are unchanged" in err[0]
    assert _rows(res)[0] == status and (_rows(res)[1] == t).all()  # the results file is unchanged

    (disk.path / "filler").unlink()
    disk.resize("16M")
    r = _tq("post", p)
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    report = (p.parent / "results" / "report.md").read_text()
    assert "(3) dynamic water: status **stopped: " in report
    assert f"**The run did not complete**: everything below for this condition is post-processed up to the last " \
           f"written step, t = {last} s" in report
    assert not [f for f in (p.parent / "results").rglob(".*.part")]


def test_mesh_build_on_a_full_disk_leaves_no_file_under_the_final_names(disk):
    """`tunnelquake mesh` on a disk too small for its files: one error line naming the file, the
    space needed and free; exit 1; no mesh.h5, model.msh, water.msh or fingerprint under their
    names and no temporary file left."""
    disk.resize("640k")
    case = disk.path / "case"
    case.mkdir()
    (case / "case.yaml").write_text(_case_text())
    r = _tq("mesh", case / "case.yaml")
    assert r.returncode == 1, r.stdout + r.stderr
    assert "Traceback" not in r.stdout + r.stderr
    err = _errors(r.stderr)
    assert len(err) == 1, err
    assert re.match(rf"error: cannot write {re.escape(str(case / 'results' / 'mesh'))}/(model\.msh|mesh\.h5|water\.msh): "
                    r"no space left on device \(about [0-9.]+ [kM]B needed, [0-9.]+ [kM]?B free on its file system\)\. "
                    "Fix: free space there", err[0]), err[0]
    assert sorted(x.name for x in (case / "results" / "mesh").iterdir()) == []


def test_mesh_and_motion_rebuilt_on_a_full_disk_keep_the_previous_complete_files(prepared, disk):
    """`mesh --force` and `motion` over complete files on a disk with 50 kB left: each exits 1
    with the error line, and the previous files are still there, byte for byte; the mesh's
    fingerprint is gone, so the next run builds the mesh again."""
    disk.resize("4M")
    p = _copy_to(prepared, disk)
    results = p.parent / "results"
    before = {f: f.read_bytes() for f in [*(results / "mesh").glob("*.msh"), results / "mesh" / "mesh.h5",
                                          results / "motion.h5"]}
    disk.fill(50_000)
    for cmd in (("mesh", p, "--force"), ("motion", p)):
        r = _tq(*cmd)
        assert r.returncode == 1, r.stdout + r.stderr
        assert "Traceback" not in r.stdout + r.stderr
        err = _errors(r.stderr)
        assert len(err) == 1 and err[0].startswith("error: cannot write ") and "no space left on device" in err[0], err
    for f, data in before.items():
        assert f.read_bytes() == data, f
    assert not (results / "mesh" / "fingerprint.json").exists()
    assert [f.name for f in results.rglob(".*") if f.is_file() and f.name != runlock.LOCK_NAME] == []


def test_mesh_build_writes_no_gmsh_or_fltk_preferences_outside_the_case(tmp_path):
    """A mesh build (a fresh process: FLTK reads and rewrites its preferences once a process)
    changes nothing in the home folder or /etc: FLTK's fltk.prefs, which gmsh's start rewrites,
    stay as they were."""
    home = tmp_path / "home"
    (home / ".fltk" / "fltk.org").mkdir(parents=True)
    user_prefs = home / ".fltk" / "fltk.org" / "fltk.prefs"
    user_prefs.write_text("; FLTK preferences file format 1.0\n")
    etc = "/etc/fltk/fltk.org/fltk.prefs"

    def stamps():
        return {f: os.stat(f).st_mtime_ns if os.path.exists(f) else None for f in (str(user_prefs), etc)}

    before = stamps()
    case = tmp_path / "case"
    case.mkdir()
    (case / "case.yaml").write_text(_case_text())
    r = _tq("mesh", case / "case.yaml", env_extra={"HOME": str(home)})
    assert r.returncode == 0, r.stdout + r.stderr
    assert (case / "results" / "mesh" / "mesh.h5").is_file()
    assert stamps() == before
    assert sorted(str(x.relative_to(home)) for x in home.rglob("*")) == [".fltk", ".fltk/fltk.org",
                                                                       ".fltk/fltk.org/fltk.prefs"]


def test_solid_only_run_on_a_full_disk_lists_each_condition_under_failed_and_goes_on_to_the_next_and_post(disk):
    """`tunnelquake run` of two solid-only conditions of a case unlike the example (the pressure
    tunnel: a weathered layer, three records, 1 s of shaking) on a tmpfs with 1 MB left after the
    mesh and motion: the first condition's tq-solid stops in the shaking with exit 5; the run says
    so in its summary with the space free, still starts the second condition (which finds no room
    to start) and post, and ends with exit 1, no traceback and no process left. The first results
    file opens with status 'stopped: ...' and every sample up to where it stopped."""
    from tunnelquake import paths

    if paths.solid_executable() is None:
        pytest.skip("tq-solid is not built")
    disk.resize("8M")
    src = ROOT / "cases" / "pressure_tunnel"
    case = disk.path / "case"
    shutil.copytree(src, case, ignore=shutil.ignore_patterns("results*"))
    p = case / "case.yaml"
    p.write_text(p.read_text().replace("  duration: 10 s", "  duration: 2 s")
                 + "\nconditions: [no_water, static_water]\ntime:\n  end_time: 1 s\n")
    for cmd in ("mesh", "motion"):
        r = _tq(cmd, p)
        assert r.returncode == 0, r.stdout + r.stderr
    # 1.2 MB: the first condition's set-up, its snapshot at the seismic start and first samples fit
    # (1.0 MB does not leave room for a sample; 1.1-1.3 MB all stop in the shaking), its whole 1 s
    # (1.37 MB) does not
    disk.resize(f"{(disk.used() + 1_200_000) // 1024}k")
    r = _tq("run", p, env_extra={"TQ_CONDITIONS_AT_ONCE": "1"})
    out = r.stdout + r.stderr
    assert r.returncode == 1, out[-3000:]
    assert "Traceback" not in out and "Error:" not in out, out[-3000:]
    assert "tq-solid: cannot write '" in out and "No space left on device" in out
    assert "condition static_water: running the solid" in out, out[-3000:]  # the next condition started
    summary = out[out.index("[tunnelquake] done:"):]
    results = p.parent / "results"
    for cond in ("no_water", "static_water"):
        assert re.search(rf"! {cond} \(solid\): tq-solid could not write its results \(exit 5; .*[0-9.]+ [kMG]?B free "
                         rf"now on the disk holding {re.escape(str(results))}\)", summary), summary
    assert "what was written is in results_no_water.h5" in summary, summary
    assert "post" in summary  # post ran: written (+) or listed under FAILED with what did not fit
    assert _processes_naming(p.parent) == []
    status, t = _rows(results / "results_no_water.h5", "crown")
    assert status.startswith("stopped: cannot write ") and "No space left on device" in status, status
    assert t.size > 0 and t[-1] < 1.0 and (t.size < 2 or (t[1:] > t[:-1]).all())
