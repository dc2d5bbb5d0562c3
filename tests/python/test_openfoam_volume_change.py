"""Incompressible water in a closed pipe cannot change volume (the refusal).

A uniform radial contraction of the closed 2D slice asks the incompressible water to
change volume: the problem has no solution (ARCHITECTURE.md section 4).  tqInterface
must stop the run at the first step with a message that names the cause and the fixes,
instead of producing garbage.  The same case with a rigid translation (volume
preserved) must run: the check does not fire on round-off.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))
DT = 1e-3


def _case(tmp_path: Path, radial: bool) -> Path:
    case = tmp_path / ("radial" if radial else "lateral")
    motion = pipe.make_pipe_case(case, dt=DT, end_time=5 * DT, two_d=True)
    t = np.arange(0, 10 * DT, DT)
    u, v = pipe.harmonic_lateral(t, 1.0, 2 * np.pi * 5)
    vr = -0.01 * np.ones_like(t) if radial else np.zeros_like(t)
    pipe.write_motion(motion, t, u, v, vr * t, vr)
    fc.run(case, "blockMesh")
    return case


def test_closed_incompressible_contraction_is_refused(tmp_path):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = _case(tmp_path, radial=True)
    with pytest.raises(RuntimeError) as err:
        fc.run(case, "pimpleFoam")
    msg = str(err.value)
    assert "changes the volume of the water" in msg
    assert "open the axial ends" in msg and "compressible" in msg
    assert not list(case.glob("0.00*"))  # stopped before any step was written


def test_closed_incompressible_translation_runs(tmp_path):
    case = _case(tmp_path, radial=False)
    fc.run(case, "pimpleFoam")
    rows = fc.read_interface(case)
    assert len(rows) == 5
