"""One validation path: whatever `run` refuses before its solvers start, `check` refuses first,
with a fix that applies (applying it makes both pass), and no command shows a traceback. The case
is the pressure tunnel (a weathered layer, its own records), not the example."""
from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from conftest import ROOT
from tunnelquake.cli import main

PRESSURE = ROOT / "cases" / "pressure_tunnel"


def _two_column(path, n: int, dt: float = 0.01, amplitude: float = 0.1):
    """A two-column record in g of `n` samples at `dt`: a 3 Hz sine."""
    t = np.arange(n) * dt
    path.write_text("# time (s)  acceleration (g)\n" + "".join(
        f"{x:.6f} {float(amplitude * np.sin(2 * np.pi * 3.0 * x))!r}\n" for x in t))


def _case(folder, *, duration: str | None = None, cutoff: str = "15 Hz", extra: str = "") -> object:
    """The pressure tunnel in `folder` with one horizontal record, `folder/rec.txt` (no second
    horizontal or vertical record), the window `duration` (None: the whole record), `cutoff`."""
    text = (PRESSURE / "case.yaml").read_text()
    text = re.sub(r"\n  second_horizontal: .*", "", text)
    text = re.sub(r"\n  vertical: .*", "\n  vertical_ratio: 0.5", text)
    text = text.replace("  file: horizontal.txt", "  file: rec.txt")
    text = text.replace("  duration: 10 s\n", "" if duration is None else f"  duration: {duration}\n")
    text = re.sub(r"  cutoff_frequency: 15 Hz.*", f"  cutoff_frequency: {cutoff}", text)
    p = folder / "case.yaml"
    p.write_text(text + extra)
    return p


def _cli(capsys, *args) -> tuple[int, str]:
    rc = main([*map(str, args)])
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err, out.out + out.err
    return rc, out.out + out.err


def _motion_of_run(p) -> str | None:
    """What `run` does to the motion before its solvers start (motion.from_case, the path of
    `tunnelquake motion` and `run`): None when it passes, else the refusal."""
    from tunnelquake.case import schema
    from tunnelquake.motion import MotionError, from_case
    from tunnelquake.schema import load_yaml, validate

    data = validate(schema(), load_yaml(p.read_text()), str(p))  # the keys alone, not check's tests
    try:
        from_case(data["ground_motion"], p.parent)
    except MotionError as e:
        return str(e)
    return None


def test_a_record_too_short_for_the_lowpass_is_refused_by_check_with_a_fix_that_applies(tmp_path, capsys):
    """An 11-sample record (0.11 s at 0.01 s) under a 15 Hz low-pass (needs 16 samples), no
    window: on today's main `check` passed it and `run` stopped after meshing advising a window
    the record cannot cover. `check` refuses it on the record's key; each fix it names (a
    16-sample record; the cut-off at the record's Nyquist frequency) makes `check` and the
    motion `run` prepares pass."""
    _two_column(tmp_path / "rec.txt", 11)
    p = _case(tmp_path)
    rc, out = _cli(capsys, "check", p)
    assert rc == 1, out
    assert "ground_motion.file = 'rec.txt'" in out, out
    assert re.search(r"the window keeps 11 samples \(dt = 0\.01 s\), too few for the 15 Hz zero-phase low-pass "
                     r"\(ground_motion\.cutoff_frequency\), which needs at least 16\. Fix: give a record of at least "
                     r"16 samples \(0\.15 s at dt = 0\.01 s\), or set ground_motion\.cutoff_frequency to 50 Hz", out), out
    assert "ground_motion.duration to at least" not in out  # the fix that cannot apply
    assert _motion_of_run(p) is not None  # run refuses it too
    # fix 1: the cut-off at the Nyquist frequency
    p = _case(tmp_path, cutoff="50 Hz")
    assert _cli(capsys, "check", p)[0] == 0 and _motion_of_run(p) is None
    # fix 2: a record of 16 samples
    _two_column(tmp_path / "rec.txt", 16)
    p = _case(tmp_path)
    assert _cli(capsys, "check", p)[0] == 0 and _motion_of_run(p) is None


def test_a_window_too_short_for_the_lowpass_names_the_shortest_window_and_that_window_works(tmp_path, capsys):
    """A 2 s record cut to a 0.1 s window (11 samples): the fix is the window of 0.15 s, which
    passes `check` and the motion of `run`; 0.14 s still does not."""
    _two_column(tmp_path / "rec.txt", 201)
    p = _case(tmp_path, duration="0.1 s")
    rc, out = _cli(capsys, "check", p)
    assert rc == 1
    assert re.search(r"ground_motion\.duration = 0\.1: .*the window keeps 11 of its 201 samples .* Fix: set "
                     r"ground_motion\.duration to at least 0\.15 s \(the record lasts 2\.01 s\)", out), out
    assert _motion_of_run(p) is not None
    for window, ok in (("0.14 s", False), ("0.15 s", True)):
        p = _case(tmp_path, duration=window)
        assert (_cli(capsys, "check", p)[0] == 0) is ok, window
        assert (_motion_of_run(p) is None) is ok, window


@pytest.mark.parametrize("n, duration, cutoff", [
    (n, d, c) for n in (2, 15, 16, 40) for d in (None, "0.1 s", "0.15 s", "0.3 s") for c in ("5 Hz", "15 Hz", "50 Hz")])
def test_check_passes_exactly_what_the_run_s_motion_passes(tmp_path, capsys, n, duration, cutoff):
    """Over record lengths, windows and cut-offs around the low-pass's limit: `check` exits 0
    exactly when the motion `run` prepares is accepted, and when both refuse, for one reason."""
    _two_column(tmp_path / "rec.txt", n)
    p = _case(tmp_path, duration=duration, cutoff=cutoff)
    rc, out = _cli(capsys, "check", p)
    refused = _motion_of_run(p) if rc == 0 else None
    assert refused is None, (rc, refused)
    if rc != 0:
        assert re.search(r"lasts|too few for the|all zeros|needs at least two rows|take out the whole motion", out), out


def _suite_case(tmp_path, lengths: list[int]):
    (tmp_path / "records").mkdir()
    for i, n in enumerate(lengths):
        _two_column(tmp_path / "records" / f"r{i}.txt", n, amplitude=0.1 * (i + 1))
    shutil.copy(tmp_path / "records" / "r0.txt", tmp_path / "rec.txt")
    entries = "".join(f"    - {{file: records/r{i}.txt, units: g}}\n" for i in range(len(lengths)))
    return _case(tmp_path, extra=f"\nsuite:\n  records:\n{entries}  scaling: pga\n")


def test_a_suite_member_too_short_for_the_lowpass_is_refused_by_check_naming_the_member(tmp_path, capsys):
    """A suite of three records, the second 11 samples long: `check` (on today's main a
    MotionError traceback) and `run` exit 1 naming suite.records[1].file and a fix that
    applies; with it at 16 samples both `check` and the suite's plan pass."""
    p = _suite_case(tmp_path, [300, 11, 250])
    for cmd in ("check", "run"):
        rc, out = _cli(capsys, cmd, p)
        assert rc == 1, out
        assert re.search(r"suite\.records\[1\]\.file = '.*r1\.txt': cannot be used: .*r1\.txt: the window keeps 11 "
                         r"samples .*Fix: give a record of at least 16 samples", out), out
    _two_column(tmp_path / "records" / "r1.txt", 16)
    rc, out = _cli(capsys, "check", p)
    assert rc == 0, out
    assert "suite: 3 members" in out


def test_an_all_zero_record_is_refused_by_check_as_by_run(tmp_path, capsys):
    """A record of zeros scaled to a PGA: `run` cannot scale it; `check` refuses it first."""
    (tmp_path / "rec.txt").write_text("".join(f"{i * 0.01:.2f} 0.0\n" for i in range(100)))
    p = _case(tmp_path)
    rc, out = _cli(capsys, "check", p)
    assert rc == 1 and "ground_motion.file = 'rec.txt'" in out and "all zeros" in out, out
    assert "all zeros" in (_motion_of_run(p) or "")


def test_check_says_the_window_is_the_whole_record_when_duration_is_unset(tmp_path, capsys):
    _two_column(tmp_path / "rec.txt", 300)
    rc, out = _cli(capsys, "check", _case(tmp_path))
    assert rc == 0, out
    assert "window the whole record;" in out and "None" not in out, out


def test_a_refused_resume_never_reports_a_cut_off_file_as_running(tmp_path):
    """The pressure tunnel's no_water, 0.3 s with a checkpoint every 0.05 s: tq-solid killed
    inside its second checkpoint (TQ_CHECKPOINT_FAULT) leaves its results file with the status
    'running'; the run's summary says the file is cut off, not 'status running'. A `--resume`
    that tq-solid refuses (its checkpoint folder held, as by another tq-solid) says the file is as
    the earlier run left it; on today's main both summaries said '(status running)'."""
    import fcntl
    import os
    import subprocess
    import sys

    from tunnelquake import paths

    if paths.solid_executable() is None:
        pytest.skip("tq-solid is not built")
    shutil.copytree(PRESSURE, tmp_path / "case", ignore=shutil.ignore_patterns("results*"))
    p = tmp_path / "case" / "case.yaml"
    text = p.read_text().replace("  duration: 10 s", "  duration: 1 s")
    text = text.replace("output:\n", "output:\n  checkpoint_interval: 0.05 s\n")
    p.write_text(text + "\nconditions: [no_water]\ntime:\n  end_time: 0.3 s\n")

    def run(*extra, env=None):
        r = subprocess.run([sys.executable, "-m", "tunnelquake", "run", str(p), "--no-post", *extra],
                           capture_output=True, text=True, timeout=300,
                           env={**os.environ, "PYTHONPATH": str(ROOT / "scripts"), **(env or {})})
        out = r.stdout + r.stderr
        assert r.returncode == 1 and "Traceback" not in out, out[-3000:]
        return out[out.index("FAILED:"):]

    summary = run(env={"TQ_CHECKPOINT_FAULT": "2:solid"})
    assert "tq-solid stopped (exit -9)" in summary, summary
    assert "status running" not in summary, summary
    assert "cut off: its solver ended without writing a status" in summary, summary
    lock = p.parent / "results" / "no_water" / "checkpoint" / "lock"
    fd = os.open(lock, os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        summary = run("--resume")
    finally:
        os.close(fd)
    assert "tq-solid stopped (exit 2)" in summary, summary
    assert "status running" not in summary, summary
    assert "results_no_water.h5 is as an earlier run left it, cut off where that run was stopped" in summary, summary


@pytest.mark.parametrize("edit, key, value_words", [
    (("  pga: 0.3 g", "  pga: 3 g"), "ground_motion.pga", "29.42 m/s^2 is 3 g: above 2 g"),
    (("  lining_thickness: 0.5 m", "  lining_thickness: 0.15 m"), "geometry.lining_thickness",
     "0.15 m is thinner than 1/40 of the excavated diameter 7 m (0.175 m)"),
    (("  lining_thickness: 0.5 m", "  lining_thickness: 2 m"), "geometry.lining_thickness",
     "2 m is more than half the excavated radius 3.5 m"),
    (("    youngs_modulus: 33 GPa", "    youngs_modulus: 33 MPa"), "materials.lining.youngs_modulus",
     "3.3e+07 Pa is outside 1e+10 to 8e+10 Pa"),
    (("    youngs_modulus: 20 GPa", "    youngs_modulus: 20000 GPa"), "materials.rock.youngs_modulus",
     "2e+13 Pa is outside 1e+07 to 1.5e+11 Pa"),
    (("    density: 2300 kg/m^3", "    density: 2.3 kg/m^3"), "materials.weathered.density",
     "2.3 kg/m^3 is outside 1000 to 3500 kg/m^3"),
    (("  head: 60 m", "  head: 6000 m"), "water.head", "6000 m is above 2000 m"),
])
def test_a_value_far_outside_the_physical_range_is_warned_of_by_check_and_run_naming_it(tmp_path, capsys, edit, key,
                                                                                        value_words):
    """Each sanity warning (tunnelquake.sanity) on the pressure tunnel: `check` exits 0 with one
    warning naming the key and the value; `run` prints the same before it meshes. The case as
    given has none."""
    text = (PRESSURE / "case.yaml").read_text()
    assert edit[0] in text
    for f in ("horizontal.txt", "along_axis.txt", "vertical.txt"):
        shutil.copy(PRESSURE / f, tmp_path / f)
    p = tmp_path / "case.yaml"
    p.write_text(text)
    rc, out = _cli(capsys, "check", p)
    assert rc == 0 and "warning" not in out, out
    p.write_text(text.replace(edit[0], edit[1], 1))
    rc, out = _cli(capsys, "check", p)
    assert rc == 0, out
    warnings = [ln for ln in out.splitlines() if ln.startswith("warning: ")]
    # (a thinner or thicker lining also moves the monitors off it: said by their own warnings)
    sane = [w for w in warnings if not w.startswith("warning: output.monitors.")]
    assert len(sane) == 1 and sane[0].startswith(f"warning: {key} {value_words}"), warnings
    from tunnelquake.case_file import load_or_report

    assert load_or_report(p) is not None  # what `run` loads the case with: the same warnings first
    assert capsys.readouterr().err.splitlines() == warnings


def test_a_suite_member_scaled_beyond_2_g_is_warned_of_by_check_and_by_the_suite_s_plan(tmp_path, capsys):
    """A suite with scaling none whose second record is in cm/s^2 but declared in g (981x): its
    member's PGA, 200 g, is in no key; `check` and the plan `run` makes (suite_members.plan_members)
    warn of it naming the member, the record and the PGA. The first member (0.1 g) is not named."""
    p = _suite_case(tmp_path, [300, 300])
    _two_column(tmp_path / "records" / "r1.txt", 300, amplitude=196.1)  # 0.2 g written in cm/s^2
    p.write_text(p.read_text().replace("scaling: pga", "scaling: none").replace("  pga: 0.3 g\n", ""))
    rc, out = _cli(capsys, "check", p)
    assert rc == 0, out
    warnings = [ln for ln in out.splitlines() if ln.startswith("warning: ")]
    assert len(warnings) == 1, warnings
    m = re.match(r"warning: suite member r1 \(r1\.txt, scaled by 1\): PGA ([0-9.]+) m/s\^2 is ([0-9.]+) g: above 2 g",
                 warnings[0])
    assert m and 150 < float(m.group(2)) < 250, warnings  # the record's 196 g as processed (baseline, filter)
    from tunnelquake.case import load_case
    from tunnelquake.suite_members import plan_members

    plan_members(load_case(p))
    assert capsys.readouterr().err.strip().splitlines() == warnings


def test_a_record_used_as_recorded_with_a_peak_above_2_g_is_warned_of(tmp_path, capsys):
    """No ground_motion.pga: the record's own peak is the PGA. A record in cm/s^2 declared in g
    (200 g) is warned of by `check`, naming the file; the same record at 0.2 g is not."""
    _two_column(tmp_path / "rec.txt", 300, amplitude=196.1)
    p = _case(tmp_path)
    p.write_text(p.read_text().replace("  pga: 0.3 g\n", ""))
    rc, out = _cli(capsys, "check", p)
    assert rc == 0, out
    assert re.search(r"warning: ground_motion\.file rec\.txt: its peak \(no pga scales it\) [0-9.]+ m/s\^2 is 19[0-9](\.[0-9]+)? "
                     r"g: above 2 g", out), out
    _two_column(tmp_path / "rec.txt", 300, amplitude=0.2)
    rc, out = _cli(capsys, "check", p)
    assert rc == 0 and "warning" not in out, out


def test_too_many_water_ranks_for_the_mesh_are_refused_by_check_as_by_run(tmp_path, capsys):
    """parallel.fluid_ranks 16 on the pressure tunnel's slice (192 water cells; a rank needs 20):
    `check` passed it and `run` refused it after meshing and writing the water case. `check`
    refuses it naming the key and the most ranks the mesh takes (9), which passes; `run`'s
    decomposition refuses 16 with the same words (one rule, case.fluid_ranks_problem)."""
    from tunnelquake import fluid_case as fc

    for f in ("horizontal.txt", "along_axis.txt", "vertical.txt"):
        shutil.copy(PRESSURE / f, tmp_path / f)
    p = tmp_path / "case.yaml"
    text = (PRESSURE / "case.yaml").read_text()
    p.write_text(text + "\nparallel:\n  fluid_ranks: 16\n")
    rc, out = _cli(capsys, "check", p)
    assert rc == 1, out
    words = "gives the water's 192 cells fewer than 20 a rank"
    assert f"parallel.fluid_ranks = 16: {words}. Fix: use fluid_ranks: 1 (at most 9 for this mesh)" in out, out
    p.write_text(text + "\nparallel:\n  fluid_ranks: 9\n")
    rc, out = _cli(capsys, "check", p)
    assert rc == 0, out
    owner = tmp_path / "water" / "constant" / "polyMesh" / "owner"
    owner.parent.mkdir(parents=True)
    owner.write_text('FoamFile\n{\n    note        "nPoints:500  nCells:192  nFaces:900  nInternalFaces:300";\n}\n')
    with pytest.raises(fc.FluidCaseError, match=re.escape(f"parallel.fluid_ranks = 16 {words}")):
        fc.decompose(tmp_path / "water", 16, (6.0, 1.0, 6.0), True)


def test_a_cut_off_below_one_over_the_window_is_refused_by_check_on_its_key(tmp_path, capsys):
    """ground_motion.cutoff_frequency 1e-9 Hz: the filter's design failed in `motion` with a
    LinAlgError traceback after `check` passed it. Any cut-off below 1 / the window takes out the
    whole motion: `check` refuses it on its key (10 s window: below 0.1 Hz), the motion of `run`
    likewise; 0.2 Hz passes."""
    _two_column(tmp_path / "rec.txt", 1001)
    for cutoff, ok in (("1e-9 Hz", False), ("0.05 Hz", False), ("0.2 Hz", True)):
        p = _case(tmp_path, cutoff=cutoff)
        rc, out = _cli(capsys, "check", p)
        assert (rc == 0) is ok, out
        assert (_motion_of_run(p) is None) is ok, cutoff
        if not ok:
            assert re.search(r"ground_motion\.cutoff_frequency = [0-9.e-]+: ground_motion\.cutoff_frequency [0-9.e-]+ Hz is "
                             r"below 1 / the window \(0\.1 Hz for 10 s\): the low-pass would take out the whole motion",
                             out), out


@pytest.mark.parametrize("old, new", [("  max_element_size: 5 m", "  max_element_size: 1e-9"),
                                      ("  max_element_size: 5 m", "  max_element_size: 1e-7"),
                                      ("  near_field_radial_divisions: 8", "  near_field_radial_divisions: 1000000")])
def test_mesh_divisions_beyond_any_machine_are_refused_by_check(tmp_path, capsys, old, new):
    """Mesh keys that ask for more divisions than any machine holds (`check` raised MemoryError or
    OverflowError, or at 1e-7 m listed 1.4e9 element sizes): one error naming the key and the fix,
    at once and in little memory."""
    for f in ("horizontal.txt", "along_axis.txt", "vertical.txt"):
        shutil.copy(PRESSURE / f, tmp_path / f)
    text = (PRESSURE / "case.yaml").read_text()
    assert old in text
    p = tmp_path / "case.yaml"
    p.write_text(text.replace(old, new))
    rc, out = _cli(capsys, "check", p)
    assert rc == 1, out
    key = new.strip().split(":")[0]
    assert f"mesh.{key} = " in out and "more elements than any machine can hold" in out, out
    assert "Fix: raise mesh.max_element_size" in out, out


def test_a_rock_ring_element_too_thin_for_the_mesher_is_refused_by_check(tmp_path, capsys):
    """near_field_radial_divisions 100 (graded 1.1): the first ring element, 4.7e-5 m, is thinner
    than the 1.4e-4 m within which the mesher puts a face on a boundary, and `mesh` failed with a
    RuntimeError traceback after `check` passed it. `check` refuses it naming the key; 86 (1.8e-4 m)
    passes `check` and meshes (the mesher's own face check: one region per face)."""
    for f in ("horizontal.txt", "along_axis.txt", "vertical.txt"):
        shutil.copy(PRESSURE / f, tmp_path / f)
    text = (PRESSURE / "case.yaml").read_text()
    p = tmp_path / "case.yaml"
    p.write_text(text.replace("  near_field_radial_divisions: 8", "  near_field_radial_divisions: 100"))
    rc, out = _cli(capsys, "check", p)
    assert rc == 1, out
    assert re.search(r"mesh\.near_field_radial_divisions = 100: the first radial element of the rock ring is 4\.72e-05 m, "
                     r"thinner than 0\.00014 m .* Fix: lower near_field_radial_divisions or near_field_growth", out), out
    p.write_text(text.replace("  near_field_radial_divisions: 8", "  near_field_radial_divisions: 86"))
    assert _cli(capsys, "check", p)[0] == 0
    assert _cli(capsys, "mesh", p)[0] == 0
