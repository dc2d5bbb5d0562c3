"""Two tq-solid builds on one input, side by side, each pinned to a core of its own: a benchmark, not a
test.

usage: python -m benchmarks.solid_side_by_side OUT --solid NAME=TQ_SOLID --solid NAME=TQ_SOLID INPUT.h5
           [--rounds 8] [--threads 1] [--json FILE]

Each round starts both programs at once (`tq-solid INPUT -o OUT/<name>.h5 --threads T`), each under
`taskset` on its own core, the one started first swapped every round and the cores every second
round (so each program runs first and second on each core alike), and reads each results file's
`/timings wall_s` (the shaking's wall; the static stages are before it). A shared VM's speed drifts by
±10–15 % from one minute to the next, more than many changes of the code move a run; two runs that
share the same minutes, the same memory and caches and each core in turn see the same drift, so
the ratio of each round is what compares (the median over the rounds), not the seconds. Printed and
written: each round's walls, cores and ratio of the second program to the first, the medians, the
machine line. Both results files must hold the same datasets (the programs' answers are compared
by `tunnelquake compare`, not here).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

from .common import machine


def parse_solid(text: str) -> tuple[str, Path]:
    """NAME=TQ_SOLID -> (name, program)."""
    name, sep, path = text.partition("=")
    if not sep or not name or not path:
        raise SystemExit(f"--solid {text!r}: give NAME=PATH (e.g. main=/work/main/build/solid_solver/tq-solid)")
    exe = Path(path).resolve()
    if not (exe.is_file() and os.access(exe, os.X_OK)):
        raise SystemExit(f"--solid {text!r}: {exe} is not an executable tq-solid")
    return name, exe


def shaking_wall(results: Path) -> float:
    """The results file's `/timings wall_s` (the seismic stage's wall, s)."""
    import h5py

    with h5py.File(results, "r") as f:
        return float(f["timings"].attrs["wall_s"])


def round_of(solids: list[tuple[str, Path]], inp: Path, out: Path, threads: int, cores: list[int]) -> dict:
    """One round: both programs started at once (in the order given), solids[i] pinned to cores[i];
    their walls."""
    procs = []
    for (name, exe), core in zip(solids, cores, strict=True):
        log = open(out / f"{name}.log", "w")  # noqa: SIM115 - closed below, once the program ends
        cmd = ["taskset", "-c", str(core), str(exe), str(inp), "-o", str(out / f"{name}.h5"), "--threads",
               str(threads)]
        procs.append((name, core, log, subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)))
    walls = {}
    for name, core, log, p in procs:
        rc = p.wait()
        log.close()
        if rc != 0:
            raise SystemExit(f"{name} exited {rc}: see {out / (name + '.log')}")
        walls[name] = {"wall_s": shaking_wall(out / f"{name}.h5"), "core": core}
    return walls


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.solid_side_by_side", description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path, help="folder for the results files and logs")
    ap.add_argument("input", type=Path, help="a tq-solid input (solid_input.h5)")
    ap.add_argument("--solid", action="append", default=[], help="NAME=TQ_SOLID, twice")
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--threads", type=int, default=1, help="each program's threads (default 1: a core each)")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    solids = [parse_solid(t) for t in a.solid]
    if len(solids) != 2 or solids[0][0] == solids[1][0]:
        raise SystemExit("give --solid twice, with two names")
    if shutil.which("taskset") is None:
        raise SystemExit("taskset is not installed (Debian: util-linux)")
    if (os.cpu_count() or 1) < 2:
        raise SystemExit("needs 2 cores: one for each program")
    if not a.input.is_file():
        raise SystemExit(f"{a.input}: no such input")
    a.out.mkdir(parents=True, exist_ok=True)
    rounds = []
    first, second = solids[0][0], solids[1][0]
    for r in range(a.rounds):
        cores = [(r // 2) % 2, 1 - (r // 2) % 2]  # solids[0]'s core, solids[1]'s
        order = [0, 1] if r % 2 == 0 else [1, 0]  # which starts first
        walls = round_of([solids[i] for i in order], a.input.resolve(), a.out, a.threads, [cores[i] for i in order])
        ratio = walls[second]["wall_s"] / walls[first]["wall_s"]
        rounds.append({"walls": walls, "ratio": ratio})
        print(f"round {r + 1}: {first} {walls[first]['wall_s']:.2f} s (core {walls[first]['core']}), "
              f"{second} {walls[second]['wall_s']:.2f} s (core {walls[second]['core']}), "
              f"{solids[order[0]][0]} started first, {second}/{first} {ratio:.3f}", flush=True)
    med = {n: statistics.median(x["walls"][n]["wall_s"] for x in rounds) for n in (first, second)}
    ratio = statistics.median(x["ratio"] for x in rounds)
    line = machine()
    print(f"medians: {first} {med[first]:.2f} s, {second} {med[second]:.2f} s; median ratio {second}/{first} "
          f"{ratio:.3f} over {len(rounds)} rounds\n{line}")
    if a.json:
        a.json.write_text(json.dumps({"input": str(a.input), "threads": a.threads, "rounds": rounds,
                                      "medians": med, "median_ratio": ratio, "machine": line}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
