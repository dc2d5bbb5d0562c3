"""tq-solid coupled to the fake fluid (tunnelquake.coupling.fakes) over TCP (solid half;
docs/coupler.md "Solid adapter").

The solid is a lining ring slice (radius 4.5 m, 0.3 m thick, 1 m wide, outer face fixed) whose
`lining_inner` nodes are exactly the fake's RingScenario points (64 around, 2 layers), so the
`python -m tunnelquake.coupling.fakes` command line can be the fluid:

* the fluid process killed mid-run (SIGKILL-like `os._exit`) stops tq-solid at once with exit 4,
  a message naming the cause and the fix, and a readable results.h5 whose status says why;
* a hung fluid stops tq-solid after the coupling timeout, not before and not much later;
* a fluid replaying a force history to the end: tq-solid completes, the coupling summary counts
  every window, and the booked fluid work (/energy/fluid_work) equals the solver's external
  work (the only external force) to round-off.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

ROOT = Path(__file__).resolve().parents[2]
from tunnelquake.coupling import RingScenario  # noqa: E402
from tunnelquake.paths import solid_executable  # noqa: E402

ENV = {**os.environ, "PYTHONPATH": str(ROOT / "scripts") + os.pathsep + os.environ.get("PYTHONPATH", ""),
       "OMP_NUM_THREADS": "1", "OMP_WAIT_POLICY": "PASSIVE"}
EXE = solid_executable()
pytestmark = pytest.mark.skipif(EXE is None, reason="tq-solid is not built (set TQ_BUILD_DIR)")

N_THETA, R_IN, THICK, N_RAD, WIDTH = 64, 4.5, 0.3, 2, 1.0
DT = 2e-5  # solid step = coupling window (s); below the stable step of this ring
TOKEN = "solid-coupling-test"


def ring_mesh(path: Path) -> None:
    """Lining ring slice like tq::makeRingSliceMesh: node t + NT (r + NR y), faces lining_inner
    and outer (outward normals by the right-hand rule)."""
    nt, nr = N_THETA, N_RAD + 1
    xyz = np.zeros((nt * nr * 2, 3))
    for y in range(2):
        for r in range(nr):
            rad = R_IN + THICK * r / N_RAD
            th = 2 * np.pi * np.arange(nt) / nt
            i = np.arange(nt) + nt * (r + nr * y)
            xyz[i, 0], xyz[i, 1], xyz[i, 2] = rad * np.cos(th), y * WIDTH, rad * np.sin(th)

    def nid(t, r, y):
        return (t % nt) + nt * (r + nr * y)

    conn, inner, outer = [], [], []
    faces = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
    for r in range(N_RAD):
        for t in range(nt):
            c = [nid(t, r, 0), nid(t + 1, r, 0), nid(t + 1, r + 1, 0), nid(t, r + 1, 0),
                 nid(t, r, 1), nid(t + 1, r, 1), nid(t + 1, r + 1, 1), nid(t, r + 1, 1)]
            conn.append(c)
            if r == 0:
                inner.append([c[k] for k in faces[2]])
            if r == N_RAD - 1:
                outer.append([c[k] for k in faces[4]])
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-mesh"
        f.attrs["version"] = 1
        f.attrs["slice"] = 1
        f["/nodes/coordinates"] = xyz
        f["/elements/connectivity"] = np.array(conn, np.int32)
        f["/elements/region"] = np.zeros(len(conn), np.int32)
        f["/elements"].attrs["regions"] = ["lining"]
        f["/faces/lining_inner"] = np.array(inner, np.int32)
        f["/faces/outer"] = np.array(outer, np.int32)


def solid_input(path: Path, windows: int, timeout: float, address: Path) -> None:
    """Version 2 input: the seismic stage only (from rest), the coupling as the fake expects it
    (mesh 'wall', the solid writes velocity only, the fake's defaults for the rest)."""
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-input"
        f.attrs["version"] = 2
        f.attrs["condition"] = "dynamic_water"
        f.attrs["mesh"] = "mesh.h5"
        f.create_group("solver").attrs.update({"t_end": windows * DT, "dt": DT})
        f.create_group("damping").attrs.update({"alpha": 5.0, "beta": 0.0})
        f.create_group("materials/lining").attrs.update({"E": 28e9, "nu": 0.17, "rho": 2500.0})
        f.create_group("boundary/fixed/outer").attrs["directions"] = "xyz"
        f.create_group("stages").attrs["sequence"] = "seismic"
        f.create_group("output").attrs.update({"monitor_dt": 10 * DT, "progress_s": 100.0})
        c = f.create_group("coupling")
        c.attrs.update({"scheme": "explicit", "window": 1, "window_size": DT, "windows": windows,
                        "tolerance": 1e-8, "max_iterations": 20, "acceleration": "aitken",
                        "initial_relaxation": 0.5, "transport": "tcp", "address_file": str(address),
                        "token": TOKEN, "timeout": timeout, "connect_timeout": 15.0, "face": "lining_inner",
                        "mesh": "wall", "map": "coincident", "write_fields": "velocity"})


def start_fluid(tmp: Path, windows: int, timeout: float, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "tunnelquake.coupling.fakes", "--role", "fluid", "--token", TOKEN,
           "--address-file", str(tmp / "wall.addr"), "--scheme", "explicit", "--windows", str(windows),
           "--window-size", repr(DT), "--n-theta", str(N_THETA), "--n-layers", "2", "--timeout", str(timeout),
           "--connect-timeout", "15", *extra]
    return subprocess.Popen(cmd, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def run_pair(tmp: Path, windows: int, timeout: float, *fluid_args: str):
    ring_mesh(tmp / "mesh.h5")
    solid_input(tmp / "solid_input.h5", windows, timeout, tmp / "wall.addr")
    fluid = start_fluid(tmp, windows, timeout, *fluid_args)
    t0 = time.monotonic()
    solid = subprocess.run([str(EXE), str(tmp / "solid_input.h5"), "-o", str(tmp / "results.h5")], env=ENV,
                           capture_output=True, text=True, timeout=60)
    wall = time.monotonic() - t0
    try:
        fout, ferr = fluid.communicate(timeout=3)
    except subprocess.TimeoutExpired:  # a hung fake: end it (it is ours)
        fluid.kill()
        fout, ferr = fluid.communicate(timeout=10)
    return solid, wall, fluid.returncode, fout + ferr


def read_results(path: Path) -> dict:
    with h5py.File(path, "r") as f:  # readable after a stop
        status = f.attrs["status"]
        out = {"status": status.decode() if isinstance(status, bytes) else str(status),
               "energy": f["/energy/history"][...]}
        if "/energy/fluid_work" in f:
            out["fluid_work"] = f["/energy/fluid_work"][...]
        if "coupling" in f:
            out["coupling"] = dict(f["coupling"].attrs)
        return out


def test_killed_fluid_stops_the_solid_with_a_clear_message(tmp_path):
    solid, wall, frc, flog = run_pair(tmp_path, 400, 10.0, "--die-at-window", "150")
    assert frc == 9, flog
    assert solid.returncode == 4, solid.stdout + solid.stderr
    assert wall < 10.0  # at once (end of stream), not after the 10 s timeout
    assert "water coupling" in solid.stderr and "stopped or closed the connection" in solid.stderr
    assert "Fix:" in solid.stderr
    r = read_results(tmp_path / "results.h5")
    assert r["status"].startswith("stopped: water coupling")
    assert "window 151 of 400" in r["status"]  # it says where (1-based: the 151st window)
    assert r["coupling"]["windows"] == 150  # every window before the fluid died was completed
    t = r["energy"][:, 0]
    assert t[-1] == pytest.approx(150 * DT, rel=1e-6)  # samples up to the stop are there


def test_hung_fluid_stops_the_solid_after_the_timeout(tmp_path):
    timeout = 2.0
    solid, wall, frc, flog = run_pair(tmp_path, 400, timeout, "--hang-at-window", "50")
    assert solid.returncode == 4, solid.stdout + solid.stderr
    assert "within the coupling timeout of 2 s" in solid.stderr and "raise coupling.timeout" in solid.stderr
    assert timeout <= wall < timeout + 8.0
    r = read_results(tmp_path / "results.h5")
    assert r["status"].startswith("stopped: water coupling") and "timeout" in r["status"]
    assert r["coupling"]["windows"] == 50


def test_completed_run_books_the_fluid_work(tmp_path):
    """A constant-in-time pressure history (uniform 1 MPa on the RingScenario points) replayed to
    the end: tq-solid completes; fluid work = external work (the only external force)."""
    windows = 300
    ring = RingScenario(N_THETA, 2)
    xyz = ring.fluid_coordinates()
    # Tributary area vector of each interface node, pointing from the water into the lining (outwards).
    r = np.hypot(xyz[:, 0], xyz[:, 2])
    area = 2 * np.pi * R_IN / N_THETA * WIDTH / 2
    normal = np.column_stack([xyz[:, 0] / r, np.zeros(len(r)), xyz[:, 2] / r])
    f = 1e6 * area * normal
    np.savez(tmp_path / "force.npz", times=np.array([0.0, 1.0]), values=np.stack([f, f]), ids=ring.fluid_ids(),
             coordinates=xyz)
    solid, wall, frc, flog = run_pair(tmp_path, windows, 10.0, "--history", str(tmp_path / "force.npz"))
    assert frc == 0, flog
    assert solid.returncode == 0, solid.stdout + solid.stderr
    res = read_results(tmp_path / "results.h5")
    assert res["status"] == "completed"
    assert res["coupling"]["windows"] == windows and res["coupling"]["passes"] == windows
    c = res["coupling"]  # one pass a window: no solid time in re-passes
    assert c["solid_repasses_s"] == 0 and 0 < c["solid_first_passes_s"] <= c["solid_s"]
    ext = res["energy"][:, 5]
    fw = res["fluid_work"][:, 1]
    assert np.allclose(res["fluid_work"][:, 0], res["energy"][:, 0])
    assert fw[-1] > 0
    assert np.max(np.abs(fw - ext)) <= 1e-9 * np.max(np.abs(ext))
