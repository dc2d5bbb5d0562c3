"""subcycle_levels.window_reach (check's estimate of a re-pass, benchmarks.repass_region): an explicit
step carries a change one element ring further.

A straight row of hexahedra, the water on the first end face: after k fine steps of one rate the
change has reached the nodes of the first k faces (the wall's nodes at the window's first step, one
face further at each step after), so the elements between them (k - 1) have read a changed node, and a
re-pass needs k elements (each changed node's update sums all its elements). With the row's far
part two levels coarser (steps of 4 dt), the change crosses into it only at those nodes' updates.
"""
import numpy as np

from tunnelquake.subcycle_levels import window_reach as window_region


def _row(n: int):
    """n unit hexahedra along x: face i holds nodes 4i..4i+3."""
    conn = np.array([[4 * i, 4 * i + 4, 4 * i + 5, 4 * i + 1, 4 * i + 3, 4 * i + 7, 4 * i + 6, 4 * i + 2]
                     for i in range(n)], dtype=np.int64)
    return conn, 4 * (n + 1)


def test_a_change_moves_one_ring_a_step_at_one_rate():
    conn, num_nodes = _row(40)
    for k in (1, 2, 5, 16):
        r = window_region(conn, np.zeros(num_nodes, np.int64), np.zeros(len(conn), np.int64),
                          np.arange(len(conn)), np.arange(4), np.zeros((0, 2), np.int64), k)
        assert r["changed"][0] == k - 1
        assert r["needed"][0] == k
        assert r["nodes_changed"] == 4 * k
        assert r["evals_whole"] == 40 * k and r["evals_needed"] == k * k


def test_a_coarse_node_takes_up_a_change_at_its_updates_only():
    # faces 0-10 at level 0, the rest at level 2 (updated and evaluated at the window's fine steps
    # 0, 4, 8, 12); within a step the elements are evaluated, then the due nodes updated. The wall
    # (face 0) takes up the change at step 0, face j at step j up to face 10 (step 10); element 10
    # (chunk level 0: it has level-0 nodes) reads face 10 at step 11 and again at 12, when face 11
    # (level 2) is due and takes it up; element 11 (level 2) is next evaluated at step 16, after the
    # window: faces 0-11 change, elements 0-10, and a re-pass needs element 11 too (face 11's sum)
    conn, num_nodes = _row(40)
    node_level = np.full(num_nodes, 2, np.int64)
    node_level[:44] = 0
    chunk_level = node_level[conn].min(axis=1)
    r = window_region(conn, node_level, chunk_level, np.arange(len(conn)), np.arange(4), np.zeros((0, 2), np.int64), 16)
    assert r["changed"][0] == 11 and r["changed"][2] == 0
    assert r["nodes_changed"] == 4 * 12
    assert r["needed"][0] == 11 and r["needed"][2] == 1
