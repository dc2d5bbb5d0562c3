"""Fake participants ("solver dummies") that drive the coupler (its Python module, see
__init__.py) alone, for tests and for debugging one real solver against a fake partner:

- :class:`FakeSolid` replays a prescribed interface motion (wall velocity) and records the
  forces it receives;
- :class:`FakeFluid` replays a prescribed force history (or a pressure history turned into nodal
  forces) and records the motion it receives.

A prescription is any callable ``t -> array[nodes, 3]``: the analytic ring of the C++
``tq-coupler-dummy`` (:class:`RingScenario`, coupler/testing/ring_scenario.hpp), or
:class:`History`, a sampled history (HDF5 or .npz) replayed with linear interpolation in time.

Command line (the options of tq-coupler-dummy, and --history)::

    python -m tunnelquake.coupling.fakes --role fluid --token T --address-file run/wall.addr

A fake restarts as a solver does (docs/reliability.md "Restart"): with ``--checkpoint-dir DIR
--checkpoint-windows K`` it saves its participant's state (``save_state``) at the end of every K-th
window into ``DIR/fake-<window>.bin``; ``--resume-from FILE`` starts from such a file
(``initialize_resumed``) instead of window 0. A fake's own state is its prescription, a function of
the window alone.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from . import (
    CouplerError,
    CouplingConfig,
    FieldSpec,
    MeshSpec,
    Participant,
    RingScenario,
    mpi_finalize,
    mpi_initialize,
    mpi_split_world,
)

Prescription = Callable[[float], np.ndarray]


# ----------------------------------------------------------------------------- prescriptions
class History:
    """A sampled history values[k] at times[k] (shape [samples, nodes, components]) on nodes
    (ids, coordinates), replayed with linear interpolation in time (held constant outside).

    File layout (HDF5 or .npz): ``times`` [S] (s), ``values`` [S, N, C], ``ids`` [N],
    ``coordinates`` [N, 3] (m)."""

    def __init__(self, times, values, ids, coordinates):
        self.times = np.asarray(times, dtype=np.float64)
        self.values = np.asarray(values, dtype=np.float64)
        self.ids = np.asarray(ids, dtype=np.int64)
        self.coordinates = np.asarray(coordinates, dtype=np.float64).reshape(-1, 3)
        if self.values.ndim != 3 or self.values.shape[0] != len(self.times) or self.values.shape[1] != len(self.ids):
            raise ValueError(
                f"history: values must be [samples={len(self.times)}, nodes={len(self.ids)}, components], got {self.values.shape}"
            )
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("history: times must increase strictly")

    @classmethod
    def load(cls, path) -> History:
        path = Path(path)
        if path.suffix == ".npz":
            d = np.load(path)
            return cls(d["times"], d["values"], d["ids"], d["coordinates"])
        import h5py

        with h5py.File(path, "r") as f:
            return cls(f["times"][:], f["values"][:], f["ids"][:], f["coordinates"][:])

    def __call__(self, t: float) -> np.ndarray:
        i = int(np.searchsorted(self.times, t))
        if i <= 0:
            return self.values[0].copy()
        if i >= len(self.times):
            return self.values[-1].copy()
        a = (t - self.times[i - 1]) / (self.times[i] - self.times[i - 1])
        return (1 - a) * self.values[i - 1] + a * self.values[i]


def pressure_to_force(pressure: np.ndarray, area_vectors: np.ndarray) -> np.ndarray:
    """Nodal forces on the lining from a nodal water pressure (Pa): f = p·a, with a the
    node's tributary area vector (m²) pointing from the water into the lining."""
    return np.asarray(pressure, dtype=np.float64)[:, None] * np.asarray(area_vectors, dtype=np.float64)


# ----------------------------------------------------------------------------- fakes
def ring_config(scheme="implicit", windows=10, window_size=1e-3, acceleration="aitken", max_iterations=20,
                tolerance=1e-8, mapping="coincident", predictor="constant") -> CouplingConfig:
    """The configuration tq-coupler-dummy builds from the same options."""
    return CouplingConfig(
        first="solid", second="fluid", window_size=window_size, max_windows=windows, scheme=scheme,
        max_iterations=max_iterations, tolerance=tolerance, acceleration=acceleration, initial_relaxation=0.5,
        meshes=[MeshSpec("wall", mapping, "solid", 1e-6)],
        fields=[FieldSpec("wall", "velocity", 3, "solid", "consistent"),
                FieldSpec("wall", "force", 3, "fluid", "conservative")],
        predictor=predictor,
    )


class _Fake:
    role = ""
    writes = reads = ""

    def __init__(self, participant: Participant, ids, coordinates, prescription: Prescription, triangles=None,
                 mesh: str = "wall", die_at_window: int = -1, hang_at_window: int = -1,
                 busy_at_window: int = -1, busy_s: float = 0.0, busy_spin: bool = False,
                 checkpoint_dir: Path | None = None,
                 checkpoint_windows: int = 0, resume_from: Path | None = None):
        self.p = participant
        self.checkpoint_dir, self.checkpoint_windows = checkpoint_dir, checkpoint_windows
        self.resume_from = resume_from
        self.mesh = mesh
        self.prescription = prescription
        self.die_at, self.hang_at = die_at_window, hang_at_window
        self.busy_at, self.busy_s, self.busy_spin = busy_at_window, busy_s, busy_spin
        self.p.set_mesh_vertices(mesh, ids, coordinates, triangles)
        #: (window, pass, values read at the start of that pass)
        self.received: list[tuple[int, int, np.ndarray]] = []
        self.passes = 0

    def run(self) -> list[tuple[int, int, np.ndarray]]:
        """Runs the coupling to its end; returns what was read. Coupler errors propagate."""
        p = self.p
        if self.resume_from is not None:
            p.initialize_resumed(Path(self.resume_from).read_bytes())
        else:
            p.initialize()
        partner = "fluid" if self.role == "solid" else "solid"
        print(f"fake {self.role}: participant '{self.role}' coupled with '{partner}'", flush=True)
        window_size = p.config.window_size
        while p.is_coupling_ongoing():
            w, k = p.state.window, p.state.iteration
            if w == self.die_at:
                print(f"fake {self.role}: dying at window {w}", file=sys.stderr, flush=True)
                os._exit(9)
            if w == self.hang_at:
                print(f"fake {self.role}: hanging at window {w}", file=sys.stderr, flush=True)
                time.sleep(3600)
            if w == self.busy_at and k == 0:  # a long step or restart checkpoint: its exchange comes late
                print(f"fake {self.role}: busy for {self.busy_s:g} s at window {w}", flush=True)
                if self.busy_spin:  # on the CPU all along, as a busy wait in an MPI call
                    end = time.monotonic() + self.busy_s
                    while time.monotonic() < end:
                        pass
                else:
                    time.sleep(self.busy_s)
            self.received.append((w, k, p.read_data(self.mesh, self.reads)))
            p.write_data(self.mesh, self.writes, self.prescription((w + 1) * window_size))
            p.advance(p.get_max_time_step_size())
            self.passes += 1
            if self.checkpoint_windows > 0 and p.is_time_window_complete() \
                    and p.state.window % self.checkpoint_windows == 0:
                self.save(p.state.window)
        self.received.append((p.state.window, 0, p.read_data(self.mesh, self.reads)))
        p.finalize()
        return self.received


    def save(self, window: int) -> None:
        """The participant's state after `window` completed windows, written whole (by rename)."""
        path = Path(self.checkpoint_dir) / f"fake-{window:09d}.bin"
        part = path.with_suffix(".part")
        part.write_bytes(self.p.save_state())
        os.replace(part, path)


class FakeSolid(_Fake):
    """Replays a prescribed wall velocity; reads the force."""

    role, writes, reads = "solid", "velocity", "force"


class FakeFluid(_Fake):
    """Replays a prescribed force (N per node); reads the wall velocity."""

    role, writes, reads = "fluid", "force", "velocity"


# ----------------------------------------------------------------------------- command line
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tunnelquake.coupling.fakes", description=__doc__.split("\n\n")[0])
    ap.add_argument("--role", choices=["solid", "fluid"], required=True)
    ap.add_argument("--token", required=True)
    ap.add_argument("--transport", choices=["tcp", "mpi"], default="tcp")
    ap.add_argument("--address-file")
    ap.add_argument("--port", type=int, default=0)
    ap.add_argument("--listen", action="store_true")
    ap.add_argument("--connect", action="store_true")
    ap.add_argument("--bind", default="127.0.0.1")
    ap.add_argument("--scheme", default="implicit")
    ap.add_argument("--acceleration", default="aitken")
    ap.add_argument("--predictor", default="constant", choices=("constant", "linear", "damped"))
    ap.add_argument("--windows", type=int, default=10)
    ap.add_argument("--window-size", type=float, default=1e-3)
    ap.add_argument("--max-iterations", type=int, default=20)
    ap.add_argument("--tolerance", type=float, default=1e-8)
    ap.add_argument("--n-theta", type=int, default=64)
    ap.add_argument("--n-layers", type=int, default=2)
    ap.add_argument("--map", default="coincident")
    ap.add_argument("--timeout", type=float, default=10.0)
    ap.add_argument("--connect-timeout", type=float, default=10.0)
    ap.add_argument("--die-at-window", type=int, default=-1)
    ap.add_argument("--hang-at-window", type=int, default=-1)
    ap.add_argument("--busy-at-window", type=int, default=-1, help="sleep --busy-s s before this window's exchange")
    ap.add_argument("--busy-s", type=float, default=0.0)
    ap.add_argument("--busy-spin", action="store_true", help="spin on the CPU while busy instead of sleeping")
    ap.add_argument("--history", help="replay this HDF5/.npz history instead of the analytic ring scenario")
    ap.add_argument("--report", help="write 'key value' lines: windows, passes, max_error, error_kind, exit")
    ap.add_argument("--checkpoint-dir", type=Path, help="save the participant's state here (fake-<window>.bin)")
    ap.add_argument("--checkpoint-windows", type=int, default=0, help="... at the end of every K-th window")
    ap.add_argument("--resume-from", type=Path, help="start from this saved state instead of window 0")
    a = ap.parse_args(argv)
    restart = {"checkpoint_dir": a.checkpoint_dir, "checkpoint_windows": a.checkpoint_windows,
               "resume_from": a.resume_from}

    ring = RingScenario(a.n_theta, a.n_layers)
    cfg = ring_config(a.scheme, a.windows, a.window_size, a.acceleration, a.max_iterations, a.tolerance, a.map,
                      a.predictor)
    listen = True if a.listen else False if a.connect else None
    report: dict[str, str] = {}
    solid = a.role == "solid"
    rc = 0
    mpi = a.transport == "mpi"
    try:
        if mpi:  # one application of an MPMD mpirun job beside the partner's
            mpi_initialize()
            mpi_split_world(a.role, "fluid" if solid else "solid")
        p = Participant(a.role, cfg, a.token, transport=a.transport, address_file=a.address_file, listen=listen,
                        bind=a.bind, connect_port=a.port, connect_timeout=a.connect_timeout,
                        receive_timeout=a.timeout)
        if a.history:
            h = History.load(a.history)
            fake = (FakeSolid if solid else FakeFluid)(p, h.ids, h.coordinates, h,
                                                       die_at_window=a.die_at_window, hang_at_window=a.hang_at_window,
                                                       busy_at_window=a.busy_at_window, busy_s=a.busy_s,
                                                       busy_spin=a.busy_spin, **restart)
        elif solid:
            fake = FakeSolid(p, ring.solid_ids(), ring.solid_coordinates(), lambda t: ring.velocity(t, True),
                             ring.solid_triangles(), die_at_window=a.die_at_window, hang_at_window=a.hang_at_window,
                             busy_at_window=a.busy_at_window, busy_s=a.busy_s, busy_spin=a.busy_spin,
                             **restart)
        else:
            fake = FakeFluid(p, ring.fluid_ids(), ring.fluid_coordinates(), lambda t: ring.force(t, False),
                             ring.fluid_triangles(), die_at_window=a.die_at_window, hang_at_window=a.hang_at_window,
                             busy_at_window=a.busy_at_window, busy_s=a.busy_s, busy_spin=a.busy_spin,
                             **restart)
        received = fake.run()
        # Check what was read against the partner's prescription (analytic scenario only): the
        # fluid every pass (the solid's data are never relaxed), the solid at window starts.
        err = 0.0
        if not a.history:
            for w, k, got in received:
                if solid and (k != 0 or w == 0):
                    continue
                if not solid and w >= a.windows:
                    continue
                want = ring.force(w * a.window_size, True) if solid else ring.velocity((w + 1) * a.window_size, False)
                err = max(err, float(np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want)))))
        report.update(windows=str(p.state.window), passes=str(fake.passes), max_error=repr(err))
        print(f"fake {a.role}: {p.state.window} windows, {fake.passes} passes, "
              f"max relative error of received data {err:g}")
        parts = p.partner_part_nodes("wall")
        print(f"fake {a.role}: the partner in {len(parts)} part(s) of {' '.join(map(str, parts))} nodes")
        rc = 0 if err <= 1e-12 else 3
    except CouplerError as e:
        print(f"fake {a.role}: {type(e).__name__}: {e}", file=sys.stderr)
        report["error_kind"] = type(e).__name__
        rc = 2
    report["exit"] = str(rc)
    if a.report:
        Path(a.report).write_text("".join(f"{k} {v}\n" for k, v in report.items()))
    if mpi:
        mpi_finalize()
    return rc


if __name__ == "__main__":
    sys.exit(main())
