"""The material models: one list of names (`solver_input_table.MODELS`; tq-solid's registry is checked
against the table built from it by the C++ test MaterialRegistry.TheTableAndTheRegistryNameTheSameModels)
from which the case schema takes its choices, and the Kelvin–Voigt rock's key from the case to tq-solid.

1. The case's `materials.<name>.model` choices are the table's MODELS.
2. `kelvin_voigt` without `retardation_time`, or with a negative one, is refused by the case check naming
   the key.
3. A slice whose rock is `kelvin_voigt` (τ = 1 ms) is written with `retardation_time` and accepted by
   tq-solid, whose stable step is then set by a rock element and below half the elastic rock's: the
   viscous bound (2/ω)(√(1+ξ²) − ξ), ξ = τω/2, of the rock's smallest elements falls below the
   lining's elastic bound (measured: 4.68e-5 s set by the lining, 6.95e-6 s set by the rock; the
   closed-form check of the bound is the C++ test KelvinVoigtMaterial.StableStepAccountsForTheViscosity).
   With subcycling (elements at their own elastic step) tq-solid refuses it at --check, naming τ.
4. `tunnelquake check` refuses subcycling with a viscous stress first (a Kelvin–Voigt material, or
   Rayleigh's stiffness term), naming time.subcycling and the material.
5. check's step estimate (case.critical_step) takes the viscous bound as tq-solid does, at the
   block's own largest frequency 2 c_p / h (h its smallest element side), against the step tq-solid
   takes (solid_step: --check --json), the same mesh: Kelvin–Voigt rock τ = 1 ms and 10 ms (measured
   6.9514e-6 and 6.9753e-7 s estimated against 6.9514e-6 and 6.9753e-7 s critical; tolerance 1 %)
   and a Kelvin–Voigt lining τ = 0.2 ms (5.69e-6 against 5.41e-6 s: the lining's layer h_1 / c_p is
   2.6 % above tq-solid's element bound, the viscous bound ~1/(τ ω²) twice that; tolerance 7 %).
   Without the viscous term the estimate stayed at the elastic 4.80e-5 s, 6.9x the rock's step.
"""
from __future__ import annotations

import json
import subprocess

import h5py
import pytest
from case_texts import synthetic_motion, tunnel

from tunnelquake import paths
from tunnelquake.case import load_case, schema
from tunnelquake.meshing import build_tunnel_mesh
from tunnelquake.motion import from_case
from tunnelquake.prepare import write_motion
from tunnelquake.scene import runtime_estimate
from tunnelquake.schema import CaseError
from tunnelquake.solid_input import solid_step, write_solid_input
from tunnelquake.solver_input_table import MODELS

CASE = tunnel("material_models", [-40.0, 40.0], [0.0, 10.0], [-30.0, 60.0], centre_z=20.0, radius=4.0, lining=0.5,
              mode="slice") + """materials:
  rock: {model: ROCK, youngs_modulus: 8 GPa, poisson_ratio: 0.27, density: 2700EXTRA}
  lining: {model: elastic, youngs_modulus: 28 GPa, poisson_ratio: 0.17, density: 2500}
interface: {model: bonded}
water: {head: 0 m, model: compressible}
""" + synthetic_motion("0.1 g", 0, 1.0) + """in_situ: {kx: 1.0, ky: 1.0, kz: 1.0}
time: {end_time: 0.01}
"""


def _case(tmp_path, rock="elastic", extra=""):
    p = tmp_path / "case.yaml"
    p.write_text(CASE.replace("ROCK", rock).replace("EXTRA", extra))
    return load_case(p)


def test_the_case_takes_the_model_names_from_the_solver_table():
    assert "kelvin_voigt" in MODELS
    assert schema().fields["materials"].item.fields["model"].choices == MODELS


@pytest.mark.parametrize("extra, why", [("", "is required by model kelvin_voigt"),
                                        (", retardation_time: -1 ms", "retardation_time")])
def test_kelvin_voigt_needs_a_non_negative_retardation_time(tmp_path, extra, why):
    with pytest.raises(CaseError) as e:
        _case(tmp_path, "kelvin_voigt", extra)
    assert "materials.rock.retardation_time" in str(e.value) and why in str(e.value)


def _stable_step(exe, path):
    """tq-solid's critical step and the block that sets it (its --check --json)."""
    report = path.with_suffix(".json")
    out = subprocess.run([str(exe), str(path), "--check", "--threads", "1", "--json", str(report)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    r = json.loads(report.read_text())
    return r["dt_critical"], r["block"]


@pytest.mark.skipif(paths.solid_executable() is None, reason="tq-solid is not built")
def test_kelvin_voigt_rock_reaches_tq_solid_and_shortens_its_step(tmp_path):
    elastic = _case(tmp_path)
    build_tunnel_mesh(elastic.data["geometry"], elastic.data["mesh"], tmp_path)
    motion, _ = from_case(elastic.data["ground_motion"], elastic.dir)
    write_motion(motion, tmp_path / "motion.h5")
    kv = _case(tmp_path, "kelvin_voigt", ", retardation_time: 1 ms")
    files = {}
    for name, case in (("elastic", elastic), ("kv", kv)):
        files[name] = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", "no_water",
                                        tmp_path / f"{name}.h5")
    with h5py.File(files["kv"]) as f:
        assert f["materials/rock"].attrs["model"] == "kelvin_voigt"
        assert f["materials/rock"].attrs["retardation_time"] == pytest.approx(1e-3, rel=1e-12)
        assert "retardation_time" not in f["materials/lining"].attrs
    exe = paths.solid_executable()
    dt_elastic, _ = _stable_step(exe, files["elastic"])
    dt_kv, block = _stable_step(exe, files["kv"])
    assert block == "rock"
    assert dt_kv < 0.5 * dt_elastic
    # subcycling with a viscous material is refused by tq-solid's starter (--check), before any stage
    sub = _case(tmp_path, "kelvin_voigt", ", retardation_time: 1 ms")
    sub.data["time"]["subcycling"] = 3
    path = write_solid_input(sub, tmp_path / "mesh.h5", tmp_path / "motion.h5", "no_water", tmp_path / "sub.h5")
    out = subprocess.run([str(exe), str(path), "--check"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "retardation time" in out.stdout + out.stderr, out.stdout + out.stderr


@pytest.mark.parametrize("extra, why", [
    ("", "materials.rock is kelvin_voigt with retardation_time 0.001 s"),
    ("damping: {model: rayleigh, ratio: 0.05, frequencies: [1.5, 10]}\n", "damping.model rayleigh adds beta K"),
])
def test_the_case_check_refuses_subcycling_with_a_viscous_stress(tmp_path, extra, why):
    p = tmp_path / "case.yaml"
    rock = ("kelvin_voigt", ", retardation_time: 1 ms") if not extra else ("elastic", "")
    p.write_text(CASE.replace("ROCK", rock[0]).replace("EXTRA", rock[1]).replace(
        "time: {end_time: 0.01}", "time: {end_time: 0.01, subcycling: 3}") + extra)
    with pytest.raises(CaseError) as e:
        load_case(p)
    assert "time.subcycling" in str(e.value) and why in str(e.value), str(e.value)


@pytest.mark.skipif(paths.solid_executable() is None, reason="tq-solid is not built")
@pytest.mark.parametrize("rock, lining, tol", [
    (", retardation_time: 1 ms", None, 0.01),
    (", retardation_time: 10 ms", None, 0.01),
    (None, "0.2 ms", 0.07),
])
def test_check_estimates_the_viscous_step_tq_solid_takes(tmp_path, rock, lining, tol):
    text = CASE.replace("ROCK", "kelvin_voigt" if rock else "elastic").replace("EXTRA", rock or "")
    if lining:
        text = text.replace("lining: {model: elastic,", "lining: {model: kelvin_voigt, retardation_time: "
                            f"{lining},")
    p = tmp_path / "case.yaml"
    p.write_text(text)
    case = load_case(p)
    build_tunnel_mesh(case.data["geometry"], case.data["mesh"], tmp_path)
    motion, _ = from_case(case.data["ground_motion"], case.dir)
    write_motion(motion, tmp_path / "motion.h5")
    inp = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", "no_water", tmp_path / "in.h5")
    est, got = runtime_estimate(case).dt, solid_step(paths.solid_executable(), inp)
    print(f"step: estimated {est:.5g} s, tq-solid {got:.5g} s")
    assert est == pytest.approx(got, rel=tol)
