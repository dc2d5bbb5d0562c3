"""Mesh quality under large wall motion with tqInterpolatedDisplacement.

The wall of a water-filled pipe (R 4.5 m, L 9 m, open ends) is moved by 10 cm sideways
and contracted by 10 cm radially (more than an earthquake gives, cm).  Reference:
the motion is a rigid translation plus a homogeneous scaling of the cross-section,
which the linear-decay interpolation reproduces up to the faceting of the wall
(distances and directions are taken to the nearest wall face, not to the circle); so the
cells keep their shape: checkMesh must report 'Mesh OK.', the maximum
non-orthogonality and skewness may change by at most 1 % and no cell may invert.
The point displacement is also checked against that closed form within 3 % of the
motion (measured 1.6 mm of 10 cm, 48 wall faces around).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

R = 4.5
SHIFT = 0.10  # m, sideways
SHRINK = 0.10  # m, radially inwards
NSTEPS = 10
DT = 0.01


def _quality(log: str) -> dict:
    q = {"ok": "Mesh OK." in log}
    q["nonorth"] = float(re.search(r"Mesh non-orthogonality Max: ([0-9.eE+-]+)", log).group(1))
    q["skew"] = float(re.search(r"Max skewness = ([0-9.eE+-]+)", log).group(1))
    q["minvol"] = float(re.search(r"Min volume = ([0-9eE+-]+(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?)", log).group(1))
    return q


def test_ten_cm_wall_motion_keeps_mesh_quality(tmp_path):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = tmp_path / "case"
    motion = pipe.make_pipe_case(
        case,
        dt=DT,
        end_time=NSTEPS * DT,
        two_d=False,
        L=9.0,
        ny=6,
        nq=12,
        nr=8,
        open_ends=True,
    )
    t = np.arange(0, (NSTEPS + 3) * DT, DT)
    s = np.minimum(t / (NSTEPS * DT), 1.0)  # linear ramp to the full motion
    z = np.zeros_like(t)
    u = np.column_stack([SHIFT * s, z, z])
    v = np.column_stack([np.full_like(t, SHIFT / (NSTEPS * DT)), z, z])
    pipe.write_motion(motion, t, u, v, -SHRINK * s, np.full_like(t, -SHRINK / (NSTEPS * DT)))
    fc.run(case, "blockMesh")
    before = _quality(fc.run(case, "checkMesh", log="checkMesh.0"))
    fc.run(case, "pimpleFoam")
    last = max(
        (p for p in case.iterdir() if p.name.replace(".", "").isdigit()),
        key=lambda p: float(p.name),
    ).name
    assert float(last) == pytest.approx(NSTEPS * DT)
    after = _quality(fc.run(case, "checkMesh", "-time", last, log="checkMesh.last"))
    assert before["ok"] and after["ok"]
    assert after["nonorth"] <= before["nonorth"] * 1.01 + 1e-6
    assert after["skew"] <= before["skew"] * 1.01 + 1e-6
    assert after["minvol"] > 0

    # closed form of the interpolated motion: shift + scaling (R - SHRINK)/R in x-z
    x0 = _read_points(case / "constant" / "polyMesh" / "points")
    x1 = _read_points(case / last / "polyMesh" / "points")
    scale = (R - SHRINK) / R
    expect = x0.copy()
    expect[:, 0] = x0[:, 0] * scale + SHIFT
    expect[:, 2] = x0[:, 2] * scale
    err = np.abs(x1 - expect).max()
    assert err < 0.03 * SHRINK, f"point motion deviates from shift+scaling by {err:.2e} m"
    print(
        f"10 cm shift + 10 cm contraction: non-orthogonality {before['nonorth']} -> "
        f"{after['nonorth']}, skewness {before['skew']} -> {after['skew']}, "
        f"max point error {err:.1e} m"
    )


def _read_points(path: Path) -> np.ndarray:
    text = Path(path).read_text()
    # the list starts after its count line
    m = re.search(r"\n(\d+)\s*\n\(", text)
    body = text[m.end() : text.rindex(")")]
    return np.array([float(x) for x in re.sub(r"[()]", " ", body).split()]).reshape(-1, 3)
