"""Each coupling rule in one function that every caller asks (docs/architecture.md "One owner per
contract"): the paper scheme's one-step windows (case.coupling_window_problem), the window and the
number of windows (fluid_case.coupling_window_size, coupling_windows), the checkpoint cadence in
windows (fluid_case.checkpoint_windows); the solid's step read from tq-solid's --check --json.

For each rule the function's answer is compared with what every caller does with it: the case
check, the coupling settings both sides are given, the verification ring, tq-solid's reader."""
from __future__ import annotations

import json
import math
import re
import subprocess

import h5py
import pytest

from conftest import EXAMPLE
from tunnelquake import fluid_case as fc
from tunnelquake import paths, water_case
from tunnelquake.case import coupling_window_problem, load_case
from tunnelquake.foam_dict import parse
from tunnelquake.schema import CaseError
from tunnelquake.solid_input import solid_step, write_solid_input
from tunnelquake.verification.ring import Ring, RingError


def _example_with(tmp_path, old: str, new: str):
    text = EXAMPLE.read_text()
    assert old in text
    p = tmp_path / "case.yaml"
    p.write_text(text.replace(old, new))
    return p


def test_the_paper_scheme_rule_is_the_one_every_caller_applies(tmp_path):
    why = coupling_window_problem("paper", 4)
    assert why is not None and "one-step windows" in why
    for scheme, window in (("paper", 1), ("implicit", 16), ("explicit", 4)):
        assert coupling_window_problem(scheme, window) is None
    # the case check
    with pytest.raises(CaseError) as e:
        load_case(_example_with(tmp_path, "  scheme: implicit\n", "  scheme: paper\n"))
    assert "coupling.window" in str(e.value) and coupling_window_problem("paper", 16) in str(e.value)
    # the settings both sides are given (a case changed after its check)
    case = load_case(EXAMPLE)
    case.data["coupling"].update(scheme="paper", window=4, reuse=0)
    with pytest.raises(fc.FluidCaseError, match="one-step windows"):
        fc.coupling_settings(case, 4e-4, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    case.data["coupling"]["window"] = 1
    assert fc.coupling_settings(case, 1e-4, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)["scheme"] == "paper"
    # the verification ring
    with pytest.raises(RingError, match="one-step windows"):
        Ring(scheme="paper", window=4).check()
    Ring(scheme="paper", window=1).check()


def test_the_window_count_both_sides_get_is_the_one_rule(tmp_path):
    case = load_case(EXAMPLE)
    w = fc.coupling_window_size(16, 6.30061234e-5)
    assert w == pytest.approx(16 * 6.3006e-5, rel=1e-15)  # 5 significant digits, rounded down
    assert fc.coupling_window_size(1, 9.30806e-05) == pytest.approx(9.3080e-05, rel=1e-15)
    for t_end, n in ((10 * w, 10), (10.5 * w, 11), (0.1 * w, 1), (1000 * w * (1 + 1e-13), 1000)):
        assert fc.coupling_windows(t_end, w) == n, (t_end / w, n)
    s = fc.coupling_settings(case, w, tmp_path / "wall.addr", "ab" * 16, t_end=0.0237)
    n = fc.coupling_windows(0.0237, w)
    assert n == math.ceil(0.0237 / w)
    solid = fc.solid_coupling_attrs(s)
    ctrl = parse(water_case.dictionaries(fc.water_case(case, s, slice_mode=True))["system/controlDict"])
    assert solid["windows"] == ctrl["functions"]["interface"]["exchange"]["windows"] == n
    assert solid["window_size"] == ctrl["deltaT"] == w
    assert ctrl["endTime"] == pytest.approx(n * w, rel=1e-15)


def test_the_checkpoint_cadence_both_sides_get_is_the_one_rule(tmp_path):
    assert fc.checkpoint_windows(1.0, 2.5e-4) == 4000
    assert fc.checkpoint_windows(1e-5, 1e-3) == 1  # at least every window
    assert fc.checkpoint_windows(0.0, 1e-3) == 0  # no checkpoints
    case = load_case(EXAMPLE)
    case.data["output"]["checkpoint_interval"] = 0.05
    s = fc.coupling_settings(case, 16 * 6.3006e-5, tmp_path / "wall.addr", "ab" * 16, t_end=0.2)
    k = fc.checkpoint_windows(0.05, 16 * 6.3006e-5)
    assert k == 50  # 0.05 / 1.0081e-3 = 49.6
    assert s["checkpoint_windows"] == fc.solid_coupling_attrs(s)["checkpoint_windows"] == k
    case.data["output"]["checkpoint_interval"] = 0.0
    s = fc.coupling_settings(case, 1e-3, tmp_path / "wall.addr", "ab" * 16, t_end=0.2)
    assert "checkpoint_windows" not in fc.solid_coupling_attrs(s)  # tq-solid's default: none is due


def _solid():
    exe = paths.solid_executable()
    if exe is None:
        return None
    out = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=10)
    return exe if "--json" in out.stdout else None


@pytest.fixture(scope="module")
def slice_input(tmp_path_factory):
    """The example's slice mesh (mesh defaults) and motion, and its dynamic_water input without /coupling."""
    from tunnelquake.meshing import build_tunnel_mesh
    from tunnelquake.motion import from_case
    from tunnelquake.prepare import write_motion

    tmp = tmp_path_factory.mktemp("rules")
    case = load_case(EXAMPLE)
    d = case.data
    d["time"]["end_time"] = 0.01
    d["mesh"]["mode"] = "slice"
    build_tunnel_mesh(d["geometry"], d["mesh"], tmp)
    motion, _ = from_case(d["ground_motion"], case.dir)
    write_motion(motion, tmp / "motion.h5")
    inp = write_solid_input(case, tmp / "mesh.h5", tmp / "motion.h5", "dynamic_water", tmp / "in.h5")
    return case, tmp, inp


@pytest.mark.skipif(_solid() is None, reason="tq-solid with --check --json is not built")
def test_the_solid_step_is_read_to_full_precision(slice_input):
    """solid_step reads --check --json: the step itself (safety x the critical step, exactly), not its
    printed 6 digits (which agree to their last one)."""
    _, tmp, inp = slice_input
    exe = _solid()
    dt = solid_step(exe, inp)
    report = tmp / "check.json"
    run = subprocess.run([str(exe), str(inp), "--check", "--json", str(report)], capture_output=True, text=True,
                         timeout=120)
    r = json.loads(report.read_text())
    assert dt == r["dt"] == r["safety"] * r["dt_critical"]
    printed = float(re.search(r"dt = (\S+) s", run.stdout).group(1))
    assert printed == pytest.approx(dt, rel=5e-6)
    assert r["steps"] == math.ceil(r["t_end"] / dt) and r["block"] in ("rock", "lining")
    # --json without --check is a usage error
    bad = subprocess.run([str(exe), str(inp), "--json", str(report)], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 1 and "--json goes with --check" in bad.stderr


@pytest.mark.skipif(_solid() is None, reason="tq-solid with --check --json is not built")
def test_tq_solid_refuses_what_the_paper_scheme_rule_refuses(slice_input):
    """The one /coupling written from the settings object, with the paper scheme: tq-solid's reader
    accepts one-step windows and refuses windows of several steps with the same reason."""
    case, tmp, inp = slice_input
    exe = _solid()
    window = fc.coupling_window_size(case.data["coupling"]["window"], solid_step(exe, inp))
    s = fc.coupling_settings(case, window, tmp / "wall.addr", "ab" * 16, t_end=0.01)
    for scheme, k, code in (("implicit", s["window"], 0), ("paper", 1, 0), ("paper", 4, 2)):
        out = write_solid_input(case, tmp / "mesh.h5", tmp / "motion.h5", "dynamic_water", tmp / f"{scheme}{k}.h5",
                                coupling={**s, "scheme": scheme, "window": k, "reuse": 0, "predictor": "constant",
                                          "window_force_weight": 0.5})
        with h5py.File(out) as f:
            assert f["coupling"].attrs["windows"] == s["windows"]
        run = subprocess.run([str(exe), str(out), "--check"], capture_output=True, text=True, timeout=120)
        assert run.returncode == code, run.stdout + run.stderr
        if code:
            assert "one-step windows" in run.stderr


@pytest.mark.skipif(_solid() is None, reason="tq-solid with --check --json is not built")
def test_tq_solid_takes_the_window_count_it_is_given(slice_input):
    """The number of windows is the case's (fluid_case.coupling_windows), given to both sides: tq-solid's
    reader refuses a /coupling without it, or with none, naming the attribute, instead of counting its own."""
    case, tmp, inp = slice_input
    exe = _solid()
    window = fc.coupling_window_size(case.data["coupling"]["window"], solid_step(exe, inp))
    s = fc.coupling_settings(case, window, tmp / "wall.addr", "ab" * 16, t_end=0.01)
    for name, edit in (("absent", lambda a: a.__delitem__("windows")), ("zero", lambda a: a.__setitem__("windows", 0))):
        out = write_solid_input(case, tmp / "mesh.h5", tmp / "motion.h5", "dynamic_water", tmp / f"w_{name}.h5",
                                coupling=s)
        with h5py.File(out, "r+") as f:
            edit(f["coupling"].attrs)
        run = subprocess.run([str(exe), str(out), "--check"], capture_output=True, text=True, timeout=120)
        assert run.returncode == 2, (name, run.stdout + run.stderr)
        assert "/coupling" in run.stderr and "windows" in run.stderr, (name, run.stderr)
        assert "Traceback" not in run.stderr and "terminate" not in run.stderr


#: variant, water overrides, coupling overrides -> whether the water sends its wall pressure less its mean:
#: exactly when tq-solid carries a volume law in a closed section (its uniform pressure is that mean;
#: docs/coupler.md "Volume law in the solid"), never with open ends or with the whole pressure exchanged
MEAN_PRESSURE_CASES = (
    (None, {}, {}, True),
    (None, {"model": "incompressible"}, {}, True),
    (None, {}, {"volume_law": "water"}, False),
    ("3d_solid_law", {}, {}, True),
    ("3d_open", {}, {}, False),
    ("3d_open_incompressible", {}, {}, False),
)


@pytest.mark.parametrize("variant, water, coupling, subtract", MEAN_PRESSURE_CASES)
def test_the_mean_pressure_flag_both_sides_get_is_one_setting(tmp_path, variant, water, coupling, subtract):
    """Whether the water sends its wall pressure less its area mean is one coupling setting, written to
    /coupling (subtract_mean_pressure) and into the water's tqInterface entry (subtractMeanPressure) from
    the same settings object: the two agree for every water model, and a change of the setting alone
    changes both."""
    case = load_case(EXAMPLE, variant)
    case.data["water"].update(water)
    case.data["coupling"].update(coupling)
    slice_mode = case.data["mesh"]["mode"] == "slice"

    def sides(s):
        solid = fc.solid_coupling_attrs(s).get("subtract_mean_pressure", 0.0) == 1.0
        ctrl = parse(water_case.dictionaries(fc.water_case(case, s, slice_mode))["system/controlDict"])
        return solid, ctrl["functions"]["interface"].get("subtractMeanPressure", "no") == "yes"

    s = fc.coupling_settings(case, 1e-3, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    assert s["subtract_mean_pressure"] is subtract
    assert sides(s) == (subtract, subtract)
    # the setting changed in the settings object alone: both sides follow
    assert sides({**s, "subtract_mean_pressure": not subtract}) == (not subtract, not subtract)


@pytest.mark.skipif(_solid() is None, reason="tq-solid with --check --json is not built")
def test_tq_solid_refuses_a_mean_pressure_no_volume_law_carries(slice_input):
    """/coupling subtract_mean_pressure 1 says the water leaves out its mean wall pressure: tq-solid takes
    it with its closed-section volume law (the example's settings) and refuses it, naming the attribute,
    where no law of a closed section carries that mean (the whole pressure exchanged, or open ends)."""
    case, tmp, inp = slice_input
    exe = _solid()
    window = fc.coupling_window_size(case.data["coupling"]["window"], solid_step(exe, inp))
    s = fc.coupling_settings(case, window, tmp / "wall.addr", "ab" * 16, t_end=0.01)
    assert s["subtract_mean_pressure"] is True and s["volume_law"] == "compressible"
    for name, edit, code in (
            ("closed law", {}, 0),
            ("no law", {"volume_law": "none", "bulk_modulus": 0.0, "water_density": 0.0}, 2),
            ("open ends", {"water_ends": "open"}, 2)):
        out = write_solid_input(case, tmp / "mesh.h5", tmp / "motion.h5", "dynamic_water",
                                tmp / f"mean_{name.replace(' ', '_')}.h5", coupling={**s, **edit})
        with h5py.File(out) as f:
            assert f["coupling"].attrs["subtract_mean_pressure"] == 1
        run = subprocess.run([str(exe), str(out), "--check"], capture_output=True, text=True, timeout=120)
        assert run.returncode == code, (name, run.stdout + run.stderr)
        if code:
            assert "subtract_mean_pressure" in run.stderr and "water_ends closed" in run.stderr, (name, run.stderr)
            assert "Traceback" not in run.stderr and "terminate" not in run.stderr
