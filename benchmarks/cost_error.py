"""python -m benchmarks.cost_error FOLDER: the slice's run time against its error, one point per
coupling or stepping setting.

Each *point* is the example case (cases/paper_tunnel/case.yaml, or --case) with a few keys
changed, one condition, cut to the record's first --end seconds (`time.end_time`; the record itself
is read whole, so its processing is the same as the full run's). Two ladders:

  dynamic_water  the coupling's settings: coupling.window (the solid steps per water step: the
                 water's own rate), coupling.tolerance, coupling.scheme (implicit / explicit),
                 and single-rate stepping against the case's time.subcycling; against a converged
                 reference (one-step windows, tolerance 1e-5, single-rate)
  no_water       the solid's stepping: time.subcycling 1, 2, 3 against single-rate (0)

With --variant NAME the case file's variant is laid over every point and the 3D ladder runs
instead (points_3d: condition 3 of the `3d` variant, the solid on one thread): the variant's
settings against single-rate stepping at tolerance 1e-5, the window, the tolerance, the
subcycling and the volume law one at a time; its files are named cost_error_<variant>*.

The error of a point is the largest relative difference, over the monitors, of its monitored
peaks against the reference's: the lining's principal stresses at the monitors (max sigma3,
the most compressive sigma1), the lining rings' section forces (the largest |N|, |M|, |V| over the
sections and the shaking) and the largest diameter change, the peak hydrodynamic pressure, and the
monitors' peak |u_x|, |u_z|. The peak damage is recorded beside it but not in the worst (a
threshold quantity: zero in many runs).

Cost: CPU seconds, less sensitive than the wall time to the load of a shared machine. Coupled:
the shaking's CPU of tq-solid (/coupling solid_cpu_s + coupler_cpu_s) + the water's
ExecutionTime. Solid-only: the CPU of the whole `tunnelquake run` process tree (os.wait4:
start, meshing, statics and the shaking). Each point is run once, at most --jobs at a time
(default 2), under `nice`.

Writes FOLDER/cost_error.json (every point) and FOLDER/cost_error_<condition>.png (error against
CPU, the default marked, the Pareto front drawn); --docs copies the figures and the JSON to
docs/bench/. --suffix S names them cost_error[_<variant>]S* (a run of another --end beside the
default one's). The table gives each point's coupling energy against the interface work
(|coupling_energy| / interface_work_peak of the run's /coupling record).
--tabulate-only re-reads the JSON and redraws without running. Prints the table.
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

from tunnelquake.paths import ROOT

from . import common
from .paper import pareto_front, set_key, slug

DEFAULT_CASE = ROOT / "cases" / "paper_tunnel" / "case.yaml"
#: within this of the reference on every monitored peak: "as accurate as the reference"
TARGET = 1e-3


@dataclass(frozen=True)
class Point:
    name: str
    condition: str
    overrides: dict = field(default_factory=dict)  # dotted case key -> value
    role: str = ""  # "reference", "default" or ""


def points() -> list[Point]:
    """The settings tried; the reference and the default of each ladder first."""
    dw, nw = "dynamic_water", "no_water"
    tol = "coupling.tolerance"
    win = "coupling.window"
    sub = "time.subcycling"
    pred = "coupling.predictor"  # the explicit scheme has no iterations to start (auto: constant)
    return [
        Point("implicit, window 1, tol 1e-5, subcycling 0", dw, {win: 1, tol: 1e-5, sub: 0}, "reference"),
        Point("implicit, window 16, tol 1e-3, subcycling 3", dw, {}, "default"),  # the case's own settings
        Point("subcycling 0", nw, {}, "reference"),
        Point("subcycling 3", nw, {sub: 3}),
        Point("implicit, window 1, tol 1e-3", dw, {win: 1}),
        Point("implicit, window 4, tol 1e-3", dw, {win: 4}),
        Point("implicit, window 32, tol 1e-3", dw, {win: 32}),
        Point("implicit, window 16, tol 1e-2", dw, {tol: 1e-2}),
        Point("implicit, window 16, tol 1e-4", dw, {tol: 1e-4}),
        Point("implicit, window 64, tol 1e-3", dw, {win: 64}),
        Point("subcycling 1", nw, {sub: 1}),
        Point("subcycling 2", nw, {sub: 2}),
        Point("explicit, window 1", dw, {"coupling.scheme": "explicit", win: 1, "coupling.reuse": 0, pred: "auto"}),
        Point("explicit, window 4", dw, {"coupling.scheme": "explicit", win: 4, "coupling.reuse": 0, pred: "auto"}),
        Point("implicit, window 16, tol 1e-3, subcycling 0", dw, {sub: 0}),
        Point("implicit, window 8, tol 1e-3", dw, {win: 8}),
        Point("implicit, window 16, tol 1e-5", dw, {tol: 1e-5}),
    ]


#: the 3D ladder's keys on every point: the solid on one thread, so that its CPU seconds
#: (solid_cpu_s: the calling thread's) are the whole solid's and the points compare
THREADS_1 = {"parallel.threads": 1}


def points_3d() -> list[Point]:
    """The settings tried on the case's 3D variant (--variant), condition 3 alone: the variant's
    own settings the default; the reference single-rate (subcycling 0) at tolerance 1e-5 in windows
    of 16 (one-step windows cost about 16 water passes a window more, beyond what this bench can
    run in 3D); the window (the water's rate), the tolerance, the subcycling and where the volume
    law is carried (the water's remainder only; in the whole block, which that needs where the variant
    meshes half of it, mesh.symmetry) and the residual's scale (coupling.residual_scale) one at a
    time, and the explicit scheme (one pass a window, no
    reuse of past passes) in the default's windows."""
    dw, win, tol, sub = "dynamic_water", "coupling.window", "coupling.tolerance", "time.subcycling"
    law = "coupling.volume_law"
    return [Point(name, dw, {**THREADS_1, **keys}, role) for name, keys, role in (
        ("window 16, tol 1e-5, subcycling 0", {tol: 1e-5, sub: 0}, "reference"),
        ("window 16, tol 1e-4, subcycling 3", {}, "default"),
        ("window 16, tol 1e-4, subcycling 0", {sub: 0}, ""),
        ("window 16, tol 1e-3, subcycling 3", {tol: 1e-3}, ""),
        ("window 16, tol 5e-4, subcycling 3", {tol: 5e-4}, ""),
        ("window 16, tol 3e-4, subcycling 3", {tol: 3e-4}, ""),
        ("window 32, tol 1e-4, subcycling 3", {win: 32}, ""),
        ("window 24, tol 1e-4, subcycling 3", {win: 24}, ""),
        ("window 8, tol 1e-4, subcycling 3", {win: 8}, ""),
        ("volume law in the solid (the whole block)", {law: "solid", "mesh.symmetry": "none"}, ""),
        ("window 16, tol 1e-4, residual scale current", {"coupling.residual_scale": "current"}, ""),
        ("explicit, window 16", {"coupling.scheme": "explicit", "coupling.reuse": 0,
                                  "coupling.window_force_weight": 0.5, "coupling.predictor": "auto",
                                  "coupling.residual_scale": "current"}, ""),
    )]


def lay(d: dict, over: dict) -> None:
    """Lay the nested keys of `over` over `d` (a case file's variant over the rest of it)."""
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(d.get(k), dict):
            lay(d[k], v)
        else:
            d[k] = copy.deepcopy(v)


# ----------------------------------------------------------------------------------------------
# running

def write_point(p: Point, base: dict, base_dir: Path, folder: Path, end: float, variant: str | None = None) -> Path:
    """FOLDER/<condition>/<slug>/case.yaml: the case (with its `variant` laid over it) with the
    point's keys, time.end_time = end, one condition, the record path made absolute."""
    import yaml

    d = copy.deepcopy(base)
    variants = d.pop("variants", None) or {}
    if variant:
        lay(d, variants[variant])
    gm = d["ground_motion"]
    if gm.get("file"):
        gm["file"] = str((base_dir / gm["file"]).resolve())
    d.setdefault("time", {})["end_time"] = f"{end:g} s"
    d["conditions"] = [p.condition]
    d["output"] = {**d.get("output", {}), "directory": "results", "checkpoint_interval": 0}
    for k, v in p.overrides.items():
        set_key(d, k, v)
    out = folder / p.condition / slug(p.name)
    out.mkdir(parents=True, exist_ok=True)
    (out / "case.yaml").write_text(f"# python -m benchmarks.cost_error: {p.name}\n" + yaml.safe_dump(d, sort_keys=False))
    return out


def water_cpu(fluid_log: Path) -> float | None:
    """The water solver's CPU seconds: the last `ExecutionTime = x s` of its log."""
    try:
        found = re.findall(r"^ExecutionTime = ([0-9.eE+-]+) s", fluid_log.read_text(), re.M)
    except OSError:
        return None
    return float(found[-1]) if found else None


def ring_peaks(path: Path) -> dict[str, float]:
    """The largest |N|, |M|, |V| over every ring's sections and samples, and the largest |diameter
    change| (relative to the seismic start)."""
    import numpy as np

    from tunnelquake.ring_forces import read_ring_forces

    out: dict[str, float] = {}
    for q in ("N", "M", "V", "diameter_change"):
        vals = [float(np.max(np.abs(getattr(r, q)))) for r in read_ring_forces(path) if getattr(r, q).size]
        if vals:
            out[q] = max(vals)
    return out


def run_point(p: Point, case_dir: Path, limit: float) -> dict:
    """Run one point (`nice tunnelquake run --no-post`) and return its record: CPU and wall time,
    status, the coupling's counts, the monitored peaks."""
    import h5py

    from tunnelquake.post import peaks, read_condition

    env = dict(os.environ)
    env["TQ_CONDITIONS_AT_ONCE"] = "1"
    env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    env["PYTHONPATH"] = str(ROOT / "scripts") + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    res = case_dir / "results" / f"results_{p.condition}.h5"
    res.unlink(missing_ok=True)
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    timed_out = False
    with open(case_dir / "run.log", "w") as log:
        proc = subprocess.Popen(["nice", "-n", "10", sys.executable, "-m", "tunnelquake", "run", str(case_dir),
                                 "--no-post"], stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        timer = threading.Timer(limit, lambda: os.killpg(proc.pid, signal.SIGTERM))
        timer.start()
        try:
            _, status, ru = os.wait4(proc.pid, 0)
        finally:
            timed_out = not timer.is_alive()
            timer.cancel()
    rec: dict = {"name": p.name, "condition": p.condition, "overrides": p.overrides, "role": p.role,
                 "wall_s": time.perf_counter() - t0, "tree_cpu_s": ru.ru_utime + ru.ru_stime,
                 "rc": os.waitstatus_to_exitcode(status), "load": [load0, os.getloadavg()[0]]}
    if not res.is_file():
        rec["status"] = "stopped by the bench" if timed_out else "no results (see run.log)"
        return rec
    try:
        r = read_condition(res, p.condition)
    except (ValueError, KeyError, OSError) as e:
        rec["status"] = f"no shaking written ({e})"
        return rec
    rec["completed"] = bool(r.complete) and not timed_out
    rec["t_end"] = float(r.t_end)
    rec["status"] = "completed" if rec["completed"] else f"{r.status.split('. ', 1)[0]} (at t = {r.t_end:.3f} s)"
    with h5py.File(res, "r") as f:
        if "timings" in f:
            rec["timings"] = {k: float(x) for k, x in f["timings"].attrs.items()}
    c = r.coupling
    if c:
        rec["coupling"] = {k: (float(x) if isinstance(x, (int, float)) or hasattr(x, "dtype") else str(x))
                           for k, x in c.items()}
        w = water_cpu(case_dir / "results" / p.condition / "fluid.log")
        if "solid_cpu_s" in c and w is not None:
            rec["water_cpu_s"] = w
            rec["cpu_s"] = float(c["solid_cpu_s"]) + float(c.get("coupler_cpu_s", 0.0)) + w
    else:
        rec["cpu_s"] = rec["tree_cpu_s"]
    rec["peaks"] = peaks(r)
    rec["rings"] = ring_peaks(res)
    return rec


# ----------------------------------------------------------------------------------------------
# errors, front, figure

def _rel(v, ref) -> float:
    if v is None or ref is None or not (math.isfinite(v) and math.isfinite(ref)):
        return math.nan
    return 0.0 if v == ref else (abs(v - ref) / abs(ref) if ref else math.inf)


#: (label, key in post.peaks) of the monitors' peaks that enter the worst error
MONITOR_KEYS = (("sigma3", "max_tension"), ("sigma1", "min_sigma1"), ("pressure", "hydrodynamic_pressure_peak"),
                ("u_x", "max_ux"), ("u_z", "max_uz"))


def energy_ratio(rec: dict) -> float:
    """The coupling's energy error against the interface work: |coupling_energy| over the largest
    |work| the water did on the lining (interface_work_peak); NaN where the run did not record both."""
    c = rec.get("coupling") or {}
    try:
        e, w = float(c["coupling_energy"]), float(c["interface_work_peak"])
    except (KeyError, TypeError, ValueError):
        return math.nan
    return abs(e) / w if w > 0 else math.nan


def errors(rec: dict, ref: dict) -> dict:
    """Each quantity's largest relative difference against the reference (over the monitors for
    the monitors' peaks), the worst of them, and which; the damage apart."""
    out: dict = {}
    for label, key in MONITOR_KEYS:
        es = [_rel(rec["peaks"].get(m, {}).get(key), ref["peaks"][m].get(key)) for m in ref["peaks"]]
        es = [e for e in es if not math.isnan(e)]
        if es:
            out[label] = max(es)
    for q, v in ref.get("rings", {}).items():
        e = _rel(rec.get("rings", {}).get(q), v)
        if not math.isnan(e):
            out[f"ring {q}"] = e
    worst = max(out, key=out.get) if out else None
    dm = [_rel(rec["peaks"].get(m, {}).get("max_damage"), ref["peaks"][m].get("max_damage")) for m in ref["peaks"]]
    dm = [e for e in dm if not math.isnan(e)]
    return {"each": out, "worst": out[worst] if worst else math.nan, "worst_of": worst,
            "damage": max(dm) if dm else math.nan}


def analyse(runs: list[dict]) -> dict:
    """Per condition: each completed point's errors against the reference, the Pareto front of
    (CPU, worst error) and whether the default is on it, and the cheaper points within TARGET."""
    out: dict = {}
    for cond in dict.fromkeys(r["condition"] for r in runs):
        rs = [r for r in runs if r["condition"] == cond]
        ref = next((r for r in rs if r["role"] == "reference" and r.get("completed")), None)
        if ref is None:
            out[cond] = {"rows": rs, "note": "no completed reference"}
            continue
        for r in rs:
            if r.get("completed") and "peaks" in r:
                r["errors"] = errors(r, ref)
        # where no point is marked default, the reference is the default (single-rate stepping)
        default = next((r for r in rs if r["role"] == "default"), ref)
        cand = [r for r in rs if "errors" in r and (r is not ref or r is default) and r.get("cpu_s")]
        pts = [(r["cpu_s"], r["errors"]["worst"]) for r in cand]
        front = [cand[i]["name"] for i in pareto_front(pts)]
        cheaper_ok = [r["name"] for r in cand if default is not None and default.get("cpu_s")
                      and r["cpu_s"] < default["cpu_s"] and r["errors"]["worst"] <= TARGET and r is not default]
        out[cond] = {"reference": ref["name"], "front": front,
                     "default": default["name"] if default else None,
                     "default_on_front": (default["name"] in front) if default and "errors" in default else None,
                     "cheaper_within_target": cheaper_ok}
    return out


def table(runs: list[dict], an: dict) -> str:
    lines = []
    for cond, a in an.items():
        lines += [f"\n{cond}: reference {a.get('reference')}; front: {', '.join(a.get('front', []))}",
                  "| setting | CPU s (water) | wall s | passes a window | worst error (which) | damage "
                  "| coupling energy / interface work | status |",
                  "|---|---:|---:|---:|---|---:|---:|---|"]
        for r in (r for r in runs if r["condition"] == cond):
            c = r.get("coupling") or {}
            passes = (f"{c['passes'] / c['windows']:.2f}" if c.get("windows") and "passes" in c else "–")
            e = r.get("errors")
            err = ("reference" if r["role"] == "reference" else
                   f"{100 * e['worst']:.3f} % ({e['worst_of']})" if e else "–")
            dmg = f"{100 * e['damage']:.2f} %" if e and r["role"] != "reference" else "–"
            mark = " (default)" if r["role"] == "default" else ""
            water = f" ({r['water_cpu_s']:.1f})" if "water_cpu_s" in r else ""
            en = energy_ratio(r)
            lines.append(f"| {r['name']}{mark} | {r.get('cpu_s', math.nan):.1f}{water} | {r['wall_s']:.0f} | {passes} "
                         f"| {err} | {dmg} | {'–' if math.isnan(en) else f'{en:.1e}'} | {r.get('status', '?')} |")
    return "\n".join(lines)


def _short(name: str) -> str:
    return (name.replace("implicit, window ", "k ").replace("explicit, window ", "explicit k ")
            .replace(", tol ", " tol ").replace(", subcycling ", " sub ").replace("subcycling ", "sub "))


def plot(cond: str, runs: list[dict], a: dict, path: Path, end: float, variant: str | None = None) -> None:
    """Worst monitored-peak difference (%) against CPU s of the completed points, linear axes; the
    default a red star, the front joined; the reference and the stopped points named in a box."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rs = [r for r in runs if r["condition"] == cond and "errors" in r and r["role"] != "reference" and r.get("cpu_s")]
    if not rs:
        return
    ref = next(r for r in runs if r["condition"] == cond and r["role"] == "reference")
    ref_default = not any(r["role"] == "default" for r in runs if r["condition"] == cond)
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    for i, r in enumerate(sorted(rs, key=lambda r: r["cpu_s"])):
        e = 100 * r["errors"]["worst"]
        d = r["role"] == "default"
        ax.scatter(r["cpu_s"], e, marker="*" if d else "o", s=220 if d else 40,
                   color="C3" if d else ("C0" if r["name"] in a["front"] else "0.45"), zorder=3)
        ax.annotate(_short(r["name"]) + (" (default)" if d else "") + f" [{r['errors']['worst_of']}]",
                    (r["cpu_s"], e), fontsize=7, xytext=(5, -10 if i % 2 else 4), textcoords="offset points")
    if ref_default:  # the default is the reference: drawn at difference 0
        ax.scatter(ref["cpu_s"], 0.0, marker="*", s=220, color="C3", zorder=3, clip_on=False)
        ax.annotate(_short(ref["name"]) + " (default = reference)", (ref["cpu_s"], 0.0), fontsize=7,
                    xytext=(-150, 8), textcoords="offset points")
    fr = sorted((r["cpu_s"], 100 * r["errors"]["worst"]) for r in rs + ([ref] if ref_default else [])
                if r["name"] in a["front"])
    if fr:
        ax.step([x for x, _ in fr], [y for _, y in fr], where="post", color="C0", lw=1, label="Pareto front")
    if max(100 * r["errors"]["worst"] for r in rs) < 5 * 100 * TARGET:
        ax.axhline(100 * TARGET, color="C2", ls="--", lw=1, label=f"{100 * TARGET:g} %")
    ax.set_ylim(bottom=0)
    notes = [f"reference: {_short(ref['name'])}, {ref['cpu_s']:.0f} CPU s" + (" (the default)" if ref_default else "")]
    notes += [f"{_short(r['name'])}: stopped at t = {r.get('t_end', math.nan):.2f} s (energy guard)"
              for r in runs if r["condition"] == cond and not r.get("completed")]
    fig.text(0.01, 0.01, "; ".join(notes), ha="left", va="bottom", fontsize=6.5, wrap=True)
    ax.set_xlabel("CPU s (tq-solid + water for the coupled runs; whole run solid-only)")
    ax.set_ylabel("worst monitored-peak difference from the reference, %")
    where = f" ({variant} variant)" if variant else ""
    ax.set_title(f"{cond}{where}, first {end:g} s: cost against error, one point per setting", fontsize=9)
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, alpha=0.3)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def render(data: dict, folder: Path, docs: bool, tag: str = "") -> str:
    """Tabulate and draw; `tag` ('_3d' for --variant 3d) names the files apart from the slice's."""
    runs = data["runs"]
    an = analyse(runs)
    data["analysis"] = an
    store = folder / f"cost_error{tag}.json"
    store.write_text(json.dumps(data, indent=1, default=str))
    for cond in an:
        png = folder / f"cost_error{tag}_{cond}.png"
        plot(cond, runs, an[cond], png, data["end"], data.get("variant"))
        if docs and png.is_file():
            shutil.copy(png, ROOT / "docs" / "bench" / png.name)
    if docs:  # the measured points beside the figures, for a redraw without rerunning (--tabulate-only)
        shutil.copy(store, ROOT / "docs" / "bench" / store.name)
    text = (f"{data['machine']}; first {data['end']:g} s of the record\n" + table(runs, an) + "\n\n"
            + json.dumps(an, indent=1))
    (folder / f"cost_error{tag}.md").write_text(text)
    return text


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.cost_error", description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--case", type=Path, default=DEFAULT_CASE)
    ap.add_argument("--end", type=float, default=6.0, help="s of the record run (time.end_time)")
    ap.add_argument("--jobs", type=int, default=2, help="points at a time")
    ap.add_argument("--limit", type=float, default=1800.0, help="wall s after which a point is stopped")
    ap.add_argument("--only", nargs="*", default=None, help="names of the points to run (default: all)")
    ap.add_argument("--docs", action="store_true", help="copy the figures to docs/bench/")
    ap.add_argument("--tabulate-only", action="store_true")
    ap.add_argument("--variant", default=None,
                    help="the case file's variant to lay over it (3d: the 3D ladder, points_3d)")
    ap.add_argument("--suffix", default="",
                    help="appended to the files' names (cost_error_3d_2.5s*.json/png for --suffix _2.5s): "
                         "keeps a run of another length apart from the default one's files")
    a = ap.parse_args(argv)
    import yaml

    if a.suffix and not re.fullmatch(r"[A-Za-z0-9_.-]+", a.suffix):
        ap.error(f"--suffix {a.suffix!r}: use letters, digits and _ . - only (it names files), e.g. --suffix _2.5s")
    folder = a.folder.resolve()
    folder.mkdir(parents=True, exist_ok=True)
    tag = (f"_{slug(a.variant)}" if a.variant else "") + a.suffix
    store = folder / f"cost_error{tag}.json"
    data = json.loads(store.read_text()) if store.is_file() else {"end": a.end, "runs": [], "variant": a.variant}
    if not a.tabulate_only:
        base = yaml.safe_load(a.case.read_text())
        if a.variant and a.variant not in (base.get("variants") or {}):
            ap.error(f"--variant {a.variant}: {a.case} has no such variant (its variants: "
                     f"{', '.join(base.get('variants') or {}) or 'none'})")
        ladder = points_3d() if a.variant else points()
        todo = [p for p in ladder if a.only is None or p.name in a.only]
        lock = threading.Lock()

        def one(p: Point) -> None:
            d = write_point(p, base, a.case.resolve().parent, folder, a.end, a.variant)
            rec = run_point(p, d, a.limit)
            rec["point"] = asdict(p)
            rec["machine"] = common.machine()  # a store may gather runs of several machines
            print(f"{p.condition} {p.name}: {rec.get('status')} cpu {rec.get('cpu_s', math.nan):.1f} s "
                  f"wall {rec['wall_s']:.0f} s", flush=True)
            with lock:
                data["runs"] = [r for r in data["runs"] if not (r["name"] == p.name and r["condition"] == p.condition)]
                data["runs"].append(rec)
                store.write_text(json.dumps(data, indent=1, default=str))

        with ThreadPoolExecutor(max_workers=a.jobs) as ex:
            list(ex.map(one, todo))
    if not (a.tabulate_only and data.get("machine")):  # a redraw keeps the machine line of the runs
        data["machine"] = common.machine()
    data["end"] = data.get("end", a.end)
    print(render(data, folder, a.docs, tag))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
