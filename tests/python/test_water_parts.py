"""The water on MPI ranks as parts of its coupler participant (docs/coupler.md "Water on several MPI
ranks", "A participant in parts"): each OpenFOAM rank exchanges the wetted-face points it owns with
the solid ranks that hold them, and no rank gathers the face.

A soft-rock slice (rock E = 1.5 GPa, 2,200 kg/m³, elastic lining) under one cycle of a 4 Hz sine,
condition dynamic_water only, END_S of shaking, run by `tunnelquake run CASE --ranks 2` with
`parallel.fluid_ranks: 2` (the coarse mesh: 42 water cells a rank) twice: with the water's ranks in
parts (the default) and with the gathered water (`TQ_WATER_GATHER=1`: the master holds the one
participant, the reference). Every sum of the parts is the gathered run's in the same order (each
point force added in rank order from zero on its owner as on the master; the scheme's norms, IQN-ILS's
Gram matrix and the divergence monitor's sums exact and added over the ranks as integers), so every
dataset and attribute of the results (but the wall times) must be bitwise equal, with the same passes.
Asserted too: the water coupled in 2 parts against 2 solid parts, each water rank holding a part of
the face, none all of it, the parts adding up to the gathered run's points.
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
from tunnelquake.compare import results_differences  # noqa: E402

pytestmark = pytest.mark.skipif(coupled_run_missing(mpirun=True) is not None,
                                reason=str(coupled_run_missing(mpirun=True)))

PERIOD_S, PGA, END_S = 0.25, 1.5, 0.1


def _write_case(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    data = yaml.safe_load(EXAMPLE.read_text())
    data["mesh"].update(COARSE_EXAMPLE_MESH)
    for m in data["materials"].values():
        m["model"] = "elastic"
    data["materials"]["rock"].update({"youngs_modulus": "1.5 GPa", "density": "2200 kg/m^3"})
    data["geometry"].update({"x_range": [-30.0, 30.0], "z_range": [6.0, 58.0]})
    data["conditions"] = ["dynamic_water"]
    t = np.arange(0.0, PERIOD_S + 5e-4, 1e-3)
    np.savetxt(folder / "motion.txt", np.c_[t, np.sin(2 * np.pi * t / PERIOD_S)], fmt="%.6f %.12e")
    data["ground_motion"] = {"source": "file", "file": "motion.txt", "format": "two_column", "units": "m/s^2",
                             "duration": f"{PERIOD_S} s", "pga": f"{PGA} m/s^2",
                             "vertical_ratio": data["ground_motion"]["vertical_ratio"], "cutoff_frequency": "10 Hz",
                             "baseline_correction": False, "convention": "incident"}
    data["time"] = {"end_time": f"{END_S} s", "subcycling": 0}
    data["output"].update({"history_interval": "1e-3 s", "snapshot_times": []})
    data["parallel"] = {"threads": 1, "fluid_ranks": 2}
    p = folder / "case.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def _run(case: Path) -> tuple[Path, str]:
    assert main(["run", str(case), "--ranks", "2", "--no-post"]) == 0
    res = case.parent / "results" / "results_dynamic_water.h5"
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed", f.attrs["status"]
        assert int(f["ranks"].attrs["ranks"]) == 2
    return res, (case.parent / "results" / "dynamic_water" / "fluid.log").read_text()


def test_water_ranks_in_parts_give_the_gathered_water_bitwise(tmp_path, monkeypatch):
    monkeypatch.setenv("TQ_WATER_GATHER", "1")
    gathered, glog = _run(_write_case(tmp_path / "gathered"))
    monkeypatch.delenv("TQ_WATER_GATHER")
    parts, plog = _run(_write_case(tmp_path / "parts"))

    coupled = r"participant 'fluid' coupled with 'solid' on mesh 'wall' \((\d+) points"
    g = re.search(coupled + r"\), scheme", glog)
    assert g, glog[-3000:]  # the gathered run: one participant on the master
    p = re.search(coupled + r" in 2 parts, one a rank, (\d+) on the master, against 2 parts of 'solid'\)", plog)
    assert p, plog[-3000:]
    total, master = int(p.group(1)), int(p.group(2))
    assert total == int(g.group(1)) and 0 < master < total, (total, master)

    with h5py.File(parts, "r") as f:
        passes, windows = int(f["coupling"].attrs["passes"]), int(f["coupling"].attrs["windows"])
        force = f["coupling/force_x"][:, 1]
    assert passes > windows > 0  # the implicit iteration ran
    assert np.max(np.abs(force - force[0])) > 0  # the water's force moved
    assert results_differences(gathered, parts) == []
    print(f"\n{windows} windows, {passes} passes; water face {total} points, {master} on rank 0, "
          f"{total - master} on rank 1; every dataset bitwise equal to the gathered water")
