#!/usr/bin/env python3
"""A model of millions of solid elements on MPI ranks: meshed, partitioned and stepped, with the
peak memory of every rank (a benchmark, not a test).

usage: python -m benchmarks.solid_ranks_large FOLDER [--n 126] [--steps 100] [--ranks 2]
                                              [--threads 1] [--samples 10] [--plain]

Writes the elastic box of benchmarks.solid_ranks with n^3 unit hex8 (n = 126: 2,000,376 elements,
2,048,383 nodes; base fixed, a ramped top load, gravity) through a structured generator (numpy, no
gmsh: a box needs none), then runs `mpirun -np R tq-solid --distributed` on it for `steps` steps
(every rank reads the mesh, partitions it by recursive coordinate bisection and builds its part).
Prints the time of each phase (the mesh written; tq-solid's start: reading, partition, solvers; the
stepping loop), the CPU time of the whole command (user + system, mpirun included) and the peak
resident memory of each rank as tq-solid reports it (getrusage, /ranks in the results). `--plain`
also runs the same model as one process (OpenMP threads only) for its peak memory
(/usr/bin/time's maximum resident set size).
"""
from __future__ import annotations

import argparse
import re
import shutil
import time
from pathlib import Path

import h5py

from benchmarks.common import machine
from benchmarks.solid_ranks import timed, write_box
from tunnelquake import paths
from tunnelquake.solid_ranks import solid_command


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path)
    ap.add_argument("--n", type=int, default=126)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--samples", type=int, default=10,
                    help="monitor samples over the steps (each gathers every element's state to rank 0)")
    ap.add_argument("--plain", action="store_true", help="also run it as one process for its peak memory")
    args = ap.parse_args(argv)
    exe = paths.solid_executable()
    t0 = time.perf_counter()
    inp = write_box(args.folder, args.n, args.steps, args.samples)
    mesh_s = time.perf_counter() - t0
    mesh_mb = (args.folder / "mesh.h5").stat().st_size / 2**20
    print(f"{args.n ** 3:,} elements, {(args.n + 1) ** 3:,} nodes: mesh.h5 ({mesh_mb:.0f} MiB) and the input "
          f"written in {mesh_s:.1f} s", flush=True)
    res = args.folder / "results_ranks.h5"
    cmd = solid_command(exe, inp, res, args.threads, args.ranks)
    proc, wall, cpu = timed(cmd)
    print(proc.stdout, flush=True)
    with h5py.File(res, "r") as f:
        t = f["timings"].attrs
        loop, steps, us = float(t["wall_s"]), int(t["steps"]), float(t["us_per_element_step"])
        r = f["ranks"].attrs
        imbalance, frontier = float(r["largest_part_over_mean"]), int(r["frontier_node_copies"])
        wait = float(t["wait_fraction"])
    m = re.search(r"peak memory per rank \(MiB\):([ 0-9]+)", proc.stdout)
    peaks = [int(x) for x in m.group(1).split()] if m else []
    print(f"on {args.ranks} rank(s) x {args.threads} thread(s): {steps} steps; whole command {wall:.1f} s wall, "
          f"{cpu:.1f} s CPU; start (read, partition, solvers, statics) {wall - loop:.1f} s, stepping loop "
          f"{loop:.1f} s ({us:.3f} us per element-step); largest part {imbalance:.4f} x the mean, {frontier:,} "
          f"frontier node copies, wait fraction {wait:.2f}; peak memory per rank (MiB): "
          f"{' '.join(map(str, peaks))}")
    if args.plain:
        gnu_time = shutil.which("time") or "/usr/bin/time"
        res1 = args.folder / "results_plain.h5"
        proc, wall, cpu = timed([gnu_time, "-f", "maxrss_kB %M"] + solid_command(exe, inp, res1, args.threads, 1))
        m = re.search(r"maxrss_kB (\d+)", proc.stderr)
        with h5py.File(res1, "r") as f:
            loop1 = float(f["timings"].attrs["wall_s"])
        print(f"one process x {args.threads} thread(s): whole command {wall:.1f} s wall, {cpu:.1f} s CPU, stepping "
              f"loop {loop1:.1f} s; peak memory {int(m.group(1)) / 1024:.0f} MiB" if m else proc.stderr)
    print(machine())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
