"""Nothing silently mixed or corrupted (docs/user_guide.md "Resuming a run", docs/formats.md
"Restart checkpoints" and "Input fingerprint", docs/reliability.md "Fault campaign").

1. The changed-input matrix: a key of each group (geometry, solid material, water, coupling, record,
   time and output, design) changed after a run; `run --resume` runs again every condition whose
   results that key shaped, naming the key, and keeps the others; `post` refuses results of other
   inputs naming the key and the fix, and re-posts freely after a change of a design key, saying
   so in the report.
2. The corruption matrix: each kind of checkpoint file (the solid's state, its results copy, the
   water's fields, the manifest) cut short or with one bit flipped. Each is detected by its CRC-32
   (or its size) and named with its cause; the resume falls back to the newest intact checkpoint
   (or pair) and ends bitwise equal to a run never stopped; it never completes with changed data.

Reference for the bitwise checks: the same case run without interruption (tolerance 0: the
solvers are deterministic, as tests/python/test_restart.py shows)."""
from __future__ import annotations

import os
import shutil
import subprocess
import time

import h5py
import pytest
from test_restart import _case_text, _copy, _start, _stop
from test_restart_coupled import _wait_for_pair

from conftest import ran_case
from tunnelquake.case import load_case
from tunnelquake.cli import main
from tunnelquake.compare import results_differences as _differences
from tunnelquake.restart import intact_checkpoints, resume_plan

#: the solid-only run: shaking simulated and checkpoint interval, s
END, INTERVAL = 0.6, 0.15
#: the coupled run: a pair every INTERVAL_W s of END_W s
END_W, INTERVAL_W = 0.2, 0.05


def _two_conditions(end: float, interval: float) -> str:
    return _case_text("no_water", end, interval).replace("conditions: [no_water]",
                                                         "conditions: [no_water, dynamic_water]")


@pytest.fixture(scope="module")
def completed(tmp_path_factory):
    """no_water and dynamic_water run to the end (a short record), with their report."""
    return ran_case(tmp_path_factory.mktemp("completed"), _two_conditions(0.04, 0.0))


#: one key of each group, its text in the example and the changed text; the conditions it reruns
MATRIX = [
    ("geometry", "lining_thickness: 0.75 m", "lining_thickness: 0.7 m", "geometry.lining_thickness",
     {"no_water", "dynamic_water"}),
    ("solid material", "youngs_modulus: 28.0 GPa", "youngs_modulus: 30.0 GPa", "materials.lining.youngs_modulus",
     {"no_water", "dynamic_water"}),
    ("water", "viscosity: 1.308e-3", "viscosity: 1.0e-3", "water.viscosity", {"dynamic_water"}),
    ("coupling", "tolerance: 1e-3", "tolerance: 1e-4", "coupling.tolerance", {"dynamic_water"}),
    ("record", "pga: 1.575 m/s^2", "pga: 2.0 m/s^2", "ground_motion.pga", {"no_water", "dynamic_water"}),
    ("time and output", "  monitors:", "  history_interval: 0.01 s\n  monitors:", "output.history_interval",
     {"no_water", "dynamic_water"}),
]


def test_changed_input_matrix(completed, tmp_path, capsys):
    """For each group: the key changed, `run --resume` plans to run again exactly the conditions
    whose results it shaped (the notes name the key, its old and new value), and keeps the others;
    `post` refuses with the key and the fix. Then a post-only key (group design) changed: `--resume`
    keeps both conditions, `post` re-posts and its report says which design key changed. Last, a
    real `--resume` after the lining's Young's modulus changed: both conditions run again, and
    their results then carry the new fingerprint."""
    original = (completed / "case.yaml").read_text()
    for group, old, new, key, reruns in MATRIX:
        folder = tmp_path / group.replace(" ", "_")
        shutil.copytree(completed, folder)
        assert original.count(old) == 1, old
        (folder / "case.yaml").write_text(original.replace(old, new))
        case = load_case(folder / "case.yaml")
        what, nothing, _ = resume_plan(case)
        assert nothing is None, (group, nothing)
        for cond in ("no_water", "dynamic_water"):
            if cond in reruns:
                assert what[cond] == "start", (group, cond, what[cond])
                note = " ".join(what[cond].notes)
                assert f"results_{cond}.h5 was computed with other inputs: {key} " in note, (group, note)
                assert f"({group})" in note, (group, note)
            else:
                assert what[cond] == "completed" and not what[cond].notes, (group, cond, what[cond].notes)
        report = folder / "results" / "report.md"
        before = report.read_bytes()
        capsys.readouterr()
        assert main(["post", str(folder / "case.yaml")]) == 1, group
        err = capsys.readouterr().err
        assert f"was computed with other inputs than the case gives now: {key} " in err, (group, err)
        assert "Fix: run the changed condition(s) again" in err, err
        assert "Traceback" not in err
        assert report.read_bytes() == before  # nothing re-posted

    # design: post-only keys re-post freely and the report says which changed
    folder = tmp_path / "design"
    shutil.copytree(completed, folder)
    (folder / "case.yaml").write_text(original.replace("displacement_reference: absolute",
                                                       "displacement_reference: base"))
    what, nothing, _ = resume_plan(load_case(folder / "case.yaml"))
    assert dict(what) == {"no_water": "completed", "dynamic_water": "completed"}
    assert "nothing to resume" in nothing
    assert main(["post", str(folder / "case.yaml")]) == 0
    text = (folder / "results" / "report.md").read_text()
    assert "Design settings changed since the last report (this one uses today's): output.displacement_reference " \
           "absolute -> base (design)" in text, text[:3000]
    assert "results_no_water.h5: computed with this case's inputs" in text

    # the case from the issue: the lining's E changed, `--resume` must not keep the completed no_water
    folder = tmp_path / "resumed"
    shutil.copytree(completed, folder)
    (folder / "case.yaml").write_text(original.replace("youngs_modulus: 28.0 GPa", "youngs_modulus: 30.0 GPa"))
    capsys.readouterr()
    assert main(["run", str(folder / "case.yaml"), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert "completed earlier: kept" not in out, out[-3000:]
    assert ("resume: no_water: results_no_water.h5 was computed with other inputs: materials.lining.youngs_modulus "
            "2.8e+10 -> 3e+10 (solid material); it runs again") in out, out[-3000:]
    from tunnelquake import fingerprint as F

    case = load_case(folder / "case.yaml")
    for cond in ("no_water", "dynamic_water"):
        res = folder / "results" / f"results_{cond}.h5"
        assert F.read_results(res)["digest"] == F.condition_inputs(case, cond)["digest"]
        with h5py.File(res, "r") as f:
            assert f.attrs["status"] == "completed"
    assert main(["post", str(folder / "case.yaml")]) == 0


# ------------------------------------------------------------------------------------------------
# The corruption matrix

def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])


def _flip(path):
    data = bytearray(path.read_bytes())
    data[len(data) * 2 // 3] ^= 0x10
    path.write_bytes(bytes(data))


def _resume_refused(case_dir, folder):
    """tq-solid resumed from checkpoint 2 of `folder` (the case's no_water condition): asserts that
    it stops with exit 2 and leaves the results file as it was; returns the run (its messages)."""
    from tunnelquake import paths

    res = case_dir / "results" / "results_no_water.h5"
    before = res.read_bytes()
    got = subprocess.run([str(paths.solid_executable()), str(case_dir / "results" / "no_water" / "solid_input.h5"),
                          "-o", str(res), "--checkpoint-dir", str(folder), "--resume", "--resume-sequence", "2"],
                         capture_output=True, text=True, timeout=120)
    assert got.returncode == 2, got.stderr[-2000:]
    assert res.read_bytes() == before
    return got


@pytest.fixture(scope="module")
def solid_runs(tmp_path_factory):
    """The no_water case run whole (the reference) and stopped by SIGKILL inside its third
    checkpoint (TQ_CHECKPOINT_FAULT): checkpoints 1 and 2 are left whole."""
    ref = tmp_path_factory.mktemp("solid_ref")
    (ref / "case.yaml").write_text(_case_text("no_water", END, INTERVAL))
    assert main(["run", str(ref / "case.yaml"), "--no-post"]) == 0
    stopped = _copy(ref, tmp_path_factory.mktemp("solid_stopped"))
    proc = _start(stopped, env={"TQ_CHECKPOINT_FAULT": "3:solid"})
    out, _ = proc.communicate(timeout=240)
    assert proc.returncode == 1 and "tq-solid stopped (exit -9)" in out, out[-2000:]
    return ref, stopped


#: what is damaged: the file, and the checkpoint the resume continues from
SOLID_KINDS = {"solid state": ("solid-000002.bin", 1), "results copy": ("results-000002.h5", 1),
               "manifest": ("checkpoint.json", 2), "numbered manifest": ("checkpoint-000002.json", 2)}


@pytest.mark.parametrize("damage", ["truncate", "flip"])
@pytest.mark.parametrize("kind", list(SOLID_KINDS))
def test_damaged_solid_checkpoint_is_detected_and_the_resume_falls_back(solid_runs, tmp_path, capsys, kind,
                                                                         damage):
    """One file of the newest checkpoint cut to half or with one bit flipped: tq-solid itself
    refuses it (its CRC-32 or size), `run --resume` names the file and why, continues from the
    newest intact checkpoint (the one before; the same one through its other manifest when one of
    its two manifests is damaged) and ends bitwise equal to the run never stopped."""

    ref, stopped = solid_runs
    dst = tmp_path / "case"
    shutil.copytree(stopped.parent, dst)
    case_yaml = dst / "case.yaml"
    folder = dst / "results" / "no_water" / "checkpoint"
    name, fallback = SOLID_KINDS[kind]
    (_truncate if damage == "truncate" else _flip)(folder / name)

    if kind != "manifest":  # tq-solid's own check, before it writes anything
        got = _resume_refused(dst, folder)
        assert "cannot resume" in got.stderr and ("CRC-32" in got.stderr or "bytes instead of" in got.stderr
                                                  or "cut short" in got.stderr), got.stderr[-2000:]

    t0 = time.monotonic()
    what, _, _ = resume_plan(load_case(case_yaml))
    assert time.monotonic() - t0 < 5.0
    assert what["no_water"] == "checkpoint" and int(what["no_water"].point["sequence"]) == fallback
    notes = " ".join(what["no_water"].notes)
    assert name in notes and "damaged" in notes, notes
    assert main(["run", str(case_yaml), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert f"resume: no_water: damaged checkpoint in {folder}: " in out, out[-3000:]
    point = what["no_water"].point
    assert f"resume: no_water continues from its checkpoint at t = {float(point['time']):.6g} s" in out, out[-3000:]
    assert _differences(ref / "results" / "results_no_water.h5", dst / "results" / "results_no_water.h5") == []


def test_a_checkpoint_of_another_state_layout_is_refused_by_name(solid_runs, tmp_path):
    """A checkpoint whose state another tq-solid wrote (the layout digit after TQRSTAT differs), with
    checksums that match: tq-solid refuses it naming both layouts and the fix, before it writes
    anything, instead of reading the other layout's items into this build's parts."""
    import re
    import zlib


    _, stopped = solid_runs
    dst = tmp_path / "case"
    shutil.copytree(stopped.parent, dst)
    folder = dst / "results" / "no_water" / "checkpoint"
    state = bytearray((folder / "solid-000002.bin").read_bytes())
    assert bytes(state[:7]) == b"TQRSTAT"
    this_layout = chr(state[7])
    other = "1" if this_layout != "1" else "9"
    state[7] = ord(other)
    (folder / "solid-000002.bin").write_bytes(bytes(state))
    manifest = folder / "checkpoint-000002.json"
    text = re.sub(r'"solid_crc32": "[0-9a-f]{8}"', f'"solid_crc32": "{zlib.crc32(bytes(state)):08x}"',
                  manifest.read_text())
    body = text[:text.index('"manifest_crc32"')]
    text = re.sub(r'"manifest_crc32": "[0-9a-f]{8}"', f'"manifest_crc32": "{zlib.crc32(body.encode()):08x}"', text)
    manifest.write_text(text)
    got = _resume_refused(dst, folder)
    assert (f"was written by another version of tq-solid (state layout {other}, this build reads {this_layout}); "
            "run without --resume to start again") in got.stderr, got.stderr[-2000:]


def test_truncated_manifests_alone_are_damage_not_no_checkpoint(solid_runs, tmp_path, capsys):
    """Every manifest cut short: `--resume` says which are damaged and why (not 'no condition has a
    restart checkpoint'), and runs the condition from the start, ending equal to the reference."""
    ref, stopped = solid_runs
    dst = tmp_path / "case"
    shutil.copytree(stopped.parent, dst)
    folder = dst / "results" / "no_water" / "checkpoint"
    for m in folder.glob("checkpoint*.json"):
        _truncate(m)
    assert main(["run", str(dst / "case.yaml"), "--resume", "--no-post"]) == 0
    captured = capsys.readouterr()
    assert "no condition has a restart checkpoint" not in captured.err + captured.out
    assert "checkpoint.json is damaged: it is cut short" in captured.out, captured.out[-3000:]
    assert "no intact checkpoint is left: it runs from the start" in captured.out
    assert _differences(ref / "results" / "results_no_water.h5", dst / "results" / "results_no_water.h5") == []


@pytest.fixture(scope="module")
def water_runs(tmp_path_factory):
    """dynamic_water run whole (the reference) and stopped (SIGKILL of all) once both sides wrote
    their third checkpoint pair."""
    ref = tmp_path_factory.mktemp("water_ref")
    (ref / "case.yaml").write_text(_case_text("dynamic_water", END_W, INTERVAL_W))
    assert main(["run", str(ref / "case.yaml"), "--no-post"]) == 0
    stopped = _copy(ref, tmp_path_factory.mktemp("water_stopped"))
    proc = _start(stopped)
    try:
        _wait_for_pair(stopped, proc, 3)
    finally:
        _stop(proc, stopped.parent, "SIGKILL all", (b"tq-solid", b"PimpleFoam"))
    return ref, stopped


@pytest.mark.parametrize("damage", ["truncate", "flip"])
def test_damaged_water_checkpoint_is_detected_before_the_water_starts(water_runs, tmp_path, capsys, damage):
    """The water's file of the newest pair cut to half or with one bit flipped: `--resume` names it
    and its cause within 5 s (nothing waits for a connection), falls back to the pair before and
    ends bitwise equal to the uninterrupted run."""
    ref, stopped = water_runs
    # resumed in place (the coupled solid input names its folder), the stopped state restored after
    dst = stopped.parent
    shutil.copytree(dst / "results", tmp_path / "saved")
    try:
        _damage_water_and_resume(ref, dst, capsys, damage)
    finally:
        shutil.rmtree(dst / "results")
        shutil.copytree(tmp_path / "saved", dst / "results")


def _damage_water_and_resume(ref, dst, capsys, damage):
    case = load_case(dst / "case.yaml")
    newest, damaged = intact_checkpoints(case, "dynamic_water")
    assert newest is not None and not damaged
    fluid = dst / "results" / "dynamic_water" / "checkpoint" / os.path.basename(newest["fluid"])
    (_truncate if damage == "truncate" else _flip)(fluid)
    t0 = time.monotonic()
    what, _, _ = resume_plan(load_case(dst / "case.yaml"))
    assert time.monotonic() - t0 < 5.0
    point = what["dynamic_water"].point
    assert what["dynamic_water"] == "checkpoint" and int(point["sequence"]) < int(newest["sequence"])
    notes = " ".join(what["dynamic_water"].notes)
    assert fluid.name in notes and ("CRC-32" in notes or "cut short" in notes), notes
    capsys.readouterr()
    assert main(["run", str(dst / "case.yaml"), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert f"continues from its checkpoint at t = {float(point['time']):.6g} s" in out, out[-3000:]
    assert "did not connect" not in out
    assert _differences(ref / "results" / "results_dynamic_water.h5",
                        dst / "results" / "results_dynamic_water.h5") == []


def test_damaged_water_checkpoint_given_to_the_water_stops_the_run_at_once_with_its_cause(water_runs, tmp_path,
                                                                                          capsys, monkeypatch):
    """The water's own check, with `run`'s bypassed (restart.fluid_problem made to pass every file):
    tqInterface refuses the flipped file with a FATAL ERROR naming its CRC-32, and `run` reports
    that cause and ends the waiting solid within children.PARTNER_GRACE_S (5 s) of the water's
    stop, not after the 120 s coupling timeout with "did not connect in time"; exit 1, never
    completed."""
    from tunnelquake import restart

    ref, stopped = water_runs
    dst = stopped.parent
    shutil.copytree(dst / "results", tmp_path / "saved")
    try:
        newest, _ = intact_checkpoints(load_case(dst / "case.yaml"), "dynamic_water")
        _flip(dst / "results" / "dynamic_water" / "checkpoint" / os.path.basename(newest["fluid"]))
        monkeypatch.setattr(restart, "fluid_problem", lambda path: (None, newest["inputs"]))
        t0 = time.monotonic()
        assert main(["run", str(dst / "case.yaml"), "--resume", "--no-post"]) == 1
        wall = time.monotonic() - t0
        out = capsys.readouterr().out
        assert "(water) failed with exit code 1" in out, out[-3000:]
        assert "its CRC-32 is " in out and "(the file is damaged)" in out, out[-3000:]
        assert "did not connect" not in out, out[-3000:]
        assert wall < 60.0, wall  # static stages, the water's start and its refusal, then 5 s at most
        with h5py.File(dst / "results" / "results_dynamic_water.h5", "r") as f:
            assert f.attrs["status"] != "completed"
    finally:
        shutil.rmtree(dst / "results")
        shutil.copytree(tmp_path / "saved", dst / "results")
