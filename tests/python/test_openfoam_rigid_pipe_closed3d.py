"""Closed 3D rigid pipe of `tunnelquake bench --fluid`: stock and ours on the same mesh.

Reference (tests/verification/fluid_rigid_pipe/README.md; Batchelor 1967 §6.4): water in a closed
rigid pipe shaken along x has p = p0 − ρ a R cos θ at every axial position and the resultant
ρπR²L a. With end plates moving with the pipe (tunnel.make_case on a mesh whose ends are walls)
the 3D water is the slice's, uniform along the axis, so:
- the 3D pipe's errors equal the 2D slice's on the same cross-section, for both set-ups (the stock
  pimpleFoam + displacementLaplacian and ours, transpiration), within 1e-4 (the linear solvers'
  tolerances; measured 2e-5);
- the wall pressure's cos θ coefficient is the same in every axial layer within 1e-3 (an open or
  leaking end would make it vary along the pipe);
- ours meets the rigid-pipe test's tolerances: resultant within 1 %, wall pressure within 2 % of
  ρ a R.
N = 48 faces around (9 cells along the 9 m pipe), 50 steps a period at 1 Hz: a few seconds.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import fluid as bf
from benchmarks.fluid_common import foamcase as fc

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

N, STEPS = 48, 50


def _layer_coefficients(case, a_last: float) -> np.ndarray:
    """Per axial layer of wall faces: the cos θ coefficient of the wall pressure over −ρ a R."""
    last = sorted((p for p in (case / "postProcessing" / "interface").iterdir() if p.name != "0"),
                  key=lambda p: float(p.name))[-1].name
    f = fc.read_faces(case, last)
    y, theta, p = np.round(f[:, 1], 6), np.arctan2(f[:, 2], f[:, 0]), f[:, 6]
    out = []
    for yl in np.unique(y):
        m = y == yl
        a = np.column_stack([np.cos(theta[m]), np.sin(theta[m]), np.ones(m.sum())])
        out.append(np.linalg.lstsq(a, p[m], rcond=None)[0][0] / (-1000.0 * a_last * bf.PIPE_R))
    return np.array(out)


@pytest.mark.parametrize("variant", ["ours", "stock"])
def test_closed_3d_pipe_is_the_slice(tmp_path, variant):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    ny = bf.pipe3d_axial(N)
    poly2, _ = bf.pipe_mesh(tmp_path, N)
    poly3, cells = bf.pipe_mesh(tmp_path, N, ny)
    two = bf.run_pipe(tmp_path, poly2, variant, N, STEPS)
    three = bf.run_pipe(tmp_path, poly3, variant, N, STEPS, length=bf.PIPE3D_L, tag="-3d")
    for key in ("force_error", "pressure_error", "pressure_dev"):
        assert abs(three[key] - two[key]) < 1e-4, f"{variant} {key}: 3D {three[key]:+.5%} vs slice {two[key]:+.5%}"
    a_last = bf.PIPE_A0 * math.cos(2 * math.pi * bf.PIPE_FREQ * (three["steps"] - 1) * three["dt"])
    layers = _layer_coefficients(tmp_path / f"{variant}-3d-N{N}-S{STEPS}", a_last)
    assert len(layers) == ny
    assert np.ptp(layers) < 1e-3, f"{variant}: cos θ coefficient varies along the pipe: {layers}"
    if variant == "ours":
        assert abs(three["force_error"]) < 0.01 and three["pressure_dev"] < 0.02
    print(f"{variant}, {cells} cells: F {three['force_error']:+.3%} (slice {two['force_error']:+.3%}), "
          f"p {three['pressure_error']:+.3%} (slice {two['pressure_error']:+.3%}), layers ±{np.ptp(layers):.1e}")
