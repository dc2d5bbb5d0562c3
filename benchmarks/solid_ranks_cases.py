#!/usr/bin/env python3
"""Staged cases on MPI ranks against one process (a measurement, not a test).

usage: python -m benchmarks.solid_ranks_cases FOLDER [--scene slice|scene3d|example3d] [--end 1.0]
                                              [--ranks 1,2,3,4,8] [--rounds 0] [--configs ...]
                                              [--compare-only]

Writes one condition's solid input through the product (`tunnelquake` meshing, motion and
solid_input.write_solid_input), runs tq-solid on it as one process, then under
`mpirun -np N tq-solid --distributed` for each N (oversubscribed where the cores are short), and
compares every dataset under /monitors, /energy, /interface, /ring_forces and /snapshots with the
one-process run: the largest difference relative to the largest magnitude of its dataset (an
interface pair's opening and slip against the snapshot's largest displacement), the monitors'
accelerations apart, and the datasets written in single precision (the ring forces) in units of
the last bit of their largest magnitude; and the same for the one-process run with the generic SIMD path
(TQ_SOLID_SIMD=generic), the computation's own round-off.

    slice      the built-in example (cases/paper_tunnel), slice mode, condition no_water: in-situ,
               excavation, lining with the dynamic contact, Mohr-Coulomb damage in rock and lining,
               viscoelastic base and free-field sides, the record's first END seconds
    scene3d    a 3D scene unlike the example: cases/pressure_tunnel (a weathered layer over the rock,
               its own records across the tunnel and vertical, scaled to 0.8 g and 0.5 g) as a 3D
               block 3 m long, coarse, its lining and rock Mohr-Coulomb and weakened (they yield),
               the dynamic contact with 0.01 MPa cohesion and friction 0.05 (pairs slip), condition
               static_water (the hydrostatic stage)

    example3d  the example's 3D model (cases/paper_tunnel, mesh mode 3d: 80 m long), condition
               no_water, single-rate (the `3d` variant itself, subcycled and coupled to OpenFOAM's
               water: benchmarks.solid_ranks_coupled)

--rounds R > 0 also times R rounds of the --configs (default plain:1,ranks:1x1: one rank against
the one-process run; ranks:1x2,ranks:2x1: 2 ranks x 1 thread against 1 rank x 2 threads), alternated
within each round: the whole command's CPU time (user + system, mpirun included), tq-solid's own
(GNU time around the executable, summed over the ranks: mpirun's left out) and the stepping loop's
wall time, medians and median ratios to the first configuration; with `--ranks ''` only
these (no comparison runs).
"""
from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import yaml

from benchmarks.common import machine
from tunnelquake import paths
from tunnelquake.case import load_case
from tunnelquake.prepare import make_mesh, make_motion, mesh_dir
from tunnelquake.solid_input import write_solid_input
from tunnelquake.solid_ranks import solid_command

ROOT = Path(__file__).resolve().parents[1]
GNU_TIME = shutil.which("time") or "/usr/bin/time"
GROUPS = ("/monitors", "/energy", "/interface", "/ring_forces", "/snapshots")


def _scene(name: str, folder: Path, end: float) -> tuple[Path, str]:
    """The case file of a scene written into `folder` (paths made absolute), and its condition."""
    if name == "slice":
        src = ROOT / "cases" / "paper_tunnel" / "case.yaml"
        data = yaml.safe_load(src.read_text())
        data.pop("variants", None)
        cond = "no_water"
    elif name == "scene3d":
        src = ROOT / "cases" / "pressure_tunnel" / "case.yaml"
        data = yaml.safe_load(src.read_text())
        data.pop("variants", None)
        data["geometry"].update({"x_range": [-30.0, 30.0], "y_range": [0.0, 3.0], "z_range": [-10.0, 60.0]})
        data["mesh"].update({"mode": "3d", "max_element_size": "6 m", "lining_elements_around": 16,
                             "lining_elements_through": 1, "near_field_radial_divisions": 3,
                             "elements_along_axis": 3})
        data["interface"] = {"model": "dynamic_contact", "cohesion": "0.01 MPa", "static_friction": 0.05,
                             "dynamic_friction": 0.05}
        # weaker ground and lining and a stronger shaking than the case's, so that both yield and
        # pairs slip or open
        data["materials"]["rock"].update({"cohesion": "0.3 MPa", "tensile_strength": "0.15 MPa"})
        data["materials"]["lining"].update({"tensile_strength": "0.5 MPa"})
        data["ground_motion"]["pga"] = "0.8 g"
        data["ground_motion"]["vertical"]["pga"] = "0.5 g"
        data["ground_motion"].pop("second_horizontal", None)  # a 3D block's y faces are on rollers
        for m in data["output"]["monitors"].values():
            m[1] = 1.5
        cond = "static_water"
    elif name == "example3d":
        src = ROOT / "cases" / "paper_tunnel" / "case.yaml"
        data = yaml.safe_load(src.read_text())
        data.pop("variants", None)
        data["mesh"]["mode"] = "3d"  # the `3d` variant's model, its solid alone, single-rate
        cond = "no_water"
    else:
        raise SystemExit(f"unknown scene {name!r}: slice, scene3d or example3d")
    gm = data["ground_motion"]
    for g in (gm, gm.get("vertical") or {}, gm.get("second_horizontal") or {}):
        if "file" in g:
            g["file"] = str((src.parent / g["file"]).resolve())
    data["conditions"] = [cond]
    data["time"] = {**(data.get("time") or {}), "end_time": f"{end} s"}
    data["output"].update({"directory": str(folder / "results"), "snapshot_times": [end]})
    folder.mkdir(parents=True, exist_ok=True)
    case = folder / "case.yaml"
    case.write_text(yaml.safe_dump(data, sort_keys=False))
    return case, cond


def _datasets(res: Path) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed", (res, f.attrs["status"])

        def take(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu":  # single precision kept so
                out[name] = np.asarray(obj[()], dtype=np.float32 if obj.dtype == np.float32 else float)

        for g in GROUPS:
            if g in f:
                f[g].visititems(lambda n, o, g=g: take(g + "/" + n, o))
    return out


def _scale(ref: dict, k: str) -> float:
    """A dataset's largest magnitude; an interface pair's opening and slip (differences of the two
    nodes' displacements, round-off of 0 while the pairs stay bonded) against the snapshot's
    largest displacement."""
    scale = float(np.nanmax(np.abs(ref[k]))) if ref[k].size and not np.all(np.isnan(ref[k])) else 0.0
    if k.endswith("/interface/opening") or k.endswith("/interface/slip"):
        u = k.rsplit("/interface/", 1)[0] + "/u"
        if u in ref:
            scale = max(scale, float(np.nanmax(np.abs(ref[u]))))
    return scale


def _compare(ref: dict, got: dict) -> dict:
    """The largest relative difference of the accelerations and of everything else, where, the
    datasets equal bitwise, and how many of the ring forces' envelope peak times differ (the time of
    a peak is the sample of the largest value: two nearly equal samples may swap on round-off)."""
    out = {"worst": (0.0, ""), "acc": (0.0, ""), "bitwise": [], "peak_times": [0, 0], "f32_ulps": (0.0, "")}
    assert set(ref) == set(got), set(ref) ^ set(got)
    for k, a in ref.items():
        b = got[k]
        assert a.shape == b.shape, (k, a.shape, b.shape)
        if "/envelope/" in k and a.ndim == 2 and a.shape[1] == 4:  # max, its time, min, its time
            out["peak_times"][0] += int(np.sum(a[:, 1::2] != b[:, 1::2]))
            out["peak_times"][1] += a[:, 1::2].size
            a, b = a[:, 0::2], b[:, 0::2]
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        if a.dtype == np.float32:  # written in single precision (ring forces): its last bit, 6e-8, apart
            last = float(np.spacing(np.float32(np.nanmax(np.abs(a))))) if a.size and not np.all(np.isnan(a)) else 1.0
            ulps = float(np.max(np.where(same, 0.0, np.abs(a.astype(float) - b)))) / last if a.size else 0.0
            if ulps == 0:
                out["bitwise"].append(k)
            if ulps > out["f32_ulps"][0]:
                out["f32_ulps"] = (ulps, k)
            continue
        diff = float(np.max(np.where(same, 0.0, np.abs(a - b)))) if a.size else 0.0
        scale = _scale(ref, k)
        rel = diff / scale if scale > 0 else diff
        if diff == 0:
            out["bitwise"].append(k)
        key = "acc" if k.endswith("/a") else "worst"
        if rel > out[key][0]:
            out[key] = (rel, k)
    return out


def _run(cmd: list[str], log: Path) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    with log.open("w") as out:
        proc = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, env={**os.environ, "OMP_NUM_THREADS": "1"})
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"failed ({proc.returncode}): {' '.join(cmd)}\n{log.read_text()[-3000:]}")
    return {"cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), "wall_s": wall}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path)
    ap.add_argument("--scene", default="slice")
    ap.add_argument("--end", type=float, default=1.0, help="seconds of shaking")
    ap.add_argument("--ranks", default="1,2,3,4,8")
    ap.add_argument("--rounds", type=int, default=0)
    ap.add_argument("--configs", default="plain:1,ranks:1x1",
                    help="what --rounds times: plain:T (one process, T threads), ranks:RxT (R ranks x T threads)")
    ap.add_argument("--compare-only", action="store_true", help="compare the results files already in FOLDER")
    args = ap.parse_args(argv)
    if args.compare_only:
        return _compare_only(args.folder.resolve(), [int(x) for x in args.ranks.split(",")])
    folder = args.folder.resolve()
    case_file, cond = _scene(args.scene, folder, args.end)
    case = load_case(case_file)
    summary = make_mesh(case)
    _, motion = make_motion(case)
    inp = write_solid_input(case, mesh_dir(case) / "mesh.h5", motion, cond, folder / "solid_input.h5")
    exe = paths.solid_executable()
    cores = len(os.sched_getaffinity(0))
    print(f"{args.scene}: condition {cond}, {args.end} s, mesh {summary.get('elements', summary)}", flush=True)
    if args.rounds > 0 and not args.ranks:  # timing alone
        _time_configs(exe, inp, folder, args.configs.split(","), args.rounds, cores)
        print(machine())
        return 0
    plain = folder / "plain.h5"
    t = _run(solid_command(exe, inp, plain, 1, 1), folder / "plain.log")
    print(f"one process: {t['wall_s']:.1f} s wall", flush=True)
    ref = _datasets(plain)
    # The computation's own round-off: the same one-process run with the generic SIMD path.
    generic = folder / "generic.h5"
    _run(["env", "TQ_SOLID_SIMD=generic", *solid_command(exe, inp, generic, 1, 1)], folder / "generic.log")
    c = _compare(ref, _datasets(generic))
    print(f"one process, generic SIMD path: largest relative difference {c['worst'][0]:.3g} ({c['worst'][1]}), "
          f"accelerations {c['acc'][0]:.3g} ({c['acc'][1]})", flush=True)
    for n in (int(x) for x in args.ranks.split(",")):
        res = folder / f"ranks{n}.h5"
        cmd = solid_command(exe, inp, res, 1, n, cores) if n > 1 else _one_rank(exe, inp, res, cores)
        t = _run(cmd, folder / f"ranks{n}.log")
        c = _compare(ref, _datasets(res))
        with h5py.File(res, "r") as f:
            mism = f["ranks"].attrs["frontier_copies_max_difference"] if "ranks" in f else 0.0
        print(f"{n} rank(s): largest relative difference {c['worst'][0]:.3g} ({c['worst'][1]}), accelerations "
              f"{c['acc'][0]:.3g} ({c['acc'][1]}); {len(c['bitwise'])} of {len(ref)} datasets bitwise; envelope "
              f"peak times differing {c['peak_times'][0]} of {c['peak_times'][1]}; frontier copies differ by {mism}; "
              f"{t['wall_s']:.1f} s wall", flush=True)
        if n > 1:
            print(f"  not bitwise: {', '.join(sorted(set(ref) - set(c['bitwise'])))}", flush=True)
    if args.rounds > 0:
        _time_configs(exe, inp, folder, args.configs.split(","), args.rounds, cores)
    print(machine())
    return 0


def _time_configs(exe, inp, folder: Path, configs: list[str], rounds: int, cores: int) -> None:
    """Each configuration (plain:T one process with T threads, ranks:RxT R ranks of T threads) run in
    turn within every round; the CPU time of the whole command (mpirun included) and the stepping
    loop's wall time (/timings), each configuration's median and its ratio to the first's."""
    runs: dict[str, list[dict]] = {c: [] for c in configs}
    for r in range(rounds):
        for c in configs:
            kind, _, spec = c.partition(":")
            res = folder / f"timed_{kind}_{spec}.h5"
            if kind == "plain":
                cmd = solid_command(exe, inp, res, int(spec), 1)
            else:
                n, _, threads = spec.partition("x")
                cmd = solid_command(exe, inp, res, int(threads), int(n), cores) if int(n) > 1 else \
                    _one_rank(exe, inp, res, cores, int(threads))
            # tq-solid's own CPU time, each rank's apart from mpirun's: GNU time around the executable
            at = cmd.index(str(exe))
            cmd = cmd[:at] + [GNU_TIME, "-f", "tq-solid CPU %U %S"] + cmd[at:]
            log = folder / f"timed_{kind}_{spec}.log"
            t = _run(cmd, log)
            t["solid_cpu_s"] = sum(float(u) + float(v) for u, v in re.findall(r"tq-solid CPU ([0-9.]+) ([0-9.]+)",
                                                                               log.read_text()))
            with h5py.File(res, "r") as f:
                t["loop_s"] = float(f["timings"].attrs["wall_s"])
            runs[c].append(t)
            print(f"round {r + 1} {c}: CPU {t['cpu_s']:.2f} s (tq-solid's own {t['solid_cpu_s']:.2f} s), stepping "
                  f"loop {t['loop_s']:.2f} s, whole command {t['wall_s']:.2f} s", flush=True)
    first = configs[0]
    for c in configs:
        parts = []
        for key, what in (("cpu_s", "CPU"), ("solid_cpu_s", "tq-solid's own CPU"), ("loop_s", "stepping loop")):
            ratios = [a[key] / b[key] for a, b in zip(runs[c], runs[first], strict=True)]
            parts.append(f"{what} {statistics.median(x[key] for x in runs[c]):.2f} s, / {first} "
                         f"{statistics.median(ratios):.3f} (rounds {' / '.join(f'{x:.3f}' for x in ratios)})")
        print(f"  {c} (medians of {rounds}): " + "; ".join(parts), flush=True)


def _compare_only(folder: Path, ranks: list[int]) -> int:
    ref = _datasets(folder / "plain.h5")
    for name in ["generic"] + [f"ranks{n}" for n in ranks]:
        if not (folder / f"{name}.h5").is_file():
            continue
        c = _compare(ref, _datasets(folder / f"{name}.h5"))
        print(f"{name}: largest relative difference {c['worst'][0]:.3g} ({c['worst'][1]}), accelerations "
              f"{c['acc'][0]:.3g} ({c['acc'][1]}); single precision: {c['f32_ulps'][0]:.3g} ulp "
              f"({c['f32_ulps'][1]}); {len(c['bitwise'])} of {len(ref)} datasets bitwise; envelope "
              f"peak times differing {c['peak_times'][0]} of {c['peak_times'][1]}")
    return 0


def _one_rank(exe, inp, res, cores, threads: int = 1) -> list[str]:
    """mpirun -np 1 tq-solid --distributed (solid_command gives the plain line for one rank)."""
    cmd = solid_command(exe, inp, res, threads, 2, cores)
    cmd[cmd.index("-np") + 1] = "1"
    if "--oversubscribe" in cmd and cores >= threads:
        cmd.remove("--oversubscribe")
        i = cmd.index("--bind-to")
        del cmd[i:i + 2]
    return cmd


if __name__ == "__main__":
    if shutil.which("mpirun") is None:
        raise SystemExit("needs mpirun")
    raise SystemExit(main())
