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


def case_region(case_path: str, variant: str | None, condition: str, window: int | None) -> dict:
    from tunnelquake.case import load_case
    from tunnelquake.scene import PARTICIPANTS, current_solid_mesh, subcycling_levels
    from tunnelquake.subcycle_levels import mesh_level_arrays, mesh_window_reach

    case = load_case(case_path, variant)
    d = case.data
    if "fluid" not in PARTICIPANTS[condition]:
        raise SystemExit(f"condition {condition!r} has no water coupled: no window is stepped again")
    k = int(window or d["coupling"]["window"])
    with current_solid_mesh(case) as mesh_h5:
        a = mesh_level_arrays(mesh_h5, d["materials"], subcycling_levels(d, condition),
                              float(d["time"]["safety_factor"]), float(d["time"].get("dt") or 0.0),
                              d["interface"]["model"], wet=True)
        out = mesh_window_reach(mesh_h5, a, k)
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
