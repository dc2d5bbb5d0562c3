"""tq-solid's OpenMP threads (solid_input.solid_threads): the cores are divided among the solvers
that run at once, so that no team of threads waits at its parallel loops for a thread another
solver holds off its core (docs/benchmarks.md "Threads of solvers side by side")."""
import types

import h5py
import numpy as np

from tunnelquake import solid_input


def _mesh(path, elements):
    with h5py.File(path, "w") as f:
        f["elements/connectivity"] = np.zeros((elements, 8), dtype=np.int64)
    return path


def _case(threads):
    return types.SimpleNamespace(data={"parallel": {"threads": threads}})


def test_the_cores_are_divided_among_the_solvers_running_at_once(tmp_path, monkeypatch):
    monkeypatch.setattr(solid_input.os, "sched_getaffinity", lambda pid: set(range(4)), raising=False)
    big = _mesh(tmp_path / "big.h5", solid_input.SMALL_MESH_ELEMENTS + 1)
    small = _mesh(tmp_path / "small.h5", solid_input.SMALL_MESH_ELEMENTS - 1)
    assert solid_input.solid_threads(_case(0), big) == 4          # alone: every core
    assert solid_input.solid_threads(_case(0), big, share=2) == 2  # beside another condition
    assert solid_input.solid_threads(_case(0), big, share=3) == 1
    assert solid_input.solid_threads(_case(0), big, share=8) == 1  # never none
    assert solid_input.solid_threads(_case(0), small, share=1) == 1  # a small mesh: one thread
    assert solid_input.solid_threads(_case(3), big, share=2) == 3  # the case's own value is kept
