"""`check`'s run-time estimate rests on a probe measured on this machine (tunnelquake.rates,
docs/benchmarks.md "check's run-time estimate"): the probe runs once a processor and build and is
cached; the estimate scales with what it measured; and it predicts a real run's CPU time.

References: the probe's CPU time is the program's own resource usage (os.wait4), checked against a
program that burns a known share of CPU; the estimate's prediction against tq-solid's CPU seconds of
the same case measured here, within the 30 % the estimate claims."""
from __future__ import annotations

import os
import resource
import stat
import sys

import pytest

from conftest import EXAMPLE
from tunnelquake import rates as R


def _fake_probe(folder, loops: int):
    """A probe program that burns CPU for `loops` iterations and logs each start to `runs.log`."""
    prog = folder / "probe"
    prog.write_text(f"#!{sys.executable}\n"
                    "import pathlib, sys\n"
                    f"pathlib.Path({str(folder / 'runs.log')!r}).open('a').write('run\\n')\n"
                    f"s = 0\nfor i in range({loops}):\n    s += i * i\n")
    prog.chmod(prog.stat().st_mode | stat.S_IXUSR)
    return prog


def test_probe_runs_once_a_processor_and_build_and_its_cpu_seconds_are_the_programs_own(tmp_path, monkeypatch):
    monkeypatch.setenv("TQ_RATES_FILE", str(tmp_path / "cache" / "rates.json"))
    prog = _fake_probe(tmp_path, 1_000_000)
    first = R.machine_rates(program=prog)
    runs = (tmp_path / "runs.log").read_text().count("run")
    assert first.source == "measured now" and runs == R.PROBE_RUNS
    # CPU seconds of the program itself: about what this process needs for the same loop
    t0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
    s = 0
    for i in range(1_000_000):
        s += i * i
    own = resource.getrusage(resource.RUSAGE_SELF).ru_utime - t0
    assert 0.4 * own < first.probe_s < 2.5 * own + 0.1, (first.probe_s, own)
    # cached: the second call runs nothing
    again = R.machine_rates(program=prog)
    assert again.probe_s == first.probe_s and again.source.startswith("cached")
    assert (tmp_path / "runs.log").read_text().count("run") == runs
    # another build (the program changed): measured again
    prog.write_text(prog.read_text() + "# rebuilt\n")
    os.utime(prog, (prog.stat().st_atime, prog.stat().st_mtime + 10))
    assert R.machine_rates(program=prog).source == "measured now"
    assert (tmp_path / "runs.log").read_text().count("run") == 2 * runs


def test_probe_that_cannot_run_is_said_not_guessed(tmp_path, monkeypatch):
    monkeypatch.setenv("TQ_RATES_FILE", str(tmp_path / "rates.json"))
    with pytest.raises(R.ProbeFailed, match="not built"):
        R.machine_rates(program=tmp_path / "missing")
    bad = tmp_path / "bad"
    bad.write_text("#!/bin/sh\necho broken >&2\nexit 3\n")
    bad.chmod(0o755)
    with pytest.raises(R.ProbeFailed, match="exited 3: broken"):
        R.machine_rates(program=bad)


def test_estimate_scales_with_the_measured_probe():
    """Each condition's CPU seconds are the element-steps times the probe's seconds times the
    measured multiples: twice the probe, twice the estimate; the solid-only condition exactly
    elements x steps x SOLID_PER_PROBE_S x probe."""
    from tunnelquake.case import case_geology, ground_layers, load_case
    from tunnelquake.meshing.params import element_counts, resolve
    from tunnelquake.scene import runtime_estimate

    case = load_case(EXAMPLE)
    one = runtime_estimate(case, rates=R.MachineRates(0.5, "test", "given"))
    two = runtime_estimate(case, rates=R.MachineRates(1.0, "test", "given"))
    for cond in one.seconds:
        assert two.seconds[cond] == pytest.approx(2 * one.seconds[cond], rel=1e-12)
    d = case.data
    counts = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    assert one.seconds["no_water"] == pytest.approx(
        (counts["rock"] + counts["lining"]) * one.steps * R.SOLID_PER_PROBE_S * 0.5, rel=1e-12)
    assert "test's speed" in one.line() and "probe 0.5 CPU s" in one.line()


def test_the_water_on_ranks_takes_the_measured_share_of_a_pass_where_its_cells_allow(monkeypatch):
    """parallel.fluid_ranks on a case unlike the example (cases/pressure_tunnel, its dynamic_water):
    the water's part of the coupled condition's wall time is WATER_RANKS_FACTOR of one rank's when
    each rank has WATER_RANK_CELLS cells or more and the condition has a core for each rank, one
    rank's otherwise (fewer cells a rank, one core, the solid-only conditions beside it on the two
    cores); the solid's part and the CPU seconds stay."""
    import copy

    from tunnelquake import cores
    from tunnelquake.case import case_geology, ground_layers, load_case
    from tunnelquake.meshing.params import element_counts, resolve
    from tunnelquake.scene import passes_per_window, runtime_estimate

    case = load_case(EXAMPLE.parents[1] / "pressure_tunnel" / "case.yaml")
    assert "dynamic_water" in case.data["conditions"]
    side_by_side = copy.deepcopy(case)
    side_by_side.data["parallel"]["fluid_ranks"] = 2
    case.data["conditions"] = ["dynamic_water"]
    d = case.data
    counts = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    rates = R.MachineRates(0.5, "test", "given")
    on_two = copy.deepcopy(case)
    on_two.data["parallel"]["fluid_ranks"] = 2

    def water_and_estimates(cells: int):
        c = dict(counts, water=cells)
        one, two = runtime_estimate(case, counts=c, rates=rates), runtime_estimate(on_two, counts=c, rates=rates)
        cp = d["coupling"]
        passes = passes_per_window(cp) * one.steps / cp["window"]
        return passes * (rates.water_pass + cells * rates.water_cell_pass), one, two

    monkeypatch.setattr(cores, "available", lambda: 2)
    water, one, two = water_and_estimates(2 * R.WATER_RANK_CELLS)
    assert two.seconds["dynamic_water"] == pytest.approx(
        one.seconds["dynamic_water"] - (1 - R.WATER_RANKS_FACTOR) * water, rel=1e-12)
    assert two.cpu == one.cpu
    assert f"the water on 2 ranks, {R.WATER_RANKS_FACTOR:.2f}x one rank's share of the time" in two.line()
    assert "ranks" not in one.line()
    _, one, two = water_and_estimates(2 * R.WATER_RANK_CELLS - 1)
    assert two.seconds == one.seconds
    c = dict(counts, water=4 * R.WATER_RANK_CELLS)
    beside = runtime_estimate(side_by_side, counts=c, rates=rates)
    assert beside.seconds == beside.cpu and "ranks" not in beside.line()
    monkeypatch.setattr(cores, "available", lambda: 1)
    _, one, two = water_and_estimates(4 * R.WATER_RANK_CELLS)
    assert two.seconds == one.seconds


def _pressure_tunnel(folder, end: float):
    """cases/pressure_tunnel (a case unlike the example: another section, three-component motion, a
    weathered layer) with its no_water condition alone and `end` s of shaking."""
    import shutil

    src = EXAMPLE.parents[1] / "pressure_tunnel"
    folder.mkdir(parents=True, exist_ok=True)
    for f in src.glob("*.txt"):
        shutil.copy(f, folder / f.name)
    text = (src / "case.yaml").read_text()
    text = "\n".join("conditions: [no_water]" if line.startswith("conditions:") else line
                     for line in text.splitlines())
    if "\nconditions:" not in text:
        text += "\nconditions: [no_water]"
    (folder / "case.yaml").write_text(text + f"\ntime:\n  end_time: {end} s\n")
    return folder / "case.yaml"


def _solid_cpu(case_yaml) -> float:
    """CPU seconds of the children (tq-solid) of one `tunnelquake run --no-post` of the case."""
    from tunnelquake.cli import main

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert main(["run", str(case_yaml), "--no-post"]) == 0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


#: rounds of the estimate's check against a real run: each the two lengths and the probe beside them
ESTIMATE_ROUNDS = 3


def test_estimate_predicts_the_cpu_seconds_of_a_case_unlike_the_example(tmp_path):
    """The solid-only condition of the pressure tunnel, 0.6 s of shaking against 0.05 s (the
    difference takes the start and the static stages off): the CPU seconds tq-solid took for the
    0.55 s between them within 30 % of what the estimate says of them at the probe's CPU seconds.

    The VM's speed drifts by 10-25 % over seconds and with the other work on it, and CPU seconds
    follow it (caches, a busy sibling core): one difference of two runs against the probe cached
    hours before gave 0.68 to 1.10 of the estimate (2026-11-29, the 2-core VM at load 7-9, alone
    and beside a busy loop). So each of ESTIMATE_ROUNDS rounds runs the two lengths (in alternated
    order) with the probe between them, and the ratio is the median of the rounds' ratios, each at
    its own probe: the estimate and the run measured at one speed of the machine (7 runs, the same
    machine, load 7-10: 0.887 / 0.899 / 0.947 / 0.921 alone, 0.825 / 0.824 / 0.903 beside a busy
    loop)."""
    import statistics

    from tunnelquake.case import load_case
    from tunnelquake.scene import runtime_estimate

    short, long_ = _pressure_tunnel(tmp_path / "short", 0.05), _pressure_tunnel(tmp_path / "long", 0.6)
    cases = {short: load_case(short), long_: load_case(long_)}
    ratios = []
    for r in range(ESTIMATE_ROUNDS):
        first, second = (short, long_) if r % 2 == 0 else (long_, short)
        cpu = {first: _solid_cpu(first)}
        rates = R.MachineRates(R.measure(runs=1), R.processor(), "measured beside the runs")
        cpu[second] = _solid_cpu(second)
        measured = cpu[long_] - cpu[short]
        assert measured > 0
        est = (runtime_estimate(cases[long_], rates=rates).cpu["no_water"]
               - runtime_estimate(cases[short], rates=rates).cpu["no_water"])
        ratios.append(est / measured)
        print(f"round {r + 1}: probe {rates.probe_s:.3f} CPU s, estimate {est:.3f} CPU s, measured "
              f"{measured:.3f} CPU s ({cpu[long_]:.3f} - {cpu[short]:.3f}), ratio {est / measured:.3f}")
    ratio = statistics.median(ratios)
    print(f"median ratio {ratio:.3f}")
    assert abs(ratio - 1) < 0.30, ratios


def test_no_probe_no_estimate_and_a_slurm_task_gets_a_day_saying_why(monkeypatch):
    """Without a probe (no build) the estimate says so instead of guessing, and a Slurm array task's
    time limit is a day with the reason in the script's comment (suite.slurm_time sets it)."""
    from tunnelquake.case import load_case
    from tunnelquake.scene import runtime_estimate
    from tunnelquake.suite_launch import SLURM_TIME_UNKNOWN_MIN, slurm_time

    def no_probe(*a, **k):
        raise R.ProbeFailed("/nowhere/tq-solid-bench is not built (scripts/bootstrap.sh builds it)")

    monkeypatch.setattr(R, "machine_rates", no_probe)
    case = load_case(EXAMPLE)
    est = runtime_estimate(case)
    assert est.seconds == {} and est.line() == ("run time: not estimated (this machine's speed could not be "
                                                "measured: /nowhere/tq-solid-bench is not built (scripts/bootstrap.sh "
                                                "builds it))")
    case.data.setdefault("suite", {})["slurm_time"] = None
    minutes, why = slurm_time(case, 2)
    assert minutes == SLURM_TIME_UNKNOWN_MIN == 1440 and "is not built" in why and "suite.slurm_time" in why
