"""Checkpoint/rollback of the water state.

The fake solid (replay exchange) asks for each step to be solved again: the first
attempt uses a wrong wall motion (predictorScale 1.5, like a predictor), then
tqInterface restores fields, old-time levels, mesh points, V0, meshPhi and time
(tq::fieldCheckpoint) and the step is solved again with the right motion.

Reference: the same run without rollbacks.  Solving a step, rolling back and solving
it again with the same input must give the same fields to round-off; measured
bit-identical, asserted to 1e-12 relative.  Covered: checkpoint before the first
step (Euler), checkpoints mid-run with backward ddt, the displacementLaplacian mesh
motion (its cellDisplacement solution is restored too), a 3D pipe, and the transpiration
interface (static mesh: the wall velocity pending in tqInterfaceVelocity is given again
after the restore), also for the compressible water (rhoPimpleFoam: rho, h, T, psi).  Every
variant solves the pressure as the product does (tqProjected, GAMG inside, to an absolute 1e-6), so
a state the restore misses (its projection basis, GAMG's agglomeration direction on a moving mesh)
shows up at the solver tolerance, far above 1e-12.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

FREQ = 10.0
OMEGA = 2 * np.pi * FREQ
DT = 1 / FREQ / 50
NSTEPS = 8

VARIANTS = {
    # the first step rolled back, with the product's pressure solver (tqProjected, GAMG inside):
    # its basis, empty when the state was saved, and GAMG's agglomeration direction, flipped by
    # the abandoned attempt's rebuild on the moving mesh, are put back
    "2d-euler-from-start": dict(geom=dict(), rollbacks=1, rollback_from=1),
    "2d-backward-laplacian": dict(
        geom=dict(ddt="backward", motion_solver="laplacian"),
        rollbacks=2,
        rollback_from=3,
    ),
    "3d-backward": dict(
        geom=dict(two_d=False, L=9.0, ny=6, nq=8, nr=6, ddt="backward"),
        rollbacks=1,
        rollback_from=2,
    ),
    "2d-transpiration": dict(geom=dict(interface_motion="transpiration"), rollbacks=1, rollback_from=1),
    # the production pressure solver: its projection basis is part of the saved state (a basis
    # left from the abandoned attempt would start the re-solve elsewhere: a difference at the
    # solver tolerance, 1e-6, not round-off)
    "3d-transpiration-tqProjected": dict(
        geom=dict(two_d=False, L=9.0, ny=6, nq=8, nr=6, interface_motion="transpiration"),
        rollbacks=1,
        rollback_from=2,
    ),
    "3d-transpiration-compressible": dict(
        geom=dict(two_d=False, L=9.0, ny=6, nq=8, nr=6, interface_motion="transpiration", water="compressible"),
        rollbacks=1,
        rollback_from=2,
    ),
}


def _run(case: Path, **kw) -> Path:
    motion = pipe.make_pipe_case(case, dt=DT, end_time=NSTEPS * DT, **kw)
    t = np.arange(0, (NSTEPS + 3) * DT, DT)
    u, v = pipe.harmonic_lateral(t, 1.0, OMEGA)
    pipe.write_motion(motion, t, u, v)
    fc.run(case, "blockMesh")
    fc.run(case, "rhoPimpleFoam" if kw.get("water") == "compressible" else "pimpleFoam")
    return case


def _last_time(case: Path) -> str:
    times = [p for p in case.iterdir() if p.is_dir() and p.name.replace(".", "").isdigit()]
    return max(times, key=lambda p: float(p.name)).name


@pytest.mark.parametrize("name", list(VARIANTS))
def test_rollback_reproduces_fields(tmp_path, name):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    var = VARIANTS[name]
    ref = _run(tmp_path / "ref", **var["geom"])
    rb = _run(
        tmp_path / "rb",
        rollbacks=var["rollbacks"],
        predictor_scale=1.5,
        rollback_from=var["rollback_from"],
        **var["geom"],
    )

    t_ref, t_rb = _last_time(ref), _last_time(rb)
    assert float(t_ref) == pytest.approx(NSTEPS * DT) and t_rb == t_ref
    fields = ["U", "p", "phi"]
    if var["geom"].get("interface_motion", "meshMotion") == "meshMotion":
        fields.append("pointDisplacement")
    if var["geom"].get("water") == "compressible":
        fields += ["rho", "T"]
    for field in fields:
        a = fc.read_internal_field(ref / t_ref / field)
        b = fc.read_internal_field(rb / t_rb / field)
        assert a.shape == b.shape
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max(), field

    r_ref = fc.read_interface(ref)
    r_rb = fc.read_interface(rb)
    accepted = r_rb[r_rb.accepted == 1]
    rejected = r_rb[r_rb.accepted == 0]
    n_rolled = (NSTEPS - var["rollback_from"] + 1) * var["rollbacks"]
    assert len(accepted) == NSTEPS and len(rejected) == n_rolled
    assert int(r_rb.nRollbacks[-1]) == n_rolled
    np.testing.assert_allclose(accepted.t, r_ref.t, rtol=0, atol=1e-12)
    scale = np.abs(r_ref.Fx).max()
    np.testing.assert_allclose(accepted.Fx, r_ref.Fx, rtol=0, atol=1e-12 * scale)
    # the rejected predictor attempts really differed (the test can see a bad restore)
    first = rejected[0]
    k = int(np.argmin(np.abs(r_ref.t - first.t)))
    assert abs(first.Fx - r_ref.Fx[k]) > 1e-3 * scale
