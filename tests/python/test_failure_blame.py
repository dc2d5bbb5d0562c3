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


def test_a_coupled_partner_busy_past_the_short_grace_is_left_to_meet_the_loss_by_itself(tmp_path, capsys):
    """The water killed (SIGKILL) while the solid, coupled, is 8 s into a long step or restart
    checkpoint (a checkpoint's fsyncs on a busy disk): longer than PARTNER_GRACE_S, which is for a
    partner still waiting for its connection. The coupled solid is given PARTNER_COUPLED_GRACE_S, meets
    the closed connection at its next exchange and stops saying so: not ended by `run` (no "did not
    stop" line, its own exit status, not -15), and the water is blamed."""
    import signal
    import time

    from tunnelquake.children import PARTNER_COUPLED_GRACE_S, PARTNER_GRACE_S

    busy_s = 8.0
    assert PARTNER_GRACE_S < busy_s < PARTNER_COUPLED_GRACE_S - 2.0
    addr = str(tmp_path / "wall.addr")
    solid = Side("solid", FAKE + ["--role", "solid", "--address-file", addr, "--busy-at-window", "5", "--busy-s",
                                  str(busy_s)], tmp_path / "solid.log", ENV, lambda line: False)
    fluid = Side("water", FAKE + ["--role", "fluid", "--address-file", addr], tmp_path / "fluid.log", ENV,
                 lambda line: False)
    deadline = time.monotonic() + 30
    while not any("busy for" in line for line in list(solid.lines)) and time.monotonic() < deadline:
        time.sleep(0.01)
    os.kill(fluid.proc.pid, signal.SIGKILL)
    failed = watch_pair(solid, fluid, grace=30.0, poll_s=0.02)
    for s in (solid, fluid):
        s.close()
    assert solid.coupled and fluid.coupled
    assert failed is fluid and fluid.proc.returncode == -9
    assert solid.ended_after is None and solid.proc.returncode not in (0, -15), solid.proc.returncode
    assert lost_its_partner(solid), solid.log.read_text()[-2000:]
    assert "did not stop" not in capsys.readouterr().out
