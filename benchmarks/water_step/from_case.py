"""The water step benchmark on the water case the product writes for a case's condition
dynamic_water (`benchmark.py --from-case CASE [--variant NAME]`).

1. A copy of the case (condition dynamic_water only, a short time.end_time, results in the work
   folder, the ground motion's file made absolute) runs coupled: `tunnelquake run --no-post`. Its
   water folder (<results>/dynamic_water/fluid) is the case the product writes and runs: model,
   solver, step (the coupling window), ends, mesh, every dictionary.
2. The same description (fluid_case.water_case from the case and the run's window) is written
   again by the product's writer, and each of its files is checked against the run's: identical
   but for tqInterface's `exchange`, which the benchmark sets.
3. 'ours': that case with the fake solid (`replay` of a wall motion table) instead of the coupler,
   `steps` steps, each step's solver line printed (log_interval = the step) so that each step can
   be timed. 'stock': the same case with the stock tutorials' linear solvers and PIMPLE controls
   (benchmark.STOCK: GAMG p to relTol 0.01, 2 outer correctors, momentum predictor, corrected
   viscous Laplacian, full log, runTimeModifiable; (e|h) as U) on the product's wall conditions
   and transpiration: tqInterface refuses compressible water on a moving mesh (rhoPimpleFoam makes
   the wall flux relative to the mesh motion), so the stock moving-mesh set-up does not run on a
   compressible case.

The wall motion is what OpenFOAM is sent in the coupled run with the volume law and the
translation in the solid: the lining's deformation (ovaling n = 2, 1 mm at 5 Hz from rest), no
rigid translation and no uniform radial part (tunnel.benchmark_motion with a0 = 0, radial off).
"""

from __future__ import annotations

import dataclasses
import os
import re
import subprocess
import sys
from pathlib import Path

import yaml

from tunnelquake import fluid_case as fc
from tunnelquake import water_case as wc
from tunnelquake.case import load_case
from tunnelquake.foam_dict import Quoted

from ..fluid_common import pipe, tunnel

#: s of the short coupled run that writes the water case (a few windows)
RUN_END_TIME = 0.02


def _absolute(path: str, base: Path) -> str:
    p = Path(path)
    return str(p if p.is_absolute() else (base / p).resolve())


def short_copy(case_path: Path, dest: Path, end_time: float = RUN_END_TIME) -> Path:
    """A copy of the case file for a short coupled run of dynamic_water alone, results under dest."""
    case_path = Path(case_path)
    src = case_path / "case.yaml" if case_path.is_dir() else case_path
    if not src.is_file():
        raise SystemExit(f"--from-case {case_path}: no case file there; give a case.yaml or the folder holding it")
    raw = yaml.safe_load(src.read_text())
    raw["conditions"] = ["dynamic_water"]
    raw.setdefault("time", {})
    raw["time"] = dict(raw["time"] or {}, end_time=end_time)
    raw.setdefault("output", {})["directory"] = str(dest / "results")
    gm = raw.get("ground_motion") or {}
    if gm.get("file"):
        gm["file"] = _absolute(gm["file"], src.parent)
    for v in (raw.get("variants") or {}).values():
        g = (v or {}).get("ground_motion") or {}
        if g.get("file"):
            g["file"] = _absolute(g["file"], src.parent)
        (v or {}).pop("conditions", None)
        if isinstance(v, dict) and isinstance(v.get("time"), dict):
            v["time"].pop("end_time", None)
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / "case.yaml"
    out.write_text(yaml.safe_dump(raw, sort_keys=False))
    return out


def run_short(copy: Path, variant: str | None) -> Path:
    """Run the copy coupled (tunnelquake run --no-post); returns its written water folder."""
    scripts = Path(__file__).resolve().parents[2] / "scripts"
    env = dict(os.environ, PYTHONPATH=str(scripts) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cmd = [sys.executable, "-m", "tunnelquake", "run", str(copy), "--no-post"]
    if variant:
        cmd += ["--variant", variant]
    log = copy.parent / "log.run"
    with log.open("w") as f:
        proc = subprocess.run(cmd, env=env, stdout=f, stderr=subprocess.STDOUT)
    if proc.returncode != 0:
        raise SystemExit(f"--from-case: {' '.join(cmd)} failed (rc {proc.returncode}); see {log}")
    found = sorted(copy.parent.glob("results*/dynamic_water/fluid/system/controlDict"))
    if not found:
        raise SystemExit(f"--from-case: no dynamic_water/fluid written under {copy.parent}; see {log}")
    return found[0].parent.parent


def _without_exchange(text: str) -> str:
    """A controlDict's text less tqInterface's exchange dictionary (the part the benchmark sets)."""
    start = text.find("exchange")
    if start < 0:
        return text
    depth, i = 0, text.index("{", start)
    while True:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
        if depth == 0:
            return text[:start] + text[i:]


def product_description(copy: Path, variant: str | None, fluid: Path) -> tuple[wc.WaterCase, tuple, list[str]]:
    """The WaterCase of the run's water (fluid_case.water_case from the case and the run's window),
    the tunnel axis point (the case's geometry) and the files of the run's water case that the writer writes otherwise (none expected; the
    exchange dictionary aside)."""
    case = load_case(copy, variant)
    control = (fluid / "system" / "controlDict").read_text()
    window = float(re.search(r"^deltaT\s+([0-9.eE+-]+);", control, re.M).group(1))
    end = float(re.search(r"^endTime\s+([0-9.eE+-]+);", control, re.M).group(1))
    addr = re.search(r'addressFile\s+"([^"]*)"', control).group(1)
    settings = fc.coupling_settings(case, window, Path(addr), "x", t_end=end)
    boundary = (fluid / "constant" / "polyMesh" / "boundary").read_text()
    slice_mode = re.search(r"\btype\s+empty\s*;", boundary) is not None
    restart = {}
    m = re.search(r'restartDir\s+"([^"]*)";\s*restartWindows\s+(\d+);', control)
    if m:
        restart = {"restart_dir": m.group(1), "restart_windows": int(m.group(2))}
        fp = re.search(r'inputFingerprint\s+"([^"]*)"', control)
        if fp:
            restart["input_fingerprint"] = fp.group(1)
    w = fc.water_case(case, settings, slice_mode, restart=restart or None)
    differ = []
    for rel, text in wc.dictionaries(w).items():
        written = (fluid / rel).read_text() if (fluid / rel).is_file() else None
        a, b = (text, written) if not rel.endswith("controlDict") else (
            _without_exchange(text), _without_exchange(written or ""))
        if written is None or a != b:
            differ.append(rel)
    g = case.data["geometry"]
    axis = (float(g["tunnel_centre_x"]), 0.0, float(g["tunnel_centre_z"]))
    return w, axis, differ


def stock_overrides(w: wc.WaterCase, stock: dict) -> dict:
    """The stock linear solvers and PIMPLE controls on this case (`stock`: benchmark.STOCK; the
    product's wall conditions and transpiration kept: see the module's doc)."""
    STOCK = stock  # noqa: N806
    s = dict(tunnel.SETTINGS)
    s.update({k: v for k, v in STOCK.items() if k not in ("interface_motion", "motion_solver", "wall",
                                                            "laplacian_diffusivity", "cellDisplacement",
                                                            "correctPhi", "log")})
    if w.compressible:
        s["laplacianU"] = None  # rhoPimpleFoam's term is laplacian((rho*nuEff),U), set below
    ends = "empty" if w.mode == "slice" else ("open" if not w.closed else "wall")
    over = tunnel.overrides(s, ends, moving=False)
    if w.compressible:
        over = wc.combined(over, {
            "system/fvSolution": {"solvers": {Quoted("(e|h)(Final)?"): pipe.solver_controls(STOCK["U"])}},
            "system/fvSchemes": {"laplacianSchemes": {"laplacian((rho*nuEff),U)": STOCK["laplacianU"]}}})
    return over


def write_variant(w: wc.WaterCase, axis: tuple[float, float, float], fluid: Path, folder: Path, steps: int,
                  stock: dict | None) -> Path:
    """A benchmark case in `folder`: the run's mesh, the product's dictionaries with the replay
    exchange, `steps` steps; stock (benchmark.STOCK): with stock_overrides. Returns the motion table's path."""
    import shutil

    if folder.exists():
        shutil.rmtree(folder)
    shutil.copytree(fluid / "constant" / "polyMesh", folder / "constant" / "polyMesh")
    motion = folder / "constant" / "wallMotion.dat"
    dt = w.delta_t
    b = dataclasses.replace(w, exchange=pipe.replay_exchange(motion, axis), end_time=steps * dt,
                            write_interval=steps * dt, log_interval=None if stock is not None else dt,
                            restart_dir=None, restart_windows=0, restart_from=None, input_fingerprint=None)
    wc.write(b, folder, stock_overrides(w, stock) if stock is not None else None)
    tunnel.benchmark_motion(motion, dt, steps, radial=False, a0=0.0, uo0=1e-3)
    return motion
