"""A vertical record of its own, and a vertical-only motion: the components are scaled as the
ground_motion keys say (the horizontal record's factor by default, the recorded V/H ratio kept),
put on one clock, and refused with the key named when the keys contradict each other."""
from __future__ import annotations

import numpy as np
import pytest

from tunnelquake.case import CaseError, load_case
from tunnelquake.motion import from_case
from tunnelquake.units import STANDARD_GRAVITY as G

DT = 0.005


def _record(path, dt, peak, f, n=400):
    t = np.arange(n) * dt
    a = peak * np.sin(2 * np.pi * f * t) * np.sin(np.pi * t / t[-1]) ** 2
    np.savetxt(path, np.c_[t, a], fmt="%.6f %.10e")
    return np.loadtxt(path)[:, 1]  # the values as written


def _case(tmp_path, motion: str):
    """A small elastic slice case whose ground_motion section is `motion` (records in tmp_path)."""
    text = f"""name: components
geometry:
  x_range: [-30.0, 30.0]
  y_range: [0.0, 1.0]
  z_range: [-30.0, 30.0]
  tunnel_centre_x: 0.0
  tunnel_centre_z: 0.0
  excavated_radius: 3.0 m
  lining_thickness: 0.4 m
mesh:
  mode: slice
  max_element_size: 5 m
  lining_elements_around: 16
  lining_elements_through: 2
  near_field_half_width: 8.0
  near_field_radial_divisions: 3
materials:
  rock: {{model: elastic, youngs_modulus: 12 GPa, poisson_ratio: 0.25, density: 2600 kg/m^3}}
  lining: {{model: elastic, youngs_modulus: 32 GPa, poisson_ratio: 0.2, density: 2500 kg/m^3}}
interface: {{model: bonded}}
ground_motion:
{motion}
  cutoff_frequency: 100 Hz
  baseline_correction: false
  duration: 1.5 s
stages:
  sequence: [in_situ, excavation, lining, seismic]
conditions: [no_water]
output:
  monitors:
    crown: [0.0, 0.5, 2.8]
    invert: [0.0, 0.5, -2.8]
"""
    (tmp_path / "case.yaml").write_text(text)
    return tmp_path / "case.yaml"


def test_a_vertical_record_is_scaled_with_the_horizontal_records_factor(tmp_path):
    h = _record(tmp_path / "h.txt", DT, 0.20, 2.0)
    v = _record(tmp_path / "v.txt", DT, 0.08, 5.0)
    case = load_case(_case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n"
                                     "  vertical: {file: v.txt, units: g}"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    k = 0.3 / np.max(np.abs(h[:301]))  # the 1.5 s window: 301 samples
    np.testing.assert_allclose(m.ax, 0.5 * k * h[:301] * G, rtol=1e-12, atol=1e-15)  # outcrop: half
    np.testing.assert_allclose(m.az, 0.5 * k * v[:301] * G, rtol=1e-12, atol=1e-15)  # the recorded V/H kept
    assert "vertical: scaled by" in "\n".join(m.steps) and "(the horizontal record's factor)" in "\n".join(m.steps)


def test_a_vertical_record_with_its_own_pga_and_its_own_step(tmp_path):
    _record(tmp_path / "h.txt", DT, 0.20, 2.0)
    t2 = np.arange(200) * 0.01
    v = 0.05 * t2  # linear: the interpolation onto the 0.005 s clock is exact
    np.savetxt(tmp_path / "v.txt", np.c_[t2, v], fmt="%.6f %.10e")
    case = load_case(_case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n"
                                     "  vertical: {file: v.txt, units: g, pga: 0.1 g}"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    assert m.dt == pytest.approx(DT, rel=1e-12) and m.az.size == m.ax.size == 301
    t = np.arange(301) * m.dt
    expected = 0.5 * (0.1 / 0.05 / t2[150]) * 0.05 * t * G  # scaled to peak 0.1 g over the 1.5 s window
    np.testing.assert_allclose(m.az, expected, rtol=1e-9, atol=1e-12)


def test_a_vertical_only_motion(tmp_path):
    v = _record(tmp_path / "v.txt", DT, 0.08, 5.0)
    case = load_case(_case(tmp_path, "  source: none\n  vertical: {file: v.txt, units: g, pga: 0.2 g}"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    assert not np.any(m.ax)
    assert np.max(np.abs(m.az)) == pytest.approx(0.5 * 0.2 * G, rel=1e-12)
    np.testing.assert_allclose(m.az / np.max(np.abs(m.az)), v[:301] / np.max(np.abs(v[:301])), atol=1e-12)


@pytest.mark.parametrize("motion, key, problem", [
    ("  source: file\n  file: h.txt\n  units: g\n  vertical_ratio: 0.5\n  vertical: {file: v.txt, units: g}",
     "ground_motion.vertical_ratio", "is given together with a vertical record"),
    ("  source: none", "ground_motion.vertical", "source 'none' leaves no motion at all"),
    ("  source: none\n  pga: 0.3 g\n  vertical: {file: v.txt, units: g}", "ground_motion.pga",
     "scales the horizontal record, and source 'none' has none"),
    ("  source: file\n  file: h.txt\n  units: g\n  vertical: {units: g}", "ground_motion.vertical.file",
     "is required when vertical is given"),
    ("  source: file\n  file: h.txt\n  units: g\n  vertical: {file: v.txt}", "ground_motion.vertical.file",
     "a two-column record states no units"),
])
def test_contradicting_motion_keys_are_refused_naming_the_key(tmp_path, motion, key, problem):
    _record(tmp_path / "h.txt", DT, 0.2, 2.0)
    _record(tmp_path / "v.txt", DT, 0.1, 5.0)
    with pytest.raises(CaseError) as e:
        load_case(_case(tmp_path, motion))
    assert key in str(e.value) and problem in str(e.value), str(e.value)


def test_a_vertical_only_motion_moves_a_symmetric_tunnel_symmetrically(tmp_path):
    """A vertically incident P wave on a model symmetric about x = 0: the lining's crown and invert
    (on the axis of symmetry) move vertically only; their horizontal displacement stays at round-off
    against the vertical one (1e-6), and the vertical displacement reaches the record's order."""
    import h5py

    from tunnelquake.cli import main

    _record(tmp_path / "v.txt", DT, 0.08, 5.0)
    p = _case(tmp_path, "  source: none\n  vertical: {file: v.txt, units: g, pga: 0.2 g}")
    assert main(["run", str(p), "--no-post"]) == 0
    with h5py.File(tmp_path / "results" / "results_no_water.h5", "r") as f:
        for name in ("crown", "invert"):
            u = f[f"monitors/{name}/u"][...]
            assert np.max(np.abs(u[:, 2])) > 1e-4, name  # metres: the wave moved it
            assert np.max(np.abs(u[:, 0])) < 1e-6 * np.max(np.abs(u[:, 2])), name
