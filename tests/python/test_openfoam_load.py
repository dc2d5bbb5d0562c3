"""libtqFoam.so loads in a stock pimpleFoam run and integrates the interface traction (eq. 15).

Case: a closed 2D box (1 m x 1 m, one cell thick), full of water (rho 1000 kg/m^3,
nu 1.308e-6 m^2/s; the water case's numerics, tunnelquake.water_case), shaken rigidly along x by
OpenFOAM's own solidBody motion,
displacement A sin(wt).  All walls move with the box: U tqInterfaceVelocity (from
libtqFoam.so) with p fixedFluxExtrapolatedPressure, the pairing docs/water.md recommends.

References:
- Rigid closed container under uniform acceleration a (VERIFICATION.md, Water):
  p = p0 - rho a.(x - x0), resultant of the water on all walls = -rho V a.
  Here a = -A w^2 sin(wt), so F_x(t) = rho V A w^2 sin(wt).  Tolerance 1 % on the
  amplitude (100 Euler steps per period: amplitude error O((w dt)^2); the force at
  t_n+1 follows the wall acceleration at t_n, a lag of one step, also checked).
- OpenFOAM's own 'forces' function object on the same patch: the pressure and
  viscous forces of tqInterface with wallPressure patchValue use the same
  definition, so they agree to round-off (relative 1e-9 of the amplitude).
- Conservation of the face-to-point map: sum of point forces = sum of face
  forces to round-off.
- wallPressure extrapolated (wall-cell value plus the normal gradient of the
  wall's acceleration) and patchValue (fixedFluxExtrapolatedPressure's own wall
  value) must both give rho V a: with this boundary-condition pair the discrete
  solution of a rigidly accelerating container is exact (measured -3e-4).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from tunnelquake import water_case as wc
from tunnelquake.foam_dict import Quoted, Uniform

RHO = 1000.0
NU = 1.308e-6
AMP = 0.01  # m
FREQ = 2.0  # Hz
OMEGA = 2 * np.pi * FREQ
NCELL = 20
DT = 1.0 / FREQ / 100
END = 1.0 / FREQ  # one period


_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))


def make_box_case(case: Path) -> None:
    """The box, written by the water case's writer (tunnelquake.water_case: its numerics, its
    tqInterface entries) with what the box sets otherwise: its mesh and patches, the solidBody
    motion of the whole mesh, four tqInterface function objects and OpenFOAM's forces."""
    w = wc.WaterCase(model="incompressible", ends=("empty", "empty"), density=RHO, viscosity=RHO * NU,
                     bulk_modulus=2.2e9, delta_t=DT, end_time=END, write_interval=END / 4, free_surface_level=0.0,
                     interface_motion="meshMotion")
    interface = wc.control_dict(w)["functions"]["interface"]
    functions = {f"{patch}{tag}": dict(interface, patch=patch, wallPressure=mode)
                 for tag, mode in (("PV", "patchValue"), ("Ex", "extrapolated")) for patch in ("right", "walls")}
    functions = {k: functions[k] for k in ("rightPV", "wallsPV", "rightEx", "wallsEx")}
    functions["interface"] = None
    functions["forcesRight"] = {"type": "forces", "libs": [Quoted("libforces.so")], "patches": ["right"],
                                "rho": "rhoInf", "rhoInf": RHO, "CofR": [0, 0, 0], "writePrecision": 15,
                                "log": False}
    # the box starts with its velocity A w: the water moves with it; all its walls move with it
    moving = Quoted("(right|walls)")
    u0 = Uniform([AMP * OMEGA, 0, 0])
    wc.write(w, case, {
        "system/blockMeshDict": {
            "convertToMeters": 1,
            "vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0.1], [1, 0, 0.1], [1, 1, 0.1],
                         [0, 1, 0.1]],
            "blocks": ["hex", list(range(8)), [NCELL, NCELL, 1], "simpleGrading", [1, 1, 1]],
            "edges": [],
            "boundary": ["right", {"type": "wall", "faces": [[1, 2, 6, 5]]},
                         "walls", {"type": "wall", "faces": [[0, 4, 7, 3], [0, 1, 5, 4], [3, 7, 6, 2]]},
                         "frontAndBack", {"type": "empty", "faces": [[0, 3, 2, 1], [4, 5, 6, 7]]}],
            "mergePatchPairs": [],
        },
        "system/controlDict": {"libs": [Quoted(str(fc.LIBRARY)), Quoted("libforces.so")], "functions": functions},
        "constant/dynamicMeshDict": {
            "motionSolverLibs": None, "tqInterpolatedDisplacementCoeffs": None, "motionSolver": "solidBody",
            "solidBodyCoeffs": {"solidBodyMotionFunction": "oscillatingLinearMotion",
                                "oscillatingLinearMotionCoeffs": {"amplitude": [AMP, 0, 0], "omega": OMEGA}}},
        "0/U": {"internalField": u0, "boundaryField": {
            "interface": None, "end_y(min|max)": None,
            moving: {"type": "tqInterfaceVelocity", "value": u0}, "frontAndBack": {"type": "empty"}}},
        "0/p": {"boundaryField": {
            "interface": None, "end_y(min|max)": None,
            moving: {"type": "fixedFluxExtrapolatedPressure", "value": Uniform(0)}, "frontAndBack": {"type": "empty"}}},
        "0/pointDisplacement": None,
    })


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built: cmake --build build --target tqFoam"
    case = tmp_path_factory.mktemp("box")
    make_box_case(case)
    fc.run(case, "blockMesh")
    log = fc.run(case, "pimpleFoam")
    return case, log


def test_library_loads_in_stock_pimplefoam(box):
    case, log = box
    assert "tqInterface" in log
    rows = fc.read_interface(case, "rightPV")
    # one row per solved step, all accepted (no exchange partner)
    assert len(rows) == round(END / DT)
    assert np.all(rows.accepted == 1)


def test_matches_openfoam_forces_to_roundoff(box):
    case, _ = box
    ours = fc.read_interface(case, "rightPV")
    ref = fc.read_forces(case, "forcesRight")
    assert len(ref) == len(ours)
    np.testing.assert_allclose(ref[:, 0], ours.t, rtol=0, atol=1e-9)
    scale = np.abs(ref[:, 4]).max()  # pressure force amplitude on 'right'
    assert scale > 1.0
    for k, col in enumerate(("Fpx", "Fpy", "Fpz")):
        np.testing.assert_allclose(ours[col], ref[:, 4 + k], rtol=0, atol=1e-9 * scale)
    for k, col in enumerate(("Fvx", "Fvy", "Fvz")):
        np.testing.assert_allclose(ours[col], ref[:, 7 + k], rtol=0, atol=1e-9 * scale)


def test_point_forces_sum_to_face_forces(box):
    case, _ = box
    for name in ("rightPV", "wallsEx"):
        rows = fc.read_interface(case, name)
        for c in "xyz":
            scale = max(np.abs(rows["F" + c]).max(), 1.0)
            np.testing.assert_allclose(rows["S" + c], rows["F" + c], rtol=0, atol=1e-10 * scale)
    # and per face at a write time: face forces match pWall*Sf + viscous
    faces = fc.read_faces(case, f"{END / 2:g}", "rightEx")
    points = fc.read_points(case, f"{END / 2:g}", "rightEx")
    np.testing.assert_allclose(
        points[:, 12:15].sum(axis=0),
        faces[:, 8:11].sum(axis=0),
        rtol=0,
        atol=1e-10 * np.abs(faces[:, 8]).sum(),
    )


def _resultant(case, mode):
    a = fc.read_interface(case, "right" + mode)
    b = fc.read_interface(case, "walls" + mode)
    return a.t, a.Fx + b.Fx, a.Fy + b.Fy


def test_rigid_container_resultant_is_rho_V_a(box):
    case, _ = box
    volume = 1.0 * 1.0 * 0.1
    amp_ref = RHO * volume * AMP * OMEGA**2  # N
    t, fx, fy = _resultant(case, "Ex")
    # skip the first step (start-up of the old-time levels)
    amp, phase, mean = fc.harmonic_fit(t[1:], fx[1:], OMEGA)
    # F = amp_ref sin(wt) = amp_ref cos(wt - pi/2)
    assert abs(amp / amp_ref - 1) < 0.01, (amp, amp_ref)
    # Euler step ending at t_n+1 sees the central second difference of the wall
    # position about t_n: a lag of exactly one step
    assert abs((phase - np.pi / 2) - OMEGA * DT) < 0.05 * OMEGA * DT
    assert abs(mean) < 0.01 * amp_ref
    assert np.abs(fy).max() < 1e-6 * amp_ref
    t, fx_pv, _ = _resultant(case, "PV")
    amp_pv, _, _ = fc.harmonic_fit(t[1:], fx_pv[1:], OMEGA)
    assert abs(amp_pv / amp_ref - 1) < 0.01, (amp_pv, amp_ref)
    print(
        f"rigid box: amplitude error extrapolated {amp / amp_ref - 1:+.2e}, "
        f"patchValue {amp_pv / amp_ref - 1:+.2e}, phase lag {phase - np.pi / 2:.4f} rad "
        f"(one step: w dt = {OMEGA * DT:.4f})"
    )
