"""The bootstrap finds everything, and a second run is a quick no-op that changes nothing."""
from __future__ import annotations

import os
import subprocess
import time

from conftest import ROOT

BOOTSTRAP = ROOT / "scripts" / "bootstrap.sh"


def _mtimes(paths):
    return {p: os.stat(p).st_mtime_ns for p in paths if p.exists()}


def test_bootstrap_check_finds_everything():
    out = subprocess.run(["bash", str(BOOTSTRAP), "--check"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    for part in ("Debian packages", "OpenFOAM v1912 headers", "Python environment", "libtqFoam.so", "tq-solid"):
        assert f"ok: {part}" in out.stdout or f"ok: built {part}" in out.stdout, out.stdout


def test_second_bootstrap_is_a_quick_no_op():
    watched = [ROOT / ".venv" / ".tq-stamp", ROOT / "build" / "build.ninja", ROOT / "build" / "CMakeCache.txt"]
    before = _mtimes(watched)
    t0 = time.perf_counter()
    out = subprocess.run(["bash", str(BOOTSTRAP)], capture_output=True, text=True, timeout=300)
    elapsed = time.perf_counter() - t0
    assert out.returncode == 0, out.stdout + out.stderr
    assert elapsed < 60.0, f"second bootstrap took {elapsed:.1f} s (the bootstrap's goal is under a minute)"
    assert "Debian packages: all present" in out.stdout
    assert "Python environment: up to date" in out.stdout
    assert "native build: up to date" in out.stdout
    assert _mtimes(watched) == before
