"""The shipped case unlike the example (cases/pressure_tunnel: 7 m bore, 0.5 m reinforced lining,
60 m head, a weathered layer over the rock, a horizontal and a vertical record of its own) runs
through `tunnelquake run` (its first 1.5 s here) and its report is its own: no paper text, no NaN,
nothing "not computed", the layered mesh, the lining forces and the capacity check. The forces in
the report are those of the results file."""
from __future__ import annotations

import re
import shutil

import h5py
import numpy as np
import pytest

from conftest import ROOT
from tunnelquake.cli import main
from tunnelquake.ring_forces import read_ring_forces

CASE = ROOT / "cases" / "pressure_tunnel"


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    d = tmp_path_factory.mktemp("pressure_tunnel")
    for f in CASE.iterdir():
        if f.is_file():
            shutil.copy(f, d / f.name)
    text = (d / "case.yaml").read_text()
    assert "  duration: 10 s\n" in text
    (d / "case.yaml").write_text(text.replace("  duration: 10 s\n", "  duration: 1.5 s\n"))
    assert main(["run", str(d)]) == 0
    return d / "results"


def test_the_report_is_the_cases_own(ran):
    report = (ran / "report.md").read_text()
    for word in ("paper", "Liu", "top_arch", "haunch", "bottom_arch", "not computed", "nan", "1.575"):
        assert word not in report, word
    for m in ("crown", "springline", "invert", "shoulder"):
        assert m in report
    assert "2.942 m/s² = 0.3 g" in report
    assert "## Lining forces" in report and "reinforced M–N (radial)" in report


def test_the_mesh_has_the_weathered_layer_as_a_region(ran):
    with h5py.File(ran / "mesh" / "mesh.h5", "r") as f:
        regions = [r.decode() if isinstance(r, bytes) else str(r) for r in f["/elements"].attrs["regions"]]
    assert regions[:2] == ["rock", "lining"] and "weathered" in regions


def test_the_reports_thrust_extremes_are_the_results_files(ran):
    report = (ran / "report.md").read_text()
    for cond in ("no_water", "static_water", "dynamic_water"):
        ring = read_ring_forces(ran / f"results_{cond}.h5")[0]
        block = report[report.index(f"**{cond}** (ring"):]
        row = re.search(r"\| N \(kN/m\) \| (\S+) \| (\S+)° \| (\S+) \| (\S+) \|", block)
        assert row, block[:400]
        assert float(row.group(1)) == pytest.approx(np.max(ring.N) / 1e3, rel=1e-3)
        assert float(row.group(4)) == pytest.approx(np.min(ring.N) / 1e3, rel=1e-3)
    # The 60 m head (p_i = rho_w g h at the axis) is shared by the lining and the rock it is bonded
    # to: it adds hoop tension to the lining's mean thrust at the start of the shaking, less than the
    # whole ring's p_i a (a = 3.0 m, the inner radius) would carry alone.
    n0 = {c: float(np.mean(read_ring_forces(ran / f"results_{c}.h5")[0].N[0])) for c in ("no_water", "static_water")}
    p_i_a = 1000 * 9.81 * 60 * 3.0
    assert 0 < n0["static_water"] - n0["no_water"] < p_i_a, n0
