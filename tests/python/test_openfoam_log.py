"""The water's per-pass log (docs/water.md §2 "Log"): tqInterface's logInterval and quietSolver.

A coupled pass of the paper slice printed ≈ 1 kB (the solver's lines, the residuals, the loads,
rolled-back passes included): 18 MB a simulated second through a pipe to `tunnelquake run`.
With `logInterval` and `quietSolver yes` (what `water.log: brief` writes) only the passes that
reach a multiple of the interval, the first and the last are printed, never a rolled-back one.

Reference: the same run printing every pass (what `water.log: verbose` writes). The log is output only,
so interface.dat (every attempt, rolled back ones included) must be bit-identical, and the
printed loads must be those of the accepted rows at the expected times. Case: the compressible
transpiration pipe of test_openfoam_rollback.py, each step solved twice (the first attempt
with 1.5x the wall motion, rolled back).
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

FREQ = 10.0
OMEGA = 2 * np.pi * FREQ
DT = 1 / FREQ / 50  # 0.002 s
NSTEPS = 20
INTERVAL = 0.01  # s: prints at t = DT (first), 0.01, 0.02, 0.03, 0.04 (also the last)
PRINTED = [DT, 0.01, 0.02, 0.03, 0.04]


def _run(case: Path, log_interval: float | None, interface: dict | None = None) -> str:
    """The pipe with the water case's log: every pass (log_interval None, water.log: verbose) or
    brief; `interface`: tqInterface's entries set otherwise."""
    motion = pipe.make_pipe_case(case, dt=DT, end_time=NSTEPS * DT, two_d=True, interface_motion="transpiration",
                                 water="compressible", rollbacks=1, predictor_scale=1.5, rollback_from=1,
                                 log_interval=log_interval, functions={"interface": interface} if interface else None)
    t = np.arange(0, (NSTEPS + 3) * DT, DT)
    u, v = pipe.harmonic_lateral(t, 1.0, OMEGA)
    pipe.write_motion(motion, t, u, v)
    fc.run(case, "blockMesh")
    return fc.run(case, "rhoPimpleFoam")


def _printed_loads(out: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Times and x forces of tqInterface's printed rows, and how many were rolled back."""
    rows = re.findall(r"^tqInterface interface: t = (\S+)( \(rolled back\))?\n\s+force on lining \[N\] \((\S+) ",
                      out, flags=re.M)
    t = np.array([float(r[0]) for r in rows if not r[1]])
    fx = np.array([float(r[2]) for r in rows if not r[1]])
    return t, fx, sum(1 for r in rows if r[1])


def test_brief_log_prints_the_interval_and_keeps_every_row(tmp_path):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    verbose = _run(tmp_path / "verbose", None)
    brief = _run(tmp_path / "brief", INTERVAL)

    # the log is output only: every attempt's row, bit for bit
    a = np.loadtxt(next((tmp_path / "verbose" / "postProcessing" / "interface").glob("*/interface.dat")))
    b = np.loadtxt(next((tmp_path / "brief" / "postProcessing" / "interface").glob("*/interface.dat")))
    assert a.shape == b.shape == (2 * NSTEPS, 19)
    assert np.array_equal(a, b)
    # each row's text: the OpenFOAM file stream's format (scientific, 15 digits: %.15e), the
    # accepted flag and the rollback count as integers, one space between
    text = next((tmp_path / "brief" / "postProcessing" / "interface").glob("*/interface.dat")).read_text()
    rows = [r for r in text.splitlines() if not r.startswith("#")]
    assert len(rows) == 2 * NSTEPS
    for row, values in zip(rows, b, strict=True):
        fields = row.split(" ")
        assert fields[1] == str(int(values[1])) and fields[18] == str(int(values[18]))
        assert [fields[0]] + fields[2:18] == [f"{v:.15e}" for v in [values[0], *values[2:18]]]

    # verbose: every pass, rolled-back ones marked, the residual lines
    t_v, _, rolled_v = _printed_loads(verbose)
    assert len(t_v) == NSTEPS and rolled_v == NSTEPS
    assert verbose.count("Solving for p") >= 2 * NSTEPS
    assert len(re.findall(r"^Time = ", verbose, flags=re.M)) == 2 * NSTEPS

    # brief: the accepted pass reaching each multiple of the interval, the first and the last
    t_b, fx_b, rolled_b = _printed_loads(brief)
    assert rolled_b == 0
    np.testing.assert_allclose(t_b, PRINTED, rtol=0, atol=1e-9)
    acc = a[a[:, 1] == 1]
    k = [int(np.argmin(np.abs(acc[:, 0] - t))) for t in PRINTED]
    np.testing.assert_allclose(fx_b, acc[k, 2], rtol=1e-10, atol=0)  # the log prints 12 digits
    # the solver's own lines only for the printed steps (both attempts of each: the step is
    # printed whole before it is known whether it is accepted), no residual lines
    steps = [float(x) for x in re.findall(r"^Time = (\S+)", brief, flags=re.M)]
    np.testing.assert_allclose(sorted(set(steps)), PRINTED, rtol=0, atol=1e-9)
    assert len(steps) == 2 * len(PRINTED)
    assert "Solving for" not in brief
    # it ends as a full log does: the solver's last ExecutionTime, then End
    last = re.findall(r"^ExecutionTime = (\S+) s", brief, flags=re.M)
    assert len(last) == 2 * len(PRINTED)
    assert brief.rstrip().endswith("End")
    assert len(brief) < 0.5 * len(verbose)


def test_quiet_solver_needs_an_interval(tmp_path):
    with pytest.raises(RuntimeError) as e:
        _run(tmp_path / "bad", None, {"quietSolver": True})
    assert "quietSolver yes needs a positive logInterval" in str(e.value)
    assert "logInterval 0.01;" in str(e.value)
