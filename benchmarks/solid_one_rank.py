#!/usr/bin/env python3
"""One rank against the one-process tq-solid: instructions executed and CPU time (a benchmark, not a
test).

usage: PYTHONPATH=scripts:. python -m benchmarks.solid_one_rank FOLDER --baseline EXE
           [--inputs box,slice] [--box-n 40] [--box-steps 5,15] [--slice-end 0.005,0.05]
           [--cache-sim] [--rounds 7] [--round-steps 600] [--json FILE]

Three configurations, each with one thread:

    baseline   EXE (another build's tq-solid) as one process
    plain      this build's tq-solid as one process
    rank       mpirun -np 1 tq-solid --distributed of this build (tunnelquake.solid_ranks)

**Instructions** (`--inputs`): each configuration under `valgrind --tool=callgrind` (mpirun itself
outside it: valgrind wraps the rank's process), the instructions of every thread of the tq-solid
process, on two lengths of each input. The instructions do not depend on the load of the machine,
which moves CPU seconds by 10-25 % a run on a shared VM, but for what tq-solid does by the clock:
the results are flushed every 2 s of wall time (`SolidRun::flushAndReport`), and valgrind's
slowdown makes that nearly every step; the flushes' inclusive instructions (`ResultsWriter::flush`)
are therefore taken off the totals and reported apart. The difference of the two lengths over the
difference of their steps is the cost of a step; the shorter run less its steps at that cost is the
start-up (reading the input and the mesh, building the solver, the static stages, MPI's start and
end, writing the results). Inputs:

    box     the elastic box of benchmarks.solid_ranks (n^3 unit hex8, base fixed, a ramped load on
            the top, gravity; unstaged), --box-steps steps, a monitor sample every 10 steps
    slice   the example (cases/paper_tunnel), slice mode, condition static_water with the case's own
            time.subcycling (in-situ, excavation, lining, hydrostatic, then the record's first
            --slice-end seconds)

`--cache-sim` adds callgrind's simulated caches (first level and last level, misses of instruction
fetches, data reads and data writes) to the same runs.

**CPU time** (`--rounds R`): the three configurations alternated within each of R rounds on the box
of `--box-n` with `--round-steps` steps (unmeasured by valgrind): the CPU time (user + system) of
the whole command, mpirun included, tq-solid's own (GNU time around the executable: mpirun's left
out) and the stepping loop's wall time (/timings); each round's ratio to the baseline, and the median
of those paired ratios.

Prints the machine line and every figure; writes them as JSON (default FOLDER/solid_one_rank.json).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
from pathlib import Path

import h5py
import yaml

from benchmarks.common import machine
from benchmarks.solid_ranks import timed, write_box
from tunnelquake import paths
from tunnelquake.solid_ranks import solid_command

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ("baseline", "plain", "rank")
#: callgrind's events with --cache-sim=yes (instruction fetches, data reads, data writes; misses of
#: the first-level and of the last-level cache)
CACHE_EVENTS = ("Ir", "Dr", "Dw", "I1mr", "D1mr", "D1mw", "ILmr", "DLmr", "DLmw")
FLUSH = "ResultsWriter::flush()"
GNU_TIME = shutil.which("time") or "/usr/bin/time"


def one_rank_command(exe: Path, inp: Path, res: Path) -> list[str]:
    """mpirun -np 1 tq-solid --distributed, 1 thread (solid_command gives the plain line for one
    rank: its 2-rank line with -np 1, not oversubscribed)."""
    cmd = solid_command(exe, inp, res, 1, 2, cores=2)
    cmd[cmd.index("-np") + 1] = "1"
    return cmd


def command(config: str, exe: Path, baseline: Path, inp: Path, res: Path) -> list[str]:
    if config == "baseline":
        return solid_command(baseline, inp, res, 1, 1)
    if config == "plain":
        return solid_command(exe, inp, res, 1, 1)
    return one_rank_command(exe, inp, res)


def slice_input(folder: Path, end: float) -> Path:
    """The example's slice, condition static_water with the case's subcycling, `end` s of the
    record: its solid input written through the product."""
    from tunnelquake.case import load_case
    from tunnelquake.prepare import make_mesh, make_motion, mesh_dir
    from tunnelquake.solid_input import write_solid_input

    src = ROOT / "cases" / "paper_tunnel" / "case.yaml"
    data = yaml.safe_load(src.read_text())
    data.pop("variants", None)
    gm = data["ground_motion"]
    for g in (gm, gm.get("vertical") or {}, gm.get("second_horizontal") or {}):
        if "file" in g:
            g["file"] = str((src.parent / g["file"]).resolve())
    data["conditions"] = ["static_water"]
    data["time"] = {**(data.get("time") or {}), "end_time": f"{end} s"}
    data["output"].update({"directory": str(folder / "results")})
    folder.mkdir(parents=True, exist_ok=True)
    case_file = folder / "case.yaml"
    case_file.write_text(yaml.safe_dump(data, sort_keys=False))
    case = load_case(case_file)
    make_mesh(case)
    _, motion = make_motion(case)
    return write_solid_input(case, mesh_dir(case) / "mesh.h5", motion, "static_water", folder / "solid_input.h5")


def _events(out: Path) -> dict[str, int]:
    """The totals of a callgrind output file by event (its 'events:' and 'totals:' lines)."""
    names: list[str] = []
    totals: list[int] = []
    for line in out.read_text(errors="replace").splitlines():
        if line.startswith("events:"):
            names = line.split()[1:]
        elif line.startswith("totals:") or (line.startswith("summary:") and not totals):
            totals = [int(x) for x in line.split()[1:]]
    return dict(zip(names, totals, strict=False))


def _flush_ir(out: Path) -> int:
    """The inclusive instructions of the results' flushes in one callgrind output file."""
    ann = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                         capture_output=True, text=True, check=True).stdout
    total = 0
    for line in ann.splitlines():
        if FLUSH in line and "[clone" not in line:
            m = re.match(r"\s*([0-9,]+)", line)
            if m:
                total = max(total, int(m.group(1).replace(",", "")))
    return total


def callgrind(config: str, exe: Path, baseline: Path, inp: Path, folder: Path, tag: str, cache_sim: bool) -> dict:
    """One run under callgrind: the events summed over the tq-solid process's threads, the main
    thread's instructions, the flushes' instructions, the steps taken."""
    res = folder / f"{tag}_{config}.h5"
    prefix = folder / f"callgrind_{tag}_{config}.out"
    for old in folder.glob(prefix.name + "*"):
        old.unlink()
    cmd = command(config, exe, baseline, inp, res)
    at = cmd.index(str(exe if config != "baseline" else baseline))
    vg = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={prefix}", "--separate-threads=yes",
          f"--cache-sim={'yes' if cache_sim else 'no'}"]
    cmd = cmd[:at] + vg + cmd[at:]
    log = folder / f"callgrind_{tag}_{config}.log"
    with log.open("w") as f:
        proc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env={**os.environ, "OMP_NUM_THREADS": "1"})
    if proc.returncode != 0:
        raise SystemExit(f"failed ({proc.returncode}): {' '.join(cmd)}\n{log.read_text()[-3000:]}")
    return collect(prefix, res)


def collect(prefix: Path, res: Path) -> dict:
    """The figures of one callgrind run from its output files (`prefix`, a file a thread) and its
    results file."""
    outs = sorted(prefix.parent.glob(prefix.name + "-*")) or ([prefix] if prefix.is_file() else [])
    if not outs:
        raise SystemExit(f"no callgrind output {prefix}")
    events: dict[str, int] = {}
    for o in outs:
        for k, v in _events(o).items():
            events[k] = events.get(k, 0) + v
    main_ir = _events(outs[0]).get("Ir", 0)  # the first thread: tq-solid's main thread
    flush = sum(_flush_ir(o) for o in outs)
    with h5py.File(res, "r") as f:
        steps = int(f["timings"].attrs["steps"])
    return {"events": events, "ir": events["Ir"], "main_thread_ir": main_ir, "flush_ir": flush,
            "ir_less_flush": events["Ir"] - flush, "threads": len(outs), "steps": steps}


def instructions(name: str, inputs: list[Path], exe: Path, baseline: Path, folder: Path, cache_sim: bool) -> dict:
    """The three configurations on the two lengths of an input: per step and start-up, and the ratios
    to the baseline."""
    runs: dict[str, list[dict]] = {c: [] for c in CONFIGS}
    for i, inp in enumerate(inputs):
        for c in CONFIGS:
            r = callgrind(c, exe, baseline, inp, folder, f"{name}{i}", cache_sim)
            runs[c].append(r)
            print(f"{name} length {i}: {c}: {r['ir']:,} instructions ({r['threads']} thread(s); main thread "
                  f"{r['main_thread_ir']:,}; flushes {r['flush_ir']:,}), {r['steps']} steps", flush=True)
    return summarize(name, runs, cache_sim)


def summarize(name: str, runs: dict[str, list[dict]], cache_sim: bool) -> dict:
    """A step's events and the start-up's instructions of each configuration from its two runs
    (`callgrind`'s), and their ratios to the baseline's."""
    out: dict = {"runs": runs, "configs": {}}
    for c in CONFIGS:
        a, b = runs[c]
        dsteps = b["steps"] - a["steps"]
        per_step = {k: (b["events"][k] - a["events"][k]) / dsteps for k in a["events"]}
        step = (b["ir_less_flush"] - a["ir_less_flush"]) / dsteps
        start = a["ir_less_flush"] - a["steps"] * step
        out["configs"][c] = {"step_ir": step, "start_ir": start, "step_events": per_step,
                             "step_ir_with_flushes": per_step["Ir"], "steps": [a["steps"], b["steps"]]}
    base = out["configs"]["baseline"]
    for c in CONFIGS:
        d = out["configs"][c]
        d["step_ratio"] = d["step_ir"] / base["step_ir"]
        d["start_ratio"] = d["start_ir"] / base["start_ir"]
        d["step_ratio_with_flushes"] = d["step_ir_with_flushes"] / base["step_ir_with_flushes"]
        d["events_ratio"] = {k: (v / base["step_events"][k] if base["step_events"].get(k) else None)
                             for k, v in d["step_events"].items()}
        extra = ""
        if cache_sim:
            extra = "; misses a step " + ", ".join(
                f"{k} {v:,.0f} ({_fmt(d['events_ratio'][k])})" for k, v in d["step_events"].items()
                if k not in ("Ir", "Dr", "Dw"))
        print(f"{name}: {c}: {d['step_ir']:,.0f} instructions a step ({d['step_ratio']:.5f} of the baseline; "
              f"flushes included {d['step_ratio_with_flushes']:.5f}), start-up {d['start_ir']:,.0f} "
              f"({d['start_ratio']:.4f}){extra}", flush=True)
    return out


def _fmt(ratio: float | None) -> str:
    return "n/a" if ratio is None else f"{ratio:.4f}"


def cpu_rounds(inp: Path, exe: Path, baseline: Path, folder: Path, rounds: int) -> dict:
    """The configurations alternated in each round: CPU time of the whole command and the stepping
    loop's wall time, each round's ratio to the baseline, medians."""
    runs: dict[str, list[dict]] = {c: [] for c in CONFIGS}
    for r in range(rounds):
        order = CONFIGS if r % 2 == 0 else tuple(reversed(CONFIGS))
        for c in order:
            res = folder / f"round_{c}.h5"
            cmd = command(c, exe, baseline, inp, res)
            at = cmd.index(str(exe if c != "baseline" else baseline))
            # tq-solid's own CPU time apart from mpirun's: GNU time around the executable
            proc, wall, cpu = timed(cmd[:at] + [GNU_TIME, "-f", "tq-solid CPU %U %S"] + cmd[at:])
            own = sum(float(u) + float(v) for u, v in re.findall(r"tq-solid CPU ([0-9.]+) ([0-9.]+)", proc.stderr))
            with h5py.File(res, "r") as f:
                loop = float(f["timings"].attrs["wall_s"])
            runs[c].append({"cpu_s": cpu, "solid_cpu_s": own, "wall_s": wall, "loop_s": loop,
                            "load": os.getloadavg()[0]})
        print(f"round {r + 1} (load {os.getloadavg()[0]:.1f}): " + ", ".join(
            f"{c} CPU {runs[c][-1]['cpu_s']:.2f} s" for c in CONFIGS) + "; / baseline " + ", ".join(
            f"{c} {runs[c][-1]['cpu_s'] / runs['baseline'][-1]['cpu_s']:.3f}" for c in CONFIGS[1:]), flush=True)
    out: dict = {"runs": runs}
    for c in CONFIGS[1:]:
        ratios = [a["cpu_s"] / b["cpu_s"] for a, b in zip(runs[c], runs["baseline"], strict=True)]
        loops = [a["loop_s"] / b["loop_s"] for a, b in zip(runs[c], runs["baseline"], strict=True)]
        own = [a["solid_cpu_s"] / b["solid_cpu_s"] if b["solid_cpu_s"] > 0 else float("nan")  # GNU time: 0.01 s
               for a, b in zip(runs[c], runs["baseline"], strict=True)]
        out[c] = {"cpu_ratios": ratios, "cpu_ratio_median": statistics.median(ratios),
                  "solid_cpu_ratios": own, "solid_cpu_ratio_median": statistics.median(own),
                  "loop_ratios": loops, "loop_ratio_median": statistics.median(loops),
                  "cpu_median_s": statistics.median(x["cpu_s"] for x in runs[c]),
                  "solid_cpu_median_s": statistics.median(x["solid_cpu_s"] for x in runs[c])}
        print(f"  {c} / baseline, median of {rounds} paired ratios: CPU {statistics.median(ratios):.3f} (rounds "
              f"{' / '.join(f'{x:.3f}' for x in ratios)}), tq-solid's own CPU {statistics.median(own):.3f} (rounds "
              f"{' / '.join(f'{x:.3f}' for x in own)}), stepping loop {statistics.median(loops):.3f}; medians "
              f"{statistics.median(x['cpu_s'] for x in runs[c]):.2f} against "
              f"{statistics.median(x['cpu_s'] for x in runs['baseline']):.2f} s", flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path)
    ap.add_argument("--baseline", type=Path, required=True, help="the other build's tq-solid")
    ap.add_argument("--inputs", default="box,slice", help="what callgrind counts: box, slice, or none ('')")
    ap.add_argument("--box-n", type=int, default=40)
    ap.add_argument("--box-steps", default="5,15", help="the box's two lengths, steps")
    ap.add_argument("--slice-end", default="0.005,0.05", help="the slice's two lengths, seconds of the record")
    ap.add_argument("--cache-sim", action="store_true")
    ap.add_argument("--rounds", type=int, default=7, help="CPU-time rounds on the box (0: none)")
    ap.add_argument("--round-steps", type=int, default=600)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    if shutil.which("mpirun") is None or (args.inputs and shutil.which("valgrind") is None):
        raise SystemExit("needs mpirun and valgrind")
    folder = args.folder.resolve()
    folder.mkdir(parents=True, exist_ok=True)
    exe = paths.solid_executable()
    baseline = args.baseline.resolve()
    print(f"this build: {exe}; baseline: {baseline}; {machine()}", flush=True)
    result: dict = {"exe": str(exe), "baseline": str(baseline), "machine_start": machine(), "instructions": {}}
    for name in [x for x in args.inputs.split(",") if x]:
        if name == "box":
            steps = [int(x) for x in args.box_steps.split(",")]
            inputs = [write_box(folder / f"box{s}", args.box_n, s, samples=max(1, s // 10)) for s in steps]
        elif name == "slice":
            inputs = [slice_input(folder / f"slice{i}", float(e)) for i, e in enumerate(args.slice_end.split(","))]
        else:
            raise SystemExit(f"unknown input {name!r}: box or slice")
        result["instructions"][name] = instructions(name, inputs, exe, baseline, folder, args.cache_sim)
    if args.rounds > 0:
        inp = write_box(folder / f"box_rounds{args.round_steps}", args.box_n, args.round_steps)
        result["cpu"] = cpu_rounds(inp, exe, baseline, folder, args.rounds)
        result["cpu"]["input"] = f"box n {args.box_n}, {args.round_steps} steps"
    result["machine"] = machine()
    print(result["machine"])
    path = args.json or folder / "solid_one_rank.json"
    path.write_text(json.dumps(result, indent=1))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
