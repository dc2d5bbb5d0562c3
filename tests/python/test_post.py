"""Post-processing: needs no solver, survives a results file cut off mid-run, draws the
paper's Figs. 5, 8, 9 and 10 from what results.h5 holds, writes ParaView XDMF, and compares with the
paper's §3.3 numbers in report.md. The results files here are small synthetic ones written in
tq-solid's layout (docs/solid_solver.md "Input and output") with known signals."""
from __future__ import annotations

import csv
import shutil

import h5py
import numpy as np
import pytest

from conftest import EXAMPLE
from tunnelquake import paper
from tunnelquake import post as P
from tunnelquake.cli import main


def _write_partial_results(path, n_rows=(400, 390, 395), amp_x=0.05, amp_s=1.1e6):
    """A results file as tq-solid writes it, stopped mid-run: monitors have different row counts
    (the last flush reached some datasets and not others) and status 'running'."""
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-results"
        f.attrs["status"] = "running"
        for name, n in zip(paper.MONITORS, n_rows, strict=True):
            t = np.arange(n) * 0.005
            g = f.create_group(f"monitors/{name}")
            g["time"] = t[:, None]
            u = np.zeros((n, 3))
            u[:, 0] = amp_x * np.sin(2 * np.pi * t)
            u[:, 2] = -0.5 * amp_x * np.sin(2 * np.pi * t)
            g["u"] = u
            s = np.zeros((n, 3))
            s[:, 2] = amp_s * np.sin(2 * np.pi * t) ** 2
            g["principal"] = s


def _case(tmp_path):
    case = tmp_path / "case.yaml"
    case.write_text(EXAMPLE.read_text().replace("../../../shared", str(EXAMPLE.parents[3] / "shared")))
    res_dir = tmp_path / "results"
    res_dir.mkdir(exist_ok=True)
    return case, res_dir


def test_cut_off_results_post_process_up_to_the_last_row(tmp_path):
    case, res_dir = _case(tmp_path)
    _write_partial_results(res_dir / "results_no_water.h5")
    assert main(["post", str(case)]) == 0
    report = (res_dir / "report.md").read_text()
    assert "status **running**" in report and "The run did not complete" in report
    with open(res_dir / "monitors_no_water.csv") as fh:
        rows = list(csv.reader(fh))
    assert len(rows) - 1 == 390  # the shortest monitor bounds the table
    # peaks of the known signals: |ux| = 0.05 m at t = 0.25 s, sigma3 = 1.1 MPa
    pk = P.peaks(P.read_condition(res_dir / "results_no_water.h5", "no_water"))
    assert pk["haunch"]["max_ux"] == pytest.approx(0.05, rel=1e-9)
    assert pk["haunch"]["max_uz"] == pytest.approx(0.025, rel=1e-9)
    assert pk["top_arch"]["max_tension"] == pytest.approx(1.1e6, rel=1e-9)
    assert (res_dir / "figures" / "fig06_max_displacements.png").stat().st_size > 10_000
    # the table puts the paper's 6.00 cm beside our 5 cm for the top arch in x; the run stopped at
    # 1.945 s (389 x 0.005 s, the last row all monitors have), before the paper's peak at 14.9 s:
    # 0.83 is inside the ±20 % band so far, but a later peak could leave it, so the verdict waits
    assert ("| max_ux (cm) | no_water | top_arch | 6 | 5 | 0.83 | not computed (run ends at "
            f"{389 * 0.005:.2f} s, before the paper's 14.9 s) |") in report


# ---- a small synthetic tunnel: lining ring, rock ring, interface pairs, snapshots ---------------

R_IN, R_OUT, R_ROCK, N_AROUND, N_RAD, WIDTH = 4.5, 5.25, 7.0, 16, 2, 0.5
MON_POINTS = {"top_arch": (0.0, 4.5), "haunch": (4.5, 0.0), "bottom_arch": (0.0, -4.5)}


def _ring_mesh():
    """Lining (N_RAD layers from R_IN to R_OUT) and rock (one layer to R_ROCK), one element along y;
    the rock's inner nodes duplicate the lining's outer ones (the interface pairs)."""
    th = np.linspace(0, 2 * np.pi, N_AROUND, endpoint=False)  # angle from the crown towards +x
    radii = [*np.linspace(R_IN, R_OUT, N_RAD + 1), R_OUT, R_ROCK]  # R_OUT twice: lining and rock side
    coords, index = [], {}
    for k, r in enumerate(radii):
        for i, t in enumerate(th):
            for j, y in enumerate((0.0, WIDTH)):
                index[k, i, j] = len(coords)
                coords.append((r * np.sin(t), y, r * np.cos(t)))
    conn, region = [], []
    for k in range(len(radii) - 1):
        if k == N_RAD:  # between the duplicated layers: no element
            continue
        for i in range(N_AROUND):
            i2 = (i + 1) % N_AROUND
            conn.append([index[k, i, 0], index[k + 1, i, 0], index[k + 1, i2, 0], index[k, i2, 0],
                         index[k, i, 1], index[k + 1, i, 1], index[k + 1, i2, 1], index[k, i2, 1]])
            region.append(1 if k < N_RAD else 0)
    pairs = [(index[N_RAD + 1, i, j], index[N_RAD, i, j]) for i in range(N_AROUND) for j in (0, 1)]
    return np.array(coords), np.array(conn), np.array(region), np.array(pairs), th


def _write_results(path, *, status="completed", t_end=2.0, dt=0.01, hydro=None, snaps=(1.0, 2.0),
                   damage_of=None, state_of=None, input_t_end=None):
    """A complete results file: monitors with known signals, snapshots with damage [E] = damage_of(
    element centroid angle, radius, time) and interface state per pair = state_of(angle)."""
    coords, conn, region, pairs, th = _ring_mesh()
    t = np.arange(0.0, t_end + 1e-9, dt)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-results"
        f.attrs["status"] = status
        f.attrs["rayleigh_alpha"], f.attrs["rayleigh_beta"] = 4 * np.pi * 1.5 * 0.05, 0.0
        if input_t_end is not None:
            inp = path.parent / f"{path.stem}_input.h5"
            with h5py.File(inp, "w") as g:
                g.create_group("solver").attrs["t_end"] = input_t_end
                g.create_group("materials/lining").attrs["damage_constant"] = 100.0
            f.attrs["input"] = str(inp)
        f["mesh/coordinates"], f["mesh/connectivity"], f["mesh/region"] = coords, conn, region
        f["mesh"].attrs["regions"] = ["rock", "lining"]
        for k, (m, (x, z)) in enumerate(MON_POINTS.items()):
            g = f.create_group(f"monitors/{m}")
            g.attrs.update({"x": x, "y": 0.5 * WIDTH, "z": z})
            g["time"] = t[:, None]
            u = np.zeros((t.size, 3))
            u[:, 0], u[:, 2] = 0.01 * (k + 1) * np.sin(np.pi * t), 0.005 * np.sin(np.pi * t)
            g["u"] = u
            pr = np.zeros((t.size, 3))
            pr[:, 2] = 1e5 * (k + 1) * np.sin(np.pi * t) ** 2
            g["principal"] = pr
            g["damage"] = (0.1 * (k + 1) * np.clip(t - 1.0, 0, None))[:, None]
            if hydro is not None:
                g["water_pressure"] = np.column_stack([t, hydro[m] * np.sin(np.pi * t / t_end)])
        ig = f.create_group("interface")
        ig["pairs"] = pairs
        ig.attrs["states"] = list(P.CONTACT_STATES)
        ang = np.arctan2(coords[pairs[:, 1], 0], coords[pairs[:, 1], 2])
        for k, ts in enumerate(snaps):
            g = f.create_group(f"snapshots/{k}")
            g["u"] = np.full((coords.shape[0], 3), ts * 1e-3)
            g["v"] = np.zeros((coords.shape[0], 3))
            stress = np.zeros((conn.shape[0], 6))
            stress[:, 0], stress[:, 2], stress[:, 5] = 1e5 * ts, -2e5, 5e4  # xx, zz, zx
            g["stress"] = stress
            cen = coords[conn].mean(axis=1)
            if damage_of is not None:
                g["damage"] = np.where(region == 1, damage_of(np.arctan2(cen[:, 0], cen[:, 2]),
                                                              np.hypot(cen[:, 0], cen[:, 2]), ts), 0.0)
            if state_of is not None:
                st = state_of(ang)
                g["interface/state"] = st
                g["interface/failed"] = (st != 0).astype(np.int64)
                g["interface/opening"] = np.zeros(st.size)
                g["interface/slip"] = np.zeros(st.size)
            g.attrs["time"] = ts
    return path


HYDRO = {"top_arch": 0.2e6, "haunch": 0.466e6, "bottom_arch": 0.3e6}


def _haunch_damage(a, r, ts):
    """Largest at the haunches (|sin| of the angle), larger at the water side, growing with time."""
    return 0.5 * ts / 2.0 * np.abs(np.sin(a)) * (R_OUT - r + 0.1) / (R_OUT - R_IN)


def _haunch_slip(a):
    """Pairs within 30° of the haunches slip (2) or separate (1); the others stay bonded (0)."""
    d = np.degrees(np.abs(np.abs(a) - np.pi / 2))
    return np.where(d < 15, 2, np.where(d < 30, 1, 0)).astype(np.int64)


def test_hydrodynamic_pressure_fig5_and_the_report_rows(tmp_path):
    path = _write_results(tmp_path / "results_dynamic_water.h5", t_end=10.0, dt=0.05, hydro=HYDRO,
                          snaps=(10.0,))
    res = P.read_condition(path, "dynamic_water")
    pk = P.peaks(res)
    # p = P sin(pi t / 10): the peak is P at t = 5 s; its |value| is what Fig. 5 and the table report
    for m, amp in HYDRO.items():
        assert pk[m]["hydrodynamic_pressure_peak"] == pytest.approx(amp, rel=1e-12)
        assert pk[m]["hydrodynamic_pressure_peak_time"] == pytest.approx(5.0, abs=1e-9)
    assert P.fig_hydrodynamic_pressure(res, tmp_path / "fig05.png").stat().st_size > 10_000
    from tunnelquake.paper import comparison_sections

    text = "\n".join(comparison_sections([res], {"fig05": "figures/fig05.png"}, {}))
    # 0.466 MPa at the haunch equals the paper's; 0.2 MPa at the top arch is 0.78 of 0.256: outside ±20 %
    assert ("| hydrodynamic pressure peak (MPa) | dynamic_water | haunch | 0.466 | 0.466 | 1.00 | reproduced | "
            "[fig05](figures/fig05.png) |") in text
    assert "| hydrodynamic pressure peak (MPa) | dynamic_water | top_arch | 0.256 | 0.2 | 0.78 | **not reproduced**" \
        in text
    assert "| time of the pressure peak (s, ±0.5) | dynamic_water | haunch | 5.2 | 5.00 | — | reproduced |" in text
    # the discussion states the measured ratio (0.2/0.256 = 0.78; 0.3/0.326 = 0.92 is inside the band)
    assert "Ours / paper = 0.78–0.78 at top_arch" in text


def test_damage_section_and_fig9_show_the_files_values(tmp_path):
    path = _write_results(tmp_path / "results_dynamic_water.h5", damage_of=_haunch_damage, state_of=_haunch_slip)
    res = P.read_condition(path, "dynamic_water")
    assert [t for _, t in res.snapshots] == [1.0, 2.0]
    snap = P.read_snapshot(res, res.snapshots[-1][0])
    polys, d, elems = P.damage_section(res, snap)
    # every lining element of the (one-layer) section, with the file's damage, element by element
    lining = np.nonzero(res.mesh["region"] == 1)[0]
    assert sorted(elems) == sorted(lining)
    np.testing.assert_array_equal(d, snap["damage"][elems])
    # the outlines tile the faceted ring: sum of areas = N/2 sin(2 pi/N) (R_OUT^2 - R_IN^2)
    area = sum(0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
               for q in polys)
    # (to 1e-8: the outline points are rounded to 1e-9 m to merge the two planes)
    assert area == pytest.approx(N_AROUND / 2 * np.sin(2 * np.pi / N_AROUND) * (R_OUT**2 - R_IN**2), rel=1e-8)
    assert P.fig_damage_section([res], tmp_path / "fig09.png").stat().st_size > 10_000
    # Fig. 10: the pairs of the middle section at their angle, with the file's states
    sec = P.interface_section(res, snap)
    np.testing.assert_array_equal(sec["state"], _haunch_slip(np.radians(sec["angle"])))
    i = int(np.argmin(np.abs(sec["x"] - R_OUT)))  # the pair at +x: the haunch
    assert sec["angle"][i] == pytest.approx(90.0, abs=1e-9)
    assert P.fig_interface_zones([res], tmp_path / "fig10.png").stat().st_size > 10_000
    from tunnelquake.paper import comparison_sections

    text = "\n".join(comparison_sections([res], {}, {}))
    # 16 pairs per plane; those within 30° of the two haunches: 90 ± 22.5 and ± 0 -> 3 per side
    opened = int(np.sum(_haunch_slip(np.radians(sec["angle"])) != 0))
    assert f"{opened} of {sec['angle'].size} pairs separated, slipping or with a failed bond" in text
    assert "mean D inner half" in text and "| damage across the lining, dynamic_water |" in text
    # the damage is larger at the water side by construction -> reproduced
    row = next(line for line in text.splitlines() if line.startswith("| damage across the lining"))
    assert "| reproduced |" in row


def test_the_crack_pattern_is_drawn_at_the_snapshot_nearest_the_governing_time(tmp_path, monkeypatch):
    """The design's crack-pattern figure shows the damage of the field snapshot nearest each
    condition's governing time (here 1.8 s among snapshots at 1, 2 and 3 s: the one at 2 s, not the
    last), element by element, and says both times on the figure."""
    from types import SimpleNamespace

    from tunnelquake.design import figures as F

    path = _write_results(tmp_path / "results_dynamic_water.h5", t_end=3.0, snaps=(1.0, 2.0, 3.0),
                          damage_of=_haunch_damage)
    res = P.read_condition(path, "dynamic_water")
    assert F.nearest_snapshot(res, 1.8) == ("1", 2.0)
    assert F.nearest_snapshot(res, 1.5) == ("0", 1.0)  # of two at the same distance, the earlier
    ts, polys, d = F.crack_pattern(res, 1.8)
    _, _, elems = P.damage_section(res, P.read_snapshot(res, "1"))
    assert ts == 2.0
    cen = res.mesh["coordinates"][res.mesh["connectivity"][elems]].mean(axis=1)
    expected = _haunch_damage(np.arctan2(cen[:, 0], cen[:, 2]), np.hypot(cen[:, 0], cen[:, 2]), 2.0)
    np.testing.assert_allclose(d, expected, rtol=1e-12)
    assert not np.allclose(d, P.read_snapshot(res, "2")["damage"][elems])  # the last snapshot differs
    drawn = []
    monkeypatch.setattr(F, "_save", lambda fig, out: drawn.append(fig) or out.write_bytes(b"png"))
    cond = SimpleNamespace(condition="dynamic_water", governing_time=lambda: 1.8)
    assert F.fig_cracks([cond], [res], tmp_path / "cracks.png") == tmp_path / "cracks.png"
    ax = drawn[0].axes[0]
    assert "governing t = 1.800 s" in ax.get_title() and "nearest snapshot t = 2.000 s" in ax.get_title()
    np.testing.assert_allclose(ax.collections[0].get_array(), expected, rtol=1e-12)
    assert ax.collections[0].get_clim() == pytest.approx((0.0, expected.max()))  # the scale fitted to the data
    no_time = SimpleNamespace(condition="dynamic_water", governing_time=lambda: None)
    assert F.fig_cracks([no_time], [res], tmp_path / "none.png") is None


def test_xdmf_reads_back_with_meshio(tmp_path):
    meshio = pytest.importorskip("meshio")
    path = _write_results(tmp_path / "results_no_water.h5", damage_of=_haunch_damage, state_of=_haunch_slip)
    res = P.read_condition(path, "no_water")
    x = P.write_xdmf(res, tmp_path / "paraview" / "no_water.xdmf")
    with meshio.xdmf.TimeSeriesReader(str(x)) as r:
        points, cells = r.read_points_cells()
        np.testing.assert_array_equal(points, res.mesh["coordinates"])
        np.testing.assert_array_equal(cells[0].data, res.mesh["connectivity"])
        assert cells[0].type == "hexahedron"
        assert r.num_steps == len(res.snapshots)
        for k, (key, ts) in enumerate(res.snapshots):
            t, pd, cd = r.read_data(k)
            snap = P.read_snapshot(res, key)
            assert t == pytest.approx(ts, rel=1e-9)
            np.testing.assert_array_equal(pd["displacement"], snap["u"])
            np.testing.assert_array_equal(cd["damage"][0], snap["damage"])
            # principal stresses of the plane state xx = 1e5 t, zz = -2e5, zx = 5e4 (Pa), yy = 0
            c, h = 0.5 * (1e5 * ts - 2e5), np.hypot(0.5 * (1e5 * ts + 2e5), 5e4)
            np.testing.assert_allclose(cd["principal_stress"][0][0], sorted([c - h, 0.0, c + h]), atol=1e-6)
            np.testing.assert_allclose(cd["max_principal_stress"][0], c + h, rtol=1e-12)
    assert not list((tmp_path / "paraview").glob("*.part"))


def _truncate(path, rows: int, status: str, extra_fill_row: bool = True, broken_snapshot: bool = True):
    """What a kill leaves: every appended dataset cut to `rows` (one monitor one row shorter, the
    last flush not having reached it), optionally one more row of fill (an extension whose data
    never reached the disk: time 0), a snapshot group without its `time` attribute."""
    with h5py.File(path, "r+") as f:
        f.attrs["status"] = status
        for name, g in f["monitors"].items():
            for k in list(g):
                data = g[k][: rows - (name == "bottom_arch")]
                if extra_fill_row:
                    data = np.concatenate([data, np.zeros((1, *data.shape[1:]))])
                del g[k]
                g.create_dataset(k, data=data, maxshape=(None, *data.shape[1:]))
        if broken_snapshot:
            g = f.create_group(f"snapshots/{len(f['snapshots'])}")
            g["u"] = np.zeros((f["mesh/coordinates"].shape[0], 3))


def test_a_killed_run_post_processes_up_to_the_last_written_step(tmp_path, monkeypatch):
    case, res_dir = _case(tmp_path)
    full = _write_results(res_dir / "results_dynamic_water.h5", t_end=2.0, dt=0.01, hydro=HYDRO,
                          snaps=(1.0,), damage_of=_haunch_damage, state_of=_haunch_slip, input_t_end=20.0)
    shutil.copy(full, tmp_path / "complete.h5")
    _truncate(full, rows=151, status="stopped: killed")  # t = 0 ... 1.50 s written
    res = P.read_condition(full, "dynamic_water")
    # the fill row (time 0 after 1.5 s) is dropped; the monitors share the rows all of them have
    assert res.t_end == pytest.approx(1.49, abs=1e-12)  # bottom_arch's last written row
    for mo in res.monitors.values():
        assert mo.time.size == 150 and np.all(np.diff(mo.time) > 0)
        assert mo.extra["water_pressure_time"][-1] <= 1.5 + 1e-12
    assert res.planned_end == 20.0 and res.status == "stopped: killed"
    assert [t for _, t in res.snapshots] == [1.0] and res.incomplete_snapshots == ["1"]
    # peaks are those of the written part: ux = 0.02 sin(pi t) reaches 0.02 at t = 0.5 s
    with h5py.File(tmp_path / "complete.h5") as f:
        u = f["monitors/haunch/u"][:150, 0]
    assert P.peaks(res)["haunch"]["max_ux"] == pytest.approx(np.max(np.abs(u)), rel=1e-12)
    # post needs no solver: no build folder at all
    monkeypatch.setenv("TQ_BUILD_DIR", str(tmp_path / "no_build"))
    assert main(["post", str(case)]) == 0
    first = (res_dir / "report.md").read_text()
    assert "status **stopped: killed**" in first
    assert "post-processed up to the last written step, t = 1.49 s" in first
    assert "of the planned 20 s" in first and "snapshot(s) 1 were cut off mid-write" in first
    for fig in ("fig05_hydrodynamic_pressure", "fig08_damage_histories", "fig09_damage_section",
                "fig10_interface_zones"):
        assert (res_dir / "figures" / f"{fig}.png").stat().st_size > 10_000
    assert (res_dir / "paraview" / "dynamic_water.xdmf").is_file()
    with open(res_dir / "monitors_dynamic_water.csv") as fh:
        rows = list(csv.reader(fh))
    assert len(rows) - 1 == 150 and float(rows[-1][0]) == pytest.approx(1.49)
    # re-running on the same files gives the same report
    assert main(["post", str(case)]) == 0
    assert (res_dir / "report.md").read_text() == first


def test_default_snapshots_cover_the_start_every_second_and_the_end():
    """Figs. 9 and 10 need the state at the end, the XDMF an animation, the hydraulic-jacking check
    the static state at the seismic start: with output.snapshot_times empty, tq-solid is asked for
    one snapshot at the start, one a second of shaking and one at t_end."""
    from tunnelquake.solid_input import snapshot_times

    np.testing.assert_array_equal(snapshot_times([], 20.0), np.arange(0.0, 20.5, 1.0))
    np.testing.assert_array_equal(snapshot_times([], 2.5), [0.0, 1.0, 2.0, 2.5])
    np.testing.assert_array_equal(snapshot_times([], 0.02), [0.0, 0.02])
    np.testing.assert_array_equal(snapshot_times([0.5, 4.0], 20.0), [0.5, 4.0])


def test_water_side_record_keeps_the_accepted_steps(tmp_path):
    """interface.dat of the OpenFOAM function object: one row per attempt (accepted 0 = rolled back);
    only accepted rows count, a line cut off by a crash is skipped, restarts are merged by time."""
    head = ("# tqInterface: water loads on patch interface\n"
            "# t accepted Fx Fy Fz Fpx Fpy Fpz Fvx Fvy Fvz Fhsx Fhsy Fhsz sumPointFx sumPointFy sumPointFz pMean "
            "nRollbacks\n# units: s - N N N N N N N N N N N N N N N Pa -\n")
    row = "{t} {a} " + "0 " * 15 + "{p} 0\n"
    d0 = tmp_path / "postProcessing" / "interface" / "0"
    d0.mkdir(parents=True)
    (d0 / "interface.dat").write_text(head + row.format(t=0.1, a=0, p=-7e4) + row.format(t=0.1, a=1, p=-1.3e4)
                                      + row.format(t=0.2, a=1, p=2e3) + "0.3 1 0 0")
    d1 = tmp_path / "postProcessing" / "interface" / "0.2"
    d1.mkdir()
    (d1 / "interface.dat").write_text(head + row.format(t=0.3, a=0, p=5e4) + row.format(t=0.3, a=1, p=4e3))
    w = P.read_fluid_interface(tmp_path)
    np.testing.assert_array_equal(w["time"], [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(w["p_mean"], [-1.3e4, 2e3, 4e3])
    assert P.read_fluid_interface(tmp_path / "nothing") is None


def test_the_discussion_cites_the_studys_measured_deltas(tmp_path):
    """With a study beside the case file (paper.STUDY_FILE), a number outside the band is followed by
    each choice's measured effect on it ("with X instead of Y: a → b"), and its verdict says what the
    study's runs give for it: reached by a run, not reached in N runs with their span, or bracketed
    by two levels of one choice (test_paper_verdicts.py: every verdict word)."""
    import json

    from tunnelquake import paper

    path = _write_results(tmp_path / "results_dynamic_water.h5", t_end=10.0, dt=0.05, hydro=HYDRO, snaps=(10.0,))
    res = P.read_condition(path, "dynamic_water")
    ex = {f"pressure/{m}": p for m, p in HYDRO.items()}
    study = {"example_levels": {"water": "compressible, K = 2.2 GPa"},
             "choices": {paper.EXAMPLE_RUN: ex,
                         # the top arch reaches the band (0.25 of 0.256) at no cost: the others stay within
                         "water: incompressible": {"pressure/top_arch": 0.25e6, "pressure/haunch": 0.5e6,
                                                   "pressure/bottom_arch": 0.31e6}}}
    (tmp_path / paper.STUDY_FILE).write_text(json.dumps(study))
    text = "\n".join(paper.comparison_sections([res], {}, {"case_dir": str(tmp_path)}))
    assert ("with water incompressible instead of compressible, K = 2.2 GPa: hydrodynamic pressure peak top arch "
            "0.2 → 0.25 MPa") in text
    row = next(line for line in text.splitlines() if line.startswith("| hydrodynamic pressure peak (MPa) | "
                                                                        "dynamic_water | top_arch"))
    assert "reached by water: incompressible (0.25 MPa)" in row
    study["choices"]["water: incompressible"]["pressure/top_arch"] = 0.18e6
    (tmp_path / paper.STUDY_FILE).write_text(json.dumps(study))
    text = "\n".join(paper.comparison_sections([res], {}, {"case_dir": str(tmp_path)}))
    assert ("not reached in 2 runs (span 0.18 … 0.2 MPa, water: incompressible … example: as cases/paper_tunnel; "
            "all below the paper's)") in text
    # the example and a water level on both sides of the paper's 0.256: bracketed by that choice
    study["choices"]["water: incompressible"]["pressure/top_arch"] = 0.35e6
    (tmp_path / paper.STUDY_FILE).write_text(json.dumps(study))
    text = "\n".join(paper.comparison_sections([res], {}, {"case_dir": str(tmp_path)}))
    assert ("bracketed by water compressible, K = 2.2 GPa–incompressible (0.2 … 0.35 MPa): a level between passes "
            "through it") in text
    row = next(line for line in text.splitlines() if line.startswith("| hydrodynamic pressure peak (MPa) | "
                                                                        "dynamic_water | top_arch"))
    assert "out of reach:" not in row
