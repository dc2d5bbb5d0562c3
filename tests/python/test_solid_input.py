"""tunnelquake.solid_input: solid_input.h5 version 2 from a validated case, and tq-solid driven by it.

1. Layout per condition (docs/formats.md "## solid_input.h5"): the stages (no hydrostatic stage
   without water), the hydrostatic pressure p = rho_w g head at the axis with gradient rho_w g, the
   motion copied from motion.h5, the monitors moved into the slice, the Mohr-Coulomb parameters
   passed through.
2. End to end on the paper's slice mesh (mesh defaults, elastic materials so the closed form
   applies): in-situ stress -> excavation -> lining -> hydrostatic -> seismic start. The lining's
   hoop stress from the water, static_water minus no_water at the seismic start (the rest of the
   initial state cancels: elastic superposition), against the lined-tunnel closed form
   (tunnelquake.references.lined_tunnel_internal_pressure; VERIFICATION.md) at the monitored
   element's centroid radius: within 2 % (measured -0.4 %; the C++ case
   tests/verification/solid_lined_tunnel gets -0.9 % at the walls on the same 48 x 3 lining mesh).
   Runs only when tq-solid is built with the staged-seismic capability.
"""
from __future__ import annotations

import subprocess

import h5py
import numpy as np
import pytest
from case_texts import synthetic_motion, tunnel

from conftest import mesh_and_motion, run_solid, solid_with
from tunnelquake import fluid_case as fc
from tunnelquake.case import load_case
from tunnelquake.references import lined_tunnel_internal_pressure
from tunnelquake.solid_input import SolidInputError, write_solid_input

CASE = tunnel("solid_input_test", [-60.0, 60.0], [0.0, 80.0], [-28.0, 154.7], centre_z=32.0, radius=5.25,
              lining=0.75, mode="slice") + """materials:
  rock: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.27, density: 2700,
         cohesion: 0.55 MPa, friction_angle: 37, tensile_strength: 1.2 MPa}
  lining: {model: MODEL, youngs_modulus: 28 GPa, poisson_ratio: 0.17, density: 2500,
           cohesion: 1.8 MPa, friction_angle: 40, tensile_strength: 1.27 MPa}
interface: {model: bonded}
water: {head: 123 m, model: compressible}
""" + synthetic_motion("1.575 m/s^2", 0.6666666666666666, 2.0) + """in_situ: {kx: 1.1, ky: 0.8, kz: 1.0}
stages:
  relaxation_tolerance: 1.0e-6
  relaxation_max_steps: 100000
time: {end_time: END}
output:
  monitors:
    haunch: [4.5, 40.0, 32.0]
    top_arch: [0.0, 40.0, 36.5]
"""


def _case(tmp_path, model="elastic", end=0.002):
    p = tmp_path / "case.yaml"
    p.write_text(CASE.replace("MODEL", model).replace("END", str(end)))
    return load_case(p)


def _coupling(case, tmp_path, token="t"):
    """The coupling settings object of `case` for a solid step of 5e-5 s (fluid_case.coupling_settings)."""
    window = fc.coupling_window_size(case.data["coupling"]["window"], 5e-5)
    return fc.coupling_settings(case, window, tmp_path / "wall.addr", token)


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    """The paper's slice mesh (mesh defaults) and a synthetic motion, once for the module."""
    tmp = tmp_path_factory.mktemp("solid_input")
    mesh_and_motion(_case(tmp), tmp)
    return tmp


def test_layout_per_condition(prepared, tmp_path):
    case = _case(tmp_path, model="mohr_coulomb_damage", end=5.0)
    files = {c: write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", c, tmp_path / f"{c}.h5")
             for c in ("no_water", "static_water", "dynamic_water")}
    with h5py.File(prepared / "motion.h5") as m:
        ax, az, t = m["incident_ax"][...], m["incident_az"][...], m["time"][...]
    with h5py.File(prepared / "mesh.h5") as m:
        y = m["nodes/coordinates"][:, 1]
    for cond, path in files.items():
        with h5py.File(path) as f:
            assert f.attrs["format"] == "tunnelquake-solid-input" and f.attrs["version"] == 2
            assert f.attrs["condition"] == cond
            seq = f["stages"].attrs["sequence"].split(",")
            water = cond != "no_water"
            assert seq == ["in_situ", "excavation", "lining", "hydrostatic", "seismic"] if water else \
                seq == ["in_situ", "excavation", "lining", "seismic"]
            assert ("hydrostatic" in f) == water
            if water:
                h = f["hydrostatic"].attrs
                assert h["pressure_at_axis"] == pytest.approx(1000 * 9.81 * 123, rel=1e-12)
                assert h["unit_weight"] == pytest.approx(1000 * 9.81, rel=1e-12)
                assert h["z_axis"] == 32.0 and h["face"] == "lining_inner"
            assert f["solver"].attrs["t_end"] == 5.0
            assert f["in_situ"].attrs["kx"] == 1.1 and f["in_situ"].attrs["z_top"] == 154.7
            assert f["boundaries/bottom"].attrs["distance"] == pytest.approx(60.0)
            assert f["boundaries/free_field"].attrs["faces"] == "xmin,xmax"
            assert set(f["boundary/fixed"]) == {"bottom", "xmin", "xmax"}  # slice: u_y = 0 by itself
            np.testing.assert_array_equal(f["motion/ax"][...], ax)
            np.testing.assert_array_equal(f["motion/az"][...], az)
            np.testing.assert_array_equal(f["motion/time"][...], t)
            assert f["motion"].attrs["cutoff_frequency"] == 20.0
            pts = f["monitors/points"][...]
            assert np.allclose(pts[:, 1], 0.5 * (y.min() + y.max()))  # projected into the slice
            lin = f["materials/lining"].attrs
            assert lin["model"] == "mohr_coulomb_damage" and lin["cohesion"] == 1.8e6
            assert lin["friction_angle"] == 40.0 and lin["damage_effect"] == "cohesion"
            assert f["materials/rock"].attrs["model"] == "elastic"
            assert f["interfaces/rock_lining"].attrs["model"] == "bonded"
    with pytest.raises(SolidInputError, match="not one of"):
        write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "wet", tmp_path / "x.h5")


def _solid_with_stages():
    return solid_with("staged-seismic")


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_tq_solid_lining_under_water_matches_closed_form(prepared, tmp_path):
    exe = _solid_with_stages()
    case = _case(tmp_path)
    sigma = {}
    for cond in ("no_water", "static_water"):
        inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", cond, tmp_path / f"{cond}.h5")
        res = tmp_path / f"results_{cond}.h5"
        run_solid(exe, inp, res, timeout=300)
        with h5py.File(res) as r:
            assert r.attrs["status"] == "completed"
            stages = {k.split("_", 1)[1]: r["stages"][k].attrs for k in r["stages"]}
            for name in ("excavation", "lining") + (("hydrostatic",) if cond == "static_water" else ()):
                assert stages[name]["converged"] == 1 and stages[name]["unbalanced_ratio"] < 1e-6
            g = r["monitors/haunch"]
            sigma[cond] = g["stress"][0]  # at the seismic start
            elem = int(g.attrs["element"])
            conn = r["mesh/connectivity"][elem]
            xyz = r["mesh/coordinates"][...][conn].mean(axis=0)
    # Haunch (theta = 0): hoop = sigma_zz. Closed form in the Lamé form A + B/r^2 through the inner
    # and outer hoop values, at the element's centroid radius.
    a, b = 4.5, 5.25
    ref = lined_tunnel_internal_pressure(1000 * 9.81 * 123, a, b, 28e9, 0.17, 8e9, 0.27)
    B = (ref["hoop_inner"] - ref["hoop_outer"]) / (1 / a**2 - 1 / b**2)
    A = ref["hoop_inner"] - B / a**2
    rc = float(np.hypot(xyz[0], xyz[2] - 32.0))
    expected = A + B / rc**2
    got = sigma["static_water"][2] - sigma["no_water"][2]
    assert a < rc < b
    assert got == pytest.approx(expected, rel=0.02), (got, expected)


@pytest.mark.parametrize("model", ["rayleigh", "mass_proportional"])
def test_damping_models_give_the_ratio_where_asked(prepared, tmp_path, model):
    """Rayleigh: xi at f1 and f2; mass-proportional: xi at f1, falling as f1/f (docs/theory.md §1)."""
    p = tmp_path / "case.yaml"
    text = CASE.replace("MODEL", "elastic").replace("END", "0.002")
    text += f"damping:\n  model: {model}\n  ratio: 0.05\n  frequencies: [1.5 Hz, 10 Hz]\n"
    p.write_text(text)
    case = load_case(p)
    out = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "no_water", tmp_path / "in.h5")
    with h5py.File(out) as f:
        a = dict(f["damping"].attrs)
    if model == "rayleigh":
        assert a["ratio"] == 0.05 and (a["f1"], a["f2"]) == (1.5, 10.0)
    else:
        w1 = 2 * np.pi * 1.5
        assert a["beta"] == 0.0
        assert a["alpha"] / (2 * w1) == pytest.approx(0.05, rel=1e-12)  # xi(w) = alpha / (2 w)
        assert a["alpha"] / (2 * 2 * np.pi * 10.0) == pytest.approx(0.05 * 1.5 / 10, rel=1e-12)


def test_energy_guard_and_window_force_weight_reach_the_solid(prepared, tmp_path):
    """coupling.energy_limit (default 0.05) becomes /coupling energy_limit; 0 leaves the key out, which
    tq-solid reads as no guard (docs/coupler.md "Energy guard"). coupling.window_force_weight is written
    when not 0.5 (the linear ramp; docs/coupler.md "Window force weight"): by default 0.75 for the
    implicit scheme's default windows of 16 steps, nothing for one-step windows."""
    case = _case(tmp_path)
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water", tmp_path / "a.h5",
                            coupling=_coupling(case, tmp_path))
    with h5py.File(inp) as f:
        assert f["coupling"].attrs["energy_limit"] == 0.05
        assert f["coupling"].attrs["window"] == 16
        assert f["coupling"].attrs["window_force_weight"] == 0.75
    case.data["coupling"]["energy_limit"] = 0.0
    case.data["coupling"]["window_force_weight"] = 0.9
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water", tmp_path / "b.h5",
                            coupling=_coupling(case, tmp_path))
    with h5py.File(inp) as f:
        assert "energy_limit" not in f["coupling"].attrs
        assert f["coupling"].attrs["window_force_weight"] == 0.9
    case.data["coupling"].update(window=1, window_force_weight=None)
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water", tmp_path / "c.h5",
                            coupling=_coupling(case, tmp_path))
    with h5py.File(inp) as f:
        assert "window_force_weight" not in f["coupling"].attrs


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_tq_solid_refuses_a_window_force_weight_that_would_do_nothing(prepared, tmp_path):
    """The weight shapes the force over the steps of an implicit window of several steps; with the
    explicit scheme or one-step windows it would be ignored, so tq-solid refuses it (exit 2, the
    attribute named) rather than run something other than what the input says (the case file's
    check refuses the same: test_case_file.py)."""
    exe = _solid_with_stages()
    case = _case(tmp_path)
    case.data["coupling"]["window_force_weight"] = 0.75
    for change in ({"scheme": "explicit", "reuse": 0}, {"window": 1}):
        c = dict(case.data["coupling"])
        case.data["coupling"].update(change)
        inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water",
                                tmp_path / "w.h5", coupling=_coupling(case, tmp_path))
        run = subprocess.run([str(exe), str(inp), "--check"], capture_output=True, text=True, timeout=60)
        assert run.returncode == 2, run.stdout + run.stderr
        assert "window_force_weight" in run.stderr and "no effect" in run.stderr, run.stderr
        case.data["coupling"] = c


def test_defect_correction_reaches_the_solid(prepared, tmp_path):
    """coupling.defect_correction (docs/coupler.md "Defect correction"; default 0, off) becomes /coupling
    defect_correction when on, and is left out when off; off, it is not in the results' fingerprint
    either (a case that does not use it keeps the fingerprint it had before the key existed), on, it
    counts in the coupling group. tq-solid refuses it with one-step windows (exit 2, the attribute
    named: there is no window to carry a defect into), as the case file's check does
    (test_case_file.py)."""
    from tunnelquake.fingerprint import condition_inputs

    case = _case(tmp_path)
    assert "coupling.defect_correction" not in condition_inputs(case, "dynamic_water")["keys"]
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water", tmp_path / "a.h5",
                            coupling=_coupling(case, tmp_path))
    with h5py.File(inp) as f:
        assert f["coupling"].attrs["window"] == 16
        assert "defect_correction" not in f["coupling"].attrs
    case.data["coupling"]["defect_correction"] = 0.25
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water", tmp_path / "b.h5",
                            coupling=_coupling(case, tmp_path))
    with h5py.File(inp) as f:
        assert f["coupling"].attrs["defect_correction"] == 0.25
    assert condition_inputs(case, "dynamic_water")["keys"]["coupling.defect_correction"][0] == "coupling"
    exe = _solid_with_stages()
    if exe is not None:
        case.data["coupling"]["window"] = 1
        inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water",
                                tmp_path / "d.h5", coupling=_coupling(case, tmp_path))
        run = subprocess.run([str(exe), str(inp), "--check"], capture_output=True, text=True, timeout=60)
        assert run.returncode == 2, run.stdout + run.stderr
        assert "defect_correction" in run.stderr and "none to carry" in run.stderr, run.stderr


def test_release_fraction_reaches_the_solid(prepared, tmp_path):
    """stages.release_fraction (default 1: the lining installed after full release) becomes /stages
    release_fraction; tq-solid (when built) reads it back without complaint (docs/theory.md §2)."""
    case = _case(tmp_path)
    assert case.data["stages"]["release_fraction"] == 1.0
    case.data["stages"]["release_fraction"] = 0.4
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "no_water", tmp_path / "r.h5")
    with h5py.File(inp) as f:
        assert f["stages"].attrs["release_fraction"] == 0.4
    exe = _solid_with_stages()
    if exe is not None:
        run = subprocess.run([str(exe), str(inp), "--check"], capture_output=True, text=True, timeout=60)
        assert run.returncode == 0, run.stdout + run.stderr


def test_the_coupling_token_is_private(prepared, tmp_path):
    """solid_input.h5 holds the run's coupling secret when it has a /coupling group: the file is
    readable and writable by its owner only (0600); an input without a token keeps the umask's mode."""
    import stat

    case = _case(tmp_path)
    inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "dynamic_water", tmp_path / "c.h5",
                            coupling=_coupling(case, tmp_path, token="secret"))
    assert stat.S_IMODE(inp.stat().st_mode) == 0o600
    with h5py.File(inp) as f:
        assert f["coupling"].attrs["token"] == "secret"
    import os

    umask = os.umask(0)
    os.umask(umask)
    plain = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", "no_water", tmp_path / "d.h5")
    assert stat.S_IMODE(plain.stat().st_mode) == 0o666 & ~umask  # no secret: the umask's mode
