"""What a coupling window's further passes would have to step again: the window's domain of dependence.

A window that the water does not accept is stepped again whole from its saved start (docs/coupler.md
"Windows of several steps"). Between two passes only the water's force on the wet wall differs, and an
explicit step carries a change one element ring further at most: a node's update reads the forces of
its own elements and its contributors (the contact's pairs) at that step, and an element reads its own
nodes. With subcycling a node of level L moves at every fine step but updates its velocity only every
2^L fine steps, and an element chunk of level L is evaluated every 2^L fine steps: at the fine steps
0, 2^L, 2·2^L, ... counted from the start of subcycling, so a window of a multiple of 2^top steps
starts with a step at which everything is due. So within the k
fine steps of a window only a region around the wet wall can differ from the first pass; everything
else is bitwise what the first pass computed.

This counts that region on a case's own mesh, levels and element chunks (subcycle_levels, tq-solid's
rule), for one window of the case's coupling.window steps, by following the steps of a window:

- a node is *changed* from its first update (at a step it is due) whose force may differ: the wet
  wall's from the first step on, any node with an element changed before, or with a contact
  partner changed before or loaded differently at that step (the contact predicts a pair's motion
  from both nodes' whole force);
- an element is *changed* from its first evaluation that reads a changed node (its stresses and
  history then differ for the rest of the window);
- a re-pass updates the changed nodes again, so it must evaluate every element with a changed node
  (a node's update sums all its elements), at its chunk's steps, and a whole chunk where any of its
  elements is needed (tq-solid evaluates chunks of 64).

The counts are an upper bound of what changes (a force that could differ is counted as differing);
tq-solid plans its re-passes by the same rule (Solver::planRepasses). It
prints, per level and in all, the elements, the changed ones and the needed ones, the element
evaluations of a re-pass against a whole pass (exact by element, and by tq-solid's chunks), the
changed nodes, and the node updates of a re-pass against a whole pass.

    PYTHONPATH=scripts:. .venv/bin/python -m benchmarks.repass_region CASE [--variant 3d]
        [--condition dynamic_water] [--window K]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np


def window_region(conn: np.ndarray, node_level: np.ndarray, chunk_level: np.ndarray, chunk_of: np.ndarray,
                  wet: np.ndarray, pairs: np.ndarray, steps: int) -> dict:
    """The domain of dependence of one window of `steps` fine steps (module docstring): conn (E, 8),
    node_level (N,), chunk_level (E,) the level each element is evaluated at, chunk_of (E,) a chunk id
    per element (unique across blocks), wet the nodes the water loads, pairs (P, 2) the contact's
    node pairs. Returns the counts (the keys printed by main)."""
    num_nodes, num_elems = len(node_level), len(conn)
    changed = np.zeros(num_nodes, dtype=bool)
    elem_changed = np.zeros(num_elems, dtype=bool)
    top = int(max(node_level.max(initial=0), chunk_level.max(initial=0)))
    evals_whole = 0
    for s in range(steps):  # tq-solid's fine steps since subcycling began, from a window's start
        active = max(lv for lv in range(top + 1) if s % (1 << lv) == 0)
        due = chunk_level <= active
        evals_whole += int(due.sum())
        elem_changed |= due & changed[conn].any(axis=1)
        force = np.zeros(num_nodes, dtype=bool)  # whose force at this step may differ
        force[conn[elem_changed & due].ravel()] = True
        force[wet] = True
        if len(pairs):  # a pair's force from both nodes' motion, or their forces of this step
            force[pairs[(changed | force)[pairs].any(axis=1)].ravel()] = True
        changed |= force & (node_level <= active)
    # the re-pass updates the changed nodes again, which needs every element of theirs at its chunk's steps
    needed = changed[conn].any(axis=1)
    chunk_needed = np.zeros(int(chunk_of.max()) + 1, dtype=bool)
    chunk_needed[chunk_of[needed]] = True
    by_chunk = chunk_needed[chunk_of]
    per_window = np.array([steps >> int(lv) for lv in range(top + 1)])  # evaluations a window by level
    levels = np.arange(top + 1)
    count = lambda mask: np.bincount(chunk_level[mask], minlength=top + 1)  # noqa: E731
    node_updates = per_window[node_level]
    return {
        "levels": levels, "elements": count(np.ones(num_elems, dtype=bool)), "changed": count(elem_changed),
        "needed": count(needed), "needed_by_chunk": count(by_chunk),
        "evals_whole": evals_whole, "evals_needed": int((per_window[chunk_level] * needed).sum()),
        "evals_by_chunk": int((per_window[chunk_level] * by_chunk).sum()),
        "nodes": num_nodes, "nodes_changed": int(changed.sum()),
        "updates_whole": int(node_updates.sum()), "updates_changed": int(node_updates[changed].sum()),
    }


def case_region(case_path: str, variant: str | None, condition: str, window: int | None) -> dict:
    from tunnelquake.case import load_case
    from tunnelquake.scene import PARTICIPANTS, current_solid_mesh, subcycling_levels
    from tunnelquake.subcycle_levels import CHUNK, mesh_level_arrays

    case = load_case(case_path, variant)
    d = case.data
    if "fluid" not in PARTICIPANTS[condition]:
        raise SystemExit(f"condition {condition!r} has no water coupled: no window is stepped again")
    k = int(window or d["coupling"]["window"])
    import h5py

    with current_solid_mesh(case) as mesh_h5:
        a = mesh_level_arrays(mesh_h5, d["materials"], subcycling_levels(d, condition),
                              float(d["time"]["safety_factor"]), float(d["time"].get("dt") or 0.0),
                              d["interface"]["model"], wet=True)
        with h5py.File(mesh_h5, "r") as f:
            conn = f["elements/connectivity"][()].astype(np.int64)
            wet = np.unique(f["faces/lining_inner"][()].ravel())
            pairs = (f["interfaces/rock_lining"][()].astype(np.int64)
                     if d["interface"]["model"] == "dynamic_contact" and "interfaces/rock_lining" in f
                     else np.zeros((0, 2), np.int64))
    chunk_of = np.zeros(len(conn), dtype=np.int64)
    first = 0
    for order in a.blocks:
        chunk_of[order] = first + np.arange(len(order)) // CHUNK
        first += (len(order) + CHUNK - 1) // CHUNK
    out = window_region(conn, a.node_level, a.chunk_level, chunk_of, wet, pairs, k)
    out.update(window=k, case=case_path, variant=variant or "", condition=condition)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case")
    ap.add_argument("--variant", default=None)
    ap.add_argument("--condition", default="dynamic_water")
    ap.add_argument("--window", type=int, default=None, help="fine steps a window (default the case's)")
    args = ap.parse_args(argv)
    r = case_region(args.case, args.variant, args.condition, args.window)
    print(f"{r['case']} {r['variant'] or '(no variant)'} {r['condition']}: windows of {r['window']} fine steps")
    print("level | elements | changed in a window | needed by a re-pass | in needed chunks")
    for lv in r["levels"]:
        print(f"{lv:5d} | {r['elements'][lv]:8d} | {r['changed'][lv]:19d} | {r['needed'][lv]:19d} | "
              f"{r['needed_by_chunk'][lv]:16d}")
    w = r["evals_whole"]
    print(f"element evaluations a window: whole pass {w}, re-pass {r['evals_needed']} by element "
          f"({r['evals_needed'] / w:.3f}), {r['evals_by_chunk']} by chunk ({r['evals_by_chunk'] / w:.3f})")
    print(f"nodes changed {r['nodes_changed']} of {r['nodes']} ({r['nodes_changed'] / r['nodes']:.3f}); node "
          f"updates a window {r['updates_whole']}, of changed nodes {r['updates_changed']} "
          f"({r['updates_changed'] / r['updates_whole']:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
