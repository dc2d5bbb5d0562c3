"""Post-processing needs no solver and survives a results file cut off mid-run (issue 7, item 5)."""
from __future__ import annotations

import csv

import h5py
import numpy as np
import pytest

from conftest import EXAMPLE
from tunnelquake import post as P
from tunnelquake.cli import main


def _write_partial_results(path, n_rows=(400, 390, 395), amp_x=0.05, amp_s=1.1e6):
    """A results file as tq-solid writes it, stopped mid-run: monitors have different row counts
    (the last flush reached some datasets and not others) and status 'running'."""
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-results"
        f.attrs["status"] = "running"
        for name, n in zip(P.MONITORS, n_rows, strict=True):
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


def test_cut_off_results_post_process_up_to_the_last_row(tmp_path):
    case = tmp_path / "case.yaml"
    case.write_text(EXAMPLE.read_text().replace("../../../shared", str(EXAMPLE.parents[3] / "shared")))
    res_dir = tmp_path / "results"
    res_dir.mkdir()
    _write_partial_results(res_dir / "results_no_water.h5")
    assert main(["post", str(case)]) == 0
    report = (res_dir / "report.md").read_text()
    assert "status **running**" in report
    with open(res_dir / "monitors_no_water.csv") as fh:
        rows = list(csv.reader(fh))
    assert len(rows) - 1 == 390  # the shortest monitor bounds the table
    # peaks of the known signals: |ux| = 0.05 m at t = 0.25 s, sigma3 = 1.1 MPa
    pk = P.peaks(P.read_condition(res_dir / "results_no_water.h5", "no_water"))
    assert pk["haunch"]["max_ux"] == pytest.approx(0.05, rel=1e-9)
    assert pk["haunch"]["max_uz"] == pytest.approx(0.025, rel=1e-9)
    assert pk["top_arch"]["max_tension"] == pytest.approx(1.1e6, rel=1e-9)
    assert (res_dir / "figures" / "fig06_max_displacements.png").stat().st_size > 10_000
    # the table puts the paper's 6.00 cm beside our 5 cm for the top arch in x
    assert "| max_ux (cm) | no_water | top_arch | 6 | 5 | 0.83 |" in report
