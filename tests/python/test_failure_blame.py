"""Which side a failed coupled run blames (`children.root_failure`, used by `tunnelquake run`).

The first side to exit is not always the cause: a solid on MPI ranks whose rank is killed is ended
by mpirun only after the water, which saw the connection close at once, has already stopped with
"partner lost". Here two coupler participants (the fakes of `tunnelquake.coupling.fakes`, the real
coupler and its real messages) couple over TCP; one dies at a window inside a wrapper that, like
mpirun, lingers 2 s before it exits, so its partner is seen failing first. `watch_pair` must
blame the side that died, and a side that fails on its own as before.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from tunnelquake.children import Side, lost_its_partner, root_failure, watch_pair

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "scripts") + os.pathsep + os.environ.get("PYTHONPATH", "")}
FAKE = [sys.executable, "-m", "tunnelquake.coupling.fakes", "--token", "tok", "--windows", "40",
        "--n-theta", "16", "--n-layers", "1", "--timeout", "20"]


def _lingering(seconds: float) -> list[str]:
    """Like mpirun after one of its ranks died: the wrapper outlives the dead process by `seconds`,
    then exits 137 itself."""
    return ["sh", "-c", f'"$@"; sleep {seconds}; exit 137', "sh"]


def _pair(tmp_path: Path, dying: str, lingering: bool, linger_s: float = 2.0) -> tuple[Side, Side, Side | None]:
    addr = str(tmp_path / "wall.addr")
    cmds = {}
    for role in ("solid", "fluid"):
        cmd = FAKE + ["--role", role, "--address-file", addr]
        if role == dying:
            cmd += ["--die-at-window", "5"]
            if lingering:
                cmd = _lingering(linger_s) + cmd
        cmds[role] = cmd
    solid = Side("solid", cmds["solid"], tmp_path / "solid.log", ENV, lambda line: False)
    fluid = Side("water", cmds["fluid"], tmp_path / "fluid.log", ENV, lambda line: False)
    failed = watch_pair(solid, fluid, grace=30.0, poll_s=0.02)
    for s in (solid, fluid):
        s.close()
    return solid, fluid, failed


@pytest.mark.parametrize("dying", ["solid", "fluid"])
def test_the_side_that_died_is_blamed_though_its_partner_exited_first(tmp_path, dying):
    solid, fluid, failed = _pair(tmp_path, dying, lingering=True)
    died, partner = (solid, fluid) if dying == "solid" else (fluid, solid)
    # the partner exited first (it saw the closed connection while the wrapper lingered) ...
    assert partner.proc.returncode != 0 and died.proc.returncode == 137
    assert lost_its_partner(partner), partner.log.read_text()[-2000:]
    # ... and the one whose process died is the cause, whichever watch_pair saw first
    assert failed is died, (failed.name if failed else None, partner.log.read_text()[-2000:])
    assert root_failure(partner, died) is died


def test_a_side_that_fails_on_its_own_first_stays_blamed(tmp_path):
    solid, fluid, failed = _pair(tmp_path, "fluid", lingering=False)
    assert failed is fluid and not lost_its_partner(fluid)
    assert root_failure(fluid, solid) is fluid
    assert lost_its_partner(solid), solid.log.read_text()[-2000:]


def test_a_partner_that_died_first_is_left_to_end_by_itself_as_mpirun_ends_a_lost_rank(tmp_path, capsys):
    """mpirun ends a solid on ranks whose rank died in two waits of 5 s (children.PARTNER_CAUSE_GRACE_S;
    measured with the water on 2 ranks: 4.0 s after the water it had lost). A dying side that lingers 7 s,
    more than PARTNER_GRACE_S, after its partner saw it go is left to end by itself: its own exit status
    (137), not a SIGTERM from `run` (-15), no "did not stop" line, and it is blamed."""
    from tunnelquake.children import PARTNER_CAUSE_GRACE_S, PARTNER_GRACE_S

    assert PARTNER_GRACE_S < 7.0 < PARTNER_CAUSE_GRACE_S
    solid, fluid, failed = _pair(tmp_path, "solid", lingering=True, linger_s=7.0)
    assert lost_its_partner(fluid), fluid.log.read_text()[-2000:]
    assert solid.proc.returncode == 137, solid.proc.returncode
    assert failed is solid
    assert "did not stop" not in capsys.readouterr().out


def _busy_solid_water_killed(tmp_path: Path, busy_s: float, spin: bool = False) -> tuple[Side, Side, Side | None]:
    """A fake solid, coupled, busy `busy_s` s at window 5 (asleep, or `spin`: on the CPU all along, as a
    busy wait in an MPI call); the water killed (SIGKILL) once the solid says it is busy; watch_pair
    as `run` calls it."""
    import signal
    import time

    addr = str(tmp_path / "wall.addr")
    solid = Side("solid", FAKE + ["--role", "solid", "--address-file", addr, "--busy-at-window", "5", "--busy-s",
                                  str(busy_s)] + (["--busy-spin"] if spin else []), tmp_path / "solid.log", ENV,
                 lambda line: False)
    fluid = Side("water", FAKE + ["--role", "fluid", "--address-file", addr], tmp_path / "fluid.log", ENV,
                 lambda line: False)
    deadline = time.monotonic() + 30
    while not any("busy for" in line for line in list(solid.lines)) and time.monotonic() < deadline:
        time.sleep(0.01)
    os.kill(fluid.proc.pid, signal.SIGKILL)
    failed = watch_pair(solid, fluid, grace=30.0, poll_s=0.02)
    for s in (solid, fluid):
        s.close()
    return solid, fluid, failed


def test_a_coupled_partner_busy_past_the_short_grace_is_left_to_meet_the_loss_by_itself(tmp_path, capsys):
    """The water killed (SIGKILL) while the solid, coupled, is 8 s into a long step or restart
    checkpoint (a checkpoint's fsyncs on a busy disk): longer than PARTNER_GRACE_S, which is for a
    partner still waiting for its connection. The coupled solid is given PARTNER_COUPLED_GRACE_S, meets
    the closed connection at its next exchange and stops saying so: not ended by `run` (no "did not
    stop" line, its own exit status, not -15), and the water is blamed."""
    from tunnelquake.children import PARTNER_COUPLED_GRACE_S, PARTNER_GRACE_S

    busy_s = 8.0
    assert PARTNER_GRACE_S < busy_s < PARTNER_COUPLED_GRACE_S - 2.0
    solid, fluid, failed = _busy_solid_water_killed(tmp_path, busy_s)
    assert solid.coupled and fluid.coupled
    assert failed is fluid and fluid.proc.returncode == -9
    assert solid.ended_after is None and solid.proc.returncode not in (0, -15), solid.proc.returncode
    assert lost_its_partner(solid), solid.log.read_text()[-2000:]
    assert "did not stop" not in capsys.readouterr().out


@pytest.mark.parametrize("spin", [False, True], ids=["asleep", "spinning"])
def test_a_partner_ended_by_run_is_said_to_be_asleep_or_busy_as_it_was(tmp_path, capsys, monkeypatch, spin):
    """A partner that has not met the loss when its grace ends (here 2 s, the fake solid busy 6 s) is
    ended by `run`, which says what its process was doing over the grace, as /proc measured it: asleep
    with no CPU (waiting: a message, a lock) or running with about the grace's seconds of CPU (a long
    step, or a busy wait in an MPI call that another rank never reached)."""
    import re

    from tunnelquake import children

    monkeypatch.setattr(children, "PARTNER_COUPLED_GRACE_S", 2.0)
    solid, fluid, failed = _busy_solid_water_killed(tmp_path, 6.0, spin)
    out = capsys.readouterr().out
    assert failed is fluid and solid.proc.returncode == -15, solid.proc.returncode
    assert solid.ended_after is not None and 2.0 <= solid.ended_after < 3.5, solid.ended_after
    said = re.search(rf"solid did not stop within 2 s: ending it \(pid {solid.proc.pid}\); its processes: .*"
                     rf"\(pid {solid.proc.pid}\) ([a-z ]+?)(?: in \S+)?, ([0-9.]+) s of CPU in the last 2\.[0-9] s", out)
    assert said, out
    state, cpu = said.group(1), float(said.group(2))
    if spin:
        assert state == "running" and cpu >= 1.0, said.group(0)  # of 2 s; a second core is free
    else:
        assert state == "sleeping" and cpu < 0.3, said.group(0)


def test_a_partner_writing_to_disk_is_left_to_end_by_itself(tmp_path, capsys, monkeypatch):
    """A partner in uninterruptible I/O wait when its grace ends (a restart checkpoint's fsync on a
    disk busy with other writes) is writing, not hung: `run` says so and leaves it up to
    PARTNER_DISK_GRACE_S more, so it meets the loss and stops by itself with its own exit status and
    its checkpoint whole. The state D is simulated (children.in_disk_wait reports the solid's process
    for the first 4 s of the grace's overrun): a real one needs a disk slower than this machine's."""
    import time

    from tunnelquake import children

    monkeypatch.setattr(children, "PARTNER_COUPLED_GRACE_S", 2.0)
    real = children.in_disk_wait
    first: list[float] = []

    def writing(pids, **kw):
        first.append(first[0] if first else time.monotonic())
        return {pids[0]: "simulated_fsync"} if time.monotonic() - first[0] < 4.0 else real(pids, **kw)

    monkeypatch.setattr(children, "in_disk_wait", writing)
    solid, fluid, failed = _busy_solid_water_killed(tmp_path, 5.0)
    out = capsys.readouterr().out
    assert first, "the grace ended without asking whether the partner writes to disk"
    assert "solid did not stop within 2 s, but is writing to disk" in out, out
    assert "ending it" not in out, out
    assert failed is fluid and solid.ended_after is None and solid.proc.returncode not in (0, -15)
    assert lost_its_partner(solid), solid.log.read_text()[-2000:]
