"""tq-solid as one application of an MPMD mpirun job, coupled over MPI to the fake fluid
("TCP on loopback by default, MPI when launched under mpirun"; docs/coupler.md
"tq-solid under mpirun").

The solid is the lining ring slice of test_solid_coupling.py (a = 4.5 m, b = 4.8 m, outer face
fixed, plane strain); the fake fluid (`python -m tunnelquake.coupling.fakes --history`) prescribes
a uniform internal pressure p = 1 MPa from t = 0 as nodal forces (tributary arc length × width).

* The same run over TCP (two processes) and under `mpirun -np 1 tq-solid : -np 1 python ...`
  over MPI: the results files agree to round-off (every physics dataset), and the response is the
  physical one — with a strong mass damping (α = 4e4 1/s, about critical for the lowest
  through-thickness mode, ω ≈ 2e4 rad/s) the ring settles within the run, and
  (1) the inner wall's radial displacement equals the plane-strain Lamé solution for a ring with
      its outer face held, u(a) = a ε_θ with σ_r(a) = −p, σ_θ(a) from
      tunnelquake.references.lined_tunnel_internal_pressure with a rigid rock (G_m → ∞), within
      1 % (the mesh has 2 one-point linear elements through 0.3 m: the Lamé field u = A r + B/r
      is nearly linear there; measured error +0.15 %);
  (2) the booked fluid work equals the solver's external work to round-off (the reference of
      test_solid_coupling.py::test_completed_run_books_the_fluid_work), and equals F · u(a) of the
      closed form (a constant force from rest on a damped system at rest at the end: all its
      work, half stored and half dissipated), within the same 1 % (measured +0.15 %).
* Faults under mpirun: the fluid dying mid-run (os._exit, no MPI_Finalize) makes mpirun end the
  job with SIGTERM; tq-solid turns it into a clear message, a readable results file whose status
  says why, exit 4 (no MPI_Finalize: it would wait for the dead process). A hung fluid: tq-solid
  stops after the coupling timeout and ends the job with MPI_Abort (the fluid would never reach
  MPI_Finalize).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

import test_solid_coupling as base  # noqa: E402  (the ring, its input and the results reader)

ROOT = base.ROOT
from tunnelquake.coupling import RingScenario, have_mpi  # noqa: E402
from tunnelquake.references import lined_tunnel_internal_pressure  # noqa: E402

MPIRUN = shutil.which("mpirun")

pytestmark = [
    pytest.mark.skipif(base.EXE is None, reason="tq-solid is not built (set TQ_BUILD_DIR)"),
    pytest.mark.skipif(MPIRUN is None, reason="no mpirun on PATH (Open MPI: apt-get install openmpi-bin)"),
    pytest.mark.skipif(not have_mpi(), reason="the coupler was built without MPI (the fake fluid's MPI transport)"),
]

P = 1e6          # Pa, internal pressure
ALPHA = 4e4      # 1/s, mass damping: the ring settles within the run
WINDOWS = 300    # × DT = 6 ms
E, NU = 28e9, 0.17
B_OUT = base.R_IN + base.THICK


def mpirun_flags() -> list[str]:
    """Open MPI on a small machine as root: the flags docs/coupler.md gives for the launch."""
    flags = ["--oversubscribe", "--bind-to", "none", "--mca", "mpi_yield_when_idle", "1"]
    return flags + (["--allow-run-as-root"] if os.geteuid() == 0 else [])


def prepare(tmp: Path, transport: str, windows: int, timeout: float) -> None:
    """Mesh, solid input (the base test's, with the damping, a final snapshot and the transport),
    and the fluid's force history: uniform pressure P on the RingScenario points."""
    base.ring_mesh(tmp / "mesh.h5")
    base.solid_input(tmp / "solid_input.h5", windows, timeout, tmp / "wall.addr")
    with h5py.File(tmp / "solid_input.h5", "a") as f:
        f["damping"].attrs["alpha"] = ALPHA
        f["output/snapshot_times"] = np.array([windows * base.DT])
        f["coupling"].attrs["transport"] = transport
    ring = RingScenario(base.N_THETA, 2)
    xyz = ring.fluid_coordinates()
    r = np.hypot(xyz[:, 0], xyz[:, 2])
    area = 2 * np.pi * base.R_IN / base.N_THETA * base.WIDTH / 2  # tributary area of a node
    f = P * area * np.column_stack([xyz[:, 0] / r, np.zeros(len(r)), xyz[:, 2] / r])
    np.savez(tmp / "force.npz", times=np.array([0.0, 1.0]), values=np.stack([f, f]), ids=ring.fluid_ids(),
             coordinates=xyz)


def fluid_args(tmp: Path, transport: str, windows: int, timeout: float, *extra: str) -> list[str]:
    return [sys.executable, "-m", "tunnelquake.coupling.fakes", "--role", "fluid", "--token", base.TOKEN,
            "--transport", transport, "--address-file", str(tmp / "wall.addr"), "--scheme", "explicit",
            "--windows", str(windows), "--window-size", repr(base.DT), "--n-theta", str(base.N_THETA),
            "--n-layers", "2", "--timeout", str(timeout), "--connect-timeout", "15",
            "--history", str(tmp / "force.npz"), *extra]


def solid_args(tmp: Path) -> list[str]:
    return [str(base.EXE), str(tmp / "solid_input.h5"), "-o", str(tmp / "results.h5")]


def run_tcp(tmp: Path) -> subprocess.CompletedProcess:
    prepare(tmp, "tcp", WINDOWS, 10.0)
    fluid = subprocess.Popen(fluid_args(tmp, "tcp", WINDOWS, 10.0), env=base.ENV, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
    solid = subprocess.run(solid_args(tmp), env=base.ENV, capture_output=True, text=True, timeout=60)
    fout, _ = fluid.communicate(timeout=10)
    assert fluid.returncode == 0, fout
    return solid


def run_mpmd(tmp: Path, windows: int, timeout: float, *fluid_extra: str):
    """`mpirun ... -np 1 tq-solid ... : -np 1 python -m tunnelquake.coupling.fakes ... --transport mpi`."""
    prepare(tmp, "mpi", windows, timeout)
    cmd = [MPIRUN, *mpirun_flags(), "-np", "1", *solid_args(tmp), ":",
           "-np", "1", *fluid_args(tmp, "mpi", windows, timeout, *fluid_extra)]
    t0 = time.monotonic()
    r = subprocess.run(cmd, env=base.ENV, capture_output=True, text=True, timeout=60)
    return r, time.monotonic() - t0


def physics(path: Path) -> dict:
    """Every dataset of results.h5 that the run computes (timings and wall-clock attributes left out)."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith("timings"):
                out[name] = obj[...]
        f.visititems(visit)
    return out


def lame_inner_displacement() -> float:
    """u_r(a) of the plane-strain ring a ≤ r ≤ b under internal p with u(b) = 0: the lined-tunnel
    closed form with a rigid rock, σ_r(a) = −p, ε_θ = [(1 − ν²) σ_θ − ν (1 + ν) σ_r] / E."""
    ref = lined_tunnel_internal_pressure(P, base.R_IN, B_OUT, E, NU, 1e6 * E, 0.25)
    s_t, s_r = ref["hoop_inner"], -P
    return base.R_IN * ((1 - NU**2) * s_t - NU * (1 + NU) * s_r) / E


def inner_radial_displacement(path: Path) -> np.ndarray:
    """Radial displacement of the lining_inner nodes at the final snapshot (mesh.h5 beside it)."""
    with h5py.File(path, "r") as f:
        u = f["snapshots/0/u"][...]
    with h5py.File(path.parent / "mesh.h5", "r") as m:
        xyz = m["/nodes/coordinates"][...]
        inner = np.unique(m["/faces/lining_inner"][...])
    r = np.hypot(xyz[inner, 0], xyz[inner, 2])
    return (u[inner, 0] * xyz[inner, 0] + u[inner, 2] * xyz[inner, 2]) / r


def test_mpi_run_equals_tcp_run_and_the_closed_form(tmp_path):
    (tmp_path / "tcp").mkdir()
    (tmp_path / "mpi").mkdir()
    tcp = run_tcp(tmp_path / "tcp")
    assert tcp.returncode == 0, tcp.stdout + tcp.stderr
    mpi, _ = run_mpmd(tmp_path / "mpi", WINDOWS, 10.0)
    assert mpi.returncode == 0, mpi.stdout + mpi.stderr
    assert "over MPI" in mpi.stdout and "warning" not in mpi.stdout, mpi.stdout

    res_t = base.read_results(tmp_path / "tcp" / "results.h5")
    res_m = base.read_results(tmp_path / "mpi" / "results.h5")
    assert res_t["status"] == res_m["status"] == "completed"
    assert res_m["coupling"]["windows"] == res_m["coupling"]["passes"] == WINDOWS

    # The two transports carry the same bytes: the results agree to round-off, dataset by dataset.
    a, b = physics(tmp_path / "tcp" / "results.h5"), physics(tmp_path / "mpi" / "results.h5")
    assert sorted(a) == sorted(b)
    for name in a:
        scale = max(float(np.max(np.abs(a[name]))), 1e-300)
        assert np.max(np.abs(a[name] - b[name])) <= 1e-12 * scale, name

    # The physics: the settled ring against Lamé, and the work of the fluid's force.
    u_ref = lame_inner_displacement()
    ur = inner_radial_displacement(tmp_path / "mpi" / "results.h5")
    assert np.max(np.abs(ur / u_ref - 1)) < 0.01, (ur.min(), ur.max(), u_ref)
    ext, fw = res_m["energy"][:, 5], res_m["fluid_work"][:, 1]
    assert np.max(np.abs(fw - ext)) <= 1e-9 * np.max(np.abs(ext))
    work_ref = P * 2 * np.pi * base.R_IN * base.WIDTH * u_ref
    assert fw[-1] == pytest.approx(work_ref, rel=0.01)


def test_fluid_dying_under_mpirun_stops_the_solid_with_a_clear_message(tmp_path):
    r, wall = run_mpmd(tmp_path, 400, 30.0, "--die-at-window", "150")
    log = r.stdout + r.stderr
    assert r.returncode == 9, log  # mpirun passes on the fluid's exit code
    assert wall < 20.0, log  # at once (mpirun's SIGTERM), not after the 30 s coupling timeout
    # tq-solid's own message: what happened, where, and what to look at.
    assert "tq-solid: water coupling: exchange with 'fluid' failed" in log, log
    assert "SIGTERM arrived while waiting for the partner: mpirun is ending the job" in log, log
    assert "Fix: see the water solver's log" in log, log
    res = base.read_results(tmp_path / "results.h5")  # readable after the stop
    assert res["status"].startswith("stopped: water coupling") and "SIGTERM" in res["status"]
    assert res["coupling"]["windows"] == 150  # every window before the fluid died
    assert res["energy"][-1, 0] == pytest.approx(150 * base.DT, rel=1e-6)


def test_hung_fluid_under_mpirun_ends_the_job_after_the_timeout(tmp_path):
    timeout = 2.0
    r, wall = run_mpmd(tmp_path, 400, timeout, "--hang-at-window", "50")
    log = r.stdout + r.stderr
    assert r.returncode == 4, log  # tq-solid's code, through MPI_Abort
    assert timeout <= wall < timeout + 20.0, log  # MPI start-up included (3 s on the loaded machine)
    assert "within the coupling timeout of 2 s" in log, log
    assert "ending the MPI job (MPI_Abort, code 4): 'fluid' does not answer" in log, log
    res = base.read_results(tmp_path / "results.h5")
    assert res["status"].startswith("stopped: water coupling") and "timeout" in res["status"]
    assert res["coupling"]["windows"] == 50
