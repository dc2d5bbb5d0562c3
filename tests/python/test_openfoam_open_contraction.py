"""Incompressible water, open ends, uniform radial contraction of the wall.

Reference: tunnelquake.references.open_pipe_contraction, the 1D (plug-flow) solution derived in
its docstring: wall pressure p_w(y) = -(rho/2)(s' - s^2) y (L - y) - rho (s'/4 + s^2/8) R^2/2
(s = 2w/R; the last term is the radial variation of the exact potential flow, 0.6 % here) and
end outflow Q = -pi R L w per end.  Tolerance 3 % of the largest mid-length pressure
for the wall pressure at every wall face away from the ends (|y - L/2| <= L/2 - 2R: the
open-end condition p = 0 on a whole end section perturbs about R near each end), and 3 % of
the largest outflow for the outflow at every step.

Mesh: the paper's water mesh (tunnelquake.meshing, PAPER_GEOMETRY, 14,784 cells, R 4.5 m,
L 80 m, open ends).  Motion: u_r = -U0 (1 - cos(pi t/T))/2 over T = 0.05 s, then held, U0 = 1
mm (the contraction of check 2); the solver sees the mid-step wall velocity w_n = (u_n -
u_{n-1})/dt and, with Euler, the wall acceleration (w_{n} - w_{n-1})/dt: the reference is
evaluated with these same discrete w and w' (the comparison tests the space discretisation
and the model, not the known one-step lag).  Both interface motions: transpiration (default)
and the moving mesh.  Case description: tests/verification/fluid_open_contraction/README.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe, tunnel
from tunnelquake.foam_dict import Quoted
from tunnelquake.references import open_pipe_contraction

pytest.importorskip("gmsh")
_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

R, L = 4.5, 80.0
U0, RAMP, DT = 1e-3, 0.05, 1e-3
NSTEPS = 70
WRITE_EVERY = 5

#: the flux through the open end (a function object of the water case)
OUTFLOW = {"type": "surfaceFieldValue", "libs": [Quoted("libfieldFunctionObjects.so")], "log": False,
           "writeFields": False, "regionType": "patch", "name": "end_ymax", "operation": "sum", "fields": ["phi"]}


@pytest.fixture(scope="module")
def polymesh(tmp_path_factory):
    return tunnel.prepare_mesh("3d", tmp_path_factory.mktemp("paper-mesh"))


def test_reference_is_consistent():
    """Mass balance and momentum of the 1D solution (finite differences)."""
    w, wd = -0.01, -2.0
    y = np.linspace(0, L, 2001)
    p, u, Q = open_pipe_contraction(pipe.RHO, R, L, w, wd, y)
    # both ends together carry what the wall squeezes out
    assert 2 * Q == pytest.approx(-2 * math.pi * R * L * w, rel=1e-12)
    assert u[-1] * math.pi * R**2 == pytest.approx(Q, rel=1e-12)
    # dp/dy = rho (s' - s^2)(y - L/2)
    s, sd = 2 * w / R, 2 * wd / R
    assert np.gradient(p, y)[1:-1] == pytest.approx(pipe.RHO * (sd - s * s) * (y - L / 2)[1:-1], rel=1e-6, abs=1e-6)


@pytest.mark.parametrize("interface_motion", ["transpiration", "meshMotion"])
def test_open_pipe_contraction(tmp_path, polymesh, interface_motion):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = tmp_path / "case"
    motion = tunnel.make_case(case, polymesh, dict(
        interface_motion=interface_motion, dt=DT, steps=NSTEPS, write_interval=WRITE_EVERY * DT,
        functions={"outflow": OUTFLOW}))
    t = np.arange(0, (NSTEPS + 3) * DT, DT)
    ur = np.where(t < RAMP, -U0 * (1 - np.cos(math.pi * t / RAMP)) / 2, -U0)
    vr = np.concatenate([[0.0], np.diff(ur) / DT])
    z = np.zeros((len(t), 3))
    pipe.write_motion(motion, t, z, z, ur, vr)
    fc.run(case, "pimpleFoam")

    def w_and_rate(time: float) -> tuple[float, float]:
        n = int(round(time / DT))
        return vr[n], (vr[n] - vr[n - 1]) / DT

    # reference scale: largest mid-length wall pressure and largest outflow over the run
    scale_p = max(abs(open_pipe_contraction(pipe.RHO, R, L, *w_and_rate(k * DT), L / 2, r=R)[0])
                  for k in range(2, NSTEPS + 1))
    scale_q = max(abs(open_pipe_contraction(pipe.RHO, R, L, *w_and_rate(k * DT), L / 2)[2])
                  for k in range(1, NSTEPS + 1))

    # wall pressure at the write times (ramp and hold)
    worst_p = 0.0
    times = sorted((p for p in (case / "postProcessing" / "interface").iterdir() if p.name != "0"),
                   key=lambda p: float(p.name))
    assert len(times) >= NSTEPS // WRITE_EVERY - 1
    for tdir in times:
        faces = fc.read_faces(case, tdir.name)
        y, p_wall = faces[:, 1], faces[:, 6]
        inner = np.abs(y - L / 2) <= L / 2 - 2 * R
        p_ref = open_pipe_contraction(pipe.RHO, R, L, *w_and_rate(float(tdir.name)), y[inner], r=R)[0]
        worst_p = max(worst_p, np.abs(p_wall[inner] - p_ref).max() / scale_p)
    assert worst_p < 0.03, f"wall pressure off by {worst_p:.2%} of the peak"

    # end outflow at every step
    data = np.loadtxt(next((case / "postProcessing" / "outflow").glob("*/surfaceFieldValue.dat")), comments="#")
    q_ref = np.array([open_pipe_contraction(pipe.RHO, R, L, *w_and_rate(tt), L / 2)[2] for tt in data[:, 0]])
    worst_q = np.abs(data[:, 1] - q_ref).max() / scale_q
    assert worst_q < 0.03, f"outflow off by {worst_q:.2%} of the peak"
    print(f"{interface_motion}: wall pressure within {worst_p:.2%} of the peak {scale_p:.4g} Pa, "
          f"outflow within {worst_q:.2%} of the peak {scale_q:.4g} m^3/s")
