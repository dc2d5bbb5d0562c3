"""The `tunnelquake` subcommands, called as tests call them: main(argv) -> exit code."""
from __future__ import annotations

import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import EXAMPLE, ROOT
from tunnelquake.cli import main


def _local_case(tmp_path, text: str):
    """The example case in a temporary folder, its record path made absolute (if present)."""
    rec = (EXAMPLE.parent / "../../../shared/data/ground_motions/elCentro_1940_NS_Peknold_dt0.02.AT2").resolve()
    text = text.replace("../../../shared/data/ground_motions/elCentro_1940_NS_Peknold_dt0.02.AT2", str(rec))
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
