"""Hydrostatic and hydrodynamic parts of the water load (both parts reported).

OpenFOAM solves the hydrodynamic pressure only (no gravity in the solver); the forces sent to
the solid (F, point forces) are hydrodynamic, and tqInterface reports the hydrostatic resultant
of rho g (H - z) on the same wall faces beside them (column Fhs of interface.dat).

Reference: a horizontal pipe (axis y, z up) holding water of volume V: the hydrostatic pressure
on the lateral wall (the interface; the end faces push along y only) gives
Fhs = (0, 0, -rho g V), the weight of the water carried by the lining, whatever the head H
(a uniform pressure has no resultant on the closed section).  The hydrodynamic force is the
rigid-pipe one, -rho V a (VERIFICATION.md), with no trace of gravity: zero at rest.  Tolerances:
1e-9 (hydrostatic, exact on the faceted wall with V the faceted volume), 1e-9 rho g V for the
force at rest, 1 % for the shaken resultant.  Both interface motions.
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

R, L, G, H = 4.5, 1.0, 9.81, 123.0
DT, NSTEPS = 2e-3, 20


def _faceted_volume(case: Path) -> float:
    """Volume enclosed by the interface faces (closed by the plane ends): divergence theorem
    on the prism along y, V = sum over the wall faces of (x Sx + z Sz)/2, from faces.dat of
    the first write time."""
    t0 = min((p.name for p in (case / "postProcessing" / "interface").iterdir() if p.name != "0"), key=float)
    f = fc.read_faces(case, t0)
    return float(np.sum(f[:, 0] * f[:, 3] + f[:, 2] * f[:, 5]) / 2)


@pytest.mark.parametrize("interface_motion", ["meshMotion", "transpiration"])
@pytest.mark.parametrize("shaken", [False, True])
def test_hydrostatic_and_hydrodynamic_parts(tmp_path, interface_motion, shaken):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = tmp_path / "case"
    motion = pipe.make_pipe_case(case, dt=DT, end_time=NSTEPS * DT, write_interval=DT, two_d=True, L=L,
                                 interface_motion=interface_motion, free_surface_level=H)
    t = DT * np.arange(NSTEPS + 3)
    z = np.zeros((len(t), 3))
    a0 = 0.5 if shaken else 0.0
    u = np.column_stack([a0 * t**2 / 2, 0 * t, 0 * t])  # constant acceleration from rest
    v = np.vstack([[0, 0, 0], np.diff(u, axis=0) / DT])  # mid-step velocity
    pipe.write_motion(motion, t, u if shaken else z, v if shaken else z)
    fc.run(case, "blockMesh")
    fc.run(case, "pimpleFoam")
    rows = fc.read_interface(case)
    volume = _faceted_volume(case)
    assert volume == pytest.approx(math.pi * R**2 * L, rel=3e-3)  # 64 faces: -0.16 %

    w = pipe.RHO * G * volume
    np.testing.assert_allclose(rows.Fhsz, -w, rtol=1e-9 if not shaken else 1e-6)
    assert np.abs(rows.Fhsx).max() < 1e-9 * w and np.abs(rows.Fhsy).max() < 1e-9 * w
    if not shaken:
        # the hydrodynamic force of water at rest: nothing (no gravity in the solver)
        assert np.abs(np.column_stack([rows.Fx, rows.Fy, rows.Fz])).max() < 1e-9 * w
    else:
        # the shaken pipe: -rho V a0 from the second step, gravity-free
        f_ref = -pipe.RHO * volume * a0
        err = np.abs(rows.Fx[2:] / f_ref - 1).max()
        assert err < 0.01, f"hydrodynamic resultant off by {err:.3%}"
        assert np.abs(rows.Fz).max() < 1e-3 * abs(f_ref)
    print(f"{interface_motion}, shaken {shaken}: Fhs_z = {rows.Fhsz[-1]:.6g} N (-rho g V = {-w:.6g}), "
          f"F = ({rows.Fx[-1]:.4g}, {rows.Fz[-1]:.3g}) N")
