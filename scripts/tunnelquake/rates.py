"""This machine's speed for `check`'s run-time estimate (scene.runtime_estimate): measured here, cached.

The probe is a fixed run of tq-solid-bench (the elastic hex8 kernel on a 16^3 box, one thread): its
CPU seconds on this machine. Every rate of the estimate is a measured multiple of it
(docs/benchmarks.md "check's run-time estimate"): the multiples are properties of the code (the
same kernels, one thread), the probe's seconds the property of the machine. CPU seconds, not wall
seconds: on a machine shared with other work the wall time says how busy it was, not how fast it is.

A run on several OpenMP threads (a large mesh: solid_input.run_threads) takes the one-thread CPU
seconds divided by the **thread speed-up** of this machine: a second probe, tq-solid-bench on a 32^3
box on 1 and on N threads in turn, compares the busiest thread's CPU seconds per element-step (each
thread's CLOCK_THREAD_CPUTIME_ID, the largest of the team): the time the steps take when each thread
has a core, which other work on the machine changes far less than the wall time (a thread that is
not running is not counted, and the one waiting for it sleeps).

A model much larger than the probe's box (4,096 elements, in a core's cache) runs out of the caches
the probe runs in, and its element-step need not cost what the small box's does, nor its threads
speed it up as the 32^3 box's do. So such a model gets a **size-class probe**: a box of about as
many elements as the model (the side of SIZE_CLASSES nearest its cube root, bounded at 40: 64,000
elements, about the 3D example's 64,416), timed on one thread alternately with the probe's own box,
one process each; the **size factor** is the median of the rounds' ratios of the busiest thread's
CPU per element-step, box of the class against the probe's, and the model's one-thread rate is the
probe's times it. Its thread speed-up is measured on the box of its class (size_class,
measure_size_factor; docs/benchmarks.md "check's estimates on the 3D cases").

A subcycled condition (time.subcycling) leaves out some of the element evaluations of a fine step
but not the rest of it (every node moves, the boundaries and the contact act): the **element-evaluation
probe** measures the evaluations' share of a step, tq-solid on a small graded box one-rate and
subcycled (measure_eval_share; MachineRates.subcycled_factor).

What the probes leave out (how this machine's memory, caches and cores treat a whole coupled
model, how its OpenFOAM runs against the probe) each completed run measures: `run` compares every
condition's measured shaking (a coupled one's solid and water together) with the estimate of that
condition at the run's own steps and passes, and keeps the ratio under the condition's kind
(part_key: solid-only or coupled, threads, the water's ranks, subcycled or not, size class, the
shaking's length within a factor of 4). The estimate
takes the median of the last RUN_RECORDS ratios of a kind as its correction (MachineRates.correction)
and says so. A run of less than RUN_RECORD_MIN_S of shaking, one resumed, one with the solid on
MPI ranks, or one whose rates were not all measured is not recorded; nor is any with
TQ_RATES_RECORD=0 in the environment.

The probes' results are cached per processor (/proc/cpuinfo's model name) and tq-solid build (the
bench program's size and modification time) in ~/.cache/tunnelquake/machine_rates.json
(TQ_RATES_FILE overrides the file), so each runs once a machine and build (the speed-up once for
each thread count asked for; the size factor and its speed-ups once a size class).
"""
from __future__ import annotations

import json
import math
import os
import platform
import re
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import paths

#: the probe: tq-solid-bench's arguments (about 0.5 CPU s on a 2026 server core)
PROBE_ARGS = ("--n", "16", "--steps", "400", "--repeat", "3", "--threads", "1")
#: probes taken, their median kept (a busy machine slows CPU seconds a little too: caches, SMT)
PROBE_RUNS = 3

#: the thread probe: tq-solid-bench's arguments without --threads (32,768 elements, about 0.6 CPU s a
#: run on a 2026 server core); each run times 9 pairs, 20 steps on one thread and 20 on N in one
#: process (--against 1), and prints the median of the pairs' ratios; THREAD_PROBE_ROUNDS runs,
#: THREAD_PROBE_GAP_S apart, their median kept. A VM's two cores are not always two: on the Zen 5
#: VM of docs/benchmarks.md 193 runs back to back over 2 minutes gave 1.8-2.4 and, in spells of 1-3
#: runs (about 10 % of them), 1.17-1.6; three runs in a row once all fell in such a spell (1.19,
#: where the model's own solid took 1.95x on 2 threads within minutes). Five runs over about 6 s
#: keep the spell out of the median (docs/benchmarks.md "The probes in a VM's passing spells").
THREAD_PROBE_ARGS = ("--n", "32", "--steps", "20", "--repeat", "9", "--against", "1")
THREAD_PROBE_ROUNDS = 5
THREAD_PROBE_GAP_S = 1.0

#: The size classes: the sides of the boxes a model larger than SIZE_CLASS_MIN_ELEMENTS is probed on
#: (the one whose cube is nearest its solid elements, in ratio; the largest for any larger model)
SIZE_CLASSES = (24, 32, 40)
#: solid elements above which a model gets a size-class probe: twice the probe's 16^3 box (the slice
#: of the example, 1,464 elements, follows the probe: docs/benchmarks.md "check's run-time estimate")
SIZE_CLASS_MIN_ELEMENTS = 2 * 16**3
#: one round of the size factor: the probe's box and the class's, one thread, one process each;
#: SIZE_ROUNDS rounds, median (0.38 s of wall a round at the 32 class on the Zen 5 VM). One round
#: alone read 1.08-1.71 within a minute there (40 rounds, 2026-12-02): the median of 3 rounds in a
#: row 1.14-1.60, of 7 1.28-1.53 (docs/benchmarks.md "The probes in a VM's passing spells")
SIZE_PROBE_ARGS = ("--steps", "400", "--repeat", "3", "--threads", "1")
SIZE_ROUNDS = 7
#: element-steps of each timed run of a size-class box (its steps: this over the box's elements)
SIZE_ELEMENT_STEPS = 32**3 * 20


def size_class(elements: int) -> int:
    """The side of the box a model of `elements` solid elements is probed on: 0 (the probe's own
    box) up to SIZE_CLASS_MIN_ELEMENTS, else the SIZE_CLASSES side whose cube is nearest in ratio
    (the largest for anything larger)."""
    import math

    if elements <= SIZE_CLASS_MIN_ELEMENTS:
        return 0
    return min(SIZE_CLASSES, key=lambda n: abs(math.log(elements / n**3)))


def _class_steps(side: int) -> int:
    return max(2, round(SIZE_ELEMENT_STEPS / side**3))


def size_probe_args(side: int) -> tuple[str, ...]:
    """tq-solid-bench's arguments for one thread on the class's box (SIZE_ELEMENT_STEPS a timing)."""
    return ("--n", str(side), "--steps", str(_class_steps(side)), "--repeat", "3", "--threads", "1")


def thread_probe_args(side: int = 0) -> tuple[str, ...]:
    """The thread probe's arguments without --threads: THREAD_PROBE_ARGS, or on a size class's box
    with as many element-steps a timing."""
    if not side:
        return THREAD_PROBE_ARGS
    return ("--n", str(side), "--steps", str(_class_steps(side)), "--repeat", "9", "--against", "1")


#: CPU seconds of one element-step of the example slice's solid-only shaking (Mohr-Coulomb damage,
#: rock-lining contact, seismic boundaries, free field, monitors, ring forces, checkpoints) per probe
#: CPU second: its no_water input over 2 s of record (31,643 steps of 1,464 elements after the
#: static stages, whose 0.39 CPU s are taken off) against the probe, alternated, median of 3 rounds
#: (docs/benchmarks.md "check's run-time estimate")
SOLID_PER_PROBE_S = 2.58e-7
#: the coupled solid's CPU per element-step it computes (every pass of a window) against the
#: solid-only one, per probe second: the exchange, the water's laws carried in the solid, the
#: window's saved state (the slice's coupled condition over 2 s, 3 rounds beside the probe: 1.27,
#: 1.125, 0.94; over the whole record 1.15; perf: 6.5 % of the coupled solid's samples are outside
#: the solid-only code)
COUPLED_SOLID_FACTOR = 1.13
#: OpenFOAM's seconds a water pass, fixed and per cell, per probe CPU second: the example's water on
#: one rank (the PCG pressure), OpenFOAM's CPU (ExecutionTime) over the passes against the probe
#: measured before and after each run, on two machines (docs/benchmarks.md "check's run-time
#: estimate", the water's constants). The Zen 5 VM (2026-12-02, 3 alternated rounds, probe 0.21-0.27
#: CPU s): the slice's 336 cells 3.17e-3 (its first 4 s), the 3D half block of 7,392 cells (44 axial)
#: 24.7e-3 (0.3 s), the whole block's 14,784 39.7e-3 (0.2 s); the Intel VM (2026-12-01, 2 rounds,
#: probe 0.38-0.50 CPU s): the slice 3.16e-3, the whole block 56.6e-3. The water's speed against
#: the solid probe's differs between the two processors by 1.43x on the whole block: the line through
#: the slice's point and the whole block's geometric mean, so +19 % on the Zen 5 VM and -16 % on the
#: Intel VM there, the half block +0.2 % (Zen 5); the former figures (1.93e-3, 3.44e-6, from the
#: solver before the PCG pressure) were +33 % and -7 % on the whole block, +11 % on the half
WATER_PER_PROBE_S = 2.14e-3
WATER_CELL_PER_PROBE_S = 3.06e-6
#: The water's share of a coupled run's wall time on parallel.fluid_ranks >= 2 ranks against one
#: rank's, where each rank has at least WATER_RANK_CELLS cells: the 3D example's whole record (14,784
#: water cells, 37,649 passes) on 2 ranks and on 1, one after the other on the 2-core AMD EPYC VM:
#: 1,855.8 against 1,915.7 s of tq-solid's wall, 1 - 59.9 / 642.7 s of one rank's exchange time =
#: 0.907. The water's own solve took 0.70x a pass (10.94 against 15.69 ms) and the solid waited for it
#: 0.51x as long, but the solid's exchange work and its step took 121 and 118 s more (its CPU in the
#: exchange 3.6 s more: the work is mostly a wait; docs/benchmarks.md "The 3D water on 2 ranks").
#: Not measured on more ranks: the 2-rank figure is taken for any N >= 2.
WATER_RANKS_FACTOR = 0.91
#: The fewest water cells a rank at which the ranks pay, the least measured that did, rounded down:
#: the 3D example's half block with 22 axial elements (3,696 cells, 1,848 a rank on 2 ranks) took
#: 0.69 / 0.79x one rank's coupled wall over its first second (14.1 / 16.5 against 20.5 / 20.8 / 20.4 s,
#: the water 2.56 / 2.93 against 3.75 / 3.86 / 3.86 ms a pass; the AMD EPYC VM, 2026-12-03); with 44
#: (7,392 cells, 3,696 a rank) 0.83 / 0.85x (the Intel VM, 2026-12-01); the whole 44-element model's
#: 7,392 a rank pay too; the slice's 168 a rank took 2.8x one rank's time a pass (an earlier VM and
#: water code). Below it `run` says so and the estimate counts one rank's time
WATER_RANK_CELLS = 1800

#: The element-evaluation probe, for a subcycled condition (time.subcycling): tq-solid on
#: subcycle_levels' probe box (4,096 elastic hex8, 16 x 16 in plan, 4 layers of 1/8 m under 12 of
#: 1 m; its step half the thin layers' critical one) one-rate and at 3 levels, EVAL_PROBE_STEPS steps
#: each, and a run of EVAL_PROBE_SHORT steps (what starting the program costs); EVAL_PROBE_ROUNDS
#: rounds, the three runs in turn in each, the median of the rounds' shares (0.6 s of wall a round on
#: the Zen 5 VM; the share is a difference of two CPU times, so a round alone read 0.63-1.16 within a
#: minute there, 40 rounds, 2026-12-02: the median of 3 in a row 0.71-1.14, of 7 0.80-0.98;
#: docs/benchmarks.md "The probes in a VM's passing spells")
EVAL_PROBE_STEPS = 2000
EVAL_PROBE_SHORT = 8
EVAL_PROBE_ROUNDS = 7
EVAL_PROBE_LEVELS = 3
#: element-steps of one probe (tq-solid-bench's 10 warm-up steps and 3 x 400 timed of 4,096
#: elements: PROBE_ARGS): the probe's CPU second over these is its box's element-step
PROBE_ELEMENT_STEPS = 16**3 * (10 + 3 * 400)

#: A fault offset imposed by a static stage (fault_offset without a rise_time): relaxation steps an
#: increment (the stage relaxes to equilibrium after each of fault_offset.increments): cases/fault_crossing,
#: 10 increments, 370 / 380 / 410 / 450 / 490 / 530 / 570 / 590 / 610 / 620 steps, 5,020 in all
#: (docs/benchmarks.md "check's estimates on the 3D cases")
RELAX_STEPS_PER_INCREMENT = 502
#: CPU of one element-step of that relaxation against the shaking's (SOLID_PER_PROBE_S): the ground
#: it drives past yield takes the return mapping at every step, and each step adds the Rayleigh
#: quotient's sums; cases/fault_crossing: 18.36 CPU s for 5,020 steps of 6,984 elements, 5.24e-7 s an
#: element-step, probe 0.525 CPU s: 9.97e-7 per probe second, 3.87 times the shaking's rate
RELAX_STEP_FACTOR = 3.87
#: The shaking after such an offset, per element-step, against the same shaking without it, where
#: the ground yields (any material but elastic / kelvin_voigt): the plastic zone the offset leaves
#: takes the return mapping at every step. cases/fault_crossing's no_water, 0.25 s (4,464 steps),
#: 1 thread, the same input with and without its fault_offset stage: 0.312 against 0.144 us an
#: element-step (the latter within 7 % of SOLID_PER_PROBE_S at the probe's 0.525 CPU s)
YIELDED_SHAKING_FACTOR = 2.17
#: Materials that never yield: an offset leaves no plastic zone in them
LINEAR_MODELS = ("elastic", "kelvin_voigt")
#: Runs kept a kind (part_key) for the estimate's correction: the median of the last ones
RUN_RECORDS = 5
#: The least shaking recorded, s: below it the program's start and its files outweigh its steps
RUN_RECORD_MIN_S = 10.0


def part_key(part: str, threads: int, subcycled: bool = False, side: int = 0, ranks: int = 1,
             seconds: float = 0.0) -> str:
    """The kind of a condition whose measured / estimated ratios correct one another: `part` 'solid'
    (a solid-only condition's shaking) or 'coupled' (a coupled condition's, the solid and the water
    together: how their time splits moves from run to run where they share cores, their sum much
    less), on `threads` solid threads (and the water on `ranks`), subcycled or not, in a size class
    (0: the probe's own box), and `seconds` of shaking within a factor of 4 (0: not said): the 3D
    example's first second took 1.13-1.26x its estimate where its whole record took 0.71-0.76x."""
    water = f", the water on {ranks} rank(s)" if part == "coupled" else ""
    length = ""
    if seconds > 0:
        low = 4.0 ** math.floor(math.log(seconds, 4) + 1e-9)
        length = f", {low:g}-{4 * low:g} s of shaking"
    return (f"{part}, {threads} thread(s){water}, {'subcycled' if subcycled else 'one rate'}"
            + (f", {side}^3 class" if side else "") + length)


@dataclass(frozen=True)
class MachineRates:
    """CPU seconds of the pieces of a run on this machine."""

    probe_s: float  # the probe's CPU seconds (median of PROBE_RUNS)
    processor: str
    source: str  # 'measured now' or 'cached <date>'
    speedups: dict = field(default_factory=dict)  # threads -> thread speed-up of the solid's step (measured)
    speedup_note: str = ""  # why a speed-up asked for is not there
    size_side: int = 0  # the size class's box side (0: the probe's own box, size_class)
    size_factor: float = 1.0  # its busiest thread's CPU per element-step against the probe box's
    eval_share: float = 0.0  # the element evaluations' share of the probe box's one-rate step (0: not measured)
    runs: dict = field(default_factory=dict)  # part_key -> this machine's recorded measured / estimated ratios

    def speedup(self, threads: int) -> float:
        """The solid step's speed-up on `threads` OpenMP threads against one: 1 for one thread, the
        measured figure otherwise (1 when it could not be measured: speedup_note says why)."""
        return 1.0 if threads <= 1 else float(self.speedups.get(int(threads), 1.0))

    def correction(self, key: str) -> tuple[float, int]:
        """The factor on the estimate of a condition of kind `key` (part_key): the median of this
        machine's recorded ratios, and how many there are (1.0, 0 where none)."""
        import statistics

        ratios = [float(r) for r in self.runs.get(key, ()) if float(r) > 0]
        return (statistics.median(ratios), len(ratios)) if ratios else (1.0, 0)

    @property
    def solid_element_step(self) -> float:
        """One thread's CPU seconds of a solid element-step: the probe's rate times the size factor."""
        return SOLID_PER_PROBE_S * self.probe_s * self.size_factor

    @property
    def solid_eval_share(self) -> float:
        """The element evaluations' share of a case's one-rate element-step: an evaluation costs what
        one of the probe box's does (the same hex8 kernel; the size factor scales both alike), which
        is eval_share of the box's element-step, the probe's CPU second over PROBE_ELEMENT_STEPS; the
        case's whole element-step is SOLID_PER_PROBE_S a probe second (0 when not measured)."""
        return min(1.0, self.eval_share / (PROBE_ELEMENT_STEPS * SOLID_PER_PROBE_S))

    def subcycled_factor(self, cost_fraction: float) -> float:
        """A subcycled step's CPU against the one-rate step's, when a fine step evaluates
        `cost_fraction` of the elements (subcycle_levels.Levels): the evaluations it leaves out,
        (1 - cost_fraction) x solid_eval_share; the rest of the step (every node's update, the
        boundaries, the contact) is taken at every fine step. 1 where eval_share was not measured
        (speedup_note says why)."""
        return 1.0 - (1.0 - cost_fraction) * self.solid_eval_share

    def repass_factor(self, cost_fraction: float, reach_fraction: float) -> float:
        """A coupling window's re-pass's CPU against its first pass's (Solver::planRepasses): a pass
        costs 1 - (1 - cost_fraction) x solid_eval_share of a one-rate step (subcycled_factor), of which
        the element evaluations cost_fraction x solid_eval_share; a re-pass evaluates
        `reach_fraction` of them (subcycle_levels.window_reach) and takes the rest as a pass does.
        1 where eval_share was not measured."""
        s = self.solid_eval_share
        whole = 1.0 - (1.0 - cost_fraction) * s
        return (whole - (1.0 - reach_fraction) * cost_fraction * s) / whole if whole > 0 else 1.0

    @property
    def water_pass(self) -> float:
        return WATER_PER_PROBE_S * self.probe_s

    @property
    def water_cell_pass(self) -> float:
        return WATER_CELL_PER_PROBE_S * self.probe_s


class ProbeFailed(RuntimeError):
    """The probe could not run (no build, it failed): the estimate says so instead of guessing."""


def processor() -> str:
    """The processor's model name (as lscpu's 'Model name'), else the platform's word for it."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def cache_file() -> Path:
    return Path(os.environ.get("TQ_RATES_FILE") or Path.home() / ".cache" / "tunnelquake" / "machine_rates.json")


def probe_program() -> Path:
    return paths.build_dir() / "solid_solver" / "tq-solid-bench"


def _key(program: Path) -> str:
    st = program.stat()
    return f"{processor()} | {program.resolve()} {st.st_size} {int(st.st_mtime)}"


def _cpu_seconds(cmd: list[str], env: dict | None = None) -> float:
    """CPU seconds (user + system) of one run of `cmd`, from its own resource usage (os.wait4)."""
    import tempfile

    from . import children

    with tempfile.TemporaryFile() as err:
        try:
            proc = children.popen(cmd, stdout=subprocess.DEVNULL, stderr=err, env=env)
        except OSError as e:
            raise ProbeFailed(f"{cmd[0]} cannot be started ({e.strerror})") from e
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            text = err.read().decode(errors="replace").strip()
            raise ProbeFailed(f"{cmd[0]} exited {proc.returncode}: {text[-300:]}")
    return usage.ru_utime + usage.ru_stime


def measure(program: Path | None = None, runs: int = PROBE_RUNS) -> float:
    """The probe's CPU seconds on this machine: the median of `runs` runs."""
    program = program or probe_program()
    if not program.is_file():
        raise ProbeFailed(f"{program} is not built (scripts/bootstrap.sh builds it)")
    cmd = [str(program), *PROBE_ARGS]
    times = sorted(_cpu_seconds(cmd) for _ in range(max(1, runs)))
    return times[len(times) // 2]


_BUSIEST = re.compile(r"busiest thread's CPU: median ([0-9.eE+-]+) us per element-step")


def _busiest_us(program: Path, args: tuple[str, ...], env: dict) -> float:
    """The busiest thread's CPU per element-step, us, that one run of tq-solid-bench prints."""
    cmd = [str(program), *args]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    except OSError as e:
        raise ProbeFailed(f"{program} cannot be started ({e.strerror})") from e
    if proc.returncode != 0:
        raise ProbeFailed(f"{program} exited {proc.returncode}: {proc.stderr.strip()[-300:]}")
    found = _BUSIEST.search(proc.stdout)
    if not found or not float(found.group(1)) > 0:
        raise ProbeFailed(f"{program} does not print its busiest thread's CPU (an older build: "
                          "scripts/bootstrap.sh rebuilds it)")
    return float(found.group(1))


def measure_size_factor(side: int, program: Path | None = None, rounds: int | None = None) -> float:
    """The size factor of the class `side`: the median over `rounds` rounds (SIZE_ROUNDS when None) of the busiest thread's
    CPU per element-step on the class's box (size_probe_args) against the probe's 16^3 box, one
    thread, the two run one after the other in each round (a shared machine's speed drifts over
    seconds: the ratio of neighbours, not of figures taken minutes apart)."""
    from .cores import solid_env

    program = program or probe_program()
    if not program.is_file():
        raise ProbeFailed(f"{program} is not built (scripts/bootstrap.sh builds it)")
    env = solid_env()
    small = ("--n", "16", *SIZE_PROBE_ARGS)
    ratios = sorted(_busiest_us(program, size_probe_args(side), env) / _busiest_us(program, small, env)
                    for _ in range(max(1, SIZE_ROUNDS if rounds is None else rounds)))
    return ratios[len(ratios) // 2]


_SPEEDUP = re.compile(r"speed-up of \d+ thread\(s\) over 1, busiest thread's CPU: median ([0-9.eE+-]+) of")


def _paired_speedup(program: Path, threads: int, env: dict, side: int = 0) -> float:
    """One run of the thread probe: the median over its pairs of the busiest thread's CPU per
    element-step on one thread against that on `threads`, the two halves of each pair run in one
    process a tenth of a second apart (a shared VM's speed drifts by a third over seconds; runs in
    turn in two processes saw that drift as a speed-up of 1.29 for one thread against one)."""
    cmd = [str(program), *thread_probe_args(side), "--threads", str(threads)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    except OSError as e:
        raise ProbeFailed(f"{program} cannot be started ({e.strerror})") from e
    older = "an older build: scripts/bootstrap.sh rebuilds it"
    if proc.returncode != 0:
        hint = f" ({older})" if "usage:" in proc.stderr else ""
        raise ProbeFailed(f"{program} exited {proc.returncode}: {proc.stderr.strip()[-300:]}{hint}")
    found = _SPEEDUP.search(proc.stdout)
    if not found:
        raise ProbeFailed(f"{program} does not print its busiest thread's speed-up ({older})")
    return float(found.group(1))


def measure_speedup(threads: int, program: Path | None = None, rounds: int | None = None,
                    side: int = 0) -> float:
    """The solid step's speed-up on `threads` threads: the median of `rounds` runs (THREAD_PROBE_ROUNDS when None) of the thread
    probe, THREAD_PROBE_GAP_S apart (on the box of size class `side`, 0 for the 32^3 one), each the
    median of its pairs' ratios of the busiest thread's CPU per element-step on one thread and on
    `threads`. The threads wait as tq-solid's do (cores.solid_env)."""
    from .cores import solid_env

    program = program or probe_program()
    if not program.is_file():
        raise ProbeFailed(f"{program} is not built (scripts/bootstrap.sh builds it)")
    env = solid_env()
    ratios = []
    for k in range(max(1, THREAD_PROBE_ROUNDS if rounds is None else rounds)):
        if k:
            time.sleep(THREAD_PROBE_GAP_S)
        ratios.append(_paired_speedup(program, threads, env, side))
    ratios.sort()
    return ratios[len(ratios) // 2]


def measure_eval_share(program: Path | None = None, rounds: int | None = None,
                       folder: Path | None = None) -> float:
    """The element evaluations' share of the probe box's one-rate step: in each round tq-solid on the
    box (subcycle_levels.write_probe_box) for EVAL_PROBE_SHORT steps (C0: its start), one-rate (C1)
    and at EVAL_PROBE_LEVELS levels (Cs), EVAL_PROBE_STEPS steps each, one thread, the CPU seconds of
    each process; the subcycled run evaluates the fraction f of the elements a fine step (its
    results' /subcycling cost_fraction) and moves every node as the one-rate run does, so what it
    saves, C1 - Cs, is (1 - f) of the evaluations: the share (C1 - Cs) / ((1 - f)(C1 - C0)). The
    median of `rounds` rounds (EVAL_PROBE_ROUNDS when None)."""
    import tempfile

    import h5py

    from .cores import solid_env
    from .subcycle_levels import write_probe_box

    program = program or paths.build_dir() / "solid_solver" / "tq-solid"
    if not program.is_file():
        raise ProbeFailed(f"{program} is not built (scripts/bootstrap.sh builds it)")
    env = {**solid_env(), "OMP_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory(prefix="tq-eval-probe-", dir=folder) as tmp:
        box = Path(tmp)
        inputs = {}
        for name, steps, levels in (("start", EVAL_PROBE_SHORT, 0), ("one", EVAL_PROBE_STEPS, 0),
                                    ("sub", EVAL_PROBE_STEPS, EVAL_PROBE_LEVELS)):
            inputs[name] = write_probe_box(box, steps, levels).rename(box / f"{name}.h5")

        def cpu(name: str) -> float:
            return _cpu_seconds([str(program), str(inputs[name]), "-o", str(box / f"{name}_results.h5"),
                                 "--threads", "1"], env)

        shares = []
        for _ in range(max(1, EVAL_PROBE_ROUNDS if rounds is None else rounds)):
            c0, c1, cs = cpu("start"), cpu("one"), cpu("sub")
            with h5py.File(box / "sub_results.h5", "r") as f:
                fraction = float(f["subcycling"].attrs["cost_fraction"]) if "subcycling" in f else 1.0
            if not (c1 > c0 and fraction < 1):
                raise ProbeFailed(f"the element-evaluation probe measured nothing ({c1:.3g} against {c0:.3g} CPU s, "
                                  f"cost fraction {fraction:.3g})")
            shares.append((c1 - cs) / ((1.0 - fraction) * (c1 - c0)))
    shares.sort()
    return shares[len(shares) // 2]


def _read_cache() -> dict:
    try:
        data = json.loads(cache_file().read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _write_cache(cache: dict) -> None:
    from .files import atomic_path

    path = cache_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps(cache, indent=1, sort_keys=True)
        with atomic_path(path, len(text)) as tmp:
            tmp.write_text(text)
    except OSError:
        pass  # an unwritable cache: measured again next time


def machine_rates(program: Path | None = None, measure_if_missing: bool = True, threads: int = 1,
                  elements: int = 0, subcycled: bool = False) -> MachineRates:
    """This machine's rates: the cached probe of this processor and build, else the probe run now
    (and cached); for a model of `elements` solid elements above SIZE_CLASS_MIN_ELEMENTS also its
    size class's factor (measure_size_factor); with `threads` > 1 also the thread speed-up on that
    many threads (on the size class's box where there is one); with `subcycled` also the element
    evaluations' share (measure_eval_share, tq-solid beside the bench program), each cached the same
    way (a size, thread or evaluation probe that cannot run leaves its figure out and says why in
    speedup_note). Raises
    ProbeFailed when the probe cannot be measured (or `measure_if_missing` is False and nothing is
    cached)."""
    program = program or probe_program()
    if not program.is_file():
        raise ProbeFailed(f"{program} is not built (scripts/bootstrap.sh builds it)")
    key = _key(program)
    cache = _read_cache()
    hit = cache.get(key)
    changed = False
    if isinstance(hit, dict) and float(hit.get("probe_s", 0)) > 0:
        source = f"cached {hit.get('date', '')}".strip()
    elif not measure_if_missing:
        raise ProbeFailed(f"no probe of this machine cached in {cache_file()}")
    else:
        hit = {"probe_s": measure(program), "date": time.strftime("%Y-%m-%d"), "args": " ".join(PROBE_ARGS)}
        source, changed = "measured now", True
    side = size_class(elements)
    # the figures of the size class (its factor, its speed-ups) or of the probe's own box
    where = hit.get("size_class", {}).get(str(side), {}) if side else hit
    notes = []
    factor = float(where.get("factor", 0)) if side else 1.0
    if side and not factor > 0:
        if not measure_if_missing:
            notes.append(f"no size-class probe ({side}^3 box) cached in {cache_file()}")
        else:
            try:
                factor = measure_size_factor(side, program)
                where.update(factor=factor, args=" ".join(size_probe_args(side)), date=time.strftime("%Y-%m-%d"))
                changed = True
            except ProbeFailed as e:
                notes.append(f"the size-class probe ({side}^3 box) could not run: {e}")
    speedups = {int(k): float(v) for k, v in (where.get("speedup") or {}).items() if float(v) > 0}
    if threads > 1 and threads not in speedups:
        if not measure_if_missing:
            notes.append(f"no thread speed-up on {threads} threads cached in {cache_file()}")
        else:
            try:
                speedups[threads] = measure_speedup(threads, program, side=side)
                where["speedup"] = {str(k): v for k, v in sorted(speedups.items())}
                where["speedup_args"] = " ".join(thread_probe_args(side))
                changed = True
            except ProbeFailed as e:
                notes.append(f"the thread probe could not run: {e}")
    eval_share = float(hit.get("eval_share", 0) or 0)
    if subcycled and not eval_share > 0:
        if not measure_if_missing:
            notes.append(f"no element-evaluation probe cached in {cache_file()}: subcycled conditions counted at one rate")
        else:
            try:
                eval_share = measure_eval_share(program.parent / "tq-solid")
                hit.update(eval_share=eval_share, eval_date=time.strftime("%Y-%m-%d"),
                           eval_args=f"{EVAL_PROBE_STEPS} steps, {EVAL_PROBE_LEVELS} levels, {EVAL_PROBE_ROUNDS} rounds")
                changed = True
            except (ProbeFailed, OSError) as e:
                notes.append(f"the element-evaluation probe could not run ({e}): subcycled conditions counted at one rate")
    if side and where:
        hit.setdefault("size_class", {})[str(side)] = where
    if changed:
        cache[key] = hit
        _write_cache(cache)
    runs = {k: [float(r["ratio"]) for r in v if isinstance(r, dict) and "ratio" in r]
            for k, v in (hit.get("runs") or {}).items() if isinstance(v, list)}
    return MachineRates(float(hit["probe_s"]), processor(), source, speedups, "; ".join(notes),
                        side if factor > 0 else 0, factor if factor > 0 else 1.0, eval_share, runs)


def records_runs() -> bool:
    """Whether completed runs are kept for the estimate's correction: not with TQ_RATES_RECORD=0."""
    return os.environ.get("TQ_RATES_RECORD", "1") != "0"


def record_run(ratios: dict[str, float], program: Path | None = None) -> bool:
    """Keep a completed run's measured / estimated ratio of each kind (part_key -> ratio) with this
    machine's and build's cached probes, the last RUN_RECORDS of a kind. Nothing is kept where no
    probe of this machine and build is cached (the ratios are against its estimate), nor with
    TQ_RATES_RECORD=0 in the environment (the tests set it). True when kept."""
    program = program or probe_program()
    if not program.is_file() or not ratios or not records_runs():
        return False
    key = _key(program)
    with _RECORD_LOCK:  # conditions side by side end in threads of one `run`
        cache = _read_cache()
        hit = cache.get(key)
        if not (isinstance(hit, dict) and float(hit.get("probe_s", 0)) > 0):
            return False
        runs = hit.setdefault("runs", {})
        stamp = time.strftime("%Y-%m-%d %H:%M")
        for kind, ratio in ratios.items():
            if not ratio > 0:
                continue
            kept = [r for r in runs.get(kind, []) if isinstance(r, dict)]
            runs[kind] = (kept + [{"ratio": float(ratio), "date": stamp}])[-RUN_RECORDS:]
        _write_cache(cache)
    return True


_RECORD_LOCK = threading.Lock()
