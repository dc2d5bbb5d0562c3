"""tunnelquake bench FOLDER --paper: the paper case's shortcuts, error against wall time.

Each setting a user can change in `cases/paper_tunnel/case.yaml` is one *variant*: a copy of the
case with one case-file key changed (or a few, for "finer" and "coarser" meshes), a shortened
record (`ground_motion.duration`, default the first 3 s, which hold the hydrodynamic peak at
≈ 2.1 s) and one condition. Each variant is written to FOLDER/<condition>/<variant>/case.yaml, run
by `tunnelquake run --no-post` (one at a time, `TQ_CONDITIONS_AT_ONCE=1`), and its monitored peaks
(post.peaks: peak |hydrodynamic pressure|, max |u_x|, max |u_z|, max principal stress σ3, max
damage D at top_arch, haunch, bottom_arch) are compared with the reference run of its condition:
relative error of each peak, the worst over the monitors per quantity, and the worst over the
quantities.

Two ladders:
  dynamic_water  (the coupled condition: pressure and the lining's response with the water)
                 reference, default, mesh, coupling scheme / window / acceleration / tolerance,
                 incompressible water (the slice refuses it), 3D (cost per step only)
  static_water   (solid only, cheap: the settings that concern the solid)
                 reference mesh, default, coarser meshes, contact off (bonded), damage off (elastic)

The default case runs first and last in each ladder (the machine is shared: the two runs show the
noise, and wall-time ratios are taken against their median). A variant that stops or is refused
is a result and is recorded as such. The 3D variant runs `--end-3d` of shaking (default 0.05 s)
and its wall time per step is extrapolated to the record: an extrapolation, not a measurement.

Writes FOLDER/paper.json (every run), FOLDER/paper.md (the tables), FOLDER/paper_<condition>.png
(error against wall time, Pareto front, the default marked). --update-docs rewrites the
`<!-- bench:paper -->` section of docs/benchmarks.md and copies the figures to docs/bench/.
--tabulate-only re-reads FOLDER/paper.json and rewrites the tables, figures (and docs) without
running anything.
"""
from __future__ import annotations

import argparse
import copy
import datetime as _dt
import json
import math
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from tunnelquake.paths import ROOT

from . import common

BEGIN, END = "<!-- bench:paper -->", "<!-- /bench:paper -->"
DEFAULT_CASE = ROOT / "cases" / "paper_tunnel" / "case.yaml"
#: (question, key in post.peaks, how the error is measured)
QUANTITIES = (
    ("pressure", "hydrodynamic_pressure_peak", "relative"),
    ("u_x", "max_ux", "relative"),
    ("u_z", "max_uz", "relative"),
    ("stress", "max_tension", "relative"),
    ("damage", "max_damage", "relative"),
)
#: an error at or below this is "safe" in the docs' table
SAFE = 0.05
TARGETS = (0.01, 0.05, 0.20)


@dataclass(frozen=True)
class Variant:
    name: str
    what: str  # the key(s) changed, as the user would write them
    condition: str
    overrides: dict = field(default_factory=dict)  # dotted key -> value
    cost_only: bool = False  # 3D: a short run for the cost per step, no errors


REFERENCE_MESH = {"mesh.max_element_size": "3.375 m", "mesh.lining_elements_around": 64,
                  "mesh.lining_elements_through": 4}
#: the coupled reference keeps 3 elements through the lining (4 cut the step by 1.32 and, with the
#: finer water, made the reference ~3x the default's cost: too long on the shared machine); the
#: through-thickness refinement is measured on the solid-only ladder
REFERENCE_MESH_COUPLED = {"mesh.max_element_size": "3.375 m", "mesh.lining_elements_around": 64}
#: one-step coupling windows without IQN-ILS column reuse (the schemes that need them, and the reference)
ONE_STEP = {"coupling.window": 1, "coupling.reuse": 0, "coupling.predictor": "auto"}  # auto: what the scheme starts from
COARSE_MESH = {"mesh.max_element_size": "13.5 m", "mesh.lining_elements_around": 32,
               "mesh.lining_elements_through": 2}


def variants(end_3d: float) -> list[Variant]:
    """Both ladders in run order: the default first and again after the main variants; the
    optional variants last (a ladder cut short on a busy machine still has its main rows)."""
    dyn, sta = "dynamic_water", "static_water"
    as_is = "cases/paper_tunnel as it is"
    coarse = "mesh: max_element_size 13.5 m, lining_elements_around 32, lining_elements_through 2"
    return [
        Variant("default", as_is, sta),
        Variant("reference", "mesh: max_element_size 3.375 m, lining_elements_around 64, lining_elements_through 4",
                sta, dict(REFERENCE_MESH)),
        Variant("coarse mesh", coarse, sta, dict(COARSE_MESH)),
        Variant("contact off", "interface.model: bonded", sta, {"interface.model": "bonded"}),
        Variant("damage off", "materials.rock/lining.model: elastic", sta,
                {"materials.rock.model": "elastic", "materials.lining.model": "elastic"}),
        Variant("default (again)", as_is, sta),
        Variant("coarse far field", "mesh.max_element_size: 13.5 m", sta, {"mesh.max_element_size": "13.5 m"}),
        Variant("default", as_is, dyn),
        Variant("reference", "mesh: max_element_size 3.375 m, lining_elements_around 64; coupling: window 1, "
                "tolerance 1e-5", dyn, {**REFERENCE_MESH_COUPLED, **ONE_STEP, "coupling.tolerance": 1e-5}),
        Variant("one-step windows", "coupling: window 1, reuse 0, tolerance 1e-4 (the default before windows)", dyn,
                {**ONE_STEP, "coupling.tolerance": 1e-4}),
        Variant("window 32", "coupling.window: 32", dyn, {"coupling.window": 32}),
        Variant("explicit", "coupling: scheme explicit, window 1, reuse 0", dyn,
                {**ONE_STEP, "coupling.scheme": "explicit"}),
        Variant("explicit k=2", "coupling: scheme explicit, window 2, reuse 0", dyn,
                {**ONE_STEP, "coupling.scheme": "explicit", "coupling.window": 2}),
        Variant("incompressible", "water.model: incompressible", dyn, {"water.model": "incompressible"}),
        Variant("coarse mesh", coarse, dyn, dict(COARSE_MESH)),
        Variant("Aitken", "coupling: acceleration aitken, reuse 0", dyn,
                {"coupling.acceleration": "aitken", "coupling.reuse": 0}),
        Variant("no reuse", "coupling.reuse: 0", dyn, {"coupling.reuse": 0}),
        Variant("constant predictor", "coupling.predictor: constant", dyn, {"coupling.predictor": "constant"}),
        Variant("scheme paper", "coupling: scheme paper, window 1, reuse 0", dyn, {**ONE_STEP, "coupling.scheme": "paper"}),
        Variant("3D closed ends", "mesh.mode: 3d, water.ends: closed (no axial flow, as in the slice)", dyn,
                {"mesh.mode": "3d", "water.ends": "closed"}),
        Variant("3D open ends", "mesh.mode: 3d, water.ends: open (the case file's)", dyn, {"mesh.mode": "3d"}),
        Variant("3D incompressible", "mesh.mode: 3d, water.model: incompressible (open ends)", dyn,
                {"mesh.mode": "3d", "water.model": "incompressible"}),
        Variant("3D", f"mesh.mode: 3d (run {end_3d:g} s, cost per step extrapolated)", dyn,
                {"mesh.mode": "3d", "time.end_time": f"{end_3d:g} s"}, cost_only=True),
        Variant("default (again)", as_is, dyn),
        Variant("thin lining mesh", "mesh.lining_elements_through: 2", dyn, {"mesh.lining_elements_through": 2}),
        Variant("tolerance 1e-4", "coupling.tolerance: 1e-4", dyn, {"coupling.tolerance": 1e-4}),
    ]


# ----------------------------------------------------------------------------------------------
# pure logic (tested with hand-made numbers in tests/python/test_bench_paper.py)

def peak_error(value: float, ref: float, how: str) -> float:
    """|value − ref| / |ref| (relative) or |value − ref| (absolute); nan when either is missing;
    a relative error against a zero reference is 0 when the value is zero too, else inf."""
    if value is None or ref is None or not math.isfinite(value) or not math.isfinite(ref):
        return math.nan
    if how == "absolute":
        return abs(value - ref)
    if ref == 0.0:
        return 0.0 if value == 0.0 else math.inf
    return abs(value - ref) / abs(ref)


def error_table(peaks: dict, ref: dict) -> dict:
    """Per quantity: per-monitor errors, and `worst` over the monitors (nan where no monitor has
    the quantity in both runs); and `worst` over the quantities. peaks/ref: post.peaks() dicts."""
    out: dict = {}
    for q, key, how in QUANTITIES:
        per = {m: peak_error(peaks.get(m, {}).get(key), ref.get(m, {}).get(key), how)
               for m in ref if m in peaks}
        finite = [e for e in per.values() if not math.isnan(e)]
        out[q] = {"monitors": per, "worst": max(finite) if finite else math.nan}
    finite = [v["worst"] for v in out.values() if not math.isnan(v["worst"])]
    out["worst"] = max(finite) if finite else math.nan
    return out


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points (time, error) that no other point dominates (time ≤ and error ≤,
    one of them <); points with a non-finite coordinate are left out. Sorted by time."""
    ok = [i for i, (t, e) in enumerate(points) if math.isfinite(t) and math.isfinite(e)]
    front = []
    for i in ok:
        ti, ei = points[i]
        if not any(points[j][0] <= ti and points[j][1] <= ei and (points[j][0] < ti or points[j][1] < ei)
                   for j in ok if j != i):
            front.append(i)
    return sorted(front, key=lambda i: points[i])


def dominators(points: list[tuple[float, float]], i: int) -> list[int]:
    """The points that dominate point i (empty: i is on the front)."""
    ti, ei = points[i]
    return [j for j, (t, e) in enumerate(points) if j != i and math.isfinite(t) and math.isfinite(e)
            and t <= ti and e <= ei and (t < ti or e < ei)]


def median(xs: list[float]) -> float:
    s = sorted(xs)
    n = len(s)
    return math.nan if not n else (s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2]))


def set_key(d: dict, dotted: str, value) -> None:
    """d['a']['b'] = value for 'a.b' (sections created as needed)."""
    *head, last = dotted.split(".")
    for k in head:
        d = d.setdefault(k, {})
    d[last] = value


# ----------------------------------------------------------------------------------------------
# running

def write_variant(v: Variant, base: dict, base_dir: Path, folder: Path, duration: float) -> Path:
    """FOLDER/<condition>/<slug>/case.yaml: the default case with the variant's keys, the record
    cut to `duration`, one condition, the record path made absolute."""
    import yaml

    d = copy.deepcopy(base)
    gm = d["ground_motion"]
    if gm.get("file"):
        gm["file"] = str((base_dir / gm["file"]).resolve())
    gm["duration"] = f"{duration:g} s"
    d["conditions"] = [v.condition]
    d["output"] = {**d.get("output", {}), "directory": "results"}
    for k, val in v.overrides.items():
        set_key(d, k, val)
    out = folder / v.condition / slug(v.name)
    out.mkdir(parents=True, exist_ok=True)
    (out / "case.yaml").write_text(f"# tunnelquake bench --paper: {v.name} ({v.what})\n"
                                   + yaml.safe_dump(d, sort_keys=False))
    return out


def slug(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name.lower()).strip("_")


def _load() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan


def run_variant(v: Variant, case_dir: Path, limit: float | None = None, duration: float = math.nan) -> dict:
    """Run one variant and return its record: wall time, status, the solver's own timings, peaks.
    A run longer than `limit` s is stopped (its whole process group: tunnelquake, tq-solid, the
    water) and recorded as such."""
    from tunnelquake.post import peaks, read_condition

    env = dict(os.environ)
    env["TQ_CONDITIONS_AT_ONCE"] = "1"
    env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    env["PYTHONPATH"] = str(ROOT / "scripts") + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    res_dir = case_dir / "results"
    old = res_dir / f"results_{v.condition}.h5"
    old.unlink(missing_ok=True)
    load0 = _load()
    t0 = time.perf_counter()
    timed_out = False
    with open(case_dir / "run.log", "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "tunnelquake", "run", str(case_dir), "--no-post"],
                                stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        try:
            rc = proc.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            timed_out = True
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                rc = proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                rc = proc.wait()
    wall = time.perf_counter() - t0
    rec = {"name": v.name, "what": v.what, "condition": v.condition, "overrides": v.overrides,
           "cost_only": v.cost_only, "rc": rc, "wall_s": wall, "duration": duration, "load": [load0, _load()], "dir": str(case_dir)}
    rec["motion"] = motion_source(case_dir / "run.log")
    if not old.is_file():
        rec["status"] = (f"stopped by the bench after {limit:.0f} s, before the shaking" if timed_out else
                         "refused: " + _why(case_dir / "run.log"))
        return rec
    try:
        r = read_condition(old, v.condition)
    except (ValueError, KeyError, OSError):  # nothing written past the static stages
        rec["status"] = "stopped before the shaking: " + _input_error(res_dir / v.condition / "solid.log",
                                                                      case_dir / "run.log")
        return rec
    rec["status"] = r.status if r.complete else f"{short(r.status)} (at t = {r.t_end:.3f} s)"
    if timed_out:
        rec["status"] = f"stopped by the bench after {limit:.0f} s (at t = {r.t_end:.3f} s)"
    rec["completed"] = r.complete
    rec["t_end"] = r.t_end
    import h5py

    with h5py.File(old, "r") as f:
        if "timings" in f:
            rec["timings"] = {k: float(x) for k, x in f["timings"].attrs.items()}
        rec["dt"] = float(f.attrs.get("dt", math.nan))
        rec["elements"] = int(f["mesh/connectivity"].shape[0]) if "mesh/connectivity" in f else None
    c = r.coupling
    if c:
        rec["coupling"] = {k: (float(x) if isinstance(x, (int, float)) or hasattr(x, "dtype") else str(x))
                           for k, x in c.items()}
    rec["peaks"] = peaks(r)
    if "timings" not in rec:  # stopped before tq-solid wrote them: its last progress line
        rate = last_rate(res_dir / v.condition / "solid.log")
        if rate:
            rec["progress"] = rate
    return rec


def last_rate(log: Path) -> dict | None:
    """The last progress line of tq-solid's log: {'step': N, 'steps_per_s': r}."""
    import re

    try:
        text = log.read_text()
    except OSError:
        return None
    found = re.findall(r"step (\d+), ([0-9.]+) steps/s", text)
    return {"step": int(found[-1][0]), "steps_per_s": float(found[-1][1])} if found else None


def _input_error(solid_log: Path, run_log: Path) -> str:
    """tq-solid's input error (its first sentence), else what the run's log says."""
    try:
        for line in solid_log.read_text().splitlines():
            if "input error:" in line:
                return short(line.split("input error:", 1)[1].strip())
    except OSError:
        pass
    return _why(run_log)


def motion_source(log: Path) -> str:
    """What `tunnelquake run` says it used as the ground motion (record path, or the synthetic one)."""
    try:
        for line in log.read_text().splitlines():
            if "] motion: " in line:
                return line.split("] motion: ", 1)[1].split(";", 1)[0].strip()
    except OSError:
        pass
    return "?"


def short(status: str) -> str:
    """A solver's stop message cut to its first sentence (the table cell), '|' escaped."""
    head = status.split(". ", 1)[0]
    return head.replace("|", "\\|")


def _why(log: Path) -> str:
    """The line of a run's log that says why it did not start."""
    try:
        lines = log.read_text().splitlines()
    except OSError:
        return "no log"
    for key in ("cannot set up the coupled run:", "error:", "FAILED"):
        for line in lines:
            if key in line:
                return short(line.split(key, 1)[1].strip() or line.strip())
    return lines[-1].strip() if lines else "no output"


# ----------------------------------------------------------------------------------------------
# tables, figure, docs

def water_cpu(fluid_log: Path) -> float | None:
    """The water solver's CPU seconds: the last `ExecutionTime = x s` of its log."""
    import re

    try:
        found = re.findall(r"^ExecutionTime = ([0-9.eE+-]+) s", fluid_log.read_text(), re.M)
    except OSError:
        return None
    return float(found[-1]) if found else None


def cpu_seconds(r: dict) -> float | None:
    """CPU seconds of a completed coupled run's shaking: the solid's thread CPU (/coupling
    solid_cpu_s) + the water's ExecutionTime; None for other runs. Less sensitive than the wall
    time to the load of a shared machine."""
    c = r.get("coupling") or {}
    if not r.get("completed") or "solid_cpu_s" not in c:
        return None
    w = water_cpu(Path(r["dir"]) / "results" / r["condition"] / "fluid.log")
    return float(c["solid_cpu_s"]) + w if w is not None else None


def analyse(runs: list[dict]) -> dict:
    """Per condition: the reference, the cost measure (CPU seconds of the shaking where every
    completed run has them, i.e. the coupled ladder, else the wall time of the whole run), the
    default runs' median cost, each run's errors and cost ratio, the Pareto front (worst error and
    per quantity) and where the default sits."""
    out = {}
    for cond in dict.fromkeys(r["condition"] for r in runs):
        rs = [r for r in runs if r["condition"] == cond]
        ref = next((r for r in rs if r["name"] == "reference" and r.get("completed")), None)
        done = [r for r in rs if r.get("completed") and not r.get("cost_only")]
        use_cpu = bool(done) and all(r.get("cpu_s") or cpu_seconds(r) for r in done)

        def cost(r, use_cpu=use_cpu):
            return (r.get("cpu_s") or cpu_seconds(r) or math.nan) if use_cpu else r["wall_s"]

        defaults = [cost(r) for r in rs if r["name"].startswith("default") and r.get("completed")]
        t_def = median(defaults)
        rows = []
        for r in rs:
            c = cost(r)
            row = {"run": r, "cost": c, "cpu": r.get("cpu_s") or cpu_seconds(r),
                   "ratio": c / t_def if t_def == t_def and t_def > 0 else math.nan}
            if ref is not None and r.get("completed") and not r.get("cost_only") and "peaks" in r:
                row["errors"] = error_table(r["peaks"], ref["peaks"])
            rows.append(row)
        # the Pareto front over the completed runs with errors (the default runs count once: the
        # median cost, the first run's errors)
        cand = [row for row in rows if "errors" in row and row["run"]["name"] != "default (again)"]
        fronts = {}
        for q in ("worst",) + tuple(q for q, _, _ in QUANTITIES):
            pts = [(row["cost"] if not row["run"]["name"].startswith("default") else t_def,
                    row["errors"]["worst"] if q == "worst" else row["errors"][q]["worst"]) for row in cand]
            if not any(math.isfinite(e) for _, e in pts):
                continue
            front = pareto_front(pts)
            i_def = next((i for i, row in enumerate(cand) if row["run"]["name"] == "default"), None)
            fronts[q] = {"points": pts, "names": [row["run"]["name"] for row in cand],
                         "front": [cand[i]["run"]["name"] for i in front],
                         "default_on_front": i_def in front if i_def is not None else None,
                         "default_dominated_by": [cand[j]["run"]["name"] for j in dominators(pts, i_def)]
                         if i_def is not None else []}
        out[cond] = {"reference": ref, "default_wall": t_def, "default_walls": defaults, "rows": rows,
                     "fronts": fronts, "cost": "CPU s of the shaking (solid + water)" if use_cpu
                     else "wall s of the whole run"}
    return out


def _pct(e: float, how: str = "relative") -> str:
    if e is None or (isinstance(e, float) and math.isnan(e)):
        return "–"
    if math.isinf(e):
        return "∞"
    return f"{e:.3f}" if how == "absolute" else f"{100 * e:.2f} %"


def _cost_3d(row: dict, t_record: float, slice_default: dict | None) -> str:
    r = row["run"]
    tm = r.get("timings", {})
    steps, solver = tm.get("steps"), tm.get("wall_s")
    if (not steps or not solver) and r.get("progress"):  # cut short: tq-solid's last progress line
        steps = r["progress"]["step"]
        solver = steps / r["progress"]["steps_per_s"]
    if not steps or not solver:
        return f"{r['status']}; wall {r['wall_s']:.0f} s"
    per = solver / steps
    setup = r["wall_s"] - solver
    n = t_record / r["dt"]
    c = r.get("coupling") or {}
    passes = f", {c['passes'] / c['windows']:.2f} water passes a step" if c.get("windows") else ""
    txt = (f"{int(steps)} steps of {r['dt']:.3g} s in {solver:.1f} s ({1e3 * per:.0f} ms a step"
           f", {r.get('elements')} solid elements{passes}; set-up {setup:.0f} s); **extrapolated**: {t_record:g} s of "
           f"record = {n:,.0f} steps ≈ {(setup + per * n) / 3600:.1f} h, the 20 s record ≈ "
           f"{(setup + per * 20 / r['dt']) / 3600:.1f} h")
    if slice_default and slice_default.get("timings", {}).get("steps"):
        st = slice_default["timings"]
        per_s = st["wall_s"] / st["steps"]
        txt += f" (the slice: {1e3 * per_s:.2f} ms a step, {per / per_s:.0f}× less)"
    return txt


def tables(an: dict) -> str:
    parts = []
    slice_runs = [row["run"] for row in an.get("dynamic_water", {}).get("rows", [])
                  if row["run"]["name"].startswith("default") and row["run"].get("completed")
                  and row["run"].get("timings", {}).get("steps")]
    # the least loaded default run: the per-step wall closest to the idle machine's
    slice_def = min(slice_runs, key=lambda r: r["timings"]["wall_s"] / r["timings"]["steps"], default=None)
    for cond, a in an.items():
        ref = a["reference"]
        qs = [(q, how) for q, key, how in QUANTITIES
              if any(math.isfinite(row["errors"][q]["worst"]) for row in a["rows"] if "errors" in row)]
        head = "| variant | keys changed | status | wall s | CPU s | cost × default | " + " | ".join(
            f"{q} err" for q, _ in qs) + " | worst | on the front |"
        rows = [head, "|---|---|---|---:|---:|---:|" + "---:|" * len(qs) + "---:|---|"]
        front = set(a["fronts"].get("worst", {}).get("front", []))
        for row in a["rows"]:
            r = row["run"]
            extra = ""
            if r.get("coupling") and r.get("completed"):
                c = r["coupling"]
                if c.get("windows"):
                    extra = f" ({c.get('passes', 0) / c['windows']:.2f} passes a step)"
            if r.get("cost_only"):
                rows.append(f"| {r['name']} | `{r['what']}` | cost only | {r['wall_s']:.0f} | | | "
                            + _cost_3d(row, 3.0, slice_def) + " |" + " |" * len(qs))
                continue
            errs = row.get("errors")
            cells = [(_pct(errs[q]["worst"], how) if errs else "–") for q, how in qs]
            worst = _pct(errs["worst"]) if errs else "–"
            on = ("reference" if r["name"] == "reference" else
                  "yes" if r["name"] in front and not r["name"].endswith("(again)") else
                  ("(repeat)" if r["name"].endswith("(again)") else ("no" if errs else "–")))
            ratio = f"{row['ratio']:.2f}" if math.isfinite(row["ratio"]) else "–"
            cpu = f"{row['cpu']:.0f}" if row.get("cpu") else "–"
            rows.append(f"| {r['name']} | `{r['what']}` | {r['status']}{extra} | {r['wall_s']:.0f} | {cpu} | {ratio} | "
                        + " | ".join(cells) + f" | {worst} | {on} |")
        ref_txt = (f"reference: `{ref['what']}`, {ref['elements']} solid elements, Δt {ref['dt']:.3g} s"
                   if ref else "no completed reference run: no errors")
        dur = next((r.get("duration") for r in (row["run"] for row in a["rows"]) if r.get("duration")), math.nan)
        motions = sorted({r.get("motion") or motion_source(Path(r["dir"]) / "run.log") for r in (
            row["run"] for row in a["rows"])})
        parts.append(f"### {cond}: the record's first {dur:g} s\n\nmotion: {', '.join(motions)}; "
                     f"{ref_txt}; cost: {a['cost']}, the default's (median of its runs "
                     f"{', '.join(f'{w:.0f}' for w in a['default_walls'])} s) = {a['default_wall']:.0f} s.\n\n"
                     + "\n".join(rows) + "\n")
        parts.append(where_default(cond, a))
        parts.append(safe_table(cond, a, qs))
    return "\n".join(parts)


def where_default(cond: str, a: dict) -> str:
    lines = []
    for q, f in a["fronts"].items():
        label = "the worst error" if q == "worst" else f"the {q} error"
        if f["default_on_front"]:
            lines.append(f"- {label}: the default **is on the Pareto front** (front: {', '.join(f['front'])})")
        elif f["default_on_front"] is False:
            lines.append(f"- {label}: the default is **not** on the front: dominated by "
                         f"{', '.join(f['default_dominated_by'])} (front: {', '.join(f['front'])})")
    return f"Where the default sits ({cond}):\n\n" + "\n".join(lines) + "\n"


def safe_table(cond: str, a: dict, qs: list[tuple[str, str]]) -> str:
    """For each question (quantity) and target: the cheapest completed run within it."""
    rows = ["| question | " + " | ".join(f"within {100 * t:g} %" for t in TARGETS) + f" | safe shortcuts (≤ {100 * SAFE:g} %) |",
            "|---|" + "---|" * (len(TARGETS) + 1)]
    cand = [row for row in a["rows"] if "errors" in row and not row["run"]["name"].endswith("(again)")]
    t_def = a["default_wall"]
    for q, _how in qs:
        cells = []
        for t in TARGETS:
            ok = [row for row in cand if row["errors"][q]["worst"] <= t]
            best = min(ok, key=lambda row: t_def if row["run"]["name"] == "default" else row["cost"]) \
                if ok else None
            cells.append(f"{best['run']['name']} ({best['ratio']:.2f}×)" if best else "none")
        safe = [row["run"]["name"] for row in cand if row["run"]["name"] not in ("default", "reference")
                and row["errors"][q]["worst"] <= SAFE]
        rows.append(f"| {q} | " + " | ".join(cells) + f" | {', '.join(safe) or 'none'} |")
    return (f"Cheapest run within each target, per question ({cond}):\n\n" + "\n".join(rows) + "\n")


def plot(cond: str, a: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    keys = list(a["fronts"])
    if not keys:
        return
    floor = 1e-6
    ncol = 3
    nrow = (len(keys) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(13, 4.2 * nrow), squeeze=False)
    for ax, q in zip(axes.flat, keys, strict=False):
        f = a["fronts"][q]
        pts = [(t, max(e, floor)) for t, e in f["points"]]
        for (t, e), n in zip(pts, f["names"], strict=True):
            style = dict(marker="*", s=180, c="tab:red", zorder=5) if n == "default" else \
                dict(marker="s", s=60, c="k", zorder=4) if n == "reference" else dict(marker="o", s=40, c="tab:blue")
            ax.scatter([t], [e], **style)
            ax.annotate(n, (t, e), fontsize=7, xytext=(4, 3), textcoords="offset points")
        fr = [pts[f["names"].index(n)] for n in f["front"]]
        ax.step([p[0] for p in fr], [p[1] for p in fr], where="post", c="tab:green", lw=1.2, label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.axhline(SAFE, c="0.6", ls=":", lw=1)
        ax.set_xlabel(a["cost"])
        ax.set_ylabel("relative error vs reference")
        ax.set_title(f"{cond}: {'worst of the monitored peaks' if q == 'worst' else q + ' peak'}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    for ax in list(axes.flat)[len(keys):]:
        ax.axis("off")
    fig.suptitle(f"paper case, {cond}: error of the monitored peaks against {a['cost']} "
                 f"(red star: default; errors of 0 drawn at {floor:g}; dotted: {100 * SAFE:g} %)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def section(body: str, commands: list[str], where: str, figures: list[str], notes: str = "") -> str:
    figs = "\n".join(f"![{Path(f).stem}]({f})" for f in figures)
    return f"""{BEGIN}
## The paper case's shortcuts: error against wall time

{"; ".join(commands)}; {where}. Every variant is `cases/paper_tunnel/case.yaml` with the keys named
changed, the El Centro record's first seconds (`ground_motion.duration`, per ladder below; the
hydrodynamic peak of the full record's first 3 s is at ≈ 2.1 s) and one condition, run alone by `tunnelquake run --no-post` under `nice -n 10`
with `TQ_CONDITIONS_AT_ONCE=1` (wall time: the whole run: mesh, motion, static stages, shaking).
Errors: the monitored peaks (post.peaks: peak |hydrodynamic pressure|, max |u_x|, max |u_z|, max
principal stress σ3, max damage D) at top_arch, haunch and bottom_arch against the reference run
of the same condition, relative, the worst of the three monitors; "worst": the worst of the
quantities. Single runs on a shared machine: the two default runs of each ladder
show the noise of the wall times; ratios are against their median. A variant that stops is a
result (status column). The 3D row is a cost measurement on a short run, and its times for longer
records are **extrapolations**, not runs.

{body}
{figs}
{notes}
{END}"""


def render(data: dict, folder: Path, update_docs: bool, notes: str = "") -> str:
    an = analyse(data["runs"])
    body = tables(an)
    commands = data.get("commands") or [f"`{data['command']}` ({data['date']})"]
    figs = []
    for cond, a in an.items():
        p = folder / f"paper_{cond}.png"
        plot(cond, a, p)
        if p.is_file():
            figs.append(p)
    text = section(body, commands, data["machine"], [p.name for p in figs], notes)
    (folder / "paper.md").write_text(text + "\n")
    if update_docs:
        docs = ROOT / "docs"
        (docs / "bench").mkdir(exist_ok=True)
        for p in figs:
            shutil.copyfile(p, docs / "bench" / p.name)
        text_docs = section(body, commands, data["machine"], [f"bench/{p.name}" for p in figs], notes)
        target = docs / "benchmarks.md"
        target.write_text(common.update_docs(target.read_text(), text_docs, BEGIN, END))
        print(f"updated {target} and docs/bench/paper_*.png")
    return text


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="tunnelquake bench --paper", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", type=Path, help="where the variants, paper.json, paper.md and the figures go")
    p.add_argument("--duration", type=float, default=3.0, help="seconds of the record each variant runs (3)")
    p.add_argument("--end-3d", type=float, default=0.05, help="seconds of shaking of the 3D cost run (0.05)")
    p.add_argument("--only", default="", help="comma-separated conditions or variant names to run "
                   "(e.g. static_water, or 'dynamic_water:explicit'); the others are kept from paper.json")
    p.add_argument("--tabulate-only", action="store_true", help="re-read FOLDER/paper.json, run nothing")
    p.add_argument("--update-docs", action="store_true",
                   help="rewrite the <!-- bench:paper --> section of docs/benchmarks.md and docs/bench/paper_*.png")
    p.add_argument("--limit", type=float, default=1800.0, help="seconds after which a run is stopped (1800)")
    p.add_argument("--notes", type=Path, help="a markdown file (the reading of the figures) put at the end "
                   "of the section")
    p.add_argument("--case", type=Path, default=DEFAULT_CASE, help="the default case (cases/paper_tunnel)")
    args = p.parse_args(argv)
    folder = args.folder.resolve()
    folder.mkdir(parents=True, exist_ok=True)
    store = folder / "paper.json"
    data = json.loads(store.read_text()) if store.is_file() else {"runs": []}
    if not args.tabulate_only:
        import yaml

        case_file = args.case / "case.yaml" if args.case.is_dir() else args.case
        base = yaml.safe_load(case_file.read_text())
        wanted = [w.strip() for w in args.only.split(",") if w.strip()]
        todo = [v for v in variants(args.end_3d)
                if not wanted or v.condition in wanted or f"{v.condition}:{v.name}" in wanted]
        keep = [r for r in data["runs"] if not any(r["condition"] == v.condition and r["name"] == v.name
                                                   for v in todo)]
        when = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
        command = "nice -n 10 tunnelquake bench " + " ".join(shlex.quote(a) for a in ["--paper", *argv])
        data = {"runs": keep, "duration": args.duration, "date": when, "command": command,
                "commands": [c for c in data.get("commands", []) if keep] + [f"`{command}` ({when})"]}
        for v in todo:
            d = write_variant(v, base, case_file.parent, folder, args.duration)
            print(f"[bench --paper] {v.condition}: {v.name} ({v.what}) ...", flush=True)
            rec = run_variant(v, d, min(args.limit, 600.0) if v.cost_only else args.limit, args.duration)
            data["runs"].append(rec)
            print(f"[bench --paper]   {rec['status']}, wall {rec['wall_s']:.1f} s, load {rec['load'][0]:.1f}"
                  f"-{rec['load'][1]:.1f}", flush=True)
            data["machine"] = common.machine()
            store.write_text(json.dumps(data, indent=1, default=_jsonable))
        order = {(v.condition, v.name): i for i, v in enumerate(variants(args.end_3d))}
        data["runs"].sort(key=lambda r: order.get((r["condition"], r["name"]), 1e9))
        store.write_text(json.dumps(data, indent=1, default=_jsonable))
    if not data["runs"]:
        print("tunnelquake bench --paper: nothing run and no paper.json to tabulate", file=sys.stderr)
        return 1
    notes = args.notes.read_text().strip() + "\n" if args.notes else ""
    print(render(data, folder, args.update_docs, notes))
    return 0


def _jsonable(x):
    if hasattr(x, "item"):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    return asdict(x) if hasattr(x, "__dataclass_fields__") else str(x)
