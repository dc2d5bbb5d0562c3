"""Shared fixtures: paths of the repository, the example case and the shared data."""
from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "cases" / "paper_tunnel" / "case.yaml"
SHARED = ROOT.parent / "shared"
EL_CENTRO = SHARED / "data" / "ground_motions" / "elCentro_1940_NS_Peknold_dt0.02.AT2"
EL_CENTRO_PEER = SHARED / "data" / "ground_motions" / "IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2"


@pytest.fixture
def example_text() -> str:
    return EXAMPLE.read_text()


@pytest.fixture
def write_case(tmp_path):
    """Write a case text into a temporary folder and return its path."""

    def _write(text: str, name: str = "case.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p

    return _write
