"""python -m benchmarks.allrun_phases [--json OUT] -- COMMAND...: where a run's wall and CPU time go.

Runs COMMAND (e.g. `tunnelquake run cases/paper_tunnel`), stamps each line it prints with the
seconds since the start and the command's own CPU seconds so far, and samples /proc every 50 ms for every process below it: each process's
first and last sighting (its wall span) and its user+sys CPU (the last sample; a process sampled
once at most 50 ms before its end loses at most that). The Python driver's own CPU is reported
apart (its threads' work: set-up, writing inputs, post-processing). On a machine shared with other
work, compare the CPU seconds and the shares within one run, not the walls of two runs.

The serial ends: the wall from the start to the first solver's start (a tq-solid run writing results,
`-o`, or an OpenFOAM solver of SOLVERS), and from the last solver's end to the command's end, each
with the driver's CPU seconds in it (sampled with the rest) and, for the end, the CPU of the other
processes that ran then (post's drawing helper).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

TICK = os.sysconf("SC_CLK_TCK")
#: the OpenFOAM solvers a coupled condition runs (their utilities are not solvers)
SOLVERS = ("rhoPimpleFoam", "pimpleFoam", "interFoam", "pisoFoam", "icoFoam")


def _stat(pid: int) -> tuple[int, str, float] | None:
    """(parent pid, command name, user+sys CPU seconds) of a process, None once it is gone."""
    try:
        raw = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    name = raw[raw.index("(") + 1:raw.rindex(")")]
    rest = raw[raw.rindex(")") + 2:].split()
    return int(rest[1]), name, (int(rest[11]) + int(rest[12])) / TICK


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return ""


class Sampler(threading.Thread):
    """Every `period` s, every live descendant of `root`: first/last seen and its CPU so far."""

    def __init__(self, root: int, t0: float, period: float = 0.05):
        super().__init__(daemon=True)
        self.root, self.t0, self.period = root, t0, period
        self.procs: dict[int, dict] = {}
        self.root_cpu: list[tuple[float, float]] = []  # (time, the command's own CPU so far)
        self.done = threading.Event()

    def sample(self) -> None:
        now = time.monotonic() - self.t0
        table = {}
        for name in os.listdir("/proc"):
            if name.isdigit():
                st = _stat(int(name))
                if st is not None:
                    table[int(name)] = st
        below = {self.root}
        grew = True
        while grew:  # the process tree under root
            grew = False
            for pid, (ppid, _, _) in table.items():
                if ppid in below and pid not in below:
                    below.add(pid)
                    grew = True
        if self.root in table:
            self.root_cpu.append((now, table[self.root][2]))
        for pid in below:
            if pid not in table:
                continue
            _, comm, cpu = table[pid]
            rec = self.procs.get(pid)
            if rec is None or rec["comm"] != comm:  # new, or exec'd into another program
                if rec is not None:
                    self.procs[-len(self.procs) - 1] = rec  # keep the program it was before
                rec = self.procs[pid] = {"pid": pid, "comm": comm, "cmd": _cmdline(pid)[:160],
                                         "start": now, "cpu0": cpu}
            rec["end"] = now
            rec["cpu"] = cpu

    def run(self) -> None:
        while not self.done.is_set():
            self.sample()
            time.sleep(self.period)


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", type=Path, help="write the lines and the processes here")
    p.add_argument("command", nargs=argparse.REMAINDER)
    args = p.parse_args(argv)
    cmd = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not cmd:
        p.error("give the command after --")
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    sampler = Sampler(proc.pid, t0)
    sampler.start()
    lines = []
    for line in proc.stdout:
        t = time.monotonic() - t0
        st = _stat(proc.pid)  # the command's own CPU so far, with each line
        cpu = st[2] if st else float("nan")
        lines.append((round(t, 3), round(cpu, 2), line.rstrip()))
        sys.stdout.write(f"{t:8.2f} {cpu:6.2f} {line}")
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.monotonic() - t0
    sampler.done.set()
    sampler.join()
    procs = sorted(sampler.procs.values(), key=lambda r: r["start"])
    print(f"\nwall {wall:.2f} s; all processes' CPU (wait4) {usage.ru_utime + usage.ru_stime:.2f} s "
          f"(the command itself: see its row)")
    print(f"{'start':>8} {'end':>8} {'span':>7} {'cpu':>7}  program")
    for r in procs:
        cpu = r["cpu"] - (r["cpu0"] if r["pid"] < 0 else 0.0)
        r["cpu_s"] = round(cpu, 2)
        print(f"{r['start']:8.2f} {r['end']:8.2f} {r['end'] - r['start']:7.2f} {cpu:7.2f}  {r['comm']}: {r['cmd'][:110]}")
    ends = serial_ends(procs, sampler.root_cpu, wall)
    if ends:
        print(f"serial ends: before the first solver {ends['before_wall_s']:.2f} s wall (the driver's CPU "
              f"{ends['before_driver_cpu_s']:.2f} s); after the last solver {ends['after_wall_s']:.2f} s wall "
              f"(the driver's CPU {ends['after_driver_cpu_s']:.2f} s, other processes {ends['after_other_cpu_s']:.2f} s)")
    if args.json:
        args.json.write_text(json.dumps({"command": cmd, "wall_s": wall, "status": status,
                                         "cpu_all_s": usage.ru_utime + usage.ru_stime, "serial_ends": ends,
                                         "lines": lines, "processes": procs}, indent=1))
    return os.waitstatus_to_exitcode(status)


def _is_solver(r: dict) -> bool:
    return (r["comm"] == "tq-solid" and " -o " in f" {r['cmd']} ") or r["comm"] in SOLVERS


def serial_ends(procs: list[dict], root_cpu: list[tuple[float, float]], wall: float) -> dict | None:
    """The wall and CPU seconds before the first solver starts and after the last one ends (see the
    module's text); None when no solver ran. The driver's CPU at a time is its last sample before it;
    its CPU after the last sample (at most 50 ms of it) is not counted."""
    solvers = [r for r in procs if _is_solver(r)]
    if not solvers or not root_cpu:
        return None
    first, last = min(r["start"] for r in solvers), max(r["end"] for r in solvers)

    def driver_at(t: float) -> float:
        return max((c for s, c in root_cpu if s <= t), default=0.0)

    other = sum(r["cpu_s"] for r in procs if r["start"] > last)  # started after the last solver ended
    return {"before_wall_s": round(first, 3), "before_driver_cpu_s": round(driver_at(first), 2),
            "after_wall_s": round(wall - last, 3), "after_driver_cpu_s": round(root_cpu[-1][1] - driver_at(last), 2),
            "after_other_cpu_s": round(other, 2)}


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
