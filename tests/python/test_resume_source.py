"""The checkpoint a resume started from is kept until the condition completes (docs/reliability.md
"Restart", restart.keep_resume_source): tq-solid keeps its last two checkpoints, so once the resumed
run has written two newer ones the source is gone from the checkpoint folder; a second failure that
leaves those two damaged must still fall back to it.

Reference for the bitwise check: the same case run without interruption (tolerance 0: the solver is
deterministic, tests/python/test_restart.py)."""
from __future__ import annotations

import pytest
from test_checkpoint_integrity import _flip
from test_restart import _case_text, _copy, _start

from conftest import ran_case
from tunnelquake.case import load_case
from tunnelquake.cli import main
from tunnelquake.compare import results_differences as _differences
from tunnelquake.restart import KEPT, resume_plan

#: shaking simulated and checkpoint interval, s: checkpoints 1-4 at 0.05 ... 0.2 s
END, INTERVAL = 0.25, 0.05


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return ran_case(tmp_path_factory.mktemp("source_ref"), _case_text("no_water", END, INTERVAL), "--no-post")


def _killed_in(case_yaml, fault: str, *extra: str) -> None:
    """`tunnelquake run` whose tq-solid is killed (SIGKILL, a lost node) inside checkpoint `fault`."""
    proc = _start(case_yaml, *extra, env={"TQ_CHECKPOINT_FAULT": fault})
    out, _ = proc.communicate(timeout=240)
    assert proc.returncode == 1 and "tq-solid stopped (exit -9)" in out, out[-2000:]


def test_the_resume_source_outlives_two_newer_checkpoints_and_a_second_failure_falls_back_to_it(reference,
                                                                                                 tmp_path, capsys):
    """Killed inside checkpoint 2 (1 whole); resumed from 1 and killed again inside checkpoint 4, after
    2 and 3 were written, which took checkpoint 1 out of the checkpoint folder; then 2 and 3 found
    damaged (a bit flipped in each state). `run --resume` falls back to checkpoint 1, kept in
    <checkpoint>/resumed-from, names the damage, and ends bitwise equal to the run never stopped; the
    kept copy is dropped once the condition completed. Without the kept copy no intact checkpoint is
    left and the condition would run from the start."""
    case_yaml = _copy(reference, tmp_path)
    folder = case_yaml.parent / "results" / "no_water" / "checkpoint"
    _killed_in(case_yaml, "2:solid")
    assert (folder / "checkpoint-000001.json").is_file()
    _killed_in(case_yaml, "4:solid", "--resume")
    assert not (folder / "solid-000001.bin").exists()  # tq-solid's retention: its last two, 2 and 3
    assert {p.name for p in (folder / KEPT).iterdir()} == {"checkpoint-000001.json", "solid-000001.bin",
                                                          "results-000001.h5"}
    for seq in (2, 3):
        _flip(folder / f"solid-{seq:06d}.bin")

    what, _, _ = resume_plan(load_case(case_yaml))
    assert what["no_water"] == "checkpoint", what["no_water"].notes
    assert int(what["no_water"].point["sequence"]) == 1 and what["no_water"].point["kept"]
    notes = " ".join(what["no_water"].notes)
    assert "solid-000003.bin" in notes and "solid-000002.bin" in notes and "damaged" in notes, notes
    assert main(["run", str(case_yaml), "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    t1 = float(what["no_water"].point["time"])
    assert f"resume: no_water continues from its checkpoint at t = {t1:.6g} s" in out, out[-3000:]
    assert _differences(reference / "results" / "results_no_water.h5",
                        case_yaml.parent / "results" / "results_no_water.h5") == []
    assert not (folder / KEPT).exists()
