"""The shipped case unlike the example (cases/pressure_tunnel: 7 m bore, 0.5 m reinforced lining,
60 m head, a weathered layer over the rock, three records of its own: across the tunnel, along its
axis and vertical) runs through `tunnelquake run` (its first 1.5 s here) and its report is its own:
no paper text, no NaN, nothing "not computed", the layered mesh, the lining forces and the capacity
check. The forces in the report are those of the results file. The motion along the axis shears
the slice antiplane: its two y faces move as one (the periodic tie), to round-off."""
from __future__ import annotations

import re

import h5py
import numpy as np
import pytest
from case_texts import short_example

from conftest import ROOT
from tunnelquake.cli import main
from tunnelquake.ring_forces import read_ring_forces

CASE = ROOT / "cases" / "pressure_tunnel"


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    d = short_example(CASE, tmp_path_factory.mktemp("pressure_tunnel"), "1.5 s")
    assert main(["run", str(d)]) == 0
    return d / "results"


def test_the_report_is_the_cases_own(ran):
    report = (ran / "report.md").read_text()
    for word in ("paper", "Liu", "top_arch", "haunch", "bottom_arch", "not computed", "nan", "1.575"):
        assert word not in report, word
    for m in ("crown", "springline", "invert", "shoulder"):
        assert m in report
    assert "2.942 m/s² = 0.3 g" in report
    assert "- peak (y, horizontal along the axis) at the outcrop (the incident wave is half of it): 2.452 m/s² = 0.25 g" \
        in report
    assert "- peak (z, vertical) at the outcrop (the incident wave is half of it): 1.961 m/s² = 0.2 g" in report
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


def test_the_slices_y_faces_move_as_one_under_the_motion_along_the_axis(ran):
    """Every node of the slice's face y = y0 and its partner at y = y0 + w (same x, z) have the same
    displacement in x, y and z at each snapshot (to 1e-9 of the largest), and the ground moves along
    the axis: u_y reaches the order of its x motion (the y record's PGA is 0.25 g against 0.3 g)."""
    for cond in ("no_water", "dynamic_water"):
        with h5py.File(ran / f"results_{cond}.h5", "r") as f:
            xyz = f["mesh/coordinates"][...]
            snaps = [f[f"snapshots/{k}/u"][...] for k in sorted(f["snapshots"], key=int)]
        y0, y1 = xyz[:, 1].min(), xyz[:, 1].max()
        lo, hi = np.flatnonzero(np.isclose(xyz[:, 1], y0)), np.flatnonzero(np.isclose(xyz[:, 1], y1))
        assert lo.size == hi.size == xyz.shape[0] // 2
        key = {(round(x, 6), round(z, 6)): n for n, (x, _, z) in zip(hi, xyz[hi], strict=True)}
        partner = np.array([key[(round(x, 6), round(z, 6))] for x, _, z in xyz[lo]])
        largest = max(float(np.max(np.abs(u))) for u in snaps)
        assert largest > 0, cond
        for u in snaps:  # the snapshot at the seismic start included (round-off there: ~1e-20 m)
            assert np.max(np.abs(u[lo] - u[partner])) < 1e-9 * largest, cond
        shaking = [u for u in snaps if np.max(np.abs(u)) > 1e-3 * largest]
        assert shaking, cond
        for u in shaking:
            assert np.max(np.abs(u[:, 1])) > 0.1 * np.max(np.abs(u[:, 0])), cond
