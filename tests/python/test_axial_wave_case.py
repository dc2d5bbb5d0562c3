"""The shipped travelling-wave case (cases/axial_wave: an SV wave 25 deg from the vertical travelling
along a 7 m tunnel, through a domain-reduction layer) runs through `tunnelquake run` (what `./Allrun
cases/axial_wave` runs), here its whole 2 s record with a snapshot every 0.1 s, and its report shows
the lining's axial forces:
1. the report's section "The lining along the axis" gives N, the moments, shears and torsion, and
   its N rows are the extremes of `lining_axis_no_water.csv`; the figure of the forces along the
   tunnel is drawn and shown;
2. those forces are the lining's own elastic response: at every snapshot and axial layer, the
   change of N (and of M_h, M_v) since the seismic start equals the sum over the layer's elements of
   (D B Δu)_yy A (times the lever arm for the moments), with D the lining's isotropic elasticity and B
   the hexahedron's mean strain-displacement matrix (the one-point element's assumed strain), from
   the snapshot's displacements (those of the step before it, u - dt v, which its stresses were
   computed from): a path independent of the stresses the report reads. Linear elasticity makes it
   exact; tolerance 1e-6 of the largest change (with the snapshot's u itself, 0.24 % of σ_yy: one
   step of motion)."""
from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest

from conftest import ROOT
from tunnelquake.cli import main
from tunnelquake.lining_axis import _hex_volume, axis_resultants
from tunnelquake.post import lining_elements, read_condition, read_snapshot, tunnel_centre

CASE = ROOT / "cases" / "axial_wave"
E_L, NU_L = 30e9, 0.2  # the case's lining


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    d = tmp_path_factory.mktemp("axial_wave")
    shutil.copy(CASE / "case.yaml", d / "case.yaml")
    text = (d / "case.yaml").read_text()
    assert "  history_interval: 0.005 s\n" in text
    times = ", ".join(f"{0.1 * k:.1f}" for k in range(21))
    (d / "case.yaml").write_text(text.replace("  history_interval: 0.005 s\n",
                                              f"  history_interval: 0.005 s\n  snapshot_times: [{times}]\n"))
    assert main(["run", str(d)]) == 0
    return d / "results"


XI = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
               [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)  # the nodes' natural coordinates


def _mean_b(x: np.ndarray) -> np.ndarray:
    """The volume average of dN/dx [8, 3] over a hexahedron with nodes x [8, 3] (VTK order): the
    one-point element's assumed (mean) strain-displacement matrix (Flanagan & Belytschko 1981).
    2 x 2 x 2 Gauss points integrate B det J of a trilinear hexahedron exactly (degree 3 in each
    natural coordinate)."""
    total, volume = np.zeros((8, 3)), 0.0
    for g in XI / np.sqrt(3.0):
        dn = XI * np.prod(1.0 + XI * g, axis=1)[:, None] / (1.0 + XI * g) / 8.0  # dN_a/dxi_j at g
        jac = x.T @ dn
        det = np.linalg.det(jac)
        total += dn @ np.linalg.inv(jac) * det
        volume += det
    return total / volume


def _syy_increment(x: np.ndarray, du: np.ndarray) -> float:
    """sigma_yy of an isotropic elastic hexahedron from its nodes' displacement change du [8, 3]."""
    grad = (_mean_b(x).T @ du).T  # grad[i, j] = d du_i / d x_j
    eps = 0.5 * (grad + grad.T)
    lam = E_L * NU_L / ((1 + NU_L) * (1 - 2 * NU_L))
    mu = E_L / (2 * (1 + NU_L))
    return lam * np.trace(eps) + 2 * mu * eps[1, 1]


def test_the_report_shows_the_axial_forces_of_the_csv_and_the_figure(ran):
    report = (ran / "report.md").read_text()
    section = report[report.index("## The lining along the axis"):]
    section = section[:section.index("\n## ", 4)]
    for q in ("N", "M_h", "M_v", "V_h", "V_v", "T"):
        assert f"| (1) no water | {q} (" in section, section[:3000]
    with open(ran / "lining_axis_no_water.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) >= 10
    n_max = max(abs(float(r["N_maxabs_N"])) for r in rows)
    row = next(line for line in section.splitlines() if line.startswith("| (1) no water | N ("))
    assert row.split("|")[4].strip().startswith(f"{n_max:.4g} at y = "), (row, n_max)
    assert (ran / "figures" / "fig11_lining_axis.png").stat().st_size > 10_000
    assert "fig11_lining_axis.png" in report


def test_the_axial_forces_are_the_linings_elastic_response(ran):
    res = read_condition(ran / "results_no_water.h5", "no_water")
    assert res.complete and len(res.snapshots) == 21
    dt = float(res.attrs["dt"])
    c, conn = res.mesh["coordinates"], res.mesh["connectivity"]
    lin = lining_elements(res)
    centre = tunnel_centre(res)
    first = read_snapshot(res, res.snapshots[0][0])
    start = axis_resultants(c, conn, lin, first["stress"], centre)
    x = c[conn[lin]]
    cen = x.mean(axis=1)
    length = x[:, :, 1].max(axis=1) - x[:, :, 1].min(axis=1)
    area = _hex_volume(x) / length
    layer = np.searchsorted(start.y, cen[:, 1] - 1e-6)
    worst = 0.0
    for key, _ in res.snapshots[1:]:
        snap = read_snapshot(res, key)
        r = axis_resultants(c, conn, lin, snap["stress"], centre)
        # a snapshot's stresses are those its step's internal forces were computed from: the
        # displacements one step before its u (u - dt v, v the velocity of that last step)
        before = snap["u"] - dt * snap["v"]
        du = before[conn[lin]] - (first["u"] - dt * first["v"])[conn[lin]]
        syy = np.array([_syy_increment(xe, de) for xe, de in zip(x, du, strict=True)])
        for q, arm in (("N", np.ones(len(lin))), ("M_h", -(cen[:, 0] - centre[0])), ("M_v", -(cen[:, 2] - centre[1]))):
            ours = np.zeros(start.y.size)
            np.add.at(ours, layer, syy * area * arm)
            got = getattr(r, q) - getattr(start, q)
            worst = max(worst, float(np.max(np.abs(got - ours))) / max(float(np.max(np.abs(got))), 1.0))
    print(f"worst {worst:.3g}")
    assert worst < 1e-6, worst

