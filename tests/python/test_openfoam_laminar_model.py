"""laminarModel tqNewtonian (libtqFoam.so) against the stock Stokes model.

The stock laminar model (linearViscousStress) assembles the viscous term as
    div(nu dev2(T(grad U))) + laplacian(nu, U).
For a uniform nu the first term is identically (nu/3) grad(div U) (div(T(grad U)) = grad(div U),
div(tr(grad U) I) = grad(div U)), zero for incompressible flow; tqNewtonian keeps only the
implicit laplacian(nuEff, U) (docs/water.md §10).  References and tolerances:

- water (nu = 1.308e-6 m^2/s): both models give the same wall loads to the linear solvers'
  tolerance.  Case: 3D pipe R 4.5 m, L 9 m, open ends, transpiration, the benchmark's wall
  motion (rigid shaking 1 m/s^2 at 5 Hz, ovaling n = 2 of 5 mm, slow contraction), 60 steps
  of 2e-3 s, the water case's numerics (tunnelquake.water_case) with p (PCG) and U to 1e-10 absolute.  The whole viscous term is nu/(w h^2) ~ 3e-7 of the
  inertia here (h ~ 0.4 m, w = 31 1/s); the dropped part, (nu/3) grad(div U) of the discrete
  cell-centred U, is a small fraction of that: resultant force (every step) and wall pressure
  (last step) within 1e-8 of their peaks.
- the viscous term is kept: start-up of plane Couette flow in a periodic 2D channel (viscosity
  alone drives the flow; u_x(y), div U = 0 exactly) against its series solution
  (couette_startup), within 1 % of the wall speed (measured 0.07 %); both models equal to the
  solvers' 1e-12.  (On the pipe at an artificial nu = 0.5 m^2/s the two models differ by 1.4-6.5 %
  of the viscous change of the wall pressure, measured, not asserted: there the stock explicit
  term acts on the discrete div of the cell-centred U, which the transpiration wall's flux makes
  non-zero in the wall cells; zero for water's nu, first test.)
- a viscosity model other than Newtonian (nu varying in space, the dropped term not zero) is
  refused at start-up, naming transportModel and the fix.
- the compressible water (rhoPimpleFoam): the same pipe, loads within 1e-7 of Stokes's (the
  dropped (mu/3) grad(div U) is about 6e-12 of grad p); a thermo whose viscosity is not uniform
  (transport other than const) is refused at start-up.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe, tunnel
from tunnelquake import water_case as wc
from tunnelquake.foam_dict import Quoted, Uniform

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

DT, STEPS = 2e-3, 60
GEOM = dict(two_d=False, L=9.0, ny=10, nq=12, nr=8, open_ends=True)


def _run(case: Path, model: str, nu: float = pipe.NU) -> tuple[np.ndarray, np.ndarray, str]:
    """(resultant force per step, wall pressure per face at the end, solver log)."""
    return _solve(case, "pimpleFoam", laminar_model=model, nu=nu)


def _solve(case: Path, solver: str, **setup) -> tuple[np.ndarray, np.ndarray, str]:
    """The pipe of `setup` (pipe.make_pipe_case's keys besides the common ones) run by `solver`:
    (resultant force per step, wall pressure per face at the end, solver log)."""
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    motion = pipe.make_pipe_case(case, dt=DT, end_time=STEPS * DT, interface_motion="transpiration",
                                 p_tol=1e-10, u_tol=1e-10, **setup, **GEOM)
    tunnel.benchmark_motion(motion, DT, STEPS, radial=not GEOM["two_d"])
    fc.run(case, "blockMesh")
    log = fc.run(case, solver)
    rows = fc.read_interface(case)
    force = np.column_stack([rows.Fx, rows.Fy, rows.Fz])
    last = sorted((p for p in (case / "postProcessing" / "interface").iterdir() if p.name != "0"),
                  key=lambda p: float(p.name))[-1]
    faces = np.vstack([np.loadtxt(f, comments="#", ndmin=2) for f in sorted(last.glob("faces*.dat"))])
    order = np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))
    return force, faces[order, 6], log


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_water_loads_unchanged(tmp_path):
    f_st, p_st, _ = _run(tmp_path / "stokes", "Stokes")
    f_tq, p_tq, log = _run(tmp_path / "tq", "tqNewtonian")
    assert "Selecting laminar stress model tqNewtonian" in log
    df, dp = _rel(f_tq, f_st), _rel(p_tq, p_st)
    assert df < 1e-8 and dp < 1e-8, f"tqNewtonian vs Stokes: force {df:.1e}, wall pressure {dp:.1e} of the peak"


COUETTE_NU, COUETTE_H, COUETTE_U0, COUETTE_N = 0.01, 1.0, 1.0, 40
COUETTE_DT, COUETTE_STEPS = 0.01, 500


def couette_startup(y: np.ndarray, t: float, nu: float, h: float, u0: float, terms: int = 2000) -> np.ndarray:
    """Start-up of plane Couette flow: the wall y = 0 set moving at u0 at t = 0, the wall y = h
    at rest, the fluid at rest: u = u0 (1 - y/h) - sum_n (2 u0/(n pi)) sin(n pi y/h)
    exp(-n^2 pi^2 nu t/h^2) (separation of variables of u_t = nu u_yy)."""
    n = np.arange(1, terms + 1)[:, None]
    return u0 * (1 - y / h) - (2 * u0 / (n * np.pi) * np.sin(n * np.pi * y / h)
                               * np.exp(-(n * np.pi) ** 2 * nu * t / h**2)).sum(axis=0)


#: the channel's viscous term solved implicitly: a momentum predictor. Its viscosity number nu dt/dy^2
#: is 0.16 (water's on the tunnel mesh about 1e-8): without it, as the water case runs, the start-up is
#: off by 6.8 % of the wall speed (two correctors instead: 1.5 %), with it 0.068 % (measured)
PIMPLE_COUETTE = {"momentumPredictor": True}


def _couette(case: Path, model: str) -> np.ndarray:
    """Plane Couette start-up in a periodic (cyclic) 2D channel, 1 x COUETTE_N cells: u_x of the
    cells (bottom to top) at the end."""
    n, h = COUETTE_N, COUETTE_H
    end = COUETTE_DT * COUETTE_STEPS
    # the water case's writer (its numerics; the viscosity of the channel), with the channel's mesh
    # and walls, no tqInterface, and both solvers to 1e-12 (the two models compared to round-off)
    w = wc.WaterCase(model="incompressible", ends=("empty", "empty"), density=1.0, viscosity=COUETTE_NU,
                     bulk_modulus=2.2e9, delta_t=COUETTE_DT, end_time=end, write_interval=end,
                     free_surface_level=0.0)
    tight = {"tolerance": 1e-12, "relTol": 0}
    walls = {"moving": {"type": "fixedValue", "value": Uniform([COUETTE_U0, 0, 0])}, "fixed": {"type": "noSlip"},
             Quoted("(left|right)"): {"type": "cyclic"}, "frontAndBack": {"type": "empty"}}
    gone = {"interface": None, "end_y(min|max)": None}
    wc.write(w, case, {
        "system/blockMeshDict": {
            "convertToMeters": 1,
            "vertices": [[0, 0, 0], [1, 0, 0], [1, h, 0], [0, h, 0], [0, 0, 0.1], [1, 0, 0.1], [1, h, 0.1],
                         [0, h, 0.1]],
            "blocks": ["hex", list(range(8)), [1, n, 1], "simpleGrading", [1, 1, 1]],
            "edges": [],
            "boundary": ["moving", {"type": "wall", "faces": [[0, 1, 5, 4]]},
                         "fixed", {"type": "wall", "faces": [[3, 7, 6, 2]]},
                         "left", {"type": "cyclic", "neighbourPatch": "right", "faces": [[0, 4, 7, 3]]},
                         "right", {"type": "cyclic", "neighbourPatch": "left", "faces": [[1, 2, 6, 5]]},
                         "frontAndBack", {"type": "empty", "faces": [[0, 3, 2, 1], [4, 5, 6, 7]]}],
            "mergePatchPairs": [],
        },
        "system/controlDict": {"functions": {"interface": None}, "writeFormat": "ascii", "writePrecision": 15},
        "system/fvSolution": {"solvers": {"p": wc.Whole(solver="PCG", preconditioner="DIC", **tight),
                                          "pFinal": wc.Whole(solver="PCG", preconditioner="DIC", **tight),
                                          Quoted("U(Final)?"): tight},
                               "PIMPLE": PIMPLE_COUETTE},
        "constant/turbulenceProperties": {"laminar": {"laminarModel": model}},
        "0/U": {"boundaryField": gone | walls},
        "0/p": {"boundaryField": gone | {k: ({"type": "zeroGradient"} if k in ("moving", "fixed") else v)
                                         for k, v in walls.items()}},
        "0/pointDisplacement": None,
    })
    fc.run(case, "blockMesh")
    fc.run(case, "pimpleFoam")
    text = (case / f"{end:g}" / "U").read_text()
    body = text[text.index("internalField"):]
    body = body[body.index("(") + 1:]
    vecs = re.findall(r"\(([^()]+)\)", body[: body.index("boundaryField")])
    return np.array([float(v.split()[0]) for v in vecs])


def test_viscous_term_kept_couette(tmp_path):
    """The viscous term is kept: plane Couette start-up (viscosity alone drives the flow, div U = 0
    exactly) against its series solution, to 1 % of the wall speed (Euler, dt nu/dy^2 = 0.16,
    40 cells: measured error 0.07 %), and tqNewtonian equal to Stokes to the solvers' 1e-12."""
    u_st = _couette(tmp_path / "stokes", "Stokes")
    u_tq = _couette(tmp_path / "tq", "tqNewtonian")
    y = (np.arange(COUETTE_N) + 0.5) * COUETTE_H / COUETTE_N
    ref = couette_startup(y, COUETTE_DT * COUETTE_STEPS, COUETTE_NU, COUETTE_H, COUETTE_U0)
    err = np.abs(u_tq - ref).max() / COUETTE_U0
    assert err < 0.01, f"Couette start-up: largest error {err:.2%} of the wall speed"
    assert np.abs(u_tq - u_st).max() < 1e-9 * COUETTE_U0


def test_non_newtonian_refused(tmp_path):
    case = tmp_path / "cross"
    # a viscosity model other than Newtonian in the water case's transportProperties
    cross = {"transportModel": "CrossPowerLaw", "CrossPowerLawCoeffs": {"nu0": 1e-3, "nuInf": 1e-6, "m": 1, "n": 0.5}}
    motion = pipe.make_pipe_case(case, dt=DT, end_time=2 * DT, interface_motion="transpiration",
                                 laminar_model="tqNewtonian", more={"constant/transportProperties": cross}, **GEOM)
    tunnel.benchmark_motion(motion, DT, 2, radial=not GEOM["two_d"])
    fc.run(case, "blockMesh")
    with pytest.raises(RuntimeError) as err:
        fc.run(case, "pimpleFoam")
    msg = str(err.value)
    assert "transportModel is 'CrossPowerLaw'" in msg and "laminarModel Stokes" in msg


def _run_compressible(case: Path, model: str, more: dict | None = None) -> tuple[np.ndarray, np.ndarray, str]:
    """_run's pipe with the weakly compressible water (rhoPimpleFoam, K of water)."""
    return _solve(case, "rhoPimpleFoam", laminar_model=model, water="compressible", more=more)


def test_compressible_water_loads_unchanged(tmp_path):
    """The compressible water (the product's slice and 3D cases): there the dropped term is
    (mu/3) grad(div U), div U = -(1/K) Dp/Dt, next to grad p of relative size mu w/(3 K) = 6e-12
    at 5 Hz, plus, as for the incompressible water, its part on the discrete div of the
    cell-centred U in the transpiration wall's cells. Bound: the whole viscous term, nu/(w h^2) ~
    3e-7 of the inertia: resultant force (every step) and wall pressure (last step) within 1e-7 of
    their peaks (measured 7.0e-9 and 3.9e-9)."""
    f_st, p_st, _ = _run_compressible(tmp_path / "stokes", "Stokes")
    f_tq, p_tq, log = _run_compressible(tmp_path / "tq", "tqNewtonian")
    assert "Selecting laminar stress model tqNewtonian" in log
    df, dp = _rel(f_tq, f_st), _rel(p_tq, p_st)
    assert df < 1e-7 and dp < 1e-7, f"tqNewtonian vs Stokes: force {df:.1e}, wall pressure {dp:.1e} of the peak"


def test_compressible_non_const_transport_refused(tmp_path):
    """A thermo whose viscosity depends on the temperature (transport sutherland) is refused at
    start-up, naming the thermo and the fix."""
    # sutherland<hConst<perfectGas>>: one of rhoThermo's stock combinations
    sutherland = {"thermoType": {"transport": "sutherland", "equationOfState": "perfectGas"},
                  "mixture": {"transport": {"As": 1.4792e-06, "Ts": 116}}}
    with pytest.raises(RuntimeError) as err:
        _run_compressible(tmp_path / "sutherland", "tqNewtonian",
                          more={"constant/thermophysicalProperties": sutherland})
    msg = str(err.value)
    assert "the thermo's transport is not 'const': sutherland<" in msg and "laminarModel Stokes" in msg
