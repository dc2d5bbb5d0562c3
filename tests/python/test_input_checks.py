"""Case values that would pass `check` and then fail later, or be used without a word: `check`
refuses each (or warns where the value is usable), naming the key or file, the value and the fix,
before anything is meshed, generated or run."""
from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import EXAMPLE
from tunnelquake.cli import main

RECORD_KEY = "  file: ../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2\n"


def _case(tmp_path, *edits: str, record: str | None = None) -> str:
    """The example case in `tmp_path`, with each (old, new) pair of `edits` replaced once and, if
    given, `record` (a file name in tmp_path) as its ground-motion record (if_missing: error)."""
    text = EXAMPLE.read_text()
    if record is not None:
        units = "" if record.lower().endswith(".at2") else "  units: g\n"
        edits = (RECORD_KEY, f"  file: {record}\n{units}", "  if_missing: synthetic ", "  if_missing: error ", *edits)
    for old, new in zip(edits[::2], edits[1::2], strict=True):
        assert old in text, old
        text = text.replace(old, new, 1)
    p = tmp_path / "case.yaml"
    p.write_text(text)
    return str(p)


def _check(capsys, path: str) -> tuple[int, str]:
    rc = main(["check", path])
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err
    return rc, out.err


def _two_column(path, t, a):
    path.write_text("# time (s)  acceleration (g)\n" + "".join(f"{x:.4f} {float(y)!r}\n" for x, y in zip(t, a, strict=True)))


def test_nan_in_a_two_column_record_is_refused_naming_the_file_and_line(tmp_path, capsys):
    t = np.arange(0.0, 20.0 + 1e-9, 0.01)
    a = list(0.1 * np.sin(2 * np.pi * t))
    a[500] = float("nan")  # row 501, file line 502 (after the comment line)
    _two_column(tmp_path / "rec.txt", t, a)
    rc, err = _check(capsys, _case(tmp_path, record="rec.txt"))
    assert rc == 1
    assert (f"ground_motion.file = 'rec.txt': cannot be read: {tmp_path / 'rec.txt'}:502: the acceleration on "
            "row 501 is 'nan', not a finite number. Fix: correct or fill in line 502 of the record") in err


def test_inf_time_in_a_two_column_record_is_refused(tmp_path, capsys):
    (tmp_path / "rec.txt").write_text("0 0.1\n0.01 0.2\ninf 0.3\n")
    rc, err = _check(capsys, _case(tmp_path, record="rec.txt"))
    assert rc == 1
    assert f"{tmp_path / 'rec.txt'}:3: the time on row 3 is 'inf', not a finite number" in err


def test_record_shorter_than_duration_is_refused_naming_both_lengths(tmp_path, capsys):
    t = np.arange(0.0, 12.0, 0.01)  # 1200 points: lasts 12 s
    _two_column(tmp_path / "short.txt", t, 0.1 * np.sin(2 * np.pi * t))
    rc, err = _check(capsys, _case(tmp_path, record="short.txt"))
    assert rc == 1
    assert (f"ground_motion.duration = 20.0: {tmp_path / 'short.txt'} lasts 12 s (1200 points at dt = 0.01 s) "
            "but ground_motion.duration is 20 s: the run would shake for 12 s only. Fix: set "
            "ground_motion.duration to 12 s or less, or give a record at least 20 s long") in err
    # the same record with the window it covers passes
    rc, _ = _check(capsys, _case(tmp_path, "  duration: 20 s\n", "  duration: 12 s\n", record="short.txt"))
    assert rc == 0


def test_synthetic_record_shorter_than_duration_is_refused(tmp_path, capsys):
    rc, err = _check(capsys, _case(tmp_path, "  source: file\n", "  source: synthetic\n  synthetic: {duration: 8 s}\n"))
    assert rc == 1
    assert ("ground_motion.duration = 20.0: the synthetic record lasts 8.01 s (801 points at dt = 0.01 s) but "
            "ground_motion.duration is 20 s") in err
    assert "Fix: set ground_motion.synthetic.duration to at least 20 s" in err


AT2_HEAD = ("Data for a test record\n{n} points at equal spacing of {dt2} sec\nThe units are (g)\n"
            "NPTS=  {npts}, DT= {dt} SEC\n")


def _at2(path, npts, dt, n_values, dt2=None, n_words=None):
    vals = 0.01 * np.sin(np.arange(n_values) * 0.1)
    rows = ["".join(f"{v:10.5f}" for v in vals[i:i + 8]) for i in range(0, n_values, 8)]
    path.write_text(AT2_HEAD.format(n=n_words or npts, dt2=dt2 or dt, npts=npts, dt=dt) + "\n".join(rows) + "\n")


def test_at2_with_more_values_than_its_header_is_refused_naming_both(tmp_path, capsys):
    _at2(tmp_path / "rec.AT2", 2000, 0.01, 4000)  # header: 20 s; data: 40 s at that DT
    rc, err = _check(capsys, _case(tmp_path, record="rec.AT2"))
    assert rc == 1
    assert (f"{tmp_path / 'rec.AT2'}:255: header says NPTS=2000, DT=0.01 s (a record of 20 s) but the file holds "
            "4000 values (40 s at that DT); the values from line 255 on would be dropped. Fix: correct NPTS (and "
            "DT) in the header (line 4) to 4000 values, or remove the values past NPTS") in err


def test_at2_with_fewer_values_than_its_header_is_refused_naming_both(tmp_path, capsys):
    _at2(tmp_path / "rec.AT2", 4000, 0.01, 2500)
    rc, err = _check(capsys, _case(tmp_path, record="rec.AT2"))
    assert rc == 1
    assert ("header says NPTS=4000, DT=0.01 s (a record of 40 s) but the file holds 2500 values (25 s at that DT). "
            "Fix: correct NPTS in the header (line 4) or restore the missing values") in err


def test_at2_whose_dt_disagrees_with_its_header_text_is_refused(tmp_path, capsys):
    _at2(tmp_path / "rec.AT2", 2500, 0.01, 2500, dt2="0.02")
    rc, err = _check(capsys, _case(tmp_path, record="rec.AT2"))
    assert rc == 1
    assert (f"{tmp_path / 'rec.AT2'}:4: header says DT=0.01 s, but line 2 says 'spacing of 0.02 sec': the values "
            "would be played at the wrong speed. Fix: make DT on line 4 the record's true sampling step") in err


def test_at2_whose_dt_disagrees_with_its_file_name_is_refused(tmp_path, capsys):
    _at2(tmp_path / "elcentro_dt0.02.AT2", 2500, 0.01, 2500)
    (tmp_path / "elcentro_dt0.02.AT2").write_text(
        re.sub(r"^.*points at equal spacing.*$", "Processed record", (tmp_path / "elcentro_dt0.02.AT2").read_text(),
               count=1, flags=re.M))
    rc, err = _check(capsys, _case(tmp_path, record="elcentro_dt0.02.AT2"))
    assert rc == 1
    assert "header says DT=0.01 s, but the file name says dt 0.02 s: the values would be played at the wrong speed" in err


def test_at2_whose_npts_disagrees_with_its_header_text_is_refused(tmp_path, capsys):
    _at2(tmp_path / "rec.AT2", 2500, 0.01, 2500, n_words=3000)
    rc, err = _check(capsys, _case(tmp_path, record="rec.AT2"))
    assert rc == 1
    assert "header says NPTS=2500, but line 2 says 3000 points" in err


def test_nan_in_an_at2_record_is_refused_naming_the_line(tmp_path, capsys):
    _at2(tmp_path / "rec.AT2", 2500, 0.01, 2500)
    lines = (tmp_path / "rec.AT2").read_text().splitlines()
    lines[9] = "       nan" + lines[9][10:]  # the first value of data line 6 (file line 10): value 41
    (tmp_path / "rec.AT2").write_text("\n".join(lines) + "\n")
    rc, err = _check(capsys, _case(tmp_path, record="rec.AT2"))
    assert rc == 1
    assert (f"{tmp_path / 'rec.AT2'}:10: value 41 of the record is nan, not a finite number (1 such value in the "
            "record). Fix: correct or fill in the value on line 10 of the record") in err


# ---------------------------------------------------------------------------------------------
# Monitors against the lining
# ---------------------------------------------------------------------------------------------
def test_monitor_named_after_the_lining_but_in_the_rock_is_refused(tmp_path, capsys):
    rc, err = _check(capsys, _case(tmp_path, "    top_arch:    [0.0, 40.0, 36.5]", "    top_arch:    [0.0, 40.0, 39.0]"))
    assert rc == 1
    line = EXAMPLE.read_text().splitlines().index("    top_arch:    [0.0, 40.0, 36.5]") + 1
    assert (f":{line}: output.monitors.top_arch = [0.0, 40.0, 39.0]: lies 7 m from the tunnel axis (x = 0, z = 32 m "
            "in the x-z plane); the lining is 4.5 m <= r <= 5.25 m, so this point is in the rock: tq-solid records "
            "the solid's node and element nearest to it, the rock's (the lining's only within about half an element "
            "of its outer surface), and the report compares top_arch with the paper's lining values. Fix: move it "
            "into the lining, e.g. [0.0, 40.0, 36.5] on its inner surface in the same direction, or give the rock "
            "point another name (the report reads top_arch, haunch, bottom_arch as the lining's)") in err


def test_monitors_in_the_rock_or_the_water_are_warned_naming_each(tmp_path, capsys):
    path = _case(tmp_path, "    haunch:      [4.5, 40.0, 32.0]\n",
                 "    haunch:      [4.5, 40.0, 32.0]\n    rock_9m: [-9.0, 40.0, 32.0]\n"
                 "    in_water: [0.0, 40.0, 28.5]\n    axis: [0.0, 40.0, 32.0]\n    outer_face: [0.0, 40.0, 37.25]\n")
    rc, err = _check(capsys, path)
    assert rc == 0
    assert ("warning: output.monitors.rock_9m [-9.0, 40.0, 32.0]: lies 9 m from the tunnel axis (x = 0, z = 32 m in "
            "the x-z plane); the lining is 4.5 m <= r <= 5.25 m, so this point is in the rock") in err
    assert "If it is meant to monitor the lining, move it there, e.g. [-4.5, 40.0, 32.0]" in err
    assert ("warning: output.monitors.in_water [0.0, 40.0, 28.5]: lies 3.5 m from the tunnel axis") in err
    assert ("so this point is in the water, 1 m inside the lining: the solid has no element there, and tq-solid "
            "records the lining's inner surface nearest to it (about [0.0, 40.0, 27.5])") in err
    assert "output.monitors.axis [0.0, 40.0, 32.0]: lies 0 m from the tunnel axis" in err
    assert "the whole inner surface of the lining is equally near" in err
    # the example's three monitors (on the inner surface) and one on the outer surface are in the lining
    assert not re.search(r"monitors\.(top_arch|haunch|bottom_arch|outer_face)", err), err


# ---------------------------------------------------------------------------------------------
# The mesher's own rules, said by check
# ---------------------------------------------------------------------------------------------
def test_lining_elements_around_not_a_multiple_of_4_is_refused_by_check(tmp_path, capsys):
    rc, err = _check(capsys, _case(tmp_path, "  max_element_size: 6.75 m", "  lining_elements_around: 50\n"
                                                                         "  max_element_size: 6.75 m"))
    assert rc == 1
    assert (":21: mesh.lining_elements_around = 50: must be a multiple of 4 (one O-grid block per quarter). Fix: "
            "use 48") in err


def test_max_element_size_below_what_the_blocks_meet_is_refused_by_check(tmp_path, capsys):
    rc, err = _check(capsys, _case(tmp_path, "  max_element_size: 6.75 m", "  max_element_size: 0.01 m"))
    assert rc == 1
    assert (":21: mesh.max_element_size = 0.01: the near-field box side spacing is 2.333 m > max_element_size "
            "0.01 m. Fix: change near_field_half_width / lining_elements_around, or raise max_element_size to "
            "2.333 m or more") in err


def test_mesh_rules_refuse_before_meshing_in_mesh_too(tmp_path, capsys):
    """`tunnelquake mesh` loads the case through the same checks: the message, no traceback, no mesh."""
    path = _case(tmp_path, "  max_element_size: 6.75 m", "  lining_elements_around: 50\n  max_element_size: 6.75 m")
    assert main(["mesh", path]) == 1
    err = capsys.readouterr().err
    assert "mesh.lining_elements_around = 50: must be a multiple of 4" in err
    assert not (tmp_path / "results" / "mesh").exists()


# ---------------------------------------------------------------------------------------------
# A mesh too large for the machine
# ---------------------------------------------------------------------------------------------
def test_huge_3d_mesh_is_estimated_and_warned_above_the_machine_memory(tmp_path, capsys, monkeypatch):
    from tunnelquake.meshing import params

    meminfo = tmp_path / "meminfo"
    meminfo.write_text("MemTotal:       25165824 kB\nMemFree:         1000000 kB\nMemAvailable:   20971520 kB\n")
    monkeypatch.setattr(params, "MEMINFO", str(meminfo))
    path = _case(tmp_path, "  mode: slice ", "  refinement_factor: 8\n  mode: 3d ")
    rc = main(["check", path])
    out = capsys.readouterr()
    assert rc == 0 and "Traceback" not in out.err
    assert ("warning: mesh: about 40,550,400 hexahedra (rock 29,736,960, lining 3,244,032, water 7,569,408) need "
            "about 86.9 GiB to mesh and 99.5 GiB to run, more than this machine's 24.0 GiB of memory (20.0 GiB "
            "available now): meshing and the run would run out of memory. Fix: lower mesh.refinement_factor (8), "
            "raise mesh.max_element_size or use fewer divisions, or mesh.mode: slice") in out.err
    assert "mesh: 29,736,960 rock + 3,244,032 lining + 7,569,408 water hexahedra" in out.out
    # the example's slice is far below: no warning
    assert main(["check", str(EXAMPLE)]) == 0
    out = capsys.readouterr()
    assert "need about" not in out.err
    assert "mesh: 1,320 rock + 144 lining + 336 water hexahedra" in out.out


def test_element_counts_are_those_the_mesher_builds(tmp_path):
    """The estimate is exact: the counts from the division numbers equal a real build's."""
    from tunnelquake.meshing import PAPER_GEOMETRY, build_tunnel_mesh
    from tunnelquake.meshing.params import element_counts, resolve

    for mesh in ({"mode": "slice", "refinement_factor": 2, "outer_growth": 1.3, "near_field_growth": 1.2},
                 {"mode": "3d", "elements_along_axis": 12}):
        built = build_tunnel_mesh(PAPER_GEOMETRY, mesh, tmp_path / mesh["mode"])["counts"]
        est = element_counts(resolve(PAPER_GEOMETRY, mesh))
        assert est == {k: built[k] for k in est}, (mesh, est, built)
    assert element_counts(resolve(PAPER_GEOMETRY, {}))["rock"] == 58080  # the paper's 3D mesh


def _without_sections(text: str, *names: str) -> str:
    """`text` with the top-level sections `names` (their key line and indented body) removed."""
    out, skip = [], False
    for line in text.splitlines(keepends=True):
        if line and not line[0].isspace() and not line.startswith("#"):
            skip = line.split(":", 1)[0] in names
        if not skip:
            out.append(line)
    return "".join(out)


def test_a_material_the_mesh_has_no_region_for_is_refused_naming_it(tmp_path, capsys):
    """A second rock material (a weathered layer) would never be meshed: refused, not ignored."""
    rc, err = _check(capsys, _case(tmp_path, "  lining:\n", "  weathered:\n    youngs_modulus: 2 GPa\n"
                                   "    poisson_ratio: 0.3\n    density: 2200 kg/m^3\n    model: elastic\n  lining:\n"))
    assert rc == 1
    assert ("materials.weathered = 'weathered': is not a region of the mesh: no entry of layers names it, so this "
            "material would never be used. Fix: add a layer with 'material: weathered'") in err


def test_a_two_column_record_without_units_is_refused_naming_the_key(tmp_path, capsys):
    t = np.arange(0.0, 20.0 + 1e-9, 0.01)
    (tmp_path / "rec.txt").write_text("".join(f"{x:.4f} {0.1 * np.sin(x):.6f}\n" for x in t))
    text = EXAMPLE.read_text().replace(RECORD_KEY, "  file: rec.txt\n").replace("if_missing: synthetic ", "if_missing: error ")
    (tmp_path / "case.yaml").write_text(text)
    rc, err = _check(capsys, str(tmp_path / "case.yaml"))
    assert rc == 1
    assert ("a two-column record states no units, and none are given. Fix: give them: ground_motion.units: g, "
            "m/s^2, cm/s^2 or gal") in err


def test_defaults_are_the_settings_the_example_measured(tmp_path, capsys):
    """A case that leaves damping, coupling and the water model out gets the example's measured
    settings (mass-proportional damping: no cut in the stable step; windows of 16 steps with IQN-ILS
    reuse 16, weight 0.75; compressible water), and no warning about its speed."""
    from tunnelquake.case import coupling_window_force_weight, load_case

    text = _without_sections(EXAMPLE.read_text(), "damping", "coupling", "variants")
    text = text.replace("  model: compressible\n", "").replace(RECORD_KEY, "  file: x.AT2\n")
    (tmp_path / "case.yaml").write_text(text)
    case = load_case(tmp_path / "case.yaml")
    d = case.data
    assert d["damping"]["model"] == "mass_proportional"
    assert d["water"]["model"] == "compressible"
    assert (d["coupling"]["scheme"], d["coupling"]["window"], d["coupling"]["reuse"]) == ("implicit", 16, 16)
    assert coupling_window_force_weight(d["coupling"]) == 0.75
    assert not [w for w in case.warnings if "slower" in w or "longer" in w or "CPU" in w]
    # the other schemes keep one-step windows and no reuse
    (tmp_path / "case.yaml").write_text(text + "coupling:\n  scheme: explicit\n")
    c = load_case(tmp_path / "case.yaml").data["coupling"]
    assert (c["window"], c["reuse"]) == (1, 0)


def test_rayleigh_damping_warns_with_the_factor_it_slows_the_run(tmp_path, capsys):
    """Stiffness-proportional damping cuts the central-difference step to (2/w)(sqrt(1+xi^2) - xi),
    xi = beta w / 2 at the highest frequency w = 2 c_p / h (Belytschko, Liu & Moran §6.3; tq-solid's
    stableStep): for the example's innermost lining hexahedra (h = L, their volume / largest face as
    tq-solid takes it: 0.25 m x cos(pi/48) x (4.5 + 4.75) / (2 x 4.75) = 0.2429 m; c_p = 3,470 m/s) and
    5 % at 1.5 and 10 Hz, xi = 19.8 and the step is cut 39.6x, as tq-solid's own bound 2/7.0e-5 s gives."""
    import math

    rc, err = _check(capsys, _case(tmp_path, "  model: mass_proportional", "  model: rayleigh",
                                   "  subcycling: {static_water: 3, dynamic_water: 3}", "  subcycling: 0"))
    assert rc == 0  # single-rate: subcycling refuses the stiffness term
    cp = math.sqrt(28e9 * 0.83 / (1.17 * 0.66 * 2500))
    xi = 2 * 0.05 / (2 * math.pi * 11.5) * cp / (0.25 * math.cos(math.pi / 48) * (4.5 + 4.75) / (2 * 4.75))
    factor = 1 / (math.sqrt(1 + xi * xi) - xi)
    assert factor == pytest.approx(39.56, abs=0.01)
    assert f"damping.model rayleigh: its stiffness term cuts the solid's stable step about {factor:.0f}x" in err
    assert f"so the run takes about {factor:.0f}x longer; damping.model: mass_proportional (the default)" in err


def test_one_step_implicit_windows_warn_with_the_measured_factor(tmp_path, capsys):
    rc, err = _check(capsys, _case(tmp_path, "  window: 16", "  window: 1", "  reuse: 16", "  reuse: 0"))
    assert rc == 0
    assert ("warning: coupling.window 1: every solid step exchanges with the water; over the example slice's first "
            "second one-step windows took 3.7x the CPU time of windows of 16 (the default)") in err


def test_incompressible_water_with_closed_ends_in_3d_runs_with_its_approximation_stated(tmp_path, capsys):
    """Accepted (the solid holds the whole enclosed volume), with a warning that the water solver's
    remainder, the volume moved along the axis, meets K = 2.2 GPa rather than an infinite stiffness."""
    rc, err = _check(capsys, _case(tmp_path, "  model: compressible\n", "  model: incompressible\n",
                                   "  ends: open\n", "  ends: closed\n", "  mode: slice ", "  mode: 3d "))
    assert rc == 0
    assert ("warning: water.model incompressible with closed ends in 3D: the solid holds the whole enclosed volume; "
            "the water solver's remainder (volume moved along the axis between the tunnel's parts) is solved with "
            "K = 2.2 GPa, not incompressibly") in err
