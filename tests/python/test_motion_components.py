"""A vertical record of its own, and a vertical-only motion: the components are scaled as the
ground_motion keys say (the horizontal record's factor by default, the recorded V/H ratio kept),
put on one clock, and refused with the key named when the keys contradict each other."""
from __future__ import annotations

import numpy as np
import pytest
from case_texts import small_slice

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
    """A small elastic slice case whose ground_motion section is `motion` (records in tmp_path); one
    horizontal record alone has the vertical at 2/3 of it."""
    alone = "vertical" not in motion and "source: none" not in motion
    ratio = "\n  vertical_ratio: 0.6666666666666666" if alone else ""
    text = small_slice("components") + f"""ground_motion:
{motion}{ratio}
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


def _azimuth_30_against_the_free_field(results, dt: float, ax: np.ndarray):
    """The ground monitor's horizontal motion against the free field of a record at azimuth 30 deg
    on 60 m of uniform rock (E 12 GPa, nu 0.25, 2600 kg/m3): the outcrop record's displacement D
    (from the incident ax = cos 30 a / 2) arriving H / c_s after it entered at the base, u_x = cos 30 D,
    u_y = sin 30 D. Returns the peak of D, the largest misfits of u_x and u_y as fractions of that
    peak, and the monitor's motion u."""
    import h5py

    from tunnelquake.motion import integrate

    with h5py.File(results / "results_no_water.h5", "r") as f:
        t, u = f["monitors/ground/time"][:, 0], f["monitors/ground/u"][...]
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    _, disp = integrate(2 * ax / c, dt)  # the outcrop record's displacement
    delay = 60.0 / np.sqrt(12e9 / (2 * 1.25) / 2600)  # H / c_s: 60 m of rock, G = E / 2(1 + nu)
    D = np.interp(t - delay, np.arange(disp.size) * dt, disp, left=0.0)
    peak = np.max(np.abs(D))
    return peak, np.max(np.abs(u[:, 0] - c * D)) / peak, np.max(np.abs(u[:, 1] - s * D)) / peak, u


def _horizontal_pair(tmp_path):
    h1 = _record(tmp_path / "h.txt", DT, 0.20, 2.0)
    h2 = _record(tmp_path / "h2.txt", DT, 0.12, 3.0)
    return h1[:301], h2[:301]  # the 1.5 s window


@pytest.mark.parametrize("azimuth, cos, sin", [(0, 1.0, 0.0), (30, np.sqrt(3) / 2, 0.5), (90, 0.0, 1.0),
                                               (135, -np.sqrt(0.5), np.sqrt(0.5)), (-90, 0.0, -1.0)])
def test_an_azimuth_puts_cos_and_sin_of_the_record_on_x_and_y(tmp_path, azimuth, cos, sin):
    """The horizontal record at azimuth theta from x towards y: x = cos theta h, y = sin theta h
    (exactly 0 on the other axis at multiples of 90 degrees), the vertical ratio x h whatever theta."""
    h, _ = _horizontal_pair(tmp_path)
    case = load_case(_case(tmp_path, f"  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n  azimuth: {azimuth} deg"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    k = 0.3 / np.max(np.abs(h))
    scaled = 0.5 * k * h * G  # outcrop: the incident wave is half the record
    np.testing.assert_allclose(m.ax, cos * scaled, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(m.ay, sin * scaled, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(m.az, 2 / 3 * scaled, rtol=1e-12, atol=1e-15)
    if cos == 0:
        assert not np.any(m.ax)
    if sin == 0:
        assert not np.any(m.ay)


@pytest.mark.parametrize("azimuth", [0.0, 30.0, 90.0])
def test_a_second_horizontal_record_acts_at_90_degrees_to_the_first(tmp_path, azimuth):
    """h1 at theta, h2 at theta + 90 deg: x = cos h1 - sin h2, y = sin h1 + cos h2; h2 scaled with
    h1's factor (the recorded ratio kept), so the horizontal magnitude |(x, y)| = |(h1, h2)| for every theta."""
    h1, h2 = _horizontal_pair(tmp_path)
    case = load_case(_case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n"
                                     f"  azimuth: {azimuth}\n  second_horizontal: {{file: h2.txt, units: g}}"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    k = 0.3 / np.max(np.abs(h1))
    c, s = np.cos(np.radians(azimuth)), np.sin(np.radians(azimuth))
    a1, a2 = 0.5 * k * h1 * G, 0.5 * k * h2 * G
    np.testing.assert_allclose(m.ax, c * a1 - s * a2, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(m.ay, s * a1 + c * a2, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(np.hypot(m.ax, m.ay), np.hypot(a1, a2), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(m.az, 2 / 3 * a1, rtol=1e-12, atol=1e-15)  # the ratio rule: of h1


def test_three_records_of_their_own_with_their_own_peaks(tmp_path):
    """x, y, z each from its own record, each scaled to its own PGA."""
    _horizontal_pair(tmp_path)
    v = _record(tmp_path / "v.txt", DT, 0.05, 6.0)[:301]
    case = load_case(_case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n"
                                     "  second_horizontal: {file: h2.txt, units: g, pga: 0.25 g}\n"
                                     "  vertical: {file: v.txt, units: g, pga: 0.2 g}"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    for a, pga in ((m.ax, 0.3), (m.ay, 0.25), (m.az, 0.2)):
        assert np.max(np.abs(a)) == pytest.approx(0.5 * pga * G, rel=1e-12)
    np.testing.assert_allclose(m.az / np.max(np.abs(m.az)), v / np.max(np.abs(v)), atol=1e-12)


def test_a_motion_along_the_axis_only(tmp_path):
    """source: none with a second horizontal record (azimuth 0): the ground moves along the axis
    only, x and z exactly zero, y the record at its own PGA."""
    _, h2 = _horizontal_pair(tmp_path)
    case = load_case(_case(tmp_path, "  source: none\n  second_horizontal: {file: h2.txt, units: g, pga: 0.2 g}"))
    m, _ = from_case(case.data["ground_motion"], tmp_path)
    assert not np.any(m.ax) and not np.any(m.az)
    np.testing.assert_allclose(m.ay, 0.5 * 0.2 * G * h2 / np.max(np.abs(h2)), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("motion, key, problem", [
    ("  source: file\n  file: h.txt\n  units: g\n  second_horizontal: {units: g}", "ground_motion.second_horizontal.file",
     "is required when second_horizontal is given"),
    ("  source: file\n  file: h.txt\n  units: g\n  second_horizontal: {file: h2.txt}",
     "ground_motion.second_horizontal.file", "a two-column record states no units"),
    ("  source: none\n  vertical_ratio: 0.5\n  vertical: {file: v.txt, units: g}", "ground_motion.vertical_ratio",
     "source 'none' has none"),
    ("  source: file\n  file: h.txt\n  units: g\n  azimuth: 400", "ground_motion.azimuth", ""),
    ("  source: none\n  azimuth: 30\n  vertical: {file: v.txt, units: g}", "ground_motion.azimuth",
     "source 'none' with no second_horizontal leaves none"),
])
def test_misused_component_keys_are_refused_naming_the_key(tmp_path, motion, key, problem):
    _horizontal_pair(tmp_path)
    _record(tmp_path / "v.txt", DT, 0.1, 5.0)
    with pytest.raises(CaseError) as e:
        load_case(_case(tmp_path, motion))
    assert key in str(e.value) and problem in str(e.value), str(e.value)


@pytest.mark.parametrize("motion, key", [
    ("  source: file\n  file: h.txt\n  units: g\n  azimuth: 30 deg", "ground_motion.azimuth"),
    ("  source: file\n  file: h.txt\n  units: g\n  second_horizontal: {file: h2.txt, units: g}",
     "ground_motion.second_horizontal"),
])
def test_a_motion_along_the_axis_is_refused_in_3d_naming_the_key(tmp_path, capsys, motion, key):
    """A 3D model whose tunnel's ends are not plugged keeps its y faces on rollers, which would hold
    a motion along the axis back: `tunnelquake check` refuses it naming the key and the fixes (the
    plugs, a slice); across the tunnel (azimuth 180) it passes."""
    from tunnelquake.cli import main

    _horizontal_pair(tmp_path)
    p = _case(tmp_path, motion)
    p.write_text(p.read_text().replace("mode: slice", "mode: 3d"))
    assert main(["check", str(p)]) != 0
    out = capsys.readouterr()
    assert f"{key}" in out.out + out.err and "mesh.mode: slice" in out.out + out.err, out.out + out.err
    assert "mesh.tunnel_end_plugs: 1 or more" in out.out + out.err
    p.write_text(_case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  azimuth: 180").read_text()
                 .replace("mode: slice", "mode: 3d"))
    capsys.readouterr()
    main(["check", str(p)])
    out = capsys.readouterr()
    assert "ground_motion.azimuth" not in out.out + out.err, out.out + out.err


def test_a_motion_at_an_azimuth_shakes_the_slice_along_x_and_y_as_the_free_field(tmp_path):
    """End to end (tq-solid, an elastic slice with a bonded lining, undamped): the horizontal record
    at azimuth 30 deg. The slice's y faces are tied periodic, so the ground shears along the axis
    too. At the ground surface 12 m beside the tunnel (r = 3 m; ka = 0.03 at the record's 2 Hz, so
    its scattering there is negligible) the motion is the free field of uniform rock on a half-space
    of that rock: the outcrop record itself, twice the incident wave, arriving H / c_s after it
    entered at the base (Kramer 1996 §7.2): u_x = cos 30 D(t - H/c_s), u_y = sin 30 D(t - H/c_s), with
    D the record's displacement, within 1 % of its peak."""
    import h5py

    from tunnelquake.cli import main

    _record(tmp_path / "h.txt", DT, 0.20, 2.0)
    p = _case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n  azimuth: 30 deg\n"
                        "  vertical_ratio: 0.0")
    text = p.read_text().replace("    invert: [0.0, 0.5, -2.8]", "    ground: [15.0, 0.5, 30.0]")
    p.write_text(text + "time: {end_time: 1.0}\ndamping: {ratio: 0.0}\n")
    assert main(["run", str(p), "--no-post"]) == 0
    with h5py.File(tmp_path / "results" / "motion.h5", "r") as f:
        dt = float(f.attrs["dt"])
        ax, ay = f["incident_ax"][...], f["incident_ay"][...]
    np.testing.assert_allclose(ay, np.sin(np.radians(30)) / np.cos(np.radians(30)) * ax, rtol=1e-12, atol=1e-15)
    peak, ex, ey, u = _azimuth_30_against_the_free_field(tmp_path / "results", dt, ax)
    print(f"azimuth 30 deg, ground surface beside the tunnel: peak D {peak:.4g} m; max |u_x - cos D| {ex:.2%}, "
          f"max |u_y - sin D| {ey:.2%} of the peak; |u_z| {np.max(np.abs(u[:, 2])) / peak:.1e}")
    assert ex < 0.01 and ey < 0.01


def test_a_motion_at_an_azimuth_shakes_the_3d_model_through_columns_on_all_four_sides(tmp_path):
    """The same motion (azimuth 30 deg) and closed form in a 3D model: the tunnel's ends plugged
    with rock (mesh.tunnel_end_plugs), so its y faces take free-field columns (the first side's,
    shared: their quads follow the tunnel's O-grid) and the block moves along x and y as the free
    field; at the ground surface 12 m beside the tunnel, mid-length, within the same 1 % of the
    peak."""
    import h5py

    from tunnelquake.cli import main

    _record(tmp_path / "h.txt", DT, 0.20, 2.0)
    p = _case(tmp_path, "  source: file\n  file: h.txt\n  units: g\n  pga: 0.3 g\n  azimuth: 30 deg\n"
                        "  vertical_ratio: 0.0")
    text = p.read_text().replace("    invert: [0.0, 0.5, -2.8]", "    ground: [15.0, 15.0, 30.0]")
    text = text.replace("  y_range: [0.0, 1.0]", "  y_range: [0.0, 30.0]").replace(
        "  mode: slice\n", "  mode: 3d\n  elements_along_axis: 6\n  tunnel_end_plugs: 1\n")
    p.write_text(text + "time: {end_time: 1.0}\ndamping: {ratio: 0.0}\n")
    assert main(["run", str(p), "--no-post"]) == 0
    with h5py.File(tmp_path / "results" / "no_water" / "solid_input.h5", "r") as f:
        shared = f["boundaries/free_field"].attrs["shared_column_faces"]
    assert "ymin" in str(shared) and "ymax" in str(shared)
    with h5py.File(tmp_path / "results" / "motion.h5", "r") as f:
        dt = float(f.attrs["dt"])
        ax = f["incident_ax"][...]
    peak, ex, ey, _ = _azimuth_30_against_the_free_field(tmp_path / "results", dt, ax)
    print(f"3D, azimuth 30 deg, ground surface beside the tunnel: peak D {peak:.4g} m; max |u_x - cos D| {ex:.2%}, "
          f"max |u_y - sin D| {ey:.2%} of the peak")
    assert ex < 0.01 and ey < 0.01
