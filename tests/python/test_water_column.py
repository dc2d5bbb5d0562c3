"""The water column along the tunnel: its ends (water.end_ymin / end_ymax: reservoir, valve, surge
tank), the closed form of its wave speed with the lining's and the rock's compliance
(tunnelquake.verification.water_column, docs/theory.md "The water column along the tunnel"), and the
coupled run's resonances against it (docs/verification.md "The water column along the tunnel").

The coupled run: `tunnelquake run` (tq-solid + rhoPimpleFoam, 3D) of a 30 m tunnel (r_i 2.6 m, a 0.4 m
lining, E 20 GPa, bonded to rock of E 5 GPa, ν 0.25), a reservoir at y = 0 and a closed valve at
y = 30 m, shaken by a vertical Ricker pulse (15 Hz) that breathes the whole section at once; the
pressure at the valve (the mean of four wall monitors round it: the section's ovalling and
translation cancel) rings at the column's quarter-wave frequencies, measured by least squares
started from the spectrum's peaks (water_column.measured_frequencies)."""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
pytest.importorskip("scipy")
from tunnelquake import fluid_case as fc  # noqa: E402
from tunnelquake import paths, water_case  # noqa: E402
from tunnelquake.case import load_case  # noqa: E402
from tunnelquake.cli import main  # noqa: E402
from tunnelquake.schema import CaseError  # noqa: E402
from tunnelquake.verification.water_column import (  # noqa: E402
    mass_oscillation_period,
    measured_frequencies,
    quarter_wave_frequencies,
    section_compliance,
    surge_tank_frequencies,
    wave_speed,
)

coupled = pytest.mark.skipif(
    paths.solid_executable() is None or paths.openfoam_library() is None
    or not Path("/usr/share/openfoam").is_dir(),
    reason="tq-solid, libtqFoam.so or OpenFOAM v1912 missing (set TQ_BUILD_DIR)")

#: the column: wetted radius, lining, rock, water (SI)
R_I, R_O, E_L, NU_L, E_R, NU_R, K_W, RHO_W, LENGTH = 2.6, 3.0, 20e9, 0.2, 5e9, 0.25, 2.2e9, 1000.0, 30.0
G_R = E_R / (2 * (1 + NU_R))

CASE = """\
name: water_column
geometry:
  x_range: [-30.0, 30.0]
  y_range: [0.0, 30.0]
  z_range: [-30.0, 30.0]
  tunnel_centre_x: 0.0
  tunnel_centre_z: 0.0
  excavated_radius: 3.0 m
  lining_thickness: 0.4 m
mesh:
  mode: 3d
  max_element_size: 10 m
  lining_elements_around: 16
  lining_elements_through: 1
  elements_along_axis: 15
  near_field_half_width: 9 m
  near_field_radial_divisions: 4
  water_ring_divisions: 1
materials:
  rock: {model: elastic, youngs_modulus: 5 GPa, poisson_ratio: 0.25, density: 2400 kg/m^3}
  lining: {model: elastic, youngs_modulus: 20 GPa, poisson_ratio: 0.2, density: 2400 kg/m^3}
interface: {model: bonded}
water:
  ends: open
  end_ymin: {kind: reservoir}
  end_ymax: {kind: valve}
ground_motion:
  source: none
  vertical: {file: pulse.txt, format: two_column, units: m/s^2, pga: 1.0 m/s^2}
  baseline_correction: false
  convention: incident
  cutoff_frequency: 40 Hz
stages: {sequence: [seismic]}
conditions: [dynamic_water]
damping: {ratio: 0}
time: {end_time: 0.8 s}
output:
  history_interval: 0.001 s
  monitors:
    valve_top: [0.0, 30.0, 2.6]
    valve_bottom: [0.0, 30.0, -2.6]
    valve_left: [-2.6, 30.0, 0.0]
    valve_right: [2.6, 30.0, 0.0]
"""
VALVE = ("valve_top", "valve_bottom", "valve_left", "valve_right")
PULSE_FC, FREE_FROM = 15.0, 0.2  # Hz; s: the pulse (peak at 0.1 s) is over at the tunnel


def _case(tmp_path: Path, edit=lambda s: s) -> Path:
    t = np.arange(400) * 1e-3
    a = (np.pi * PULSE_FC * (t - 1.5 / PULSE_FC)) ** 2
    np.savetxt(tmp_path / "pulse.txt", np.column_stack([t, (1 - 2 * a) * np.exp(-a)]))
    p = tmp_path / "case.yaml"
    p.write_text(edit(textwrap.dedent(CASE)))
    return p


def _water(text: str, ends: str) -> str:
    """The case with its water section's end lines replaced by `ends` (lines of the water section)."""
    old = "  end_ymin: {kind: reservoir}\n  end_ymax: {kind: valve}\n"
    assert old in text
    return text.replace(old, textwrap.indent(textwrap.dedent(ends), "  "))


# ---- the closed form ------------------------------------------------------------------------------

def test_wave_speed_limits():
    """The section's compliance D = (1/A) dA/dp against its limits: a thin lining alone is Korteweg's
    pipe anchored against axial movement, D = 2r(1 − ν²)/(E e) (Wylie & Streeter, c1 = 1 − ν²); no
    lining in rock is the cavity's 1/G_r (u = p r/(2G_r)); a lining on rigid rock or a rigid lining
    leaves the water's own a = sqrt(K/ρ); and the lining in rock lies between its two parts in
    series and the softer of them."""
    e, r = 0.01, R_I
    assert section_compliance(r, r + e, E_L, NU_L, 0.0) == pytest.approx(
        2 * (r + e / 2) * (1 - NU_L**2) / (E_L * e), rel=1e-3)
    assert section_compliance(r, r, E_L, NU_L, G_R) == pytest.approx(1 / G_R, rel=1e-12)
    assert section_compliance(r, r * (1 + 1e-7), E_L, NU_L, G_R) == pytest.approx(1 / G_R, rel=1e-6)
    assert wave_speed(K_W, RHO_W, section_compliance(R_I, R_O, 1e30, NU_L, G_R)) == pytest.approx(
        math.sqrt(K_W / RHO_W), rel=1e-9)
    assert section_compliance(R_I, R_O, E_L, NU_L, math.inf) < 0.05 * section_compliance(R_I, R_O, E_L, NU_L, 0.0)
    both = section_compliance(R_I, R_O, E_L, NU_L, G_R)
    assert both < min(1 / G_R, section_compliance(R_I, R_O, E_L, NU_L, 0.0))
    # the thick lining alone against Lamé's u(r_i) = p r_i (1+ν)/E ((1−2ν) r_i² + r_o²)/(r_o² − r_i²)
    lame = 2 * (1 + NU_L) / E_L * ((1 - 2 * NU_L) * R_I**2 + R_O**2) / (R_O**2 - R_I**2)
    assert section_compliance(R_I, R_O, E_L, NU_L, 0.0) == pytest.approx(lame, rel=1e-12)
    # this file's column: the rock and the lining together take the wave speed from 1483 to 1143 m/s
    a = wave_speed(K_W, RHO_W, both)
    assert a == pytest.approx(1142.7, abs=0.1)
    assert quarter_wave_frequencies(a, LENGTH) == pytest.approx([a / 120, 3 * a / 120])


def test_surge_tank_closed_form_limits():
    """The column between a reservoir and a surge tank: a vanishing tank is a valve (the quarter
    wave a/(4L)), a large one the mass oscillation T = 2π sqrt(L A_s/(g A_t)) of the rigid column."""
    a, at = 1142.7, math.pi * R_I**2
    assert surge_tank_frequencies(a, LENGTH, at, 1e-9)[0] == pytest.approx(a / (4 * LENGTH), rel=1e-6)
    f = surge_tank_frequencies(a, LENGTH, at, 40.0)
    assert f[0] == pytest.approx(1 / mass_oscillation_period(LENGTH, at, 40.0), rel=1e-4)
    assert f[1] == pytest.approx(a / (2 * LENGTH), rel=1e-3)  # the next: nearly the open–open half wave


def test_measured_frequencies_of_a_known_signal():
    """The frequency measurement on two decaying sinusoids and noise, 5 periods of the lower: within
    0.05 %."""
    t = np.arange(0, 0.6, 1e-3)
    rng = np.random.default_rng(1)
    p = (np.exp(-0.3 * t) * np.cos(2 * np.pi * 9.52 * t + 0.4) + 0.3 * np.sin(2 * np.pi * 28.57 * t)
         + 0.01 * rng.standard_normal(t.size))
    f1, f2 = measured_frequencies(t, p)
    assert f1 == pytest.approx(9.52, rel=5e-4) and f2 == pytest.approx(28.57, rel=5e-4)


# ---- the case's ends ------------------------------------------------------------------------------

@pytest.mark.parametrize("ends, key, words", [
    ("end_ymax: {kind: surge_tank}\n", "water.end_ymax.area", "surge tank with no area"),
    ("end_ymin: {kind: valve, area: 3 m^2}\n", "water.end_ymin.area", "use kind: surge_tank"),
    ("end_ymin: {kind: valve}\nend_ymax: {kind: valve}\n", "water.end_ymax.kind", "make one end a reservoir"),
])
def test_check_refuses_ends_that_cannot_be(tmp_path, ends, key, words):
    """A surge tank with no area, an area on a valve, and valves at both ends (no end holds the
    pressure level) are refused by `check`, naming the key and the fix."""
    p = _case(tmp_path, lambda s: _water(s, ends))
    with pytest.raises(CaseError) as e:
        load_case(p)
    assert key in str(e.value) and words in str(e.value) and "Fix:" in str(e.value)
    assert main(["check", str(p)]) != 0


def test_check_refuses_end_kinds_without_an_open_column(tmp_path):
    """The end kinds need a 3D column with open ends; a surge tank needs the solid's water law."""
    p = _case(tmp_path, lambda s: s.replace("  ends: open\n", "  ends: closed\n"))
    with pytest.raises(CaseError, match=r"water.end_ymin.kind = .reservoir.: .*needs a 3D model with water.ends: open"):
        load_case(p)
    p = _case(tmp_path, lambda s: _water(s, "end_ymax: {kind: surge_tank, area: 2 m^2}\n")
              + "coupling: {volume_law: water}\n")
    with pytest.raises(CaseError, match=r"water.end_ymax.kind.*use coupling.volume_law: solid"):
        load_case(p)


def test_both_sides_get_the_ends(tmp_path):
    """The valve and the reservoir reach tq-solid's /coupling and the water case: the valve's end a
    wall, the reservoir's and the surge tank's p = 0 patches (the tank's level is tq-solid's)."""
    case = load_case(_case(tmp_path))
    s = fc.coupling_settings(case, 1e-3, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    attrs = fc.solid_coupling_attrs(s)
    assert attrs["water_ends"] == "open" and attrs["end_ymax"] == "valve" and "end_ymin" not in attrs
    assert "surge_tank_area_ymax" not in attrs
    w = fc.water_case(case, s, slice_mode=False)
    assert w.ends == ("open", "wall") and water_case.patch_types(w) == {
        "interface": "wall", "end_ymin": "patch", "end_ymax": "wall"}
    p = water_case.dictionaries(w)["0/p"]
    assert "end_ymin" in p and "end_ymax" in p
    tank = load_case(_case(tmp_path, lambda t: _water(t, "end_ymin: {kind: surge_tank, area: 0.5 m^2}\n"
                                                         "end_ymax: {kind: valve}\n")))
    s = fc.coupling_settings(tank, 1e-3, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    attrs = fc.solid_coupling_attrs(s)
    assert attrs["end_ymin"] == "surge_tank" and attrs["surge_tank_area_ymin"] == 0.5
    assert fc.water_case(tank, s, slice_mode=False).ends == ("open", "wall")
    # with the whole pressure the water solver's, tq-solid carries no column: the valve is the water's wall
    foam = load_case(_case(tmp_path, lambda t: t + "coupling: {volume_law: water}\n"))
    s = fc.coupling_settings(foam, 1e-3, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    assert not {"water_ends", "end_ymin", "end_ymax"} & set(fc.solid_coupling_attrs(s))
    assert fc.water_case(foam, s, slice_mode=False).ends == ("open", "wall")


@pytest.mark.skipif(paths.solid_executable() is None, reason="tq-solid is not built (set TQ_BUILD_DIR)")
def test_tq_solid_refuses_ends_its_column_cannot_take(tmp_path):
    """tq-solid's reader of /coupling, past `check`: the case's settings are taken; a surge tank with no
    area, an area on a valve and valves at both ends are refused naming the attribute, no traceback
    (the writer leaves the ends out of a closed section: they are written with water_ends)."""
    import subprocess

    from tunnelquake.meshing import build_tunnel_mesh
    from tunnelquake.motion import from_case
    from tunnelquake.prepare import write_motion
    from tunnelquake.solid_input import write_solid_input

    case = load_case(_case(tmp_path))
    d = case.data
    build_tunnel_mesh(d["geometry"], d["mesh"], tmp_path)
    motion, _ = from_case(d["ground_motion"], case.dir)
    write_motion(motion, tmp_path / "motion.h5")
    s = fc.coupling_settings(case, 1e-4, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    exe = str(paths.solid_executable())
    for name, edit, words in (
            ("taken", {}, None),
            ("tank without area", {"end_ymax": "surge_tank"}, "surge_tank_area_ymax > 0"),
            ("area on a valve", {"surge_tank_area_ymax": 2.0}, "surge_tank_area_ymax 2"),
            ("two valves", {"end_ymin": "valve"}, "both valve")):
        out = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", "dynamic_water",
                                tmp_path / f"{name.replace(' ', '_')}.h5", coupling={**s, **edit})
        run = subprocess.run([exe, str(out), "--check"], capture_output=True, text=True, timeout=120)
        assert run.returncode == (0 if words is None else 2), (name, run.stdout + run.stderr)
        if words:
            assert words in run.stderr and "Traceback" not in run.stderr, (name, run.stderr)


# ---- the coupled run ------------------------------------------------------------------------------

def _valve_pressure(results: Path) -> tuple[np.ndarray, np.ndarray]:
    """The mean of the four valve monitors' water pressure (Pa) against time."""
    ps = []
    with h5py.File(results, "r") as f:
        assert f.attrs["status"] == "completed", f.attrs["status"]
        for m in VALVE:
            w = f[f"monitors/{m}/water_pressure"][:]
            ps.append(w[:, 1])
    return w[:, 0], np.mean(ps, axis=0)


#: f1 within 1 %, f2 within 3 % of the closed form, which is quasi-static: the wall's radial inertia (the
#: lining and the rock moving with the breathing) lowers the frequencies, the higher mode more. Measured
#: (docs/verification.md "The water column along the tunnel"): this mesh f1 −0.19 %, f2 −2.0 %; with
#: rock and lining 10× lighter +0.25 %, +0.09 % (the inertia's share −0.44 %, −2.1 %); the mesh refined
#: (24 × 2 lining elements, 8 near-field rings, 30 axial layers) −0.40 %, −1.55 %
F1_TOL, F2_TOL = 0.01, 0.03


@coupled
def test_reservoir_valve_column_rings_at_its_quarter_wave_frequencies(tmp_path):
    """The coupled 3D run's valve pressure rings at f_n = (2n − 1) a/(4L) with a from the lining and
    the rock (9.52 and 28.57 Hz; the rigid tube's would be 12.36 and 37.08 Hz)."""
    case = _case(tmp_path)
    assert main(["run", str(case)]) == 0
    t, p = _valve_pressure(tmp_path / "results" / "results_dynamic_water.h5")
    keep = t >= FREE_FROM
    f1, f2 = measured_frequencies(t[keep], p[keep])
    a = wave_speed(K_W, RHO_W, section_compliance(R_I, R_O, E_L, NU_L, G_R))
    e1, e2 = quarter_wave_frequencies(a, LENGTH)
    print(f"\nmeasured f1 {f1:.3f} Hz, f2 {f2:.3f} Hz; closed form {e1:.3f}, {e2:.3f} Hz "
          f"({100 * (f1 / e1 - 1):+.2f} %, {100 * (f2 / e2 - 1):+.2f} %)")
    assert f1 == pytest.approx(e1, rel=F1_TOL)
    assert f2 == pytest.approx(e2, rel=F2_TOL)


#: the tank: a standpipe of 0.005 m² at y = 30 m instead of the valve, whose lowest frequency (5.08 Hz)
#: lies between the valve's quarter wave (9.52 Hz) and the rigid column's mass oscillation (5.86 Hz),
#: so that the test tells the tank's law from both of its limits within a short run (a tank of tens of
#: m² swings over minutes: the same law, out of a seismic run's reach)
TANK_AREA = 0.005


@coupled
def test_reservoir_surge_tank_column_rings_at_the_tanks_frequency(tmp_path):
    """A surge tank at the column's end: the two lowest roots of cot(ωL/a) = ω A_s a/(g A_t) (5.08 and
    20.66 Hz), A_t the meshed wetted area (the inscribed 16-gon), within F1_TOL and F2_TOL; the tank's
    level, written as its own series, swings at the lowest root within F1_TOL (the column's mass
    oscillation against the tank with the column's compliance; its stiff-column limit
    T = 2π sqrt(L A_s/(g A_t)), Wylie & Streeter, Fluid Transients, the surge tank chapter)."""
    case = _case(tmp_path, lambda s: _water(s, f"end_ymin: {{kind: reservoir}}\n"
                                               f"end_ymax: {{kind: surge_tank, area: {TANK_AREA} m^2}}\n"))
    assert main(["run", str(case)]) == 0
    t, p = _valve_pressure(tmp_path / "results" / "results_dynamic_water.h5")
    keep = t >= FREE_FROM
    f1, f2 = measured_frequencies(t[keep], p[keep])
    a = wave_speed(K_W, RHO_W, section_compliance(R_I, R_O, E_L, NU_L, G_R))
    at = 8 * R_I**2 * math.sin(2 * math.pi / 16)
    e1, e2 = surge_tank_frequencies(a, LENGTH, at, TANK_AREA)
    print(f"\nmeasured f1 {f1:.3f} Hz, f2 {f2:.3f} Hz; closed form {e1:.3f}, {e2:.3f} Hz ({100 * (f1 / e1 - 1):+.2f} %, "
          f"{100 * (f2 / e2 - 1):+.2f} %); valve {quarter_wave_frequencies(a, LENGTH)[0]:.3f} Hz, mass oscillation "
          f"{1 / mass_oscillation_period(LENGTH, at, TANK_AREA):.3f} Hz")
    assert f1 == pytest.approx(e1, rel=F1_TOL)
    assert f2 == pytest.approx(e2, rel=F2_TOL)
    # the tank's level, its own series in the results (/coupling/surge_level_ymax, read by
    # post.read_water_column with the pressure along the axis): it swings at the lowest root,
    # measured from the level alone, within F1_TOL; and it is the end station's pressure over rho g
    # (the tank's compliance A_s/(rho g) holds A_s p/(rho g) of water; to round-off)
    from tunnelquake import post as P

    W = P.read_condition(tmp_path / "results" / "results_dynamic_water.h5", "dynamic_water").water_column
    assert W is not None and "level_ymax" in W and "level_ymin" not in W
    np.testing.assert_allclose(W["y"], np.linspace(0.0, LENGTH, len(W["y"])), atol=1e-9)
    h = W["level_ymax"]
    np.testing.assert_allclose(h, W["p"][: h.size, -1] / (RHO_W * 9.80665), rtol=1e-12, atol=1e-15)
    keep = W["time"][: h.size] >= FREE_FROM
    g1 = measured_frequencies(W["time"][: h.size][keep], h[keep])[0]
    print(f"the level's lowest frequency {g1:.3f} Hz ({100 * (g1 / e1 - 1):+.2f} %), largest rise {h.max():.3f} m")
    assert g1 == pytest.approx(e1, rel=F1_TOL)
    # the report: the section, the CSV and the figure of the water along the tunnel
    report = (tmp_path / "results" / "report.md").read_text()
    assert "## The water along the tunnel" in report and "The surge tank at y max" in report
    assert (tmp_path / "results" / "water_column_dynamic_water.csv").is_file()
    assert (tmp_path / "results" / "figures" / "fig12_water_column.png").is_file()


def test_the_water_columns_series_are_read_written_and_drawn_as_stored(tmp_path):
    """post.read_water_column on tq-solid's layout (/coupling/axial_pressure/station_<k> [T, 2] with
    their y as the group's attrs, /coupling/surge_level_ymax [T, 2]): the stations in order of y,
    the rows up to the last time every series reached, the values as stored; water_column_csv
    writes them back (to its 7 significant digits) and fig_water_column draws them."""
    import csv

    from tunnelquake import post as P

    t = np.arange(6) * 0.01
    p = np.array([[k * 10.0 + i for k in range(3)] for i in range(6)])  # p[i, station]
    with h5py.File(tmp_path / "r.h5", "w") as f:
        g = f.create_group("coupling/axial_pressure")
        for k, y in enumerate((0.0, 2.5, 5.0)):
            rows = np.column_stack([t, p[:, k]])
            g[f"station_{k:03d}"] = rows if k != 1 else rows[:5]  # one station a row behind
            g.attrs[f"station_{k:03d}_y"] = y
        f["coupling/surge_level_ymax"] = np.column_stack([t, p[:, 2] / (RHO_W * 9.80665)])
    with h5py.File(tmp_path / "r.h5") as f:
        W = P.read_water_column(f)
    np.testing.assert_array_equal(W["y"], [0.0, 2.5, 5.0])
    np.testing.assert_array_equal(W["time"], t[:5])
    np.testing.assert_array_equal(W["p"], p[:5])
    np.testing.assert_array_equal(W["level_ymax"], p[:5, 2] / (RHO_W * 9.80665))
    out = P.water_column_csv(W, tmp_path / "w.csv")
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["# stations y (m): p0=0 p1=2.5 p2=5"]
    assert rows[1] == ["time_s", "p0_Pa", "p1_Pa", "p2_Pa", "surge_level_ymax_m"]
    back = np.array(rows[2:], float)
    np.testing.assert_allclose(back[:, 1:4], p[:5], rtol=1e-6)
    np.testing.assert_allclose(back[:, 4], W["level_ymax"], rtol=1e-6)
    res = P.ConditionResult("dynamic_water", tmp_path / "r.h5", "completed", {}, water_column=W)
    assert P.fig_water_column(res, tmp_path / "fig.png").stat().st_size > 10_000
