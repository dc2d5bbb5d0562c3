"""tunnelquake bench FOLDER --identify: what the paper leaves open, measured one choice at a time,
and the set of choices that matches its §3.3 numbers best (paper comparison: names the paper).

The paper (Liu, Zhang & Xiao 2021) does not give: the version of its record, the stress released
before the lining is active, the water's compressibility, the damping, the damage constant R, and
the interface's initial state. Each *choice* below is the example case (cases/paper_tunnel, slice,
whole 20 s record) with one of these changed; each runs the conditions it can change (the water
model only changes condition 3: its conditions 1 and 2 are the example's), each condition as one
`tunnelquake run --no-post` of FOLDER/<choice>/<condition>/case.yaml, two at a time under
`nice -n 5` (`--jobs`). Every §3.3 number (paper.PAPER: 3 pressure peaks and their times, 9 max
u_x, 9 max u_z, 9 max σ3) is read from each run, with condition 2's σ3 at the seismic start (the
paper's ≈ 0.76 MPa), the lining's largest damage and the interface pairs that opened.

Identification: the effects are taken as independent (one-at-a-time): a set of levels predicts
each stress as the example's plus each chosen level's change (static states add; at most the
lining's tensile strength) and each other number as the example's times each level's ratio;
coordinate descent over the dimensions picks the set with the smallest sum of squared log ratios
to the paper's numbers. The set is then run whole (`variants: paper_identified` of the example,
`--confirm` runs it, or its results are read from cases/paper_tunnel/results_paper_identified) and
the confirmed numbers are tabulated beside the prediction.

Writes FOLDER/study.json (runs), FOLDER/identified.json, and with --update-docs
docs/paper_reproduction.md (date, machine, command, the table of every §3.3 number against every
choice, the identified set) and cases/paper_tunnel/identified.json (what the example's report
compares itself with).
"""
from __future__ import annotations

import argparse
import copy
import datetime as _dt
import json
import os
import shlex
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tunnelquake.paper import misfit, number_label, paper_numbers, within
from tunnelquake.paths import ROOT

CASE = ROOT / "cases" / "paper_tunnel" / "case.yaml"
DOC = ROOT / "docs" / "paper_reproduction.md"
IDENTIFIED_JSON = ROOT / "cases" / "paper_tunnel" / "identified.json"
RECORDS = Path("/work/shared/data/ground_motions")
PEKNOLD = "elCentro_1940_NS_Peknold_dt0.02.AT2"
ALL = ("no_water", "static_water", "dynamic_water")
DYN = ("dynamic_water",)
SOLID = ("no_water", "static_water")
#: The record's first seconds, for a choice too slow over the whole record (Rayleigh damping: a
#: 38-fold smaller step). Such a run is compared with the example cut alike only: its peaks are not
#: the whole record's, so it neither brackets nor reaches a paper number, nor is it identified.
SHORT_END = "3.5 s"


def whole_record(nums: dict[str, dict]) -> dict[str, dict]:
    """The runs over the whole record, by choice name (the cut ones left out)."""
    cut = {c.name for c in choices(CASE.parent) if "time.end_time" in c.overrides}
    return {n: v for n, v in nums.items() if n not in cut}


@dataclass(frozen=True)
class Choice:
    dimension: str  # what the paper leaves open
    level: str  # this choice's value, in words
    overrides: dict = field(default_factory=dict)  # dotted case key -> value
    conditions: tuple = ALL  # the conditions the choice can change

    @property
    def name(self) -> str:
        return f"{self.dimension}: {self.level}"

    @property
    def slug(self) -> str:
        return "".join(c if c.isalnum() else "_" for c in self.name.lower()).strip("_")


def choices(case_dir: Path) -> list[Choice]:
    """The example first, then the choices in the order they run (most telling first: a study cut
    short by the time it is given keeps its main rows)."""
    peknold = str((case_dir / "../../../shared/data/ground_motions" / PEKNOLD).resolve())
    return [
        Choice("example", "as cases/paper_tunnel"),
        Choice("release fraction", "0.5", {"stages.release_fraction": 0.5}),
        Choice("record", "Peknold version", {"ground_motion.file": peknold}),
        Choice("water", "incompressible", {"water.model": "incompressible"}, DYN),
        Choice("water", "K = 22 GPa", {"water.bulk_modulus": "22 GPa"}, DYN),
        Choice("water", "K = 10 GPa", {"water.bulk_modulus": "10 GPa"}, DYN),
        Choice("release fraction", "0.7", {"stages.release_fraction": 0.7}),
        Choice("release fraction", "0.8", {"stages.release_fraction": 0.8}),
        Choice("release fraction", "0.9", {"stages.release_fraction": 0.9}),
        Choice("damping", "mass-proportional 2 %", {"damping.ratio": 0.02}),
        Choice("interface", "bonded throughout", {"interface.model": "bonded"}),
        Choice("interface", "no bond (cohesion 0)", {"interface.cohesion": 0.0}),
        Choice("damage constant R", "10", {"materials.rock.damage_constant": 10.0,
                                           "materials.lining.damage_constant": 10.0}),
        Choice("damage constant R", "1000", {"materials.rock.damage_constant": 1000.0,
                                             "materials.lining.damage_constant": 1000.0}),
        Choice("example, first 3.5 s", "as cases/paper_tunnel", {"time.end_time": SHORT_END}, SOLID),
        Choice("damping, first 3.5 s", "Rayleigh 5 % at 1.5 and 10 Hz", {"damping.model": "rayleigh",
                                                                        "time.end_time": SHORT_END}, SOLID),
    ]


#: The example's level of each dimension, in words (the table's first column).
EXAMPLE_LEVELS = {"record": "PEER NGA version", "release fraction": "1 (lining after full release)",
                  "water": "compressible, K = 2.2 GPa", "damping": "mass-proportional 5 % at 1.5 Hz",
                  "interface": "dynamic contact, bonded (cohesion 0.5 MPa) until it fails",
                  "damage constant R": "100", "example, first 3.5 s": "the whole record",
                  "damping, first 3.5 s": "mass-proportional 5 % at 1.5 Hz (the example, first 3.5 s)"}


def set_key(d: dict, dotted: str, value) -> None:
    *head, last = dotted.split(".")
    for k in head:
        d = d.setdefault(k, {})
    d[last] = value


def base_case(case_file: Path) -> dict:
    """The example's data as a self-contained case: its record path absolute, no variants."""
    import yaml

    d = yaml.safe_load(case_file.read_text())
    d.pop("variants", None)
    gm = d["ground_motion"]
    if gm.get("file"):
        gm["file"] = str((case_file.parent / gm["file"]).resolve())
    d["output"] = {**d.get("output", {}), "directory": "results"}
    return d


def write_job(c: Choice, cond: str, base: dict, folder: Path) -> Path:
    import yaml

    d = copy.deepcopy(base)
    d["conditions"] = [cond]
    for k, v in c.overrides.items():
        set_key(d, k, v)
    out = folder / c.slug / cond
    out.mkdir(parents=True, exist_ok=True)
    (out / "case.yaml").write_text(f"# tunnelquake bench --identify: {c.name}\n" + yaml.safe_dump(d, sort_keys=False))
    return out


def run_job(job_dir: Path, cond: str) -> dict:
    env = dict(os.environ)
    env["TQ_CONDITIONS_AT_ONCE"] = "1"
    env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    env["PYTHONPATH"] = str(ROOT / "scripts") + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    res = job_dir / "results" / f"results_{cond}.h5"
    res.unlink(missing_ok=True)
    t0 = time.perf_counter()
    with open(job_dir / "run.log", "w") as log:
        rc = subprocess.call(["nice", "-n", "5", sys.executable, "-m", "tunnelquake", "run", str(job_dir), "--no-post"],
                             stdout=log, stderr=subprocess.STDOUT, env=env)
    return {"rc": rc, "wall_s": time.perf_counter() - t0, "results": str(res) if res.is_file() else None}


# ----------------------------------------------------------------------------------------------
# the numbers of a run

def numbers(results: dict[str, Path], reference: str = "absolute") -> dict:
    """Every §3.3 number of a set of results files (condition -> path; missing ones are left out),
    under paper.paper_numbers()' keys, with what paper.Comparison.numbers adds."""
    from tunnelquake import paper
    from tunnelquake import post as P

    runs = [P.read_condition(Path(f), cond, reference) for cond, f in results.items() if f and Path(f).is_file()]
    return paper.Comparison([r for r in runs if r.samples], {}, {}).numbers()


#: Numbers whose changes add (a stress: the static state a choice adds or removes, capped at the
#: lining's tensile strength); the others (displacements, pressures, times) scale.
ADDITIVE = ("max_tension", "sigma3_start")


def predict(example: dict, levels: dict[str, dict], keys: list[str]) -> dict:
    """A set of levels' numbers predicted from the one-at-a-time runs (`levels`: dimension -> that
    level's numbers; None = the example's): a stress is the example's plus each chosen level's
    change from it, at most the lining's tensile strength; any other number is the example's
    times each chosen level's ratio to it."""
    from tunnelquake.paper import PAPER

    out = {}
    for k in keys:
        v = example.get(k)
        if v is None or not np.isfinite(v):
            out[k] = v
            continue
        add = k.startswith(ADDITIVE)
        for nums in levels.values():
            x = None if nums is None else nums.get(k)
            if x is None or not np.isfinite(x):
                continue
            if add:
                v += x - example[k]
            elif example[k] != 0:
                v *= x / example[k]
        out[k] = min(v, PAPER["lining_tensile_strength"]) if add else v
    return out


def identify(example: dict, by_dim: dict[str, dict[str, dict]], keys: list[str],
             sweeps: int = 4) -> tuple[dict[str, str | None], dict, list[str]]:
    """Coordinate descent: per dimension, the level (None = the example's) that minimises the
    predicted misfit with the others held; repeated until no level changes. Returns the levels,
    the predicted numbers and the log of the sweeps."""
    chosen: dict[str, str | None] = {d: None for d in by_dim}
    log = []

    def nums_of(ch):
        return {d: (by_dim[d][lv] if lv is not None else None) for d, lv in ch.items()}

    for sweep in range(sweeps):
        changed = False
        for d, levels in by_dim.items():
            best, best_f = chosen[d], None
            for lv in [None, *levels]:
                trial = {**chosen, d: lv}
                f = misfit(predict(example, nums_of(trial), keys), keys)
                if best_f is None or f < best_f - 1e-12:
                    best, best_f = lv, f
            if best != chosen[d]:
                log.append(f"sweep {sweep + 1}: {d} → {best or 'the example'} (predicted misfit {best_f:.3f})")
                chosen[d], changed = best, True
        if not changed:
            break
    return chosen, predict(example, nums_of(chosen), keys), log


# ----------------------------------------------------------------------------------------------
# running

def _store(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    os.replace(tmp, path)


def _completed(job_dir: Path, cond: str) -> float | None:
    """The wall seconds `tunnelquake run` reported for a job whose results file is complete, else
    None."""
    import re

    from tunnelquake.post import read_condition

    res = job_dir / "results" / f"results_{cond}.h5"
    if not res.is_file():
        return None
    try:
        if not read_condition(res, cond).complete:
            return None
        found = re.findall(r"finished in ([0-9.]+) s", (job_dir / "run.log").read_text())
    except (OSError, KeyError, ValueError):
        return None
    return float(found[-1]) if found else None


def run_study(folder: Path, case_file: Path, jobs: int, only: list[str]) -> dict:
    """Run every choice's conditions not yet in FOLDER/study.json (or those named in `only`),
    `jobs` at a time; the store is rewritten after each run."""
    store = folder / "study.json"
    data = json.loads(store.read_text()) if store.is_file() else {"runs": {}}
    base = base_case(case_file)
    todo = []
    for c in choices(case_file.parent):
        for cond in c.conditions:
            key = f"{c.slug}/{cond}"
            done = data["runs"].get(key, {})
            if (only and c.slug not in only and key not in only) or (not only and done.get("results")):
                continue
            adopted = _completed(folder / c.slug / cond, cond)
            if adopted and not only:  # run before (its record lost with an interrupted study): kept
                data["runs"][key] = {"rc": 0, "wall_s": adopted, "results": str(folder / c.slug / cond / "results"
                                                                                / f"results_{cond}.h5"),
                                     "choice": c.name, "slug": c.slug, "condition": cond, "adopted": True}
                continue
            todo.append((c, cond, write_job(c, cond, base, folder)))
    lock = threading.Lock()

    def one(item):
        c, cond, d = item
        print(f"[identify] {c.name}, {cond} ...", flush=True)
        rec = run_job(d, cond)
        rec.update(choice=c.name, slug=c.slug, condition=cond, load=os.getloadavg()[0])
        with lock:
            data["runs"][f"{c.slug}/{cond}"] = rec
            _store(store, data)
        print(f"[identify]   {c.name}, {cond}: rc {rec['rc']}, {rec['wall_s']:.0f} s, load {rec['load']:.1f}",
              flush=True)

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        list(pool.map(one, todo))
    return data


def results_of(data: dict, c: Choice) -> dict[str, str | None]:
    """The results file of each condition for a choice: its own run where it has one, else the
    example's (a choice that cannot change a condition)."""
    ex = choices(CASE.parent)[0]
    out = {}
    for cond in ALL:
        own = data["runs"].get(f"{c.slug}/{cond}", {}).get("results")
        out[cond] = own if cond in c.conditions else data["runs"].get(f"{ex.slug}/{cond}", {}).get("results")
    return out


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="tunnelquake bench --identify", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", type=Path, help="where the runs, study.json and identified.json go")
    p.add_argument("--jobs", type=int, default=2, help="conditions run at once (2)")
    p.add_argument("--only", default="", help="comma-separated choice slugs or slug/condition to (re)run")
    p.add_argument("--tabulate-only", action="store_true", help="re-read FOLDER/study.json, run nothing")
    p.add_argument("--confirm", action="store_true",
                   help="run the example's variant paper_identified (the confirming run) if its results are missing")
    p.add_argument("--update-docs", action="store_true",
                   help="write docs/paper_reproduction.md and cases/paper_tunnel/identified.json")
    args = p.parse_args(argv)
    folder = args.folder.resolve()
    folder.mkdir(parents=True, exist_ok=True)
    command = "tunnelquake bench " + " ".join(shlex.quote(a) for a in ["--identify", *argv])
    if not args.tabulate_only:
        data = run_study(folder, CASE, args.jobs, [s.strip() for s in args.only.split(",") if s.strip()])
        data.setdefault("commands", []).append(f"`{command}` ({_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC)")
        _store(folder / "study.json", data)
    return tabulate(folder, command, args.confirm, args.update_docs)


# ----------------------------------------------------------------------------------------------
# tables

SHORT = {"no_water": "(1)", "static_water": "(2)", "dynamic_water": "(3)"}


def fmt(v, scale=1.0) -> str:
    if v is None or not np.isfinite(v):
        return "–"
    x = v * scale
    return f"{x:.3g}" if abs(x) >= 0.01 else f"{x:.2g}"


def cell(v, p, scale) -> str:
    """A value, bold where it is within ±20 % of the paper's p."""
    txt = fmt(v, scale)
    if p and v is not None and np.isfinite(v) and abs(v / p - 1) <= 0.20:
        return f"**{txt}**"
    return txt


def extra_rows() -> list[tuple[str, str]]:
    """Rows beside the §3.3 numbers: condition 2's σ3 at the start, damage and opened pairs."""
    rows = [(f"sigma3_start/static_water/{m}", f"σ3 at the seismic start (2) {m.replace('_', ' ')} (MPa; paper ≈ 0.76)")
            for m in ("top_arch", "haunch", "bottom_arch")]
    for cond in ALL:
        rows.append((f"max_damage/{cond}", f"largest D of the lining's middle section {SHORT[cond]} (paper: "
                     + ("> 0, the haunch the most)" if cond == "dynamic_water" else "0)")))
    for cond in ALL:
        rows.append((f"opened/{cond}", f"interface pairs separated/slipping/failed {SHORT[cond]}, of 48 (in the "
                     "haunch sectors)"))
    return rows


def study_numbers(data: dict) -> dict[str, dict]:
    """Per choice name: its numbers (absolute displacements)."""
    out = {}
    for c in choices(CASE.parent):
        res = results_of(data, c)
        if any(res.get(cond) for cond in c.conditions):
            out[c.name] = numbers(res)
    return out


def table(nums: dict[str, dict], columns: list[str], heads: list[str]) -> list[str]:
    target = paper_numbers()
    keys = list(paper_numbers())
    head = "| number | paper | " + " | ".join(heads) + " |"
    lines = [head, "|---|---:|" + "---:|" * len(columns)]
    for k in keys:
        text, unit, scale = number_label(k)
        lines.append(f"| {text} ({unit}) | {fmt(target[k], scale)} | "
                     + " | ".join(cell(nums[c].get(k), target[k], scale) for c in columns) + " |")
    lines.append("| **within ±20 % of the paper** (of 33) | | "
                 + " | ".join(str(within(nums[c], keys)) for c in columns) + " |")
    lines.append("| misfit Σ ln²(ours/paper) | | " + " | ".join(f"{misfit(nums[c], keys):.2f}" for c in columns)
                 + " |")
    for k, text in extra_rows():
        vals = []
        for c in columns:
            v = nums[c].get(k)
            if k.startswith("opened/"):
                cond = k.split("/")[1]
                vals.append("–" if v is None else f"{v} ({nums[c].get(f'opened_haunch/{cond}', 0)})")
            elif k.startswith("sigma3_start"):
                vals.append(cell(v, 0.76e6, 1e-6))
            else:
                vals.append(fmt(v))
        lines.append(f"| {text} | | " + " | ".join(vals) + " |")
    return lines


def by_dimension(nums: dict[str, dict]) -> dict[str, dict[str, dict]]:
    out: dict[str, dict[str, dict]] = {}
    for c in choices(CASE.parent)[1:]:
        # a run cut short is compared with the example cut alike, never identified
        if c.name in nums and "time.end_time" not in c.overrides:
            out.setdefault(c.dimension, {})[c.level] = nums[c.name]
    return out


def overrides_of(levels: dict[str, str | None]) -> dict:
    out = {}
    for c in choices(CASE.parent)[1:]:
        if levels.get(c.dimension) == c.level:
            out.update(c.overrides)
    return out


def identified_results() -> dict[str, str]:
    folder = CASE.parent / "results_paper_identified"
    return {cond: str(folder / f"results_{cond}.h5") for cond in ALL if (folder / f"results_{cond}.h5").is_file()}


def tabulate(folder: Path, command: str, confirm: bool, update_docs: bool) -> int:
    from .common import machine

    data = json.loads((folder / "study.json").read_text())
    nums = study_numbers(data)
    ex_name = choices(CASE.parent)[0].name
    if ex_name not in nums:
        print("tunnelquake bench --identify: the example's runs are missing; nothing to compare with", file=sys.stderr)
        return 1
    keys = list(paper_numbers())
    levels, predicted, log = identify(nums[ex_name], by_dimension(nums), keys)
    overrides = overrides_of(levels)
    if confirm and not identified_results():
        print("[identify] the confirming run: tunnelquake run cases/paper_tunnel --variant paper_identified", flush=True)
        subprocess.call(["nice", "-n", "5", sys.executable, "-m", "tunnelquake", "run", str(CASE.parent),
                         "--variant", "paper_identified"])
        data.setdefault("commands", []).append(
            f"`{command}` (the confirming run, ended {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC)")
        _store(folder / "study.json", data)
    confirmed = numbers(identified_results()) if identified_results() else None
    same = [c for c in choices(CASE.parent)[1:] if {c.dimension: c.level} == {d: v for d, v in levels.items() if v}]
    if confirmed is None and same and same[0].name in nums:
        # the identified set is one of the study's choices: its case file is that choice's, so
        # that choice's runs (and the example's for the conditions it does not change) are its runs
        confirmed = nums[same[0].name]
        data.setdefault("commands", []).append(f"(the identified set is the study's choice '{same[0].name}': its runs "
                                               "confirm it)")
    if confirmed is None and IDENTIFIED_JSON.is_file():
        # the confirming run's folder is gone (a fresh checkout): its numbers stay those recorded
        # beside the case file, when they are of the same set
        before = json.loads(IDENTIFIED_JSON.read_text())
        if before.get("levels") == levels and before.get("confirmed"):
            confirmed = before["confirmed"]
    when = f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC"
    result = {"date": when, "machine": machine(), "commands": data.get("commands", []) + [f"`{command}` ({when})"],
              "levels": levels, "overrides": overrides, "example_levels": EXAMPLE_LEVELS, "sweeps": log,
              "predicted": predicted, "confirmed": confirmed, "choices": nums,
              "walls": {k: r.get("wall_s") for k, r in data["runs"].items()}}
    _store(folder / "identified.json", result)
    text = document(result, data)
    (folder / "paper_reproduction.md").write_text(text)
    print(text)
    if update_docs:
        DOC.write_text(text)
        _store(IDENTIFIED_JSON, {**{k: result[k] for k in ("date", "levels", "overrides", "example_levels",
                                                           "confirmed")}, "choices": whole_record(nums)})
        print(f"updated {DOC} and {IDENTIFIED_JSON}")
    return 0


def document(r: dict, data: dict) -> str:
    nums = r["choices"]
    cs = [c for c in choices(CASE.parent) if c.name in nums]
    ex = cs[0]
    target, keys = paper_numbers(), list(paper_numbers())
    lines = ["# The paper reproduced: what its open choices do to its §3.3 numbers", "",
             f"Generated by `tunnelquake bench FOLDER --identify` (benchmarks/paper_study.py) on {r['date']}; "
             f"machine: {r['machine']}. Commands: {'; '.join(r['commands'])}.", "",
             "Each choice is cases/paper_tunnel (slice, the PEER NGA El Centro 180° record, whole 20 s) with one key "
             "changed; the water choices change condition (3) only, their (1) and (2) are the example's. Values in "
             "**bold** are within ±20 % of the paper's. Displacements are absolute (the reference the paper's match, "
             "below). The misfit is Σ ln²(ours/paper) over the 33 numbers.", "",
             "| choice | keys | conditions run | wall s (each condition) |", "|---|---|---|---|"]
    for c in cs:
        keys_txt = ", ".join(f"`{k}: {v}`" for k, v in c.overrides.items()) or "—"
        if "ground_motion.file" in c.overrides:
            keys_txt = f"`ground_motion.file: {PEKNOLD}`"
        walls = ", ".join(f"{data['runs'][f'{c.slug}/{cond}']['wall_s']:.0f}" for cond in c.conditions
                          if f"{c.slug}/{cond}" in data["runs"])
        lines.append(f"| {c.name} | {keys_txt} | {', '.join(SHORT[x] for x in c.conditions)} | {walls} |")
    lines += ["", "Rayleigh damping (`damping.model: rayleigh`, 5 % at 1.5 and 10 Hz): `tunnelquake check` puts its "
              "stable step at 1.7e-06 s against 6.5e-05 s (38× the steps, about 49 min per condition against 77 s on "
              "an idle 2-core machine), so it runs over the record's first 3.5 s only, in conditions (1) and (2), "
              "beside the example cut alike: its effect is the difference between those two columns (the record's "
              "displacement peaks come later: the cut example's are about half the whole record's). Its condition "
              "(3) is the example's. A run cut short neither brackets nor reaches a paper number below, and is never "
              "identified. The damage constant "
              "R (`damage_constant` of the rock and the lining, 100 in the example) scales D with the plastic strain "
              "and, with `damage_effect: cohesion`, acts on the cohesion only.", "",
              "## Every §3.3 number against every choice", ""]
    heads = [c.name.replace("example: as cases/paper_tunnel", "example") for c in cs]
    lines += table(nums, [c.name for c in cs], heads)
    lines += ["", "## What each choice moves (measured)", "",
              "Per choice, the numbers it moves most from the example's (the §3.3 numbers, condition (2)'s σ3 at the "
              "start, the section's largest D and the opened interface pairs), largest change first:", ""]
    ex_nums = nums[ex.name]
    extra = [f"sigma3_start/static_water/{m}" for m in ("top_arch", "haunch", "bottom_arch")] + \
        [f"{k}/{c}" for k in ("max_damage", "opened") for c in ALL]
    short = next((x for x in cs if x.overrides == {"time.end_time": SHORT_END}), None)
    for c in cs[1:]:
        moves = []
        base = nums[short.name] if short and c is not short and "time.end_time" in c.overrides else ex_nums
        for k in keys + extra:
            a, b = base.get(k), nums[c.name].get(k)
            if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)) or a == b:
                continue
            size = abs(b - a) / max(abs(a), abs(b))
            text, unit, scale = number_label(k)
            moves.append((size, f"{text} {fmt(a, scale)} → {fmt(b, scale)}{' ' + unit if unit else ''}"))
        top = [t for _, t in sorted(moves, reverse=True)[:6]]
        lines.append(f"- with {c.dimension} {c.level} instead of {EXAMPLE_LEVELS[c.dimension]}: "
                     + ("; ".join(top) if top else "no number moves"))
    lines += ["", "## Which displacement reference the paper's numbers match", ""]
    from tunnelquake import paper
    from tunnelquake import post as P

    ex_runs = [P.read_condition(Path(f), cond) for cond, f in results_of(data, ex).items() if f and Path(f).is_file()]
    lines += paper.Comparison([r for r in ex_runs if r.samples], {}, {}).reference_rows()
    lines += ["", "## The identified set", "",
              "Coordinate descent over the dimensions on the one-at-a-time results (a set's stresses predicted as the "
              "example's plus each chosen level's measured change, capped at σt; its other numbers as the example's "
              "times each level's measured ratio), minimising the misfit:", ""]
    lines += [f"- {s}" for s in r["sweeps"]] or ["- no dimension improves on the example"]
    lines += ["", "| dimension | the example | identified |", "|---|---|---|"]
    for d, lv in r["levels"].items():
        lines.append(f"| {d} | {EXAMPLE_LEVELS[d]} | {lv or EXAMPLE_LEVELS[d] + ' (unchanged)'} |")
    lines += ["", "Case keys (the example's variant `paper_identified`): "
              + (", ".join(f"`{k}: {v}`" for k, v in r["overrides"].items()) or "none"), ""]
    cols = {ex.name: nums[ex.name], "predicted": r["predicted"]}
    if r["confirmed"]:
        cols["confirmed (run)"] = r["confirmed"]
    lines += table(cols, list(cols), ["example", "identified, predicted", "identified, run"][:len(cols)])
    if not r["confirmed"]:
        lines += ["", "The confirming run is missing: `tunnelquake run cases/paper_tunnel --variant paper_identified` "
                  "(or `--confirm`)."]
    lines += ["", "## The numbers no run of the study brings within ±20 % (alone, or beside the identified set's)", ""]
    allruns = whole_record(nums)
    if r["confirmed"]:
        allruns["identified"] = r["confirmed"]
    tp = paper.PAPER["hydrodynamic_pressure_peak_time"]
    for k in keys:
        close = (lambda v: abs(v - tp) <= 0.5) if k.startswith("pressure_time") else None
        text = paper.reach_text(k, allruns, target[k], close, r["confirmed"] or None)
        if text and not text.startswith("within"):
            label_, unit, scale = number_label(k)
            lines.append(f"- {label_} (paper {fmt(target[k], scale)} {unit}): {text}")
    return "\n".join(lines) + "\n"
