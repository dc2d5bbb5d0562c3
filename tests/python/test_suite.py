"""Record suites (docs/user_guide.md "Record suites"): the combination rule on stored member
results, the response spectrum against a closed form, scaling to a PGA and to a target spectrum,
the case file's errors, and a 3-record suite x 2 conditions of the example slice (shortened) run as
one command: its report against the members' own results, the same suite under
`mpiexec -n 3 python -m mpi4py.futures` bitwise equal to the local pool's, and Ctrl-C then
`--resume`."""
from __future__ import annotations

import csv
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from case_edits import with_time
from test_reliability import _processes_naming

from conftest import EXAMPLE
from tunnelquake import post as P
from tunnelquake import suite as S
from tunnelquake import suite_members as SM
from tunnelquake.cli import main

RECORD_DT = 0.01
RECORD_S = 3.0


# ----------------------------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------------------------
def _records(folder: Path, n: int = 3) -> list[Path]:
    """`n` short two-column records in g: windowed sines of different frequencies and noise."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    t = np.arange(0.0, RECORD_S + RECORD_DT / 2, RECORD_DT)
    for i in range(n):
        rng = np.random.default_rng(10 + i)
        f = (2.0, 3.5, 1.2, 5.0, 0.8, 2.7, 4.2, 1.6)[i % 8]
        a = 0.2 * np.sin(2 * np.pi * f * t) * np.exp(-((t - 0.8) / 0.5) ** 2) * (1 + 0.3 * rng.standard_normal(t.size))
        p = folder / f"r{i}.txt"
        p.write_text("\n".join(f"{x:.4f} {y:.8e}" for x, y in zip(t, a, strict=True)) + "\n")
        out.append(p)
    return out


def _suite_case(folder: Path, suite: str, end_time: str = "0.2 s") -> Path:
    """The example slice, solid-only conditions (no_water, static_water), a short shaking, the
    first record as its own ground motion, and the given `suite:` text."""
    text = EXAMPLE.read_text().split("\nvariants:")[0]
    text = text.replace("conditions: [no_water, static_water, dynamic_water]", "conditions: [no_water, static_water]")
    text = re.sub(r"file: \.\./\.\./\.\./shared\S*", "file: records/r0.txt", text)
    text = text.replace("if_missing: synthetic", "units: g").replace("duration: 20 s", f"duration: {RECORD_S:g} s")
    text = with_time(text, end_time=end_time) + suite
    p = folder / "case.yaml"
    p.write_text(text)
    return p


SUITE_3 = """suite:
  records:
    - {glob: "records/r[01].txt", units: g}
    - {file: records/r2.txt, units: g, direction: -x, name: third}
  scaling: pga
  pga: 1.5 m/s^2
"""


def _env() -> dict:
    env = dict(os.environ)
    scripts = str(Path(S.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([scripts] + [p for p in [env.get("PYTHONPATH")] if p])
    return env


def _tq(*args, cwd=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tunnelquake", *map(str, args)], capture_output=True, text=True,
                          env=_env(), cwd=cwd, timeout=timeout)


def _datasets(path: Path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o[...]) if isinstance(o, h5py.Dataset) else None)
    return out


#: the monitors of the stored member results
STORED_MONITORS = ("crown", "haunch", "invert")


def _stored_results(path: Path, amp: float, status: str = "completed") -> None:
    """A results file in tq-solid's layout with monitors whose peaks are known: |ux| = amp,
    |uz| = amp / 2, sigma3 = 1e6 amp."""
    with h5py.File(path, "w") as f:
        f.attrs["status"] = status
        t = np.arange(401) * 0.005
        for name in STORED_MONITORS:
            g = f.create_group(f"monitors/{name}")
            g["time"] = t[:, None]
            u = np.zeros((t.size, 3))
            u[:, 0] = amp * np.sin(2 * np.pi * t)
            u[:, 2] = -0.5 * amp * np.sin(2 * np.pi * t)
            g["u"] = u
            s = np.zeros((t.size, 3))
            s[:, 2] = 1e6 * amp * np.sin(2 * np.pi * t) ** 2
            g["principal"] = s


# ----------------------------------------------------------------------------------------------
# The combination rule
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n, rule, expect", [(3, "auto", "max"), (6, "auto", "max"), (7, "auto", "mean"),
                                             (11, "auto", "mean"), (3, "mean", "mean"), (9, "max", "max")])
def test_combination_rule_on_stored_member_results(tmp_path, n, rule, expect):
    """EN 1998-1 §4.3.3.4.3(3) (and ASCE 7-10 §16.1.4): from 7 time-history analyses on the design
    value is the mean of the members' peaks, with fewer their maximum; `combine: mean|max` forces
    one. Members' results are stored files with known peaks."""
    amps = [0.01 * (1 + 0.37 * k) for k in range(n)]
    peaks = {}
    for k, a in enumerate(amps):
        folder = tmp_path / f"m{k}"
        folder.mkdir()
        _stored_results(folder / "results_no_water.h5", a)
        peaks[f"m{k}"] = SM.member_peaks(folder, ["no_water"])
    combined, used, count = SM.combined_table(peaks, rule)
    assert (used, count) == (expect, n)
    want = np.mean(amps) if expect == "mean" else max(amps)
    for mon in STORED_MONITORS:
        q = combined["no_water"][mon]
        assert q["max_ux"] == pytest.approx(want, rel=1e-12)
        assert q["max_uz"] == pytest.approx(want / 2, rel=1e-12)
        assert q["max_tension"] == pytest.approx(1e6 * want, rel=1e-9)
        assert not any(k.startswith("t_") for k in q)


def test_a_member_not_completed_is_left_out_of_the_combination(tmp_path):
    for k, (a, status) in enumerate([(0.01, "completed"), (0.05, "interrupted"), (0.02, "completed")]):
        (tmp_path / f"m{k}").mkdir()
        _stored_results(tmp_path / f"m{k}" / "results_no_water.h5", a, status)
    peaks = {f"m{k}": SM.member_peaks(tmp_path / f"m{k}", ["no_water"]) for k in range(3)}
    combined, used, count = SM.combined_table({n: p for n, p in peaks.items() if p}, "auto")
    assert (used, count) == ("max", 2)
    assert combined["no_water"]["haunch"]["max_ux"] == pytest.approx(0.02, rel=1e-12)


def test_max_keeps_the_most_severe_member_of_each_signed_quantity():
    """Three members, each the most severe in some quantities: the combined value is that member's.
    A minimum is most severe at its smallest (the crown's most compressive stress -397, -355, -305
    kPa combine to -397, the thrust's most compressive N, the hydraulic-jacking ratio), a maximum
    at its largest; the mean (7 or more members, EN 1998-1 §4.3.3.4.3) is the plain mean."""
    members = {
        "a": {"min_sigma1": -397e3, "max_tension": 0.8e6, "min_N": -1.2e6, "max_N": -0.2e6, "min_M": -40e3,
              "max_M": 55e3, "min_jacking_ratio": 1.9, "max_crack_width": 0.11e-3, "utilisation: reinforced": 0.4},
        "b": {"min_sigma1": -355e3, "max_tension": 1.1e6, "min_N": -1.5e6, "max_N": -0.4e6, "min_M": -35e3,
              "max_M": 70e3, "min_jacking_ratio": 1.4, "max_crack_width": 0.09e-3, "utilisation: reinforced": 0.7},
        "c": {"min_sigma1": -305e3, "max_tension": 0.9e6, "min_N": -1.1e6, "max_N": 0.1e6, "min_M": -52e3,
              "max_M": 60e3, "min_jacking_ratio": 1.6, "max_crack_width": 0.14e-3, "utilisation: reinforced": 0.5},
    }
    severe = {"min_sigma1": "a", "max_tension": "b", "min_N": "b", "max_N": "c", "min_M": "c", "max_M": "b",
              "min_jacking_ratio": "b", "max_crack_width": "c", "utilisation: reinforced": "b"}
    peaks = {m: {"static_water": {"crown": dict(q)}} for m, q in members.items()}
    combined, used, n = SM.combined_table(peaks, "auto")
    assert (used, n) == ("max", 3)
    for q, m in severe.items():
        assert combined["static_water"]["crown"][q] == members[m][q], q
    assert combined["static_water"]["crown"]["min_sigma1"] == -397e3
    mean, used, _ = SM.combined_table(peaks, "mean")
    assert used == "mean" and mean["static_water"]["crown"]["min_sigma1"] == pytest.approx(-(397e3 + 355e3 + 305e3) / 3, rel=1e-12)
    # the report's units: kN/m, kN·m/m, MPa, mm
    assert SM.shown("min_N")[1:] == ("kN/m", 1e-3) and SM.shown("max_M")[1:] == ("kN·m/m", 1e-3)
    assert SM.shown("min_sigma1")[1:] == ("MPa", 1e-6) and SM.shown("max_ux")[1:] == ("mm", 1e3)
    assert SM.shown("max_crack_width")[1:] == ("mm", 1e3)


# ----------------------------------------------------------------------------------------------
# Response spectrum
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("zeta", [0.05, 0.0, 0.2])
def test_response_spectrum_of_a_step_is_the_closed_form(zeta):
    """A ground acceleration stepping to a0 at t = 0 (linear between samples: exact for the
    integrator) drives u(t) = -(a0/w^2) [1 - e^(-zeta w t) (cos wd t + zeta/sqrt(1-zeta^2) sin wd t)],
    whose largest |u| is at t = pi/wd: Sa = w^2 max|u| = a0 (1 + exp(-pi zeta / sqrt(1 - zeta^2))).
    The step is chosen so that pi/wd is a sample."""
    a0 = 2.5
    for T in (0.05, 0.5, 2.0):
        w = 2 * np.pi / T
        wd = w * math.sqrt(1 - zeta**2)
        dt = (np.pi / wd) / 200
        acc = np.full(int(round(3 * T / dt)) + 1, a0)
        sa = S.response_spectrum(acc, dt, [T], damping=zeta)[0]
        exact = a0 * (1 + math.exp(-np.pi * zeta / math.sqrt(1 - zeta**2)))
        assert sa == pytest.approx(exact, rel=1e-9), (T, zeta)


def test_response_spectrum_of_a_ramp_follows_the_closed_form_at_every_sample():
    """Between samples the integrator is exact for a linear excitation, so the response to
    a_g = r t at the samples is the closed form u(t) = -(r/w^2) [t - 2 zeta/w + e^(-zeta w t)
    (2 zeta/w cos wd t + (2 zeta^2 - 1)/wd sin wd t)] for any step, even a coarse one: the peak
    over a record ending at t_end, times w^2, is Sa."""
    r, zeta, T, dt = 1.7, 0.05, 0.4, 0.037
    w = 2 * np.pi / T
    wd = w * math.sqrt(1 - zeta**2)
    t = np.arange(0, 4.0, dt)
    u = -(r / w**2) * (t - 2 * zeta / w + np.exp(-zeta * w * t) * (2 * zeta / w * np.cos(wd * t)
                                                                    + (2 * zeta**2 - 1) / wd * np.sin(wd * t)))
    sa = S.response_spectrum(r * t, dt, [T], damping=zeta)[0]
    assert sa == pytest.approx(w**2 * np.max(np.abs(u)), rel=1e-9)
    assert S.response_spectrum(r * t, dt, [0.0])[0] == pytest.approx(r * t[-1], rel=1e-15)


def test_ec8_type1_spectrum_corners():
    ag = 0.25 * 9.80665
    S_, tb, tc, td = S.EC8_TYPE1["C"]
    sa = S.ec8_type1([0.0, tb, tc, td, 3.0], ag, "C")
    assert sa == pytest.approx([ag * S_, 2.5 * ag * S_, 2.5 * ag * S_, 2.5 * ag * S_ * tc / td,
                                2.5 * ag * S_ * tc * td / 9.0], rel=1e-12)


# ----------------------------------------------------------------------------------------------
# Scaling
# ----------------------------------------------------------------------------------------------
def _gm(**kw) -> dict:
    gm = {"duration": None, "cutoff_frequency": 20.0, "baseline_correction": True, "pga": None,
          "vertical_ratio": 2 / 3, "convention": "outcrop"}
    gm.update(kw)
    return gm


def _suite_data(tmp_path, **suite) -> tuple[list, dict]:
    paths = _records(tmp_path / "records", 5)
    members = [S.MemberRecord(p.stem, p, "g", "auto", "x", None, f"suite.records[{i}]") for i, p in enumerate(paths)]
    s = {"scaling": "pga", "pga": None, "periods": None, "target": "ec8_type1", "ec8": {"ag": None, "ground_type": "B"},
         "table": {"periods": None, "sa": None}, "fraction": 1.0, "combine": "auto", "workers": 0}
    s.update(suite)
    return members, {"suite": s, "ground_motion": _gm()}


def test_scaling_to_pga(tmp_path):
    members, d = _suite_data(tmp_path, pga=1.5)
    members[2].pga = 3.0  # a member's own PGA
    factors, pgas = S.scale_factors(members, d)
    for m, f, pga in zip(members, factors, pgas, strict=True):
        acc = S.processed(S.read_member(m), d["ground_motion"], pga)
        want = 3.0 if m is members[2] else 1.5
        assert pga == pytest.approx(want, rel=1e-14)
        assert np.max(np.abs(acc)) == pytest.approx(want, rel=1e-14)
        assert np.max(np.abs(S.processed(S.read_member(m), d["ground_motion"]))) * f == pytest.approx(want, rel=1e-14)


@pytest.mark.parametrize("target, fraction", [("ec8_type1", 1.0), ("table", 1.0), ("ec8_type1", 0.9)])
def test_scaling_to_a_target_spectrum_over_the_period_range(tmp_path, target, fraction):
    """The scaled set's mean spectrum is at or above fraction x the target over [T1, T2] and
    touches it there."""
    members, d = _suite_data(tmp_path, scaling="spectrum", periods=[0.1, 1.0], target=target, fraction=fraction,
                             ec8={"ag": 0.3 * 9.80665, "ground_type": "B"},
                             table={"periods": [0.05, 0.2, 0.6, 2.0], "sa": [4.0, 8.0, 8.0, 1.5]})
    factors, pgas = S.scale_factors(members, d)
    T = S.scaling_periods(d["suite"])
    spectra = [S.response_spectrum(S.processed(S.read_member(m), d["ground_motion"], pga), RECORD_DT, T)
               for m, pga in zip(members, pgas, strict=True)]
    ratio = np.mean(spectra, axis=0) / S.target_spectrum(d["suite"], T)
    assert ratio.min() == pytest.approx(fraction, rel=1e-9)
    assert np.all(ratio >= fraction * (1 - 1e-9))
    assert T[0] == pytest.approx(0.1) and T[-1] == pytest.approx(1.0)
    assert all(f > 0 for f in factors)


# ----------------------------------------------------------------------------------------------
# The case file
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suite, key, words", [
    ('suite:\n  records:\n    - {glob: "nowhere/*.AT2", units: g}\n', "suite.records[0].glob", "matches no file"),
    ("suite:\n  records:\n    - {file: records/r0.txt}\n", "suite.records[0].units", "is missing"),
    ("suite:\n  records:\n    - {file: records/missing.txt, units: g}\n", "suite.records[0].file", "file not found"),
    ("suite:\n  records:\n    - {file: records/r0.txt, glob: 'records/*', units: g}\n", "suite.records[0]",
     "exactly one of"),
    ("suite:\n  records:\n    - {file: records/r0.txt, units: g}\n  scaling: spectrum\n", "suite.periods",
     "is required by scaling: spectrum"),
    ("suite:\n  records:\n    - {file: records/r0.txt, units: g}\n  scaling: spectrum\n  periods: [0.1, 1]\n",
     "suite.ec8.ag", "is required by target: ec8_type1"),
    ("suite:\n  records:\n    - {file: records/r0.txt, units: g}\n  combine: average\n", "suite.combine",
     "is not one of auto, mean, max"),
    ("suite:\n  records:\n    - {file: records/r0.txt, units: g}\n    - {file: records/r1.txt, units: g, name: r0}\n",
     "suite.records[1].name", "two members are named 'r0'"),
    ("suite:\n  combine: mean\n", "suite.records", "is missing"),
])
def test_check_names_the_key_of_a_bad_suite(tmp_path, capsys, suite, key, words):
    _records(tmp_path / "records", 2)
    case = _suite_case(tmp_path, suite)
    assert main(["check", str(case)]) == 1
    err = capsys.readouterr().err
    assert f": {key}" in err and words in err, err


# ----------------------------------------------------------------------------------------------
# A suite of the example slice, as one command
# ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def local_suite(tmp_path_factory):
    folder = tmp_path_factory.mktemp("suite_local")
    _records(folder / "records", 3)
    case = _suite_case(folder, SUITE_3)
    out = _tq("run", case)
    return folder, case, out


def test_suite_of_3_records_x_2_conditions_runs_as_one_command(local_suite):
    """One command runs every member x condition; the report's per-member rows and combined row
    are the members' own peaks (post.peaks of each results file) and their maximum (3 < 7
    members); the spectra and spread figures are drawn."""
    folder, case, out = local_suite
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    res = folder / "results"
    members = ["r0", "r1", "third"]
    conds = ["no_water", "static_water"]
    report = (res / "suite_report.md").read_text()
    assert "combination: **max** over the 3 member(s)" in report
    for name in members:
        assert re.search(rf"^\| {name} \| `r\d.txt` \| -?x \| [0-9.e+-]+ \| 1\.5, 0\.153 g \| completed \|", report,
                         re.M), name
    with open(res / "suite_peaks.csv") as fh:
        rows = {(r["member"], r["condition"], r["monitor"], r["quantity"]): float(r["value"]) for r in csv.DictReader(fh)}
    for cond in conds:
        assert f"## Peaks: {cond}" in report
        own = {m: P.peaks(P.read_condition(res / "members" / m / f"results_{cond}.h5", cond)) for m in members}
        for mon in own[members[0]]:
            for q in ("max_ux", "max_uz", "max_tension", "max_damage"):
                vals = [own[m][mon][q] for m in members]
                for m, v in zip(members, vals, strict=True):
                    assert rows[(m, cond, mon, q)] == v  # repr in the CSV: the same float
                assert rows[("combined_max", cond, mon, q)] == max(vals)
            section = report.split(f"## Peaks: {cond}")[1].split(f"### {mon}")[1].split("###")[0]
            mm = SM.shown("max_ux")[2]  # shown in mm
            assert f"| **max** | **{SM._fmt(max(own[m][mon]['max_ux'] for m in members), mm)}** |" in section
        # the lining's design quantities: each member's own, the most severe combined (the smallest of a minimum)
        lin = SM.LINING
        for q, pick in (("min_N", min), ("max_N", max), ("min_M", min), ("max_M", max)):
            vals = [rows[(m, cond, lin, q)] for m in members]
            assert rows[("combined_max", cond, lin, q)] == pick(vals), q
        assert f"### {lin}" in report.split(f"## Peaks: {cond}")[1]
    # the members ran with their scaled records: a PGA of 1.5 m/s^2 each, the third reversed
    for m in members:
        with h5py.File(res / "members" / m / "motion.h5", "r") as f:
            ax = f["incident_ax"][...]
        assert np.max(np.abs(2 * ax)) == pytest.approx(1.5, rel=1e-12)
    third = np.loadtxt(res / "members" / "third" / "record_reversed.txt")
    original = np.loadtxt(folder / "records" / "r2.txt")
    assert np.allclose(third[:, 1], -original[:, 1] * 9.80665, rtol=1e-15, atol=0)
    for fig in ("suite_spectra.png", "suite_spread.png"):
        assert (res / "figures" / fig).stat().st_size > 10_000
    assert "![spectra](figures/suite_spectra.png)" in report and "![spread](figures/suite_spread.png)" in report
    # run again: every member finished, none runs
    again = _tq("run", case)
    assert again.returncode == 0
    assert "finished earlier, kept: r0, r1, third" in again.stdout
    assert "suite: running" not in again.stdout and "member r0 " not in again.stdout


@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="mpiexec (Open MPI or MPICH) is not installed")
def test_suite_under_mpi4py_futures_is_bitwise_equal_to_the_local_pool(local_suite, tmp_path):
    pytest.importorskip("mpi4py", reason="mpi4py is not installed")
    folder, case, out = local_suite
    assert out.returncode == 0
    shutil.copytree(folder / "records", tmp_path / "records")
    shutil.copy(case, tmp_path / "case.yaml")
    cmd = ["mpiexec", "-n", "3"]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    version = subprocess.run(["mpiexec", "--version"], capture_output=True, text=True)
    if re.search(r"open-?mpi|openrte|open mpi", version.stdout + version.stderr, re.I):
        cmd.append("--oversubscribe")
    cmd += [sys.executable, "-m", "mpi4py.futures", "-m", "tunnelquake", "run", str(tmp_path / "case.yaml")]
    mpi = subprocess.run(cmd, capture_output=True, text=True, env=_env(), timeout=600)
    assert mpi.returncode == 0, mpi.stdout[-3000:] + mpi.stderr[-3000:]
    assert "MPI worker(s)" in mpi.stdout
    for m in ("r0", "r1", "third"):
        for cond in ("no_water", "static_water"):
            a = _datasets(folder / "results" / "members" / m / f"results_{cond}.h5")
            b = _datasets(tmp_path / "results" / "members" / m / f"results_{cond}.h5")
            assert a.keys() == b.keys() and len(a) > 10
            for k in a:
                assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
                assert a[k].tobytes() == b[k].tobytes(), f"{m} {cond} {k} differs"




def _state(folder: Path, member: str) -> str:
    from tunnelquake.suite_members import read_state

    return read_state(folder / "results" / "members" / member).get("status", "")


def test_ctrl_c_stops_every_member_in_bounded_time_and_resume_runs_only_the_rest(tmp_path):
    """SIGINT to the suite's process group (a terminal's Ctrl-C) while the second of three members
    runs (one worker): within the bound every process ends, the command exits 130 with one line
    naming what completed, what stopped and what never started. `--resume` then runs the second
    and third members only: the first's files are not touched."""
    from tunnelquake.suite_launch import STOP_BOUND_S

    _records(tmp_path / "records", 3)
    case = _suite_case(tmp_path, SUITE_3, end_time="1.5 s")
    res = tmp_path / "results"
    proc = subprocess.Popen([sys.executable, "-m", "tunnelquake", "run", str(case), "--workers", "1", "--no-post"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_env(),
                            start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and not (
                _state(tmp_path, "r0") == "completed" and _state(tmp_path, "r1") == "running"
                and (res / "members" / "r1" / "results_no_water.h5").is_file()):
            assert proc.poll() is None, proc.stdout.read()[-3000:]
            time.sleep(0.1)
        assert _state(tmp_path, "r1") == "running"
        first = {p.name: p.stat().st_mtime_ns for p in (res / "members" / "r0").iterdir() if p.is_file()}
        t_sig = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=120)
        took = time.monotonic() - t_sig
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, out[-3000:]
    assert took < STOP_BOUND_S, took
    assert "Traceback" not in out and "KeyboardInterrupt" not in out, out[-3000:]
    last = out.strip().splitlines()[-1]
    assert last.startswith("tunnelquake run: suite interrupted by SIGINT after "), last
    assert "completed r0; stopped r1; not started third" in last, last
    assert _processes_naming(tmp_path) == []
    assert (_state(tmp_path, "r0"), _state(tmp_path, "r1"), _state(tmp_path, "third")) == \
        ("completed", "interrupted", "")
    with h5py.File(res / "members" / "r1" / "results_no_water.h5", "r") as f:
        assert f.attrs["status"] in ("interrupted", "completed")

    again = _tq("run", case, "--resume")
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert "finished earlier, kept: r0" in again.stdout
    assert "resuming: 2 member(s) left: r1, third" in again.stdout
    assert re.search(r"member r1 completed", again.stdout) and re.search(r"member third completed", again.stdout)
    assert "member r0 " not in again.stdout
    after = {p.name: p.stat().st_mtime_ns for p in (res / "members" / "r0").iterdir() if p.is_file()}
    assert after == first
    assert all(_state(tmp_path, m) == "completed" for m in ("r0", "r1", "third"))
    assert (res / "suite_report.md").read_text().count("| completed |") == 3


def test_progress_line_counts_members_and_estimates_from_the_solver_progress(tmp_path):
    """Before any member ends, the ETA comes from the running members' simulated time (their
    run.log's tq-solid progress lines); after, from the finished members' wall times."""
    from tunnelquake import suite_launch as R

    t0 = time.time() - 100
    ms = []
    for k in range(4):
        folder = tmp_path / f"m{k}"
        folder.mkdir()
        ms.append(type("M", (), {"name": f"m{k}", "folder": folder})())
    for m in ms[:2]:  # running for 100 s, the first of two conditions complete, the second at 5 of 20 s
        R._write_state(m.folder, {"status": "running", "started": t0})
        (m.folder / "run.log").write_text("tq-solid: completed 10 steps\n  t = 5 s / 20 s (25 %), step 9\n")
    assert R.member_fraction(ms[0].folder, 2) == pytest.approx(0.625)
    assert R.member_fraction(ms[2].folder, 2) is None
    line = R._progress(ms, ms, {}, 2, t0, 2)
    # each member 160 s in all: 60 s left for the two running, then 160 s for the two left on 2 workers
    assert line.startswith("suite: 0 done, 2 running, 2 left of 4; 0 failed;"), line
    assert line.endswith("ETA 3.7 min"), line  # (2 x 160 + 2 x 60) / 2 = 220 s
    done = {"m0": {"name": "m0", "status": "completed", "wall_s": 100.0, "rc": 0}}
    assert R._progress(ms, ms, done, 2, t0, 2).startswith("suite: 1 done, 1 running, 2 left of 4")
