"""The cores a run's solvers take: how many conditions run at once, tq-solid's OpenMP threads and
the way its idle threads wait. `tunnelquake run` (launch) starts the solvers with these and `check`'s
run-time estimate (scene.runtime_estimate, rates) counts the same threads."""
from __future__ import annotations

import os

#: Below this many solid elements `parallel.threads: 0` runs one thread: on the paper's slice
#: (1,464 elements, 1 s of shaking) 2 threads took 1.3x the wall time of one; on the 3D example's
#: half block of 16,104 elements 2 threads took 0.6-0.8x the wall of one, the least measured that
#: paid, rounded down (docs/benchmarks.md "The 3D example's axial mesh").
SMALL_MESH_ELEMENTS = 16000

#: spins of an idle OpenMP thread before it sleeps (GNU libgomp's GOMP_SPINCOUNT; its default is
#: 300,000, 0 with OMP_WAIT_POLICY=PASSIVE)
SOLID_SPINCOUNT = "10000"


def available() -> int:
    """The cores this process may use."""
    return len(os.sched_getaffinity(0))


def concurrent_conditions() -> int:
    """How many conditions may run at once: the cores this process may use (TQ_CONDITIONS_AT_ONCE
    overrides, e.g. 1 to run them one after the other)."""
    env = os.environ.get("TQ_CONDITIONS_AT_ONCE")
    if env:
        return max(1, int(env))
    return available()


def side_by_side(conditions_parts) -> bool:
    """Whether `run` runs the coupled conditions beside the solid-only ones (each then shares the
    cores with the other: `share` 2): both kinds present and more than one condition at once.
    `conditions_parts`: (condition, parts) pairs as scene.plan gives them."""
    water = any("fluid" in p for _, p in conditions_parts)
    alone = any("fluid" not in p for _, p in conditions_parts)
    return water and alone and concurrent_conditions() > 1


def solid_thread_count(threads: int, elements: int, share: int = 1) -> int:
    """tq-solid's OpenMP threads: `threads` (the case's `parallel.threads`) when set, else one on a
    small mesh (SMALL_MESH_ELEMENTS) and otherwise the cores divided among the `share` solvers that
    run at once: a team of threads on cores it shares with another solver waits at each parallel loop
    for a thread that is not running (three 3D runs side by side on 2 cores: 1 thread each 1.3-1.45x
    the steps a second of 2 threads each, docs/benchmarks.md "Threads of solvers side by side")."""
    if threads:
        return int(threads)
    return 1 if elements < SMALL_MESH_ELEMENTS else max(1, available() // max(1, share))


def solid_env() -> dict:
    """tq-solid's environment: an idle OpenMP thread spins briefly, then sleeps, unless the user set
    OMP_WAIT_POLICY or GOMP_SPINCOUNT. Spinning without end (a team's default on a loaded machine)
    took the cores from the water solver and the machine's other runs: 4 steps a second instead of
    ~2,800 on the slice. Sleeping at once (OMP_WAIT_POLICY=PASSIVE, used until 2026-11-22) costs a
    wake-up at each of the step's parallel loops: on the 3D paper mesh with 2 threads, 17.8-21.7 s
    for 3,968 subcycled steps against 12.3-16.0 s with 2,000-200,000 spins (docs/benchmarks.md
    "Solid subcycling and element order"); a few thousand spins bridge the gaps between the loops
    of one step and are spent long before the water's pass ends."""
    env = dict(os.environ)
    if "OMP_WAIT_POLICY" not in env and "GOMP_SPINCOUNT" not in env:
        env["GOMP_SPINCOUNT"] = SOLID_SPINCOUNT
    return env
