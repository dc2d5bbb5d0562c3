"""Weakly compressible water in a closed pipe under a slow uniform radial contraction
(VERIFICATION.md, Water).

Reference: p = -K dV/V (quasi-static, bulk modulus K = 2.2 GPa), dV/V = (1 + u_r/R)^2 - 1 for
a uniform radial wall displacement u_r of a pipe of fixed length (exact for the faceted
section too: it is scaled uniformly).  Tolerance 2 % (VERIFICATION.md), on the area-mean wall
pressure and on every wall face, over the hold phase after the contraction.

Model: rhoPimpleFoam with a linear equation of state rho = rho0 + p/(R T) (perfectFluid,
R T0 = K/rho0), interface 'transpiration' (the only motion v1912's rhoPimpleFoam handles
correctly on a moving wall: see test_compressible_moving_mesh_is_refused).  Motion: u_r =
-U0 (1 - cos(pi t/T))/2 over T, then held; U0 = 1 mm (dV/V = -4.4e-4, p = 0.98 MPa);
T = 0.05 s (2D) / 0.1 s (3D), long against the acoustic periods (5 ms breathing mode
of the section, 12 ms axial mode of the 9 m pipe).  Case: tests/verification/fluid_compressible.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

R = 4.5
U0 = 1e-3

CASES = {
    "2d": dict(ramp=0.05, dt=5e-4, geom=dict(two_d=True, L=1.0, nq=16, nr=12)),
    "3d": dict(ramp=0.1, dt=1e-3, geom=dict(two_d=False, L=9.0, ny=10, nq=12, nr=8)),
}


def _contraction(t: np.ndarray, ramp: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    ur = np.where(t < ramp, -U0 * (1 - np.cos(math.pi * t / ramp)) / 2, -U0)
    vr = np.concatenate([[0.0], np.diff(ur) / dt])  # mid-step velocity, as the solid sends it
    return ur, vr


def _run(case: Path, ramp: float, dt: float, geom: dict, interface_motion: str, end: float) -> np.ndarray:
    motion = pipe.make_pipe_case(case, dt=dt, end_time=end, write_interval=end, water="compressible",
                                 interface_motion=interface_motion, **geom)
    t = np.arange(0, end + 3 * dt, dt)
    ur, vr = _contraction(t, ramp, dt)
    z = np.zeros((len(t), 3))
    pipe.write_motion(motion, t, z, z, ur, vr)
    fc.run(case, "blockMesh")
    fc.run(case, "rhoPimpleFoam")
    return t, ur


@pytest.mark.parametrize("name", list(CASES))
def test_closed_pipe_contraction_compressible(tmp_path, name):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    c = CASES[name]
    ramp, dt = c["ramp"], c["dt"]
    end = 1.5 * ramp
    case = tmp_path / "case"
    t, ur = _run(case, ramp, dt, c["geom"], "transpiration", end)

    rows = fc.read_interface(case)
    dvv = (1 + np.interp(rows.t, t, ur) / R) ** 2 - 1
    p_ref = -pipe.K_WATER * dvv
    hold = rows.t > ramp + 2 * dt
    err_mean = np.abs(rows.pMean[hold] / p_ref[hold] - 1).max()
    assert err_mean < 0.02, f"mean wall pressure off by {err_mean:.3%} of K dV/V"

    # every wall face at the end (uniform pressure)
    faces = fc.read_faces(case, max((p.name for p in (case / "postProcessing" / "interface").iterdir()
                                      if p.name != "0"), key=float))
    p_end = -pipe.K_WATER * ((1 - U0 / R) ** 2 - 1)
    err_faces = np.abs(faces[:, 6] / p_end - 1).max()
    assert err_faces < 0.02, f"wall pressure of a face off by {err_faces:.3%}"
    # the force of a uniform pressure on a closed wall: no net force
    assert np.abs(np.column_stack([rows.Fx, rows.Fy, rows.Fz])).max() < 1e-6 * p_end * 2 * math.pi * R
    print(f"{name}: p = {rows.pMean[hold].mean():.6g} Pa, -K dV/V = {p_ref[hold].mean():.6g} Pa, "
          f"max error {err_mean:.3%} (mean), {err_faces:.3%} (faces)")


def test_compressible_moving_mesh_is_refused(tmp_path):
    """v1912's rhoPimpleFoam counts the flux of a moving fixedFlux wall twice (pEqn.H makes
    phiHbyA relative before constrainPressure): tqInterface refuses the combination."""
    c = CASES["2d"]
    case = tmp_path / "case"
    with pytest.raises(RuntimeError) as err:
        _run(case, c["ramp"], c["dt"], c["geom"], "meshMotion", 5 * c["dt"])
    msg = str(err.value)
    assert "counted twice" in msg and "interfaceMotion transpiration" in msg
