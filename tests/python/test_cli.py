"""The `tunnelquake` subcommands, called as tests call them: main(argv) -> exit code."""
from __future__ import annotations

import subprocess
import sys

import h5py
import numpy as np
import pytest
from case_edits import with_time

from conftest import EXAMPLE, ROOT
from tunnelquake.cli import main


def _local_case(tmp_path, text: str):
    """The example case in a temporary folder, its record path made absolute (if present)."""
    rec = (EXAMPLE.parent / "../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2").resolve()
    text = text.replace("../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2", str(rec))
    p = tmp_path / "case.yaml"
    p.write_text(text)
    return p


def test_check_accepts_the_example(capsys):
    assert main(["check", str(EXAMPLE)]) == 0
    assert "is valid" in capsys.readouterr().out


def test_check_rejects_a_bad_case_naming_the_key(tmp_path, capsys):
    p = _local_case(tmp_path, EXAMPLE.read_text().replace("poisson_ratio: 0.27", "poisson_ratio: 0.55"))
    assert main(["check", str(p)]) == 1
    err = capsys.readouterr().err
    assert "materials.rock.poisson_ratio = 0.55" in err and "Fix:" in err


def test_unknown_command_and_help():
    assert main(["frobnicate"]) == 2
    assert main(["--help"]) == 0


def test_console_script_is_installed():
    exe = ROOT / ".venv" / "bin" / "tunnelquake"
    out = subprocess.run([str(exe), "--version"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.startswith("tunnelquake ")


def test_motion_writes_incident_wave_and_figure(tmp_path):
    p = _local_case(tmp_path, EXAMPLE.read_text())
    assert main(["motion", str(p)]) == 0
    out = tmp_path / "results"
    with h5py.File(out / "motion.h5", "r") as f:
        ax, az, dt = f["incident_ax"][:], f["incident_az"][:], f.attrs["dt"]
    # outcrop convention: incident = record / 2, record scaled to PGA 1.575 m/s^2; z = 2/3 x; 20 s kept
    assert np.max(np.abs(ax)) == pytest.approx(1.575 / 2, rel=1e-9)
    np.testing.assert_allclose(az, ax * 0.6666667, rtol=1e-9)
    assert (ax.size - 1) * dt == pytest.approx(20.0, abs=dt)
    assert (out / "figures" / "fig03_input_motion.png").stat().st_size > 10_000
    assert not list(out.rglob("*.part")), "no half-written files may remain"


def test_post_needs_no_solver(tmp_path):
    p = _local_case(tmp_path, EXAMPLE.read_text())
    assert main(["motion", str(p)]) == 0
    assert main(["post", str(p)]) == 0
    report = (tmp_path / "results" / "report.md").read_text()
    assert "Input motion" in report and "points at dt = " in report


def test_module_entry_point():
    out = subprocess.run([sys.executable, "-m", "tunnelquake", "--version"], capture_output=True, text=True)
    assert out.returncode == 0


def test_run_end_to_end_on_the_example(tmp_path, capsys):
    """The main job on the built-in example, with its own stepping (static_water and dynamic_water
    subcycled): mesh, motion, a plan per condition that runs only the solvers each condition needs,
    and a report; the solid's energy balance closes to 1e-3 from the first step, subcycled or not
    (docs/solid_solver.md "Subcycling")."""
    from tunnelquake.case import load_case
    from tunnelquake.scene import plan

    # the first 0.02 s of shaking keeps the test short; the stages run in full
    p = _local_case(tmp_path, with_time(EXAMPLE.read_text(), end_time="0.02 s"))
    assert main(["run", str(p)]) == 0
    out = capsys.readouterr().out
    res = tmp_path / "results"
    with h5py.File(res / "mesh" / "mesh.h5", "r") as f:
        conn = f["elements/connectivity"][:]
        coords = f["nodes/coordinates"][:]
        inner = np.unique(f["faces/lining_inner"][:])
    # slice mode: one element through y, so every node lies on one of two planes
    assert np.unique(np.round(coords[:, 1], 9)).size == 2
    assert conn.shape[1] == 8
    # the lining's wetted nodes lie on the inner radius 5.25 - 0.75 = 4.5 m about (x, z) = (0, 32)
    r = np.hypot(coords[inner, 0], coords[inner, 2] - 32.0)
    np.testing.assert_allclose(r, 4.5, rtol=1e-12)
    with h5py.File(res / "motion.h5", "r") as f:
        assert np.max(np.abs(f["incident_ax"][:])) == pytest.approx(1.575 / 2, rel=1e-9)
    # skip what a scene does not need: no fluid process in conditions 1 and 2
    steps = dict(plan(load_case(p)))
    assert steps == {"no_water": ("solid",), "static_water": ("solid",), "dynamic_water": ("solid", "fluid")}
    assert "condition no_water" in out and "done:" in out
    # conditions 1 and 2 ran the solid to the end with a closed energy balance
    for cond in ("no_water", "static_water"):
        with h5py.File(res / f"results_{cond}.h5", "r") as f:
            assert f.attrs["status"] == "completed"
            hist = f["energy/history"][:]
            cols = [c.decode() if isinstance(c, bytes) else c for c in f["energy"].attrs["columns"]]
            assert hist[-1, 0] == pytest.approx(0.02, abs=1e-4)
            assert np.max(hist[:, cols.index("error")]) < 1e-3
    report = (res / "report.md").read_text()
    assert "| max_ux (cm) | no_water | top_arch |" in report

    # condition 3: tq-solid + OpenFOAM through the coupler, window by window
    from tunnelquake.launch import solver_status

    if solver_status()["fluid"] is not None:
        return  # no OpenFOAM side here: conditions 1 and 2 are what can be checked
    assert "dynamic_water (solid + fluid): completed" in out, out[-3000:]
    from tunnelquake.launch import concurrent_conditions

    if concurrent_conditions() > 1:  # the coupled condition ran beside the solid-only ones
        assert "running dynamic_water beside no_water, static_water" in out
        assert "[no_water] tq-solid: completed" in out
    assert (res / "dynamic_water" / "fluid.log").read_text().rstrip().endswith("End")
    # tq-solid's plan of the re-passes is check's rule on the same mesh (subcycle_levels.window_reach:
    # the chunks out of the water's reach within a window)
    from tunnelquake.scene import subcycling_levels
    from tunnelquake.subcycle_levels import mesh_level_arrays, mesh_window_reach

    d = load_case(p).data
    levels = mesh_level_arrays(res / "mesh" / "mesh.h5", d["materials"], subcycling_levels(d, "dynamic_water"),
                               float(d["time"]["safety_factor"]), float(d["time"].get("dt") or 0.0),
                               d["interface"]["model"], wet=True)
    reach = mesh_window_reach(res / "mesh" / "mesh.h5", levels, int(d["coupling"]["window"]))
    skipped = len(conn) - int(sum(reach["needed_by_chunk"]))
    assert 0 < skipped < len(conn)
    assert (f"({skipped} of {len(conn)} elements) out of the water's reach"
            in (res / "dynamic_water" / "solid.log").read_text())
    with h5py.File(res / "results_dynamic_water.h5", "r") as f, \
            h5py.File(res / "results_static_water.h5", "r") as g:
        assert f.attrs["status"] == "completed"
        c = dict(f["coupling"].attrs)
        # every window coupled: ceil(t_end / window), both sides pinned to the same count
        assert c["windows"] == np.ceil(0.02 / c["window_size"] - 1e-9) and c["passes"] >= c["windows"]
        hist = f["energy/history"][:]
        cols = [x.decode() if isinstance(x, bytes) else x for x in f["energy"].attrs["columns"]]
        # whole windows (the example's are 16 solid steps): the run ends at the first window end >= 0.02 s,
        # and the histories are written on the even clock: the last row at 0.02 s, a multiple of the
        # case's 0.005 s history interval
        assert 0.02 - 1e-9 <= c["windows"] * c["window_size"] < 0.02 + c["window_size"]
        assert hist[-1, 0] == pytest.approx(0.02, rel=1e-12)
        # the balance closes with the water's work booked in the external term
        assert np.max(hist[:, cols.index("error")]) < 1e-3
        fw = f["energy/fluid_work"][:, 1]
        ext = hist[:, cols.index("external")]
        # The incident wave enters at the base (z = -28 m) and needs 54.75 m / c_p(rock) = 54.75 / 1924
        # = 0.028 s to reach the lining, after these 0.02 s: the water must hold the lining's
        # hydrostatic equilibrium. So its work is nil (measured 3e-11 J against 1.85e3 J external),
        # the lining does not move more than the solid's own relaxation residual (docs/verification.md, hydrostatic equilibrium:
        # spurious lining velocity < 1e-6 m/s) and the monitors follow static_water's to 1e-9 m
        # (their motion is ~1e-10 m; measured difference 2e-11 m).
        assert np.all(np.isfinite(fw)) and np.max(np.abs(fw)) <= 1e-9 * np.max(np.abs(ext))
        for m in ("top_arch", "haunch", "bottom_arch"):
            ud, us = f[f"monitors/{m}/u"][:], g[f"monitors/{m}/u"][:]
            assert ud.shape == us.shape
            assert np.max(np.abs(ud - us)) < 1e-9, m
            assert np.max(np.abs(f[f"monitors/{m}/v"][:])) < 1e-6, m
