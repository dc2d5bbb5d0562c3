"""The solid on MPI ranks, the Python side: `--ranks N` of `tunnelquake check` and `run` refuses,
before anything runs, what tq-solid cannot run on ranks yet (every case's staged analysis), naming
it; and the mpirun command line of a run on ranks (oversubscribed only where the cores are short).
The ranks themselves are tested in tests/cpp/test_ranks.cpp (tq-solid on 1-4 ranks against one process)."""
from __future__ import annotations

import shutil

import pytest

from conftest import EXAMPLE
from tunnelquake.cli import main
from tunnelquake.solid_ranks import solid_command


def test_check_with_one_rank_is_the_plain_check(capsys):
    assert main(["check", str(EXAMPLE), "--ranks", "1"]) == 0
    assert "is valid" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["check", "run"])
def test_ranks_above_one_are_refused_for_a_staged_case_naming_what_is_missing(command, capsys, tmp_path):
    assert main([command, str(EXAMPLE), "--ranks", "3"]) == 1
    captured = capsys.readouterr()
    assert "--ranks 3" in captured.err and "staged analysis" in captured.err
    assert "without --ranks" in captured.err  # the fix
    assert "is valid" not in captured.out and "running" not in captured.out  # refused before anything ran


def test_ranks_below_one_are_refused(capsys):
    assert main(["check", str(EXAMPLE), "--ranks", "0"]) == 1
    assert "give 1 or more" in capsys.readouterr().err


def test_one_rank_is_the_plain_command_line():
    assert solid_command("tq-solid", "in.h5", "r.h5", 2, 1) == ["tq-solid", "in.h5", "-o", "r.h5", "--threads", "2"]


@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_ranks_run_under_mpirun_oversubscribed_only_where_the_cores_are_short():
    fits = solid_command("tq-solid", "in.h5", "r.h5", 1, 2, cores=2)
    assert fits[1:3] == ["-np", "2"] and fits[-1] == "--distributed" and "--oversubscribe" not in fits
    assert fits[fits.index("tq-solid"):-1] == ["tq-solid", "in.h5", "-o", "r.h5", "--threads", "1"]
    short = solid_command("tq-solid", "in.h5", "r.h5", 1, 4, cores=2)
    assert "--oversubscribe" in short and short[short.index("-np") + 1] == "4"
