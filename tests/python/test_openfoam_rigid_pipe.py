"""Rigid pipe under harmonic lateral acceleration: wall pressure and resultant.

Reference, case and tolerances: tests/verification/fluid_rigid_pipe/README.md.
p(theta) = p0 - rho a R cos(theta) within 2 % of rho a R; resultant rho pi R^2 L a within 1 %;
2D slice and 3D, 1 and 10 Hz; with the water case's numerics (tunnelquake.water_case, its pressure
solver tqProjected) and with its pressure solved by PCG to 1e-10 instead.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe

R = 4.5
A0 = 1.0  # m/s^2

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

CASES = {
    "2d-1Hz": dict(freq=1.0, geom=dict(two_d=True, L=1.0, nq=16, nr=12, p_tol=1e-10)),
    "2d-10Hz": dict(freq=10.0, geom=dict(two_d=True, L=1.0, nq=16, nr=12, p_tol=1e-10)),
    "3d-1Hz": dict(freq=1.0, geom=dict(two_d=False, L=9.0, ny=10, nq=12, nr=8, p_tol=1e-10)),
    "3d-10Hz": dict(freq=10.0, geom=dict(two_d=False, L=9.0, ny=10, nq=12, nr=8, p_tol=1e-10)),
    # the water case's pressure controls (tqProjected + GAMG, closed domain: absolute 1e-6)
    # instead of PCG to 1e-10: the same tolerances
    "2d-10Hz-tqProjected": dict(freq=10.0, geom=dict(two_d=True, L=1.0, nq=16, nr=12)),
    "3d-1Hz-tqProjected": dict(freq=1.0, geom=dict(two_d=False, L=9.0, ny=10, nq=12, nr=8)),
}


def _run(tmp_path: Path, freq: float, geom: dict):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    omega = 2 * np.pi * freq
    period = 1 / freq
    dt = period / 50
    case = tmp_path / "case"
    motion = pipe.make_pipe_case(case, dt=dt, end_time=period + dt, **geom)
    t = np.arange(0, period + 3 * dt, dt)
    u, v = pipe.harmonic_lateral(t, A0, omega)
    pipe.write_motion(motion, t, u, v)
    fc.run(case, "blockMesh")
    fc.run(case, "pimpleFoam")
    return case, omega, dt


@pytest.mark.parametrize("name", list(CASES))
def test_rigid_pipe(tmp_path, name):
    freq, geom = CASES[name]["freq"], CASES[name]["geom"]
    case, omega, dt = _run(tmp_path, freq, geom)
    L = geom["L"]
    rows = fc.read_interface(case)
    assert np.all(rows.accepted == 1)

    # Resultant: F_x = -rho pi R^2 L a(t - dt), a = A0 cos(wt)  ->  amplitude, phase pi + w dt
    f_ref = pipe.RHO * np.pi * R**2 * L * A0
    amp, phase, mean = fc.harmonic_fit(rows.t[2:], rows.Fx[2:], omega)
    err = amp / f_ref - 1
    lag = np.angle(np.exp(1j * (phase - np.pi)))
    assert abs(err) < 0.01, f"resultant amplitude error {err:+.3%}"
    assert abs(lag - omega * dt) < 0.05 * omega * dt, (lag, omega * dt)
    assert abs(mean) < 0.01 * f_ref
    # cross force: symmetry to the pressure solve's tolerance (PCG 1e-10: 1e-6 of the resultant;
    # the production controls solve to an absolute 1e-6, which leaves 1.7e-6 with tqProjected and
    # 2.3e-6 with GAMG alone, measured: bounded at 1e-5)
    cross = 1e-6 if "p_tol" in geom else 1e-5
    assert np.abs(rows.Fz).max() < cross * f_ref and np.abs(rows.Fy).max() < cross * f_ref

    # Wall pressure at the last step, which follows a(T) = A0
    times = sorted(
        (p for p in (case / "postProcessing" / "interface").iterdir() if p.name != "0"),
        key=lambda p: float(p.name),
    )
    faces = fc.read_faces(case, times[-1].name)
    x, z, p_wall = faces[:, 0], faces[:, 2], faces[:, 6]
    theta = np.arctan2(z, x)
    p_ref = -pipe.RHO * A0 * R * np.cos(theta)
    p0 = np.mean(p_wall - p_ref)
    dev = np.abs(p_wall - p0 - p_ref).max() / (pipe.RHO * A0 * R)
    assert dev < 0.02, f"wall pressure deviates by {dev:.3%} of rho a R"
    print(
        f"{name}: resultant {err:+.3%}, lag {lag / (omega * dt):.3f} steps, "
        f"max wall-pressure deviation {dev:.3%} of rho a R ({len(faces)} faces)"
    )
