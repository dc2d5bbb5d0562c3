"""`parallel.fluid_ranks: 2`: `tunnelquake run` decomposes the water and runs it under
mpirun, and the coupled answer is the 1-rank answer.

The same short coupled run (condition dynamic_water: tq-solid + rhoPimpleFoam through the coupler,
implicit IQN-ILS every solid step) is made with fluid_ranks 1 and 2. The decomposition changes
only how the water's equations are solved (the same cells, faces and discretisation; the solvers'
sweeps and sums cross a processor boundary), so the two runs take the same passes and must agree
to round-off amplified through the implicit iterations: the interface force resultants and the
monitors' water pressures (their dynamic part) to TOL = 1e-6 of their peak, well inside the 1e-4
the issue asks for. Measured 1.5e-10 to 1.0e-9 (2026-11-21). The tolerance is set to catch a
processor-boundary error: before wallCellGaussGrad took the face value on processor faces (it
took the neighbour cell's), this case's force normal to the cut differed by 7.2e-5 of its peak
(and the slice of the example by 5e-6, docs/coupler.md) - a 1e-4 tolerance would have passed it.
And the 2-rank run must really have been decomposed: two processor folders holding 42 cells each
and each its own final time, the solver started in parallel (`nProcs : 2`), the fields
reconstructed.

The case is the example's, small for time: the coarse mesh of test_coupled_checks (84 water
cells, 42 a rank), elastic rock and lining, a block cut to 60 m x 52 m around the tunnel so that
the incident wave (one cycle of a 5 Hz sine under a Hann window at the base) reaches the lining
within 0.02 s; END_S of shaking (about 330 coupling windows).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
yaml = pytest.importorskip("yaml")
from conftest import COARSE_EXAMPLE_MESH, EXAMPLE, coupled_run_missing  # noqa: E402
from tunnelquake.cli import main  # noqa: E402

pytestmark = pytest.mark.skipif(coupled_run_missing(mpirun=True) is not None,
                                reason=str(coupled_run_missing(mpirun=True)))

COARSE = COARSE_EXAMPLE_MESH
PERIOD_S, PGA, END_S = 0.2, 1.0, 0.06
TOL = 1e-6  # of the peak (see the module's docstring)


def _write_case(folder: Path, ranks: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    data = yaml.safe_load(EXAMPLE.read_text())
    data["mesh"].update(COARSE)
    for m in data["materials"].values():
        m["model"] = "elastic"
    data["geometry"].update({"x_range": [-30.0, 30.0], "z_range": [6.0, 58.0]})
    data["conditions"] = ["dynamic_water"]
    t = np.arange(0.0, PERIOD_S + 5e-4, 1e-3)
    np.savetxt(folder / "motion.txt", np.c_[t, np.sin(np.pi * t / PERIOD_S) ** 2 * np.sin(2 * np.pi * t / PERIOD_S)],
               fmt="%.6f %.12e")
    data["ground_motion"] = {"source": "file", "file": "motion.txt", "format": "two_column", "units": "m/s^2",
                             "duration": f"{PERIOD_S} s", "pga": f"{PGA} m/s^2",
                             "vertical_ratio": data["ground_motion"]["vertical_ratio"], "cutoff_frequency": "10 Hz",
                             "baseline_correction": False, "convention": "incident"}
    data["time"] = {"end_time": f"{END_S} s"}
    data["output"].update({"history_interval": "1e-3 s", "snapshot_times": []})
    data["parallel"] = {"threads": 1, "fluid_ranks": ranks}
    p = folder / "case.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def _run(case: Path) -> Path:
    assert main(["run", str(case), "--no-post"]) == 0
    res = case.parent / "results" / "results_dynamic_water.h5"
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed", f.attrs["status"]
    return res


def _histories(res: Path) -> dict[str, np.ndarray]:
    """(time, value) series: the interface force resultants and the monitors' water pressures."""
    out = {}
    with h5py.File(res, "r") as f:
        for d in "xz":
            out[f"force_{d}"] = f[f"coupling/force_{d}"][:]
        for m in f["monitors"]:
            if "water_pressure" in f[f"monitors/{m}"]:
                out[f"{m}/water_pressure"] = f[f"monitors/{m}/water_pressure"][:]
        out["passes"] = np.array([f["coupling"].attrs["passes"], f["coupling"].attrs["windows"]])
    return out


def test_two_water_ranks_give_the_one_rank_answer(tmp_path):
    one = _histories(_run(_write_case(tmp_path / "ranks1", 1)))
    two_case = _write_case(tmp_path / "ranks2", 2)
    two = _histories(_run(two_case))

    # the 2-rank run was decomposed and ran on both ranks
    fluid = two_case.parent / "results" / "dynamic_water" / "fluid"
    log = (fluid / "log.decomposePar").read_text()
    cells = [int(x) for x in re.findall(r"^Processor \d+\s*\n\s*Number of cells = (\d+)", log, flags=re.M)]
    assert cells == [42, 42], log[-2000:]
    assert re.search(r"^nProcs\s*:\s*2\s*$", (fluid.parent / "fluid.log").read_text(), flags=re.M)
    last = {p.name: sorted((t.name for t in p.iterdir() if re.fullmatch(r"[0-9.e-]+", t.name)), key=float)[-1]
            for p in sorted(fluid.glob("processor*"))}
    assert sorted(last) == ["processor0", "processor1"], last
    assert len(set(last.values())) == 1 and float(last["processor0"]) >= END_S - 1e-9, last
    assert (fluid / last["processor0"] / "p").is_file()  # reconstructed
    assert (fluid / "log.reconstructPar").is_file()

    # same coupled answer
    print()
    for key in [k for k in one if k != "passes"]:
        a, b = one[key], two[key]
        np.testing.assert_array_equal(a[:, 0], b[:, 0])
        da, db = a[:, 1] - a[0, 1], b[:, 1] - b[0, 1]  # the dynamic part (the static one is the same)
        peak = np.max(np.abs(da))
        assert peak > 0, key
        diff = np.max(np.abs(da - db)) / peak
        print(f"{key}: peak {peak:.5g}, max |2 ranks - 1 rank| = {diff:.2e} of the peak")
        assert diff <= TOL, key
    print(f"passes / windows: 1 rank {one['passes']}, 2 ranks {two['passes']}")
