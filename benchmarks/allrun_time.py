"""Wall time of the main job, `tunnelquake run CASE` (what `./Allrun` runs after the build), for
two or more trees of the code side by side: a benchmark, not a test.

usage: python -m benchmarks.allrun_time OUT --tree NAME=SRC[:BUILD] --tree NAME=SRC[:BUILD] ...
           [--case CASE.yaml] [--variant NAME] [--end SECONDS] [--rounds 3] [--json FILE]

CASE (default cases/paper_tunnel/case.yaml) is read from each tree when it is a relative path, so
that each tree runs its own version of the example; an absolute path is the same file for all.

Each tree is a checkout of this repository (SRC: its scripts/ are put first on PYTHONPATH) with
its native build (BUILD, default SRC/build, given to the run as TQ_BUILD_DIR). Every round runs
the case once with each tree, in an order that turns by one each round (so that a drift of the
machine's speed within a round does not favour one tree), each run from an empty results folder
(OUT/round<k>/<name>: the case file copied there, the record path made absolute; mesh, motion,
conditions and post all timed, as in a first `./Allrun`). Printed and written: each run's wall
seconds, the CPU seconds of its process tree (user + system of the children, `os.wait4`), the
1-minute load before it, each round's ratio of every tree to the first, and the medians. Ratios
within a round are what compares; wall seconds are the goal's figure only on a quiet machine.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from .common import machine
from .cost_error import lay

ROOT = Path(__file__).resolve().parent.parent


def parse_tree(text: str) -> tuple[str, Path, Path]:
    """NAME=SRC[:BUILD] -> (name, source tree, build folder)."""
    name, sep, rest = text.partition("=")
    if not sep or not name or not rest:
        raise SystemExit(f"--tree {text!r}: give NAME=SRC or NAME=SRC:BUILD (e.g. main=/work/main)")
    src, _, build = rest.partition(":")
    src_p = Path(src).resolve()
    build_p = Path(build).resolve() if build else src_p / "build"
    if not (src_p / "scripts" / "tunnelquake").is_dir():
        raise SystemExit(f"--tree {text!r}: {src_p} has no scripts/tunnelquake; give a checkout of this repository")
    if not build_p.is_dir():
        raise SystemExit(f"--tree {text!r}: no build folder {build_p}; build it (scripts/bootstrap.sh) or give :BUILD")
    return name, src_p, build_p


def write_case(base: dict, base_dir: Path, folder: Path, variant: str | None, end: float | None) -> Path:
    """FOLDER/case.yaml: the case with `variant` laid over it, cut to `end` s when given, its
    record path made absolute and its results in FOLDER/results."""
    import yaml

    d = copy.deepcopy(base)
    variants = d.pop("variants", None) or {}
    if variant:
        if variant not in variants:
            raise SystemExit(f"--variant {variant!r}: the case has variants {sorted(variants)}")
        lay(d, variants[variant])
    gm = d.get("ground_motion") or {}
    if gm.get("file"):
        gm["file"] = str((base_dir / gm["file"]).resolve())
    if end is not None:
        d.setdefault("time", {})["end_time"] = f"{end:g} s"
    d["output"] = {**d.get("output", {}), "directory": "results"}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "case.yaml"
    path.write_text("# python -m benchmarks.allrun_time\n" + yaml.safe_dump(d, sort_keys=False))
    return path


def run_env(src: Path, build: Path) -> dict:
    """The environment of `tunnelquake run` from tree `src` with build `build`, its OpenMP wait the
    product's own (OMP_WAIT_POLICY and GOMP_SPINCOUNT taken out, as run_once says)."""
    env = dict(os.environ, PYTHONPATH=str(src / "scripts"), TQ_BUILD_DIR=str(build))
    for name in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT"):
        env.pop(name, None)
    return env


def case_with_conditions(src: Path, conditions: list[str]) -> dict:
    """The case file `src` as a dict with these `conditions`, its variants' own conditions dropped (so
    that a variant laid over it by write_case keeps them)."""
    import yaml

    base = yaml.safe_load(src.read_text())
    base["conditions"] = list(conditions)
    for v in (base.get("variants") or {}).values():
        if isinstance(v, dict):
            v.pop("conditions", None)
    return base


def cut_case_parser(prog: str, doc: str, end: float, rounds: int) -> argparse.ArgumentParser:
    """The arguments of a benchmark that runs a variant of a case (default the example's `3d`) cut to
    its first END s, ROUNDS rounds: OUT, --case, --variant, --end, --rounds; parse with
    parse_cut_case."""
    ap = argparse.ArgumentParser(prog=prog, description=doc.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--case", type=Path, default=Path(__file__).resolve().parent.parent / "cases" / "paper_tunnel"
                    / "case.yaml")
    ap.add_argument("--variant", default="3d")
    ap.add_argument("--end", type=float, default=end, help=f"seconds of the record (default {end:g})")
    ap.add_argument("--rounds", type=int, default=rounds)
    return ap


def parse_cut_case(ap: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """cut_case_parser's arguments, refused where no round or no time would run."""
    a = ap.parse_args(argv)
    if a.rounds < 1 or not a.end > 0:
        raise SystemExit("give --rounds 1 or more and --end above 0 s")
    return a


def run_no_post(case: Path) -> float:
    """`tunnelquake run CASE --no-post` from this tree (its build, or $TQ_BUILD_DIR) into an empty
    results folder (CASE's folder/results), with run_env's environment; its log CASE's folder/run.log.
    The wall seconds; a failed run stops the benchmark."""
    res = case.parent / "results"
    if res.exists():
        shutil.rmtree(res)
    root = Path(__file__).resolve().parent.parent
    env = run_env(root, Path(os.environ.get("TQ_BUILD_DIR") or root / "build"))
    t0 = time.perf_counter()
    with (case.parent / "run.log").open("w") as log:
        rc = subprocess.run([sys.executable, "-m", "tunnelquake", "run", str(case), "--no-post"], cwd=case.parent,
                            stdout=log, stderr=subprocess.STDOUT, env=env).returncode
    if rc != 0:
        raise SystemExit(f"{case}: tunnelquake run exited {rc}; see {case.parent / 'run.log'}")
    return time.perf_counter() - t0


def run_once(src: Path, build: Path, case: Path, log: Path) -> dict:
    """`tunnelquake run CASE` from tree `src`: wall s, CPU s of the process tree, exit code. The
    OpenMP wait is the product's own (cores.solid_env: a short spin, then sleep), as `./Allrun` runs
    it: OMP_WAIT_POLICY and GOMP_SPINCOUNT are taken out of the environment (PASSIVE, which
    `./Alltest` sets, took 1.33-1.59x the coupled wall of the 3D example's first second:
    docs/benchmarks.md "OpenMP waiting")."""
    env = run_env(src, build)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    with log.open("w") as out:
        p = subprocess.Popen([sys.executable, "-m", "tunnelquake", "run", str(case)], cwd=case.parent,
                             stdout=out, stderr=subprocess.STDOUT, env=env)
        _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "rc": os.waitstatus_to_exitcode(status),
            "load_before": load}


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.allrun_time", description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, help="folder for the runs (created)")
    ap.add_argument("--tree", action="append", required=True, help="NAME=SRC[:BUILD]; the first is the baseline")
    ap.add_argument("--case", type=Path, default=Path("cases/paper_tunnel/case.yaml"),
                    help="relative: each tree's own file; absolute: one file for every tree")
    ap.add_argument("--variant", default=None)
    ap.add_argument("--end", type=float, default=None, help="cut the record to this many seconds")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", type=Path, default=None, help="write the figures here (default OUT/allrun_time.json)")
    a = ap.parse_args(argv)
    import yaml

    trees = [parse_tree(t) for t in a.tree]
    if len({t[0] for t in trees}) != len(trees):
        raise SystemExit("--tree: give each tree its own NAME")
    cases = {name: a.case if a.case.is_absolute() else src / a.case for name, src, _ in trees}
    for name, path in cases.items():
        if not path.is_file():
            raise SystemExit(f"--case {a.case}: no {path} (tree {name})")
    runs: list[dict] = []
    print(machine(), flush=True)
    for r in range(a.rounds):
        order = trees[r % len(trees):] + trees[:r % len(trees)]
        for name, src, build in order:
            folder = a.out / f"round{r + 1}" / name
            source = cases[name]
            case = write_case(yaml.safe_load(source.read_text()), source.parent, folder, a.variant, a.end)
            rec = {"round": r + 1, "tree": name, **run_once(src, build, case, folder / "run.log")}
            runs.append(rec)
            print(f"round {r + 1} {name:>12}: wall {rec['wall_s']:8.1f} s, CPU {rec['cpu_s']:8.1f} s, "
                  f"load before {rec['load_before']:.1f}, exit {rec['rc']}", flush=True)
            if rec["rc"] != 0:
                print(f"  {name} failed: see {folder / 'run.log'}", file=sys.stderr)
                return 1
    first = trees[0][0]
    summary = {}
    for name, _, _ in trees:
        mine = [x for x in runs if x["tree"] == name]
        ratios = [x["wall_s"] / next(y["wall_s"] for y in runs if y["tree"] == first and y["round"] == x["round"])
                  for x in mine]
        summary[name] = {"wall_median_s": statistics.median(x["wall_s"] for x in mine),
                         "cpu_median_s": statistics.median(x["cpu_s"] for x in mine),
                         "ratio_to_first_by_round": ratios, "ratio_median": statistics.median(ratios)}
        s = summary[name]
        print(f"{name:>12}: median wall {s['wall_median_s']:.1f} s, CPU {s['cpu_median_s']:.1f} s; "
              f"to {first}: {', '.join(f'{v:.3f}' for v in ratios)} (median {s['ratio_median']:.3f})")
    out = a.json or a.out / "allrun_time.json"
    out.write_text(json.dumps({"machine": machine(), "case": str(a.case), "variant": a.variant, "end": a.end,
                               "runs": runs, "summary": summary}, indent=1))
    print(f"written {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
