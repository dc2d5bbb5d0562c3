"""`tunnelquake run` keeps the motion an earlier run made (prepare.motion_and_figure with reuse)
only while the motion's keys, the contents of every record file it names and the code are the
same; the kept motion.h5 is the file a fresh processing writes, byte for byte."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tunnelquake import prepare
from tunnelquake.case import load_case

CASE = Path(__file__).resolve().parents[2] / "cases" / "pressure_tunnel"


@pytest.fixture
def case_dir(tmp_path):
    d = tmp_path / "case"
    shutil.copytree(CASE, d, ignore=shutil.ignore_patterns("results*"))
    return d


@pytest.fixture
def processed(monkeypatch) -> list:
    """One entry a processing of the motion."""
    out: list = []
    real = prepare.from_case

    def counting(*a, **kw):
        out.append(1)
        return real(*a, **kw)

    monkeypatch.setattr(prepare, "from_case", counting)
    return out


def _made(d):
    return prepare.motion_and_figure(load_case(d / "case.yaml"), reuse=True)


def test_the_motion_is_kept_until_a_key_or_a_record_file_changes(case_dir, processed, capsys):
    source, h5, fig = _made(case_dir)
    first = h5.read_bytes()
    said = capsys.readouterr().out
    assert len(processed) == 1 and fig.is_file() and "incident peaks" in said

    assert _made(case_dir) == (source, h5, fig)
    again = capsys.readouterr().out
    assert len(processed) == 1, "processed again with nothing changed"
    assert "motion: up to date" in again and "incident peaks" in again  # the earlier run's lines said again

    vertical = case_dir / "vertical.txt"  # a further component's record: its contents count
    vertical.write_text(vertical.read_text().replace("e-0", "1e-0", 1))
    _made(case_dir)
    assert len(processed) == 2

    text = (case_dir / "case.yaml").read_text()
    (case_dir / "case.yaml").write_text(text.replace("pga: 0.3 g", "pga: 0.31 g", 1))
    _made(case_dir)
    assert len(processed) == 3

    (case_dir / "case.yaml").write_text(text)  # back to the first keys and a fresh processing: same bytes
    vertical.write_text(vertical.read_text().replace("1e-0", "e-0", 1))
    (case_dir / "results" / prepare.MOTION_STAMP).unlink()
    _made(case_dir)
    assert len(processed) == 4 and h5.read_bytes() == first


def test_without_reuse_the_motion_is_made_again(case_dir, processed):
    _made(case_dir)
    assert prepare.motion_and_figure(load_case(case_dir / "case.yaml")) is not None  # `tunnelquake motion`
    assert len(processed) == 2
