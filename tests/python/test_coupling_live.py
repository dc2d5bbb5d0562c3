"""The coupler driven from Python (its module, tunnelquake.coupling) over loopback TCP: the
fakes replay their prescriptions through every scheme and read them back exactly, handshake
refusals, a killed or hung partner (the fake's command line in another process)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from conftest import ROOT
from tunnelquake.coupling import (
    CouplingTimeoutError,
    FieldSpec,
    HandshakeError,
    Participant,
    PartnerLostError,
    ProtocolError,
    RingScenario,
)
from tunnelquake.coupling.fakes import FakeFluid, FakeSolid, History, pressure_to_force, ring_config

PY = [sys.executable, "-m", "tunnelquake.coupling.fakes"]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "scripts") + os.pathsep + os.environ.get("PYTHONPATH", "")}


def run_pair(a, b):
    """Runs a() in a thread and b() here; returns their exceptions (None when none)."""
    err = [None, None]

    def wrap(i, f):
        try:
            f()
        except Exception as e:  # noqa: BLE001 - handed back to the test
            err[i] = e

    t = threading.Thread(target=wrap, args=(0, a))
    t.start()
    wrap(1, b)
    t.join(30)
    return err


def participant(role, cfg, tmp_path, token="tok", timeout=5.0, **kw):
    return Participant(role, cfg, token, address_file=str(tmp_path / "wall.addr"), connect_timeout=timeout,
                       receive_timeout=timeout, **kw)


def ring_fakes(cfg, tmp_path, ring, token="tok"):
    s = FakeSolid(participant("solid", cfg, tmp_path, token), ring.solid_ids(), ring.solid_coordinates(),
                  lambda t: ring.velocity(t, True), ring.solid_triangles())
    f = FakeFluid(participant("fluid", cfg, tmp_path, token), ring.fluid_ids(), ring.fluid_coordinates(),
                  lambda t: ring.force(t, False))
    return s, f


def check_received(ring, cfg, solid_rx, fluid_rx):
    """Fluid: every pass reads the solid's velocity of that window. Solid: at each window start
    reads the converged force of the previous window. Exact (coincident map = permutation)."""
    dt = cfg.window_size
    n = 0
    for w, _k, got in fluid_rx:
        if w < cfg.max_windows:
            np.testing.assert_array_equal(got, ring.velocity((w + 1) * dt, on_solid=False))
            n += 1
    for w, k, got in solid_rx:
        if k == 0 and w > 0:
            np.testing.assert_array_equal(got, ring.force(w * dt, on_solid=True))
            n += 1
    return n


@pytest.mark.parametrize("scheme,passes", [("explicit", 1), ("paper", 2), ("implicit", 3)])
def test_fakes_replay_through_every_scheme(tmp_path, scheme, passes):
    ring = RingScenario(32, 2)
    cfg = ring_config(scheme, windows=8, tolerance=1e-10)
    s, f = ring_fakes(cfg, tmp_path, ring)
    rx = {}
    es, ef = run_pair(lambda: rx.__setitem__("s", s.run()), lambda: rx.__setitem__("f", f.run()))
    assert es is None and ef is None, (es, ef)
    assert s.passes == f.passes == 8 * passes
    assert check_received(ring, cfg, rx["s"], rx["f"]) == 8 * passes + 8


def test_history_replay_interpolates_linearly(tmp_path):
    ring = RingScenario(16, 1)
    times = np.array([0.0, 0.01])
    area = np.column_stack([np.cos(ring.theta(np.arange(16))), np.zeros(16), np.sin(ring.theta(np.arange(16)))])
    # pressure 0 → 1e5 Pa over 10 ms on 0.1 m² per node, pushing the lining outwards
    values = np.stack([pressure_to_force(np.full(16, p), 0.1 * area) for p in (0.0, 1e5)])
    path = tmp_path / "force.npz"
    np.savez(path, times=times, values=values, ids=ring.fluid_ids(), coordinates=ring.fluid_coordinates())
    h = History.load(path)
    np.testing.assert_allclose(h(0.0025)[:, 0], 0.25 * 1e4 * area[:, 0], rtol=1e-14, atol=1e-9)
    assert np.allclose(h(1.0), values[-1]) and np.allclose(h(-1.0), values[0])


def test_handshake_refuses_wrong_token_and_listener_keeps_waiting(tmp_path):
    ring = RingScenario(16, 1)
    cfg = ring_config("explicit", windows=2)
    a = participant("solid", cfg, tmp_path, "token-A", timeout=1.0)
    b = participant("fluid", cfg, tmp_path, "token-B", timeout=1.0)
    a.set_mesh_vertices("wall", ring.solid_ids(), ring.solid_coordinates())
    b.set_mesh_vertices("wall", ring.fluid_ids(), ring.fluid_coordinates())
    ea, eb = run_pair(a.initialize, b.initialize)
    assert isinstance(eb, HandshakeError) and "run token differs" in str(eb) and "token-A" not in str(eb)
    assert isinstance(ea, CouplingTimeoutError) and "refused: 'fluid' with a different run token" in str(ea)


@pytest.mark.parametrize("change,expect", [
    (lambda c: setattr(c, "window_size", 2e-3), "window size (s): here 0.001, 'fluid' has 0.002"),
    (lambda c: setattr(c, "scheme", "paper"), "scheme: here explicit, 'fluid' has paper"),
    (lambda c: setattr(c, "fields", [c.fields[0], FieldSpec("wall", "force", 1, "fluid", "conservative")]),
     "field #1 'force' components: here 3, 'fluid' has 1"),
])
def test_handshake_refuses_a_different_configuration(tmp_path, change, expect):
    ring = RingScenario(16, 1)
    cs, cf = ring_config("explicit", windows=2), ring_config("explicit", windows=2)
    change(cf)
    a, b = participant("solid", cs, tmp_path), participant("fluid", cf, tmp_path)
    a.set_mesh_vertices("wall", ring.solid_ids(), ring.solid_coordinates())
    b.set_mesh_vertices("wall", ring.fluid_ids(), ring.fluid_coordinates())
    ea, eb = run_pair(a.initialize, b.initialize)
    assert isinstance(ea, HandshakeError) and expect in str(ea), ea
    assert isinstance(eb, HandshakeError) and "refused by its partner" in str(eb)


def test_handshake_refuses_a_different_interface_size(tmp_path):
    cfg = ring_config("explicit", windows=2)
    rs, rf = RingScenario(16, 1), RingScenario(15, 1)
    a, b = participant("solid", cfg, tmp_path), participant("fluid", cfg, tmp_path)
    a.set_mesh_vertices("wall", rs.solid_ids(), rs.solid_coordinates())
    b.set_mesh_vertices("wall", rf.fluid_ids(), rf.fluid_coordinates())
    ea, eb = run_pair(a.initialize, b.initialize)
    assert "has 16 nodes here and 15 on 'fluid'" in str(ea)
    assert isinstance(eb, HandshakeError) and "15 on 'fluid'" in str(eb)


def test_foreign_listener_is_refused_with_the_fault_named(tmp_path):
    """A connector that finds a foreign server at the published address (here one answering
    HTTP) stops with ProtocolError, fault bad_magic, the foreign bytes quoted; it does not wait
    for its timeout."""
    server = socket.create_server(("127.0.0.1", 0))
    (tmp_path / "wall.addr").write_text(f"tqcp 1 tcp 127.0.0.1 {server.getsockname()[1]}\n")

    def foreign():
        conn, _ = server.accept()
        with conn:
            conn.recv(65536)
            conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
            conn.recv(65536)  # the connector's REJECT, or its close

    ring = RingScenario(16, 1)
    p = participant("fluid", ring_config("explicit", windows=2), tmp_path, timeout=20.0)
    p.set_mesh_vertices("wall", ring.fluid_ids(), ring.fluid_coordinates())
    t0 = time.monotonic()
    with server:
        errors = run_pair(foreign, p.initialize)
    assert errors[0] is None, errors[0]
    e = errors[1]
    assert isinstance(e, ProtocolError) and e.fault == "bad_magic", e
    assert "'HTTP'" in str(e), str(e)
    assert time.monotonic() - t0 < 5.0  # far below the 20 s timeout


def _spawn(cmd):
    return subprocess.Popen(cmd, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_killed_partner_stops_the_other_side_at_once(tmp_path):
    ring = RingScenario(64, 2)
    cfg = ring_config("implicit", windows=50, tolerance=1e-8)
    proc = _spawn(PY + ["--role", "fluid", "--token", "tok", "--windows", "50", "--address-file",
                        str(tmp_path / "wall.addr"), "--hang-at-window", "4", "--timeout", "5"])
    try:
        p = participant("solid", cfg, tmp_path, timeout=10.0)
        killed_at = []
        timer = threading.Timer(0.5, lambda: (killed_at.append(time.monotonic()), proc.kill()))

        def motion(t):  # first called after the handshake: the kill comes while coupling
            if not timer.is_alive() and not timer.finished.is_set():
                timer.start()
            return ring.velocity(t, True)

        s = FakeSolid(p, ring.solid_ids(), ring.solid_coordinates(), motion)
        with pytest.raises(PartnerLostError) as e:
            s.run()
        waited = time.monotonic() - killed_at[0]
    finally:
        proc.kill()
        proc.wait()
    assert "waiting for DATA of window 5 of 50" in str(e.value) and "'fluid'" in str(e.value)
    assert "end of stream" in str(e.value) or "reset" in str(e.value)
    assert waited < 2.0  # from the kill: far below the 10 s timeout


def test_hung_partner_times_out_with_a_clear_message(tmp_path):
    ring = RingScenario(16, 1)
    cfg = ring_config("explicit", windows=50)
    proc = _spawn(PY + ["--role", "fluid", "--token", "tok", "--scheme", "explicit", "--windows", "50",
                        "--n-theta", "16", "--n-layers", "1", "--address-file", str(tmp_path / "wall.addr"),
                        "--hang-at-window", "2"])
    try:
        p = Participant("solid", cfg, "tok", address_file=str(tmp_path / "wall.addr"), connect_timeout=10.0,
                        receive_timeout=1.0)
        s = FakeSolid(p, ring.solid_ids(), ring.solid_coordinates(), lambda t: ring.velocity(t, True))
        t0 = time.monotonic()
        with pytest.raises(CouplingTimeoutError) as e:
            s.run()
    finally:
        proc.kill()
        proc.wait()
    assert "waiting for DATA of window 3 of 50" in str(e.value) and "within the timeout of 1 s" in str(e.value)
    assert 0.9 < time.monotonic() - t0 < 10.0



def _drive(p, writes, reads, prescription, save_at=-1, saved=None):
    """A fake's loop that saves the coupling state (save_state) once window `save_at` starts;
    returns (window, pass, values read) of every pass."""
    rx = []
    dt = p.config.window_size
    while p.is_coupling_ongoing():
        w, k = p.state.window, p.state.iteration
        rx.append((w, k, p.read_data("wall", reads)))
        p.write_data("wall", writes, prescription((w + 1) * dt))
        p.advance(p.get_max_time_step_size())
        if p.is_time_window_complete() and p.state.window == save_at:
            saved[p.name] = p.save_state()
    p.finalize()
    return rx


def test_resumed_pair_reads_what_the_uninterrupted_pair_read(tmp_path):
    """Restart (docs/coupler.md "Restart"): both sides save their state when window 3 of 6
    starts; a new pair resumed from those bytes reads, pass for pass, exactly what the
    uninterrupted pair read from window 3 on (implicit scheme, Aitken: the fluid relaxes its
    writes, so the passes carry state)."""
    ring = RingScenario(16, 2)
    cfg = ring_config("implicit", windows=6, tolerance=1e-10)

    def pair(tag, saved, resume=None):
        s = participant("solid", cfg, tmp_path / tag)
        f = participant("fluid", cfg, tmp_path / tag)
        s.set_mesh_vertices("wall", ring.solid_ids(), ring.solid_coordinates(), ring.solid_triangles())
        f.set_mesh_vertices("wall", ring.fluid_ids(), ring.fluid_coordinates())
        rx = {}

        def side(p, writes, reads, prescription):
            p.initialize_resumed(resume[p.name]) if resume else p.initialize()
            rx[p.name] = _drive(p, writes, reads, prescription, -1 if resume else 3, saved)

        err = run_pair(lambda: side(s, "velocity", "force", lambda t: ring.velocity(t, True)),
                       lambda: side(f, "force", "velocity", lambda t: ring.force(t, False)))
        assert err == [None, None], err
        return rx

    (tmp_path / "full").mkdir()
    (tmp_path / "resumed").mkdir()
    saved = {}
    full = pair("full", saved)
    assert set(saved) == {"solid", "fluid"}
    resumed = pair("resumed", {}, saved)
    for name in ("solid", "fluid"):
        later = [r for r in full[name] if r[0] >= 3]
        assert [r[:2] for r in resumed[name]] == [r[:2] for r in later]
        for a, b in zip(resumed[name], later, strict=True):
            np.testing.assert_array_equal(a[2], b[2])
