"""The water coupling of the solid on MPI ranks (docs/architecture.md "The water coupling on
ranks"): tq-solid on 1, 2, 3, 4 and 8 ranks (oversubscribed where the cores are short) coupled to the
fake water (tunnelquake.coupling.fakes replaying a pressure history) against the same coupled run as
one process.

The solid is the lining ring slice of test_solid_coupling (64 around, 2 through the thickness) with
its outer face held on one half only, under gravity (the section's area changes); the water's volume
law and its rigid translation are carried by the solid (compressible, K = 2.2 GPa, 1000 kg/m³: their
pressure implicit in each step from the sums over every wet node; the face y = WIDTH taken as a
plane of symmetry, /coupling symmetry_ymax); windows of 4 steps stepped again whole (implicit scheme: each window
restored and stepped again until the exchange converges). The water's pressure ovalises the ring and
pushes it along x (1 + cos 2θ + ½ cos θ around it) and pulses in time, so every monitored quantity
moves.

Each rank exchanges its own part of the wetted face (the wet nodes it owns) with the fake water over
its own connection; asserted: the water coupled with one part a rank, each part with the nodes that
rank says it owns, none with the whole face, the parts adding up to it (the water refuses parts that
do not cover its face once each), and every dataset of /monitors, /energy and /coupling (the works,
the coupling energy, the volume law's pressure, the wetted face's force and mean acceleration, the
water pressure at the monitors) on 2, 3, 4 and 8 ranks bitwise equal to the one-process run (every
node's force and mass is summed in the one-process order on any rank count, docs/architecture.md
"The solid on ranks"; the sums over the wet nodes are taken in that order on every rank, "The
water coupling on ranks"), but the whole-model energy sums (/energy/history, summed over each rank's
elements and then across ranks), within 1e-13 of the largest magnitude of their series (measured
5.7e-16 to 1.3e-15); the
/coupling counters (windows, passes) equal; on one rank (`--distributed` without other ranks) every
dataset bitwise equal.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_solid_coupling import N_THETA, R_IN, WIDTH, ring_mesh

from tunnelquake.coupling import RingScenario
from tunnelquake.paths import solid_executable
from tunnelquake.solid_ranks import solid_command

h5py = pytest.importorskip("h5py")

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "scripts") + os.pathsep + os.environ.get("PYTHONPATH", ""),
       "OMP_NUM_THREADS": "1", "OMP_WAIT_POLICY": "PASSIVE"}
EXE = solid_executable()
pytestmark = [pytest.mark.skipif(EXE is None, reason="tq-solid is not built (set TQ_BUILD_DIR)"),
              pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")]

DT, K_STEPS, WINDOWS = 2e-5, 4, 60  # solid step (s), steps a window, windows: 4.8 ms of shaking
TOKEN = "coupled-ranks-test"
#: the bound on the energy sums against the one-process run, relative to their series' peak
ENERGY_SUM_BOUND = 1e-13
#: the datasets summed over every element in rank order, not bitwise
RANK_ORDER_SUMS = ("energy/history",)


def half_held_ring(path: Path) -> None:
    """The ring with its outer face held on the half x > 0 only: under gravity the other half sags,
    and the section's area changes at first order (the volume law's pressure is no round-off)."""
    ring_mesh(path)
    with h5py.File(path, "a") as f:
        xyz = f["/nodes/coordinates"][...]
        outer = f["/faces/outer"][...]
        del f["/faces/outer"]
        f["/faces/outer"] = outer[xyz[outer, 0].mean(axis=1) > 0]


def solid_input(path: Path, address: Path) -> None:
    window = K_STEPS * DT
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-input"
        f.attrs["version"] = 2
        f.attrs["condition"] = "dynamic_water"
        f.attrs["mesh"] = "mesh.h5"
        f.create_group("solver").attrs.update({"t_end": WINDOWS * window, "dt": DT, "gravity_z": -9.81})
        f.create_group("damping").attrs.update({"alpha": 5.0, "beta": 0.0})
        f.create_group("materials/lining").attrs.update({"E": 28e9, "nu": 0.17, "rho": 2500.0})
        f.create_group("boundary/fixed/outer").attrs["directions"] = "xyz"
        f.create_group("stages").attrs["sequence"] = "seismic"
        f.create_group("output").attrs.update({"monitor_dt": window, "progress_s": 100.0})
        th = np.radians([0.0, 30.0, 90.0])
        pts = np.column_stack([R_IN * np.cos(th), np.full(3, 0.5 * WIDTH), R_IN * np.sin(th)])
        mg = f.create_group("monitors")
        mg["names"] = np.array(["crown", "shoulder", "side"], dtype=h5py.string_dtype())
        mg["points"] = pts
        c = f.create_group("coupling")
        c.attrs.update({"scheme": "implicit", "window": K_STEPS, "window_size": window, "windows": WINDOWS,
                        "tolerance": 1e-8, "max_iterations": 20, "acceleration": "aitken",
                        "initial_relaxation": 0.5, "transport": "tcp", "address_file": str(address),
                        "token": TOKEN, "timeout": 30.0, "connect_timeout": 30.0, "face": "lining_inner",
                        "mesh": "wall", "map": "coincident", "write_fields": "velocity",
                        "volume_law": "compressible", "bulk_modulus": 2.2e9, "water_density": 1000.0,
                        # the wet nodes of the face y = WIDTH as on a half block's plane of symmetry: the
                        # projection's volume column twice their area vectors there, so that the parts
                        # carry both vectors (a mix-up of the two would part from the one process)
                        "symmetry_ymax": 1})


def pressure_history(path: Path) -> None:
    """1 MPa × (1 + cos 2θ + ½ cos θ) around the ring (a resultant along x), pulsing as sin(2π t / 2 ms) ramped in over the run."""
    ring = RingScenario(N_THETA, 2)
    xyz = ring.fluid_coordinates()
    r = np.hypot(xyz[:, 0], xyz[:, 2])
    area = 2 * np.pi * R_IN / N_THETA * WIDTH / 2
    normal = np.column_stack([xyz[:, 0] / r, np.zeros(len(r)), xyz[:, 2] / r])
    theta = np.arctan2(xyz[:, 2], xyz[:, 0])
    shape = 1e6 * (1 + np.cos(2 * theta) + 0.5 * np.cos(theta))
    times = np.linspace(0.0, WINDOWS * K_STEPS * DT * 1.1, 60)
    amp = np.sin(2 * np.pi * times / 2e-3) * np.minimum(1.0, times / 1e-3)
    values = amp[:, None, None] * (shape[:, None] * area * normal)[None]
    np.savez(path, times=times, values=values, ids=ring.fluid_ids(), coordinates=xyz)


def run_coupled(tmp: Path, ranks: int | None) -> Path:
    """One coupled run in its own folder: `ranks` None is the one-process tq-solid, 1 is
    `--distributed` as a single rank, more under mpirun."""
    half_held_ring(tmp / "mesh.h5")
    solid_input(tmp / "solid_input.h5", tmp / "wall.addr")
    pressure_history(tmp / "force.npz")
    fluid = subprocess.Popen(
        [sys.executable, "-m", "tunnelquake.coupling.fakes", "--role", "fluid", "--token", TOKEN, "--address-file",
         str(tmp / "wall.addr"), "--scheme", "implicit", "--windows", str(WINDOWS), "--window-size",
         repr(K_STEPS * DT), "--n-theta", str(N_THETA), "--n-layers", "2", "--timeout", "30", "--connect-timeout",
         "30", "--history", str(tmp / "force.npz")], env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    res = tmp / "results.h5"
    if ranks is None:
        cmd = [str(EXE), str(tmp / "solid_input.h5"), "-o", str(res), "--threads", "1"]
    elif ranks == 1:
        cmd = [str(EXE), str(tmp / "solid_input.h5"), "-o", str(res), "--threads", "1", "--distributed"]
    else:
        cmd = solid_command(EXE, tmp / "solid_input.h5", res, 1, ranks)
    solid = subprocess.run(cmd, env=ENV, capture_output=True, text=True, timeout=240)
    try:
        fout, ferr = fluid.communicate(timeout=30)
    except subprocess.TimeoutExpired:  # a hung fake: end it (it is ours)
        fluid.kill()
        fout, ferr = fluid.communicate(timeout=10)
    assert solid.returncode == 0, solid.stdout + solid.stderr
    assert fluid.returncode == 0, fout + ferr
    if ranks and ranks > 1:
        # no rank holds the whole wetted face: each rank's part of the coupler carries the wet nodes it
        # owns, a node on a partition boundary in one part only (the water refuses parts that do not
        # cover its face once each), and the parts add up to the face
        said = re.search(r"each rank exchanges its own part of the wetted face's (\d+) nodes with the water "
                         r"\(the nodes it owns:([ \d]+)\)", solid.stdout)
        assert said, solid.stdout
        parts = [int(n) for n in said[2].split()]
        assert int(said[1]) == 2 * N_THETA and len(parts) == ranks, said[0]
        assert sum(parts) == 2 * N_THETA and max(parts) < 2 * N_THETA, parts
        print(f"{ranks} ranks: the wet nodes each rank exchanges: {parts}")
        # and the water's own count: one connection a rank, each with that rank's nodes (it checked
        # that they pair with its own once each before the first window)
        assert f"fake fluid: the partner in {ranks} part(s) of {' '.join(map(str, parts))} nodes" in fout, fout
    else:
        assert f"fake fluid: the partner in 1 part(s) of {2 * N_THETA} nodes" in fout, fout
    return res


def datasets(path: Path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] in ("completed", b"completed")
        for group in ("monitors", "energy", "coupling"):
            f[group].visititems(lambda name, obj, g=group: out.__setitem__(f"{g}/{name}", obj[...])
                                if isinstance(obj, h5py.Dataset) else None)
        out["coupling attrs"] = {k: f["coupling"].attrs[k] for k in ("windows", "passes", "max_passes")}
    return out


@pytest.fixture(scope="module")
def one_process(tmp_path_factory):
    return datasets(run_coupled(tmp_path_factory.mktemp("one_process"), None))


def test_one_rank_is_the_one_process_run_bitwise(one_process, tmp_path):
    ranked = datasets(run_coupled(tmp_path, 1))
    assert ranked["coupling attrs"] == one_process["coupling attrs"]
    assert one_process["coupling attrs"]["passes"] >= 2 * WINDOWS  # every window stepped again
    for name, ref in one_process.items():
        if name != "coupling attrs":
            assert np.array_equal(ranked[name], ref), name


@pytest.mark.parametrize("ranks", [2, 3, 4, 8])
def test_coupled_run_on_ranks_equals_the_one_process_run(one_process, tmp_path, ranks):
    ranked = datasets(run_coupled(tmp_path, ranks))
    assert ranked["coupling attrs"] == one_process["coupling attrs"]
    names = [n for n in one_process if n != "coupling attrs"]
    # what must be there: the works, the volume law's pressure, the wall's force and the monitors' water pressure
    for must in ("energy/coupling_energy", "energy/fluid_work", "coupling/volume_pressure", "coupling/force_x"):
        assert must in names
    assert any(n.startswith("monitors/") for n in names)
    worst = 0.0
    for name in names:
        ref, got = one_process[name], ranked[name]
        assert got.shape == ref.shape, name
        ref2, got2 = ref.reshape(len(ref), -1), got.reshape(len(got), -1)
        if not name.startswith("monitors/"):  # the histories of /energy and /coupling: column 0 is the time
            assert np.array_equal(got2[:, 0], ref2[:, 0]), name
            ref2, got2 = ref2[:, 1:], got2[:, 1:]
        peak = float(np.max(np.abs(ref2))) if ref2.size else 0.0  # the largest magnitude of its series
        if name[:-1] in ("coupling/force_", "coupling/acceleration_"):  # one vector: its largest component
            peak = max(float(np.max(np.abs(one_process[name[:-1] + c][:, 1]))) for c in "xyz")
        rel = float(np.max(np.abs(got2 - ref2))) / peak if peak > 0 else float(np.max(np.abs(got2), initial=0.0))
        print(f"{ranks} ranks: {name}: {rel:.2g} of its peak")
        worst = max(worst, rel)
        if name in RANK_ORDER_SUMS:
            assert rel <= ENERGY_SUM_BOUND, (name, rel)
        else:
            assert np.array_equal(got2, ref2), (name, rel)
    print(f"{ranks} ranks: largest difference of any monitored quantity {worst:.2g} of its peak")
    # the volume law carries a pressure of the water's order (no round-off compared with round-off): the
    # section's area changes as the free half sags and the x push moves it
    assert np.max(np.abs(one_process["coupling/volume_pressure"][:, 1])) > 1e-3 * 1e6


@pytest.mark.parametrize("what", ["transport mpi", "map projection"])
def test_what_the_coupled_run_on_ranks_cannot_honour_is_refused_before_it_connects(tmp_path, what):
    half_held_ring(tmp_path / "mesh.h5")
    solid_input(tmp_path / "solid_input.h5", tmp_path / "wall.addr")
    cmd = solid_command(EXE, tmp_path / "solid_input.h5", tmp_path / "results.h5", 1, 2)
    if what == "transport mpi":
        with h5py.File(tmp_path / "solid_input.h5", "a") as f:
            f["coupling"].attrs["transport"] = "mpi"
        named, fix = "/coupling transport mpi: the solid on ranks couples over TCP only", "set /coupling transport tcp"
    else:
        with h5py.File(tmp_path / "solid_input.h5", "a") as f:
            f["coupling"].attrs["map"] = "projection"
        named, fix = "/coupling map projection: the solid on ranks exchanges each rank's part", "set /coupling map coincident"
    solid = subprocess.run(cmd, env=ENV, capture_output=True, text=True, timeout=60)
    assert solid.returncode == 2, solid.stdout + solid.stderr
    assert named in solid.stderr and fix in solid.stderr, solid.stderr
    assert not (tmp_path / "wall.addr").exists()  # refused before it listened for the water
