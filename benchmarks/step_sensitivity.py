"""python -m benchmarks.step_sensitivity SOLID_INPUT FOLDER [--only NAME ...]: how far a
solid-only run's monitored peaks move under small changes of its input, the multi-rate stepping
among them.

SOLID_INPUT is a condition's `solid_input.h5` as `tunnelquake run` writes it (results/<condition>/).
Each *point* is a copy of it with a few of its values changed (POINTS: the time step's safety
factor, `/solver subcycling_levels`, the static stages' relaxation tolerance, the record scaled,
a material's attribute), run by tq-solid on one thread under `nice`. The first point, `reference`,
is the input unchanged; every other point is compared with it (or with the point its "against"
names, run first):

- its monitored peaks (benchmarks.peaks_compare: every monitor's peak |u|, max sigma3, most
  compressive sigma1, and the ring's largest |N|, |M|, |V| and diameter change), each as a
  relative difference, and the worst;
- the divergence of its histories: at each sample the largest difference of the monitors' stress
  components, over their largest magnitude in the reference, and of the ring's section thrusts N,
  over their largest magnitude; its running maximum at --times seconds.

A change of a relative size far below the time discretisation's error (1e-12 of the step, 1e-9 of
the record) says how much the peaks are determined by the model; subcycling or another step
is then judged against that. Writes FOLDER/step_sensitivity.json and prints a Markdown table.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from tunnelquake.paths import solid_executable

from .peaks_compare import compare, condition_figures

# name -> changes: safety (factor on /solver safety), levels (/solver subcycling_levels),
# relaxation_tolerance (/stages), motion (factor on /motion ax, az), associated (every material's
# dilation angle set to its friction angle), "<material>.<attribute>" (value); "against": the point
# it is compared with (default: the reference)
POINTS: dict[str, dict] = {
    "reference": {},
    "step 1-1e-12": {"safety": 1 - 1e-12},
    "record 1+1e-9": {"motion": 1 + 1e-9},
    "record 1+1e-6": {"motion": 1 + 1e-6},
    "step 1-1e-8": {"safety": 1 - 1e-8},
    "step 1-1e-6": {"safety": 1 - 1e-6},
    "step 1-1e-4": {"safety": 1 - 1e-4},
    "step 0.99": {"safety": 0.99},
    "step 0.5": {"safety": 0.5},
    "step 0.25": {"safety": 0.25},
    "relaxation 1e-9": {"relaxation_tolerance": 1e-9},
    "subcycling 1": {"levels": 1},
    "subcycling 2": {"levels": 2},
    "subcycling 3": {"levels": 3},
    "associated": {"associated": True},
    "associated, subcycling 1": {"associated": True, "levels": 1, "against": "associated"},
    "associated, subcycling 3": {"associated": True, "levels": 3, "against": "associated"},
}
TIMES = (1.0, 2.0, 2.2, 2.3, 3.0, 6.0)


def perturb(src: Path, dst: Path, changes: dict) -> None:
    """A copy of the solid input `src` at `dst` with `changes` applied (keys as in POINTS); the
    mesh it names is made absolute, so the copy may lie anywhere."""
    import h5py

    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        mesh = Path(str(f.attrs["mesh"]))
        f.attrs["mesh"] = str(mesh if mesh.is_absolute() else (src.parent / mesh).resolve())
        for key, value in changes.items():
            if key == "safety":
                f["solver"].attrs["safety"] = float(f["solver"].attrs["safety"]) * value
            elif key == "levels":
                f["solver"].attrs["subcycling_levels"] = int(value)
            elif key == "relaxation_tolerance":
                f["stages"].attrs["relaxation_tolerance"] = float(value)
            elif key == "associated":
                for m in f["materials"].values():
                    if value and "friction_angle" in m.attrs and "dilation_angle" in m.attrs:
                        m.attrs["dilation_angle"] = m.attrs["friction_angle"]
            elif key == "against":
                pass
            elif key == "motion":
                for c in ("ax", "az"):
                    f[f"motion/{c}"][...] = f[f"motion/{c}"][:] * value
            elif "." in key:
                material, attr = key.split(".", 1)
                f[f"materials/{material}"].attrs[attr] = value
            else:
                raise ValueError(f"unknown change {key!r} (safety, levels, relaxation_tolerance, motion, "
                                 "associated, <material>.<attribute>)")


def histories(path: Path):
    """Sample times, the monitors' stress components side by side and the ring's section N."""
    import h5py
    import numpy as np

    with h5py.File(path, "r") as f:
        names = [m for m in f["monitors"] if not m.startswith("@")]
        t = f[f"monitors/{names[0]}/time"][:, 0]
        stress = np.concatenate([f[f"monitors/{m}/stress"][:] for m in names], axis=1)
        ring = f["ring_forces/0/N"][:].astype(float) if "ring_forces/0/N" in f else np.zeros((len(t), 0))
    return t, stress, ring


def divergence(ref: Path, new: Path, times=TIMES) -> dict[float, float]:
    """The running maximum, at each of `times`, of the histories' largest difference (stress over
    the reference's largest stress magnitude, ring N over its largest |N|)."""
    import numpy as np

    t, s0, n0 = histories(ref)
    _, s1, n1 = histories(new)
    k = min(len(t), len(s1))
    d = np.max(np.abs(s1[:k] - s0[:k]), axis=1) / np.max(np.abs(s0))
    if n0.size:
        d = np.maximum(d, np.max(np.abs(n1[:k] - n0[:k]), axis=1) / np.max(np.abs(n0)))
    run = np.maximum.accumulate(d)
    return {x: float(run[min(int(np.searchsorted(t[:k], x - 1e-9)), k - 1)]) for x in times if x <= t[k - 1] + 1e-9}


def run_point(name: str, changes: dict, src: Path, folder: Path, condition: str) -> dict:
    out = folder / name.replace(" ", "_")
    inp = out / "solid_input.h5"
    perturb(src, inp, changes)
    res = out / f"results_{condition}.h5"
    t0 = time.perf_counter()
    with open(out / "log.txt", "w") as log:
        proc = subprocess.Popen(["nice", str(solid_executable()), str(inp), "-o", str(res), "--threads", "1"],
                                stdout=log, stderr=subprocess.STDOUT, env={**os.environ, "OMP_WAIT_POLICY": "PASSIVE"})
        _, status, ru = os.wait4(proc.pid, 0)
    return {"name": name, "changes": changes, "folder": str(out), "rc": os.waitstatus_to_exitcode(status),
            "cpu_s": ru.ru_utime + ru.ru_stime, "wall_s": time.perf_counter() - t0}


def table(recs: list[dict]) -> str:
    ref = recs[0]
    times = [float(x) for x in ref.get("times", [])]
    head = "| point | CPU s | worst difference | " + " | ".join(f"history {x:g} s" for x in times) + " |"
    lines = [head, "|" + "---|" * (3 + len(times))]
    for r in recs:
        if r is ref:
            lines.append(f"| {r['name']} | {r['cpu_s']:.1f} | – |" + " – |" * len(times))
            continue
        w = f"{100 * r['worst_value']:.3g} % ({r['worst']})" if r.get("worst") else r.get("status", "")
        div = r.get("divergence", {})
        vs = "" if r.get("against", "reference") == "reference" else f" (against {r['against']})"
        lines.append(f"| {r['name']}{vs} | {r['cpu_s']:.1f} | {w} | "
                     + " | ".join(f"{div[str(x)]:.1e}" if str(x) in div else "–" for x in times) + " |")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.step_sensitivity", description=__doc__.split("\n\n")[0])
    ap.add_argument("input", type=Path, help="a condition's solid_input.h5")
    ap.add_argument("folder", type=Path)
    ap.add_argument("--only", nargs="*", help=f"points besides the reference (default all: {', '.join(POINTS)})")
    ap.add_argument("--times", type=float, nargs="*", default=list(TIMES))
    a = ap.parse_args(argv)
    if solid_executable() is None:
        print("step_sensitivity: no tq-solid in the build folder (set TQ_BUILD_DIR)", file=sys.stderr)
        return 2
    if not a.input.is_file():
        print(f"step_sensitivity: no solid input at {a.input}", file=sys.stderr)
        return 2
    unknown = [n for n in a.only or [] if n not in POINTS]
    if unknown:
        print(f"step_sensitivity: unknown point(s) {unknown}; known: {list(POINTS)}", file=sys.stderr)
        return 2
    import h5py

    with h5py.File(a.input, "r") as f:
        condition = str(f.attrs.get("condition", "no_water"))
    names = ["reference"]
    for n in a.only if a.only is not None else POINTS:
        for m in (POINTS[n].get("against"), n):
            if m and m not in names:
                names.append(m)
    recs = []
    for n in names:
        rec = run_point(n, POINTS[n], a.input, a.folder, condition)
        print(f"{n}: rc {rec['rc']}, {rec['cpu_s']:.1f} CPU s", flush=True)
        recs.append(rec)
    ref = recs[0]
    ref["times"] = a.times
    if ref["rc"] != 0:
        print("step_sensitivity: the reference run failed (see its log.txt)", file=sys.stderr)
        return 1
    rf = condition_figures(Path(ref["folder"]), condition)
    by_name = {r["name"]: r for r in recs}
    for r in recs[1:]:
        base = by_name[r["changes"].get("against", "reference")]
        r["against"] = base["name"]
        if r["rc"] != 0 or base["rc"] != 0:
            r["status"] = "failed (see log.txt)"
            continue
        c = compare(condition_figures(Path(base["folder"]), condition), condition_figures(Path(r["folder"]), condition))
        r.update(worst=c["worst"], worst_value=c["worst_value"], diffs=c["diffs"])
        ref_h5 = Path(base["folder"]) / f"results_{condition}.h5"
        r["divergence"] = {str(k): v for k, v in
                           divergence(ref_h5, Path(r["folder"]) / f"results_{condition}.h5", a.times).items()}
    ref["peaks"] = rf["peaks"]
    (a.folder / "step_sensitivity.json").write_text(json.dumps(recs, indent=1))
    print(table(recs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
