"""The report and figures of a case unlike the example: its own monitors, materials, record and
PGA, per condition the peaks with their times and the differences between conditions, and no
trace of the paper the example reproduces. The example keeps its comparison with the paper.

The case: a 7 m bore (excavated radius 3.5 m) with a 0.5 m lining of 35 GPa concrete in 20 GPa
rock, 60 m head, four monitors of its own on the lining's inner face, and a 1 s two-column record
in g scaled to PGA 0.3 g; all three conditions (about 25 s with the coupled one)."""
from __future__ import annotations

import re
import shutil

import h5py
import numpy as np
import pytest

from conftest import EXAMPLE
from tunnelquake.cli import main

G = 9.80665
#: The case's monitors: crown, springline, invert and a shoulder at 45°, on the lining's inner face
#: (radius 3 m about the axis at x = 0, z = 15 m).
MONITORS = {"crown": [0.0, 5.0, 18.0], "springline": [3.0, 5.0, 15.0], "invert": [0.0, 5.0, 12.0],
            "shoulder": [2.1213, 5.0, 17.1213]}
STRENGTH = 2.2e6  # the lining's tensile strength, Pa

CASE = """\
name: own_tunnel
description: a pressure tunnel unlike the example
geometry:
  x_range: [-30.0, 30.0]
  y_range: [0.0, 10.0]
  z_range: [-15.0, 40.0]
  tunnel_centre_x: 0.0
  tunnel_centre_z: 15.0
  excavated_radius: 3.5 m
  lining_thickness: 0.5 m
mesh:
  mode: slice
  max_element_size: 5 m
  lining_elements_around: 32
  lining_elements_through: 2
  near_field_half_width: 8.0
  near_field_radial_divisions: 6
materials:
  rock: {model: elastic, youngs_modulus: 20 GPa, poisson_ratio: 0.25, density: 2650 kg/m^3}
  lining:
    model: mohr_coulomb_damage
    youngs_modulus: 35 GPa
    poisson_ratio: 0.2
    density: 2500 kg/m^3
    cohesion: 3.0 MPa
    friction_angle: 40 deg
    tensile_strength: 2.2 MPa
    compressive_strength: 35 MPa
water: {head: 60 m, model: compressible, bulk_modulus: 2.2 GPa}
in_situ: {kx: 1.1, ky: 0.8}
ground_motion:
  source: file
  file: record.txt
  format: two_column
  units: g
  duration: 1.0 s
  pga: 0.3 g
  vertical_ratio: 0.5
damping: {model: mass_proportional, ratio: 0.05, frequencies: [2 Hz, 10 Hz]}
conditions: [no_water, static_water, dynamic_water]
coupling: {scheme: implicit, window: 16, tolerance: 1e-3, reuse: 16}
output:
  monitors:
""" + "".join(f"    {m}: {p}\n" for m, p in MONITORS.items())


def _record(path):
    """A 2 s two-column record in g: a 3 Hz pulse under a Gaussian envelope (peak 0.25 g)."""
    t = np.arange(0.0, 2.0 + 1e-9, 0.01)
    a = 0.25 * np.sin(2 * np.pi * 3 * t) * np.exp(-(((t - 0.8) / 0.4) ** 2))
    path.write_text("# time (s)  acceleration (g)\n" + "".join(f"{x:.3f} {y:.6e}\n" for x, y in zip(t, a, strict=True)))


@pytest.fixture(scope="module")
def own_case(tmp_path_factory):
    """The case run through `tunnelquake run` (mesh, motion, three conditions, post), once."""
    folder = tmp_path_factory.mktemp("own_case")
    _record(folder / "record.txt")
    (folder / "case.yaml").write_text(CASE)
    assert main(["run", str(folder / "case.yaml")]) == 0
    return folder


def _table(report: str, heading: str) -> tuple[list[str], dict[str, list[str]]]:
    """The markdown table after the line starting with `heading`: header cells and rows by first cell."""
    lines = report.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith(heading))
    k = next(i for i in range(k, len(lines)) if lines[i].startswith("|"))
    split = lambda line: [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]  # noqa: E731
    head = split(lines[k])
    rows = {}
    for line in lines[k + 2:]:
        if not line.startswith("|"):
            break
        cells = split(line)
        rows.setdefault(cells[0], cells)
        rows[f"{cells[0]}|{cells[1]}"] = cells
    return head, rows


def _histories(res_file) -> dict[str, dict[str, np.ndarray]]:
    """Each monitor's histories straight from results.h5 (rows all monitors have), less the two
    displacement references tq-solid records beside them (post.REFERENCES)."""
    from tunnelquake.post import REFERENCES

    out = {}
    with h5py.File(res_file, "r") as f:
        n = min(f[f"monitors/{m}/time"].shape[0] for m in f["monitors"])
        for m, g in f["monitors"].items():
            if m in REFERENCES.values():
                continue
            h = {"t": g["time"][:n, 0], "u": g["u"][:n], "s": g["principal"][:n], "d": g["damage"][:n, 0]}
            if "water_pressure" in g:
                h["wt"], h["p"] = g["water_pressure"][:, 0], g["water_pressure"][:, 1]
            out[m] = h
    return out


def _peak(t, v, scale):
    """(value, time) of the largest v, first occurrence, as the report shows them."""
    k = int(np.argmax(v))
    return f"{v[k] * scale:.4g}", f"{t[k]:.3f}"


def test_report_has_no_paper_text_no_nan_and_the_cases_own_inputs(own_case):
    report = (own_case / "results" / "report.md").read_text()
    assert not re.search(r"\bnan\b", report, re.I), "a NaN in the report"
    assert "not computed" not in report and "No sample" not in report
    for word in ("paper", "Liu", "top_arch", "haunch", "bottom_arch", "top arch", "bottom arch", "§3.3", "Imperial",
                 "El Centro", "reproduced"):
        assert word.lower() not in report.lower(), word
    # the paper's PGA (m/s²) and lining strength (MPa) as numbers of their own
    for number in ("1.575", "1.27"):
        assert not re.search(rf"(?<![\d.]){re.escape(number)}(?!\d)", report), number
    # the record's PGA: 0.3 g = 2.942 m/s² at the outcrop, the vertical half of it
    assert "- PGA (x, horizontal) at the outcrop (the incident wave is half of it): 2.942 m/s² = 0.3 g" in report
    assert "- peak (z, vertical) at the outcrop (the incident wave is half of it): 1.471 m/s² = 0.15 g" in report
    with h5py.File(own_case / "results" / "motion.h5", "r") as f:
        assert 2 * np.max(np.abs(f["incident_ax"][:])) == pytest.approx(0.3 * G, rel=1e-12)
    # the geometry and materials as given
    assert ("- tunnel: excavated radius 3.5 m (diameter 7 m), lining 0.5 m thick (inner radius 3 m), axis at "
            "x = 0 m, z = 15 m") in report
    assert "| lining | mohr_coulomb_damage | 35 | 0.2 | 2500 | 3 | 40 | 2.2 | 35 |" in report
    assert "| rock | elastic | 20 | 0.25 | 2650 | — | — | — | — |" in report
    assert "- water (static_water, dynamic_water): head 60 m at the axis, 1000 kg/m³, compressible, K = 2.2 GPa" \
        in report
    assert "σt = 2.2 MPa is the lining's tensile strength" in report
    # the monitors by name, where they are: radius 3 m, at 0°, 90°, 180° and 45° from the crown
    _, mon = _table(report, "| monitor | x (m)")
    assert list(k for k in mon if "|" not in k) == list(MONITORS)
    for m, ang in (("crown", "0.0"), ("springline", "90.0"), ("invert", "180.0"), ("shoulder", "45.0")):
        assert mon[m][4:] == ["3", ang, "lining"], mon[m]
    # every condition ran to the end
    for label in ("(1) no water", "(2) static water", "(3) dynamic water"):
        assert f"- {label}: status **completed**, 201 monitor samples to t = 1.00 s of the planned 1 s" in report


@pytest.mark.parametrize("cond,label", [("no_water", "(1) no water"), ("static_water", "(2) static water"),
                                        ("dynamic_water", "(3) dynamic water")])
def test_peak_tables_are_the_maxima_of_the_histories_with_their_times(own_case, cond, label):
    res = own_case / "results"
    report = (res / "report.md").read_text()
    head, rows = _table(report, f"### {label}: ")
    wet = cond == "dynamic_water"
    expect_head = ["monitor", "max \\|u_x\\| (mm)", "at t (s)", "max \\|u_z\\| (mm)", "at t (s)",
                   "max principal stress σ3 (MPa)", "at t (s)", "σ3 / σt (lining)", "min principal stress σ1 (MPa)",
                   "at t (s)", "max damage D", "at t (s)"]
    # the water pressure only where there is moving water; no y column in a plane slice
    assert head == expect_head + (["peak \\|dynamic water pressure\\| (MPa)", "at t (s)"] if wet else [])
    hist = _histories(res / f"results_{cond}.h5")
    assert set(hist) == set(MONITORS)
    for m, h in hist.items():
        row = rows[m]
        assert row[1:3] == list(_peak(h["t"], np.abs(h["u"][:, 0]), 1e3)), (m, "ux")
        assert row[3:5] == list(_peak(h["t"], np.abs(h["u"][:, 2]), 1e3)), (m, "uz")
        assert row[5:7] == list(_peak(h["t"], h["s"][:, 2], 1e-6)), (m, "s3")
        assert row[7] == f"{np.max(h['s'][:, 2]) / STRENGTH:.3f}"
        assert row[8:10] == list(_peak(h["t"], -h["s"][:, 0], -1e-6)), (m, "s1")
        assert row[10] == f"{np.max(h['d']):.4g}"
        if wet:
            assert row[12:14] == list(_peak(h["wt"], np.abs(h["p"]), 1e-6)), (m, "p")
            assert float(row[12]) > 0
    # the CSV beside the report holds the same histories (to its 7 digits)
    csv = np.genfromtxt(res / f"monitors_{cond}.csv", delimiter=",", names=True)
    for m, h in hist.items():
        assert np.max(np.abs(csv[f"{m}_ux_m"])) == pytest.approx(np.max(np.abs(h["u"][:, 0])), rel=1e-6)
        assert np.max(csv[f"{m}_s3_Pa"]) == pytest.approx(np.max(h["s"][:, 2]), rel=1e-6)


def test_differences_between_conditions_are_the_peaks_subtracted(own_case):
    res = own_case / "results"
    report = (res / "report.md").read_text()
    for b, a, label in (("static_water", "no_water", "### (2) static water − (1) no water"),
                        ("dynamic_water", "static_water", "### (3) dynamic water − (2) static water"),
                        ("dynamic_water", "no_water", "### (3) dynamic water − (1) no water")):
        head, rows = _table(report, label)
        assert head == ["quantity", "monitor", a, b, f"{b} − {a}", "change (%)"]
        ha, hb = _histories(res / f"results_{a}.h5"), _histories(res / f"results_{b}.h5")
        w = min(ha["crown"]["t"][-1], hb["crown"]["t"][-1])
        assert f"{label} (peaks over t ≤ {w:.3f} s)" in report
        for m in MONITORS:
            x = np.max(ha[m]["s"][:, 2][ha[m]["t"] <= w + 1e-9])
            y = np.max(hb[m]["s"][:, 2][hb[m]["t"] <= w + 1e-9])
            row = rows[f"max principal stress σ3 (MPa)|{m}"]
            assert row[2:] == [f"{x / 1e6:.4g}", f"{y / 1e6:.4g}", f"{(y - x) / 1e6:+.4g}",
                               f"{100 * (y - x) / abs(x):+.2f}"], (label, m, row)
        # no water pressure difference: only one condition has it
        assert not any(k.startswith("peak \\|dynamic water pressure") for k in rows)
    # the static water's hydrostatic load raises the lining's tension at every monitor (60 m head)
    _, rows = _table(report, "### (2) static water − (1) no water")
    for m in MONITORS:
        assert float(rows[f"max principal stress σ3 (MPa)|{m}"][4]) > 0.3


def test_figures_draw_the_cases_monitors_and_its_lining_strength(own_case, monkeypatch):
    """Re-run `post` with the axes' drawing calls recorded: the stress figure's strength line is
    the lining's 2.2 MPa, the bars and curves are the case's four monitors, no marks of another run."""
    from matplotlib.axes import Axes

    calls: dict[str, list] = {"axhline": [], "set_xticks": [], "plot": []}
    for name in calls:
        orig = getattr(Axes, name)

        def wrapper(self, *args, _orig=orig, _name=name, **kw):
            calls[_name].append((args, kw))
            return _orig(self, *args, **kw)

        monkeypatch.setattr(Axes, name, wrapper)
    monkeypatch.setenv("TQ_DRAW_PROCESSES", "1")  # every figure drawn in this process, where the calls are recorded
    assert main(["post", str(own_case / "case.yaml")]) == 0
    lines = [(a[0], kw.get("label")) for a, kw in calls["axhline"]]
    assert lines == [(pytest.approx(2.2), "lining tensile strength 2.2 MPa")] * 3  # one panel per condition
    ticks = [list(a[1]) for a, _ in calls["set_xticks"] if len(a) > 1]
    assert ticks == [["crown", "springline", "invert", "shoulder"]] * 2  # x and z panels
    labels = {kw.get("label") for _, kw in calls["plot"]}
    assert {"crown", "springline", "invert", "shoulder"} <= labels
    assert not any("peak" in str(x) for x in labels)
    figs = own_case / "results" / "figures"
    for name in ("fig03_input_motion", "fig05_hydrodynamic_pressure", "fig06_max_displacements",
                 "fig07_max_principal_stress", "fig08_damage_histories"):
        assert (figs / f"{name}.png").stat().st_size > 10_000, name


def test_a_condition_stopped_before_the_shaking_reads_no_sample(own_case, tmp_path):
    """static_water's rows cut to none (a run stopped at the start of the seismic stage): its peak
    table says "no sample", the differences leave it out, and nothing reads NaN."""
    case = tmp_path / "case"
    shutil.copytree(own_case, case, ignore=shutil.ignore_patterns("fluid", "paraview"))
    with h5py.File(case / "results" / "results_static_water.h5", "a") as f:
        f.attrs["status"] = "running"
        for g in f["monitors"].values():
            for ds in g.values():
                ds.resize(0, axis=0)
    assert main(["post", str(case / "case.yaml")]) == 0
    report = (case / "results" / "report.md").read_text()
    assert "### (2) static water\n\nNo sample: the run stopped before the shaking (static stages finished:" in report
    assert "### (3) dynamic water − (1) no water" in report
    assert "static water −" not in report and "− (2) static water" not in report
    assert not re.search(r"\bnan\b", report, re.I) and "not computed" not in report


# ---- the example keeps its comparison with the paper --------------------------------------------

def test_the_example_case_keeps_its_paper_comparison(tmp_path):
    """The example (reference: paper liu2021) with a synthetic condition-1 result: the paper's §3.3
    table beside the generic tables, with the paper's numbers and ours."""
    from test_post import _write_results

    case = tmp_path / "case.yaml"
    case.write_text(EXAMPLE.read_text().replace("../../../shared", str(EXAMPLE.parents[3] / "shared")))
    assert "reference:\n  paper: liu2021" in case.read_text()
    res = tmp_path / "results"
    res.mkdir()
    _write_results(res / "results_no_water.h5", t_end=20.0, dt=0.05, snaps=(20.0,))
    assert main(["motion", str(case)]) == 0
    assert main(["post", str(case)]) == 0
    report = (res / "report.md").read_text()
    # the motion's PGA from motion.h5: the example's 1.575 m/s²
    assert "- PGA (x, horizontal) at the outcrop (the incident wave is half of it): 1.575 m/s² = 0.1606 g" in report
    # the generic peak table: ux = 0.01 (k + 1) sin(pi t) at monitor k, peak at t = 0.5 s
    _, rows = _table(report, "### (1) no water: ")
    assert rows["top_arch"][1:3] == ["10", "0.500"] and rows["haunch"][1:3] == ["20", "0.500"]
    # the paper's table: 6.00 cm (paper) beside our 1 cm at the top arch, 6.19 cm beside 2 cm at the haunch
    assert "## The paper's §3.3 numbers against ours" in report
    # a displacement's verdict gives its timing: ours peak at 0.5 s, the paper's at 14.9 s
    assert ("| max_ux (cm) | no_water | top_arch | 6 | 1 | 0.17 | **not reproduced** (ours at t = 0.50 s, the paper's "
            "at 14.9 s) | [fig06](figures/fig06_max_displacements.png) |") in report
    assert "| max_ux (cm) | no_water | haunch | 6.19 | 2 | 0.32 | **not reproduced** (ours at t = 0.50 s" in report
    assert "| max_tension (MPa) | no_water | haunch | 1.09 | 0.2 | 0.18 | **not reproduced** |" in report
    # the findings first in the comparison, then the quantities they measure, then value by value
    assert report.index("## The paper's findings") < report.index("## The paper's numbers as the quantities") \
        < report.index("## The paper's §3.3 numbers against ours") < report.index("## Discussion of the differences")
    # the discussion cites the study beside the case file (its measured one-at-a-time effects), and
    # without the study it says there is none rather than listing suspects
    assert "no study of the paper's open choices beside the case file" in report
    shutil.copy(EXAMPLE.parent / "paper_study.json", tmp_path / "paper_study.json")
    assert main(["post", str(case)]) == 0
    report = (res / "report.md").read_text()
    assert "no study of the paper's open choices" not in report
    assert re.search(r"\n- with [^\n]+ instead of [^\n]+: top arch [-\d.]+ → [-\d.]+ cm", report)
    assert "![Fig. 6: maximum displacements](figures/fig06_max_displacements.png)" in report


def test_reference_needs_the_papers_monitors_and_only_then_refuses_them_in_the_rock(tmp_path, capsys):
    """With reference.paper the paper's monitors must exist (on the lining); without it, a monitor
    called top_arch is any point of the user's, and in the rock only a warning."""
    text = EXAMPLE.read_text().replace("../../../shared", str(EXAMPLE.parents[3] / "shared"))
    no_haunch = text.replace("    haunch:      [4.5, 40.0, 32.0]\n", "")
    (tmp_path / "a.yaml").write_text(no_haunch)
    assert main(["check", str(tmp_path / "a.yaml")]) == 1
    err = capsys.readouterr().err
    assert ("reference.paper = 'liu2021': compares the monitors top_arch, haunch, bottom_arch with the paper's, and "
            "output.monitors has no haunch. Fix: add haunch to output.monitors") in err
    in_rock = text.replace("    top_arch:    [0.0, 40.0, 36.5]", "    top_arch:    [0.0, 40.0, 39.0]")
    (tmp_path / "b.yaml").write_text(in_rock.replace("reference:\n  paper: liu2021", "reference: {}"))
    assert main(["check", str(tmp_path / "b.yaml")]) == 0
    err = capsys.readouterr().err
    assert "warning: output.monitors.top_arch [0.0, 40.0, 39.0]: lies 7 m from the tunnel axis" in err
    (tmp_path / "c.yaml").write_text(no_haunch.replace("reference:\n  paper: liu2021", "reference: {}"))
    assert main(["check", str(tmp_path / "c.yaml")]) == 0


def test_lining_forces_section_comes_with_the_design_quantities(own_case):
    """The report's lining forces: nothing without runs that carry them; with them (tq-solid writes
    them by default) the section under its heading, with the thrust extremes of the results file;
    a design-quantities object's own lines under the heading."""
    from tunnelquake import report as R
    from tunnelquake.case import load_case
    from tunnelquake.ring_forces import read_ring_forces

    assert R.design_quantities(load_case(own_case / "case.yaml"), []) is None
    assert R.lining_forces_section(None) == []
    report = (own_case / "results" / "report.md").read_text()
    assert "## Lining forces" in report
    ring = read_ring_forces(own_case / "results" / "results_no_water.h5")[0]
    row = re.search(r"\*\*no_water\*\* \(ring.*?\| N \(kN/m\) \| (\S+) \|", report, re.S)
    assert row and float(row.group(1)) == pytest.approx(float(np.max(ring.N)) / 1e3, rel=1e-3)

    class Design:
        def report_lines(self):
            return ["| section | N (kN/m) |", "|---|---|", "| 0° | -812 |"]

    assert R.lining_forces_section(Design()) == ["## Lining forces", "", "| section | N (kN/m) |", "|---|---|",
                                                 "| 0° | -812 |", ""]
