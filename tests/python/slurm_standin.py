"""A stand-in for Slurm's `sbatch`, for tests on a machine without Slurm: it reads a batch script's
#SBATCH lines as sbatch does and runs the job array's tasks here, each as Slurm starts one.

What it shares with Slurm (sbatch(1), src/sbatch/opt.c):
- #SBATCH lines are read from the top of the script until the first line that is neither blank nor a
  comment; each is split into words at blanks outside single or double quotes, a backslash escapes
  the next character and an unquoted `#` starts a comment;
- an unknown option is refused, as sbatch refuses it;
- the script runs from a copy in a spool folder (so `$0` is not the script's own path), in --chdir
  (else the submission folder), its output in --output with %A, %a, %j, %x and %% replaced
  (relative to that folder; truncated, or appended with --open-mode=append), with
  SLURM_ARRAY_TASK_ID and the other SLURM_* variables set, SLURM_RESTART_COUNT only on a requeue;
- at --time the task's processes get SIGTERM, and SIGKILL KILL_WAIT_S later (Slurm's KillWait);
  a task killed (`Task.kill`) loses every process it started, as a node that fails does.

What it does not: queue anything. `sbatch` here waits for the tasks (run at once, side by side) and
exits 1 when one failed; a real one returns at submission.

    python slurm_standin.py sbatch [OPTIONS] SCRIPT     (a test puts a `sbatch` calling this on PATH)
"""
from __future__ import annotations

import itertools
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

#: s between SIGTERM and SIGKILL at the time limit (Slurm's KillWait default)
KILL_WAIT_S = 30.0
OPTIONS = {"job-name", "array", "cpus-per-task", "ntasks", "time", "output", "chdir", "open-mode"}
FLAGS = {"requeue"}


class SbatchError(Exception):
    pass


def words(line: str) -> list[str]:
    """The words of what follows #SBATCH on a line, split as sbatch splits them."""
    out, word, quote, escaped, started = [], [], "", False, False
    for ch in line:
        if escaped:
            word.append(ch)
            escaped = False
        elif ch == "\\":
            escaped = started = True
        elif quote:
            if ch == quote:
                quote = ""
            else:
                word.append(ch)
        elif ch in "\"'":
            quote, started = ch, True
        elif ch == "#":
            break
        elif ch.isspace():
            if started:
                out.append("".join(word))
            word, started = [], False
        else:
            word.append(ch)
            started = True
    if started:  # an unmatched quote runs to the end of the line, as in sbatch
        out.append("".join(word))
    return out


def directives(text: str) -> list[str]:
    """The words of the script's #SBATCH lines, up to its first command."""
    out = []
    for line in text.splitlines()[1:]:
        if line.startswith("#SBATCH"):
            out += words(line[len("#SBATCH"):])
        elif line.strip() and not line.lstrip().startswith("#"):
            break
    return out


def options(args: list[str]) -> dict[str, str | bool]:
    """--name=value, --name value and flags into {name: value}; an unknown option, or a word that is
    no option (a path split at a blank), is an error, as in sbatch."""
    out: dict[str, str | bool] = {}
    it = iter(args)
    for a in it:
        if not a.startswith("--"):
            raise SbatchError(f"Invalid directive found in batch script: {a}")
        name, eq, value = a[2:].partition("=")
        if name in FLAGS and not eq:
            out[name] = True
        elif name in OPTIONS:
            out[name] = value if eq else next(it)
        else:
            raise SbatchError(f"unrecognized option '--{name}'")
    return out


def seconds(limit: str) -> float:
    """A --time value in s: minutes, minutes:seconds, hours:minutes:seconds, days-hours,
    days-hours:minutes or days-hours:minutes:seconds (sbatch(1))."""
    days = 0
    if "-" in limit:
        d, limit = limit.split("-", 1)
        days = int(d)
        parts = [int(x) for x in limit.split(":")]
        h, m, s = (parts + [0, 0])[:3]
    else:
        parts = [int(x) for x in limit.split(":")]
        h, m, s = {1: (0, parts[0], 0), 2: (0, *parts), 3: tuple(parts)}[len(parts)]
    return float(((days * 24 + h) * 60 + m) * 60 + s)


def indices(array: str) -> list[int]:
    out = []
    for part in array.split("%")[0].split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def filename(pattern: str, job: Job, index: int) -> str:
    """An --output pattern's file name: %A, %a, %j, %x, %% replaced; none with a backslash."""
    if "\\" in pattern:
        return pattern.replace("\\", "")
    subs = {"A": str(job.job_id), "a": str(index), "j": str(job.job_id + 1 + index), "x": job.name, "%": "%"}
    return re.sub(r"%([Aajx%])", lambda m: subs[m.group(1)], pattern)


def descendants(pid: int) -> list[int]:
    """`pid` and every process below it (by parent PID, whatever their sessions)."""
    parents: dict[int, int] = {}
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat", "rb") as fh:
                    parents[int(name)] = int(fh.read().rsplit(b")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, pp in parents.items() if pp == p]
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except OSError:
        return False


_ids = itertools.count(int(time.time()) % 100000 * 10)


@dataclass
class Job:
    script: Path  # the spooled copy
    opts: dict
    submit_dir: Path
    job_id: int = field(default_factory=lambda: next(_ids))

    @property
    def name(self) -> str:
        return str(self.opts.get("job-name", self.script.name))

    @property
    def time_limit(self) -> float | None:
        return seconds(str(self.opts["time"])) if "time" in self.opts else None

    @property
    def workdir(self) -> Path:
        return Path(str(self.opts.get("chdir", self.submit_dir)))

    def start(self, index: int, restart_count: int = 0, env: dict | None = None) -> Task:
        """Array task `index` as Slurm starts it; `restart_count` > 0: a requeued one."""
        workdir = self.workdir
        out = workdir / filename(str(self.opts.get("output", "slurm-%A_%a.out")), self, index)
        mode = "a" if self.opts.get("open-mode") == "append" else "w"
        tasks = indices(str(self.opts.get("array", "0")))
        e = {**os.environ, **(env or {})}
        e.pop("SLURM_RESTART_COUNT", None)
        e.update(SLURM_JOB_ID=str(self.job_id + 1 + index), SLURM_ARRAY_JOB_ID=str(self.job_id),
                 SLURM_ARRAY_TASK_ID=str(index), SLURM_ARRAY_TASK_COUNT=str(len(tasks)),
                 SLURM_ARRAY_TASK_MIN=str(min(tasks)), SLURM_ARRAY_TASK_MAX=str(max(tasks)),
                 SLURM_JOB_NAME=self.name, SLURM_SUBMIT_DIR=str(self.submit_dir),
                 SLURM_CPUS_PER_TASK=str(self.opts.get("cpus-per-task", 1)))
        if restart_count:
            e["SLURM_RESTART_COUNT"] = str(restart_count)
        try:
            fh = open(out, mode)
        except OSError as err:  # slurmstepd: "Could not open stdout file": the task fails
            print(f"slurmstepd: error: Could not open stdout file {out}: {err.strerror}", file=sys.stderr)
            return Task(self, index, subprocess.Popen(["false"]), out, time.monotonic())
        with fh:
            proc = subprocess.Popen([str(self.script)], cwd=workdir, stdout=fh, stderr=subprocess.STDOUT, env=e,
                                    start_new_session=True)
        return Task(self, index, proc, out, time.monotonic())


@dataclass
class Task:
    job: Job
    index: int
    proc: subprocess.Popen
    output: Path
    started: float
    timed_out: bool = False

    def kill(self, sig: int = signal.SIGKILL) -> None:
        """`sig` to every process of the task (SIGKILL: as a node that fails), then wait for them."""
        pids = descendants(self.proc.pid)
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        if sig == signal.SIGKILL:
            deadline = time.monotonic() + 60
            while any(_alive(p) for p in pids if p != self.proc.pid) and time.monotonic() < deadline:
                time.sleep(0.01)
            self.proc.wait()

    def wait(self) -> int:
        """The task's exit code; at the job's --time, SIGTERM then SIGKILL after KILL_WAIT_S."""
        limit = self.job.time_limit
        while self.proc.poll() is None:
            if limit is not None and time.monotonic() - self.started > limit and not self.timed_out:
                self.timed_out = True
                self.kill(signal.SIGTERM)
                try:
                    self.proc.wait(timeout=KILL_WAIT_S)
                except subprocess.TimeoutExpired:
                    self.kill()
            time.sleep(0.05)
        return self.proc.returncode

    @property
    def wall(self) -> float:
        return time.monotonic() - self.started


def submit(script: Path, args: list[str] = (), submit_dir: Path | None = None, spool: Path | None = None) -> Job:
    """Read the script's #SBATCH lines (command-line options win, as with sbatch) and spool a copy."""
    script = Path(script)
    text = script.read_text()
    if not text.startswith("#!"):
        raise SbatchError("This does not look like a batch script. The first line must start with #!")
    opts = options(directives(text))
    opts.update(options(list(args)))
    job = Job(script, opts, Path(submit_dir or os.getcwd()))
    spool = Path(spool or os.environ.get("SLURM_STANDIN_SPOOL") or script.parent)
    spool.mkdir(parents=True, exist_ok=True)
    copy = spool / f"job{job.job_id}.script"
    shutil.copyfile(script, copy)
    copy.chmod(0o700)
    job.script = copy
    if not job.workdir.is_dir():
        raise SbatchError(f"--chdir {job.workdir}: no such folder")
    return job


def sbatch(argv: list[str]) -> int:
    *args, script = argv
    try:
        job = submit(Path(script), args)
    except (SbatchError, OSError, ValueError) as e:
        print(f"sbatch: error: {e}", file=sys.stderr)
        return 1
    print(f"Submitted batch job {job.job_id}", flush=True)
    tasks = [job.start(i) for i in indices(str(job.opts.get("array", "0")))]
    failed = 0
    for t in tasks:
        rc = t.wait()
        print(f"sbatch stand-in: task {job.job_id}_{t.index} exit {rc} in {t.wall:.1f} s"
              f"{' (time limit)' if t.timed_out else ''}", file=sys.stderr, flush=True)
        failed += rc != 0
    return 1 if failed else 0


if __name__ == "__main__":
    if sys.argv[1:2] != ["sbatch"]:
        sys.exit("usage: slurm_standin.py sbatch [OPTIONS] SCRIPT")
    sys.exit(sbatch(sys.argv[2:]))
