"""`check`'s run-time estimate learns from this machine's completed runs (tunnelquake.rates
record_run, scene.record_run_rates; docs/benchmarks.md "check's run-time estimate"): a run's
measured time against the estimate of that run at its own steps and passes gives a ratio per kind
of condition, and the next estimate of a condition of that kind is multiplied by the median of the
last RUN_RECORDS ratios.

References: the ratios are constructed here (results files written with known timings), so the
corrected estimate is known exactly: the uncorrected part times the ratio, to round-off (1e-12). A
case unlike the example: cases/pressure_tunnel (another section, head and motion)."""
from __future__ import annotations

import json

import h5py
import pytest

from conftest import EXAMPLE
from tunnelquake import rates as R

PRESSURE_TUNNEL = EXAMPLE.parents[1] / "pressure_tunnel" / "case.yaml"


@pytest.fixture
def cached_probe(tmp_path, monkeypatch):
    """A rates cache holding a probe for this build (0.5 CPU s), recording on: what a machine has
    after its first `check`."""
    program = R.probe_program()
    if not program.is_file():
        pytest.skip(f"{program} is not built")
    path = tmp_path / "rates.json"
    path.write_text(json.dumps({R._key(program): {"probe_s": 0.5, "date": "2026-12-01", "eval_share": 0.8}}))
    monkeypatch.setenv("TQ_RATES_FILE", str(path))
    monkeypatch.setenv("TQ_RATES_RECORD", "1")
    return path


def _results(path, steps: int, wall: float | None = None, coupled: tuple | None = None):
    """A results file with tq-solid's /timings (and /coupling: wall, waits, passes, windows)."""
    with h5py.File(path, "w") as f:
        t = f.create_group("timings")
        t.attrs["steps"] = steps
        t.attrs["wall_s"] = wall if wall is not None else coupled[0]
        if coupled:
            c = f.create_group("coupling")
            for k, v in zip(("coupled_wall_s", "exchange_wait_s", "passes", "windows"), coupled, strict=True):
                c.attrs[k] = v
    return path


def test_a_solid_run_measured_against_its_estimate_corrects_the_next_estimate_of_its_kind(cached_probe, tmp_path):
    from tunnelquake.case import load_case
    from tunnelquake.scene import record_run_rates, runtime_estimate

    case = load_case(PRESSURE_TUNNEL)
    before = runtime_estimate(case)
    assert not before.corrections and "earlier runs" not in before.line()
    key, part = before.kinds["no_water"]
    assert key.startswith("solid, ") and part == pytest.approx(before.seconds["no_water"], rel=1e-12)
    # a run of twice the estimate's steps (the per-step rate is what is compared) at 0.6 of its time
    steps = 2 * before.steps
    wall = 0.6 * 2 * part
    assert wall >= R.RUN_RECORD_MIN_S
    kept = record_run_rates(case, "no_water", _results(tmp_path / "r.h5", steps, wall))
    assert kept == {key: pytest.approx(0.6, rel=1e-12)}
    after = runtime_estimate(case)
    assert after.seconds["no_water"] == pytest.approx(0.6 * before.seconds["no_water"], rel=1e-12)
    assert after.cpu == before.cpu  # one thread's CPU stays the probes' figure
    assert f"corrected by this machine's earlier runs of its kind: {key} x0.60 (1 run)" in after.line()
    # another kind (the coupled condition's solid) is not corrected by it
    assert after.seconds["dynamic_water"] == pytest.approx(before.seconds["dynamic_water"], rel=1e-12)
    # nor is the same condition cut to a first second (another length of shaking)
    case.data["time"]["end_time"] = 1.0
    short = runtime_estimate(case)
    assert not short.corrections and short.kinds["no_water"][0] != key
    assert short.seconds["no_water"] == pytest.approx(short.kinds["no_water"][1], rel=1e-12)


def test_a_coupled_run_corrects_its_kind_at_its_own_passes(cached_probe, tmp_path):
    """A coupled condition is one kind, its solid and its water together (their split moves from
    run to run where they share cores); the ratio is taken at the run's own passes a window (1.3,
    not the estimate's rule), and the next estimate keeps its rule's passes."""
    from tunnelquake.case import load_case
    from tunnelquake.scene import record_run_rates, runtime_estimate

    case = load_case(PRESSURE_TUNNEL)
    before = runtime_estimate(case)
    window = int(case.data["coupling"]["window"])
    windows = before.steps // window
    at_run = runtime_estimate(case, actual={"dynamic_water": {"steps": windows * window, "passes_per_window": 1.3}},
                              corrected=False)
    key, part = at_run.kinds["dynamic_water"]
    assert key.startswith("coupled, ") and "the water on 1 rank(s)" in key
    assert part != pytest.approx(before.kinds["dynamic_water"][1], rel=1e-3)  # the passes count
    res = _results(tmp_path / "c.h5", windows * window, coupled=(0.7 * part, 0.2 * part, 1.3 * windows, windows))
    assert record_run_rates(case, "dynamic_water", res) == {key: pytest.approx(0.7, rel=1e-9)}
    after = runtime_estimate(case)
    assert after.seconds["dynamic_water"] == pytest.approx(0.7 * before.seconds["dynamic_water"], rel=1e-9)
    assert after.seconds["no_water"] == pytest.approx(before.seconds["no_water"], rel=1e-12)


def test_the_correction_is_the_median_of_the_last_runs_of_a_kind(cached_probe):
    key = R.part_key("solid", 2, True, 32)
    assert key == "solid, 2 thread(s), subcycled, 32^3 class"
    assert R.part_key("coupled", 1, False, 0, ranks=2) == "coupled, 1 thread(s), the water on 2 rank(s), one rate"
    # the shaking's length within a factor of 4: a record's 20 s and a first second are other kinds
    assert R.part_key("solid", 1, seconds=20.0).endswith(", 16-64 s of shaking")
    assert R.part_key("solid", 1, seconds=16.0).endswith(", 16-64 s of shaking")
    assert R.part_key("solid", 1, seconds=1.0).endswith(", 1-4 s of shaking")
    assert R.part_key("solid", 1, seconds=0.5).endswith(", 0.25-1 s of shaking")
    for ratio in (1.0, 2.0, 3.0, 10.0, 4.0, 5.0):
        assert R.record_run({key: ratio})
    kept = json.loads(cached_probe.read_text())
    assert [r["ratio"] for r in next(iter(kept.values()))["runs"][key]] == [2.0, 3.0, 10.0, 4.0, 5.0]
    rates = R.machine_rates(measure_if_missing=False)
    assert rates.correction(key) == (4.0, R.RUN_RECORDS)
    assert rates.correction(R.part_key("solid", 1)) == (1.0, 0)
    assert R.MachineRates(1.0, "t", "given", runs={key: [1.0, 3.0]}).correction(key) == (2.0, 2)


def test_short_runs_and_runs_without_a_cached_probe_are_not_kept(cached_probe, tmp_path, monkeypatch):
    from tunnelquake.case import load_case
    from tunnelquake.scene import record_run_rates, runtime_estimate

    case = load_case(PRESSURE_TUNNEL)
    est = runtime_estimate(case)
    short = _results(tmp_path / "s.h5", est.steps, 0.9 * R.RUN_RECORD_MIN_S)
    assert record_run_rates(case, "no_water", short) == {}
    enough = _results(tmp_path / "e.h5", est.steps, 2 * R.RUN_RECORD_MIN_S)
    monkeypatch.setenv("TQ_RATES_RECORD", "0")
    assert record_run_rates(case, "no_water", enough) == {}
    monkeypatch.setenv("TQ_RATES_RECORD", "1")
    monkeypatch.setenv("TQ_RATES_FILE", str(tmp_path / "empty.json"))  # no probe cached: nothing to compare with
    assert record_run_rates(case, "no_water", enough) == {}
    assert not (tmp_path / "empty.json").exists()
    monkeypatch.setenv("TQ_RATES_FILE", str(cached_probe))
    assert "runs" not in next(iter(json.loads(cached_probe.read_text()).values()))
