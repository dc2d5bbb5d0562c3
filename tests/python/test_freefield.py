"""The free field of plane P, SV and SH waves in layered ground, and the H5DRM layout
(tunnelquake.freefield).

1. Free surface: oblique P and SV on a homogeneous half-space give the surface amplitudes of the
   closed-form reflection coefficients (Aki & Richards 2002, eq. 5.32; references.free_surface_p/sv)
   within 1 % at angles below critical, for two Poisson ratios; SH gives 2.
2. Layers: vertical SH through one damped layer on rock against Kramer's closed form
   (references.layer_transfer_function, the tool's 1D reference) within 1 %; two layers, SH and P,
   against the layer recursion (references.sh_layers_transfer_function); an oblique SV case (with
   an evanescent P in a fast layer) satisfies the traction-free surface and the continuity of
   displacement and traction at both interfaces to round-off.
3. Time domain: a vertically incident SV pulse in a homogeneous half-space equals the incident plus
   the reflected pulse (delayed by 2 d / Vs) at depth within 1 % of the peak; an oblique SH pulse
   also carries the horizontal delay p (r - r0).
4. Record conventions: outcrop at vertical incidence is half the record (as motion.py); oblique
   outcrop divides by the free-surface amplitude; a within record is deconvolved back to the
   incident wave; the refusals (past critical, a missing component, a vanishing within motion).
5. H5DRM: a file hand-built here with h5py in OpenSees' layout (stations in shuffled order, data
   located through data_location, an origin offset) reads back to the tool's own free field; the
   tool's writer round-trips; a file in mm instead of m is refused naming the count matched and the
   largest distance.
"""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from tunnelquake import freefield as ff
from tunnelquake import references as ref
from tunnelquake.motion import _incident

ROCK = ff.HalfSpace(vp=3000.0, vs=1500.0, rho=2500.0)


# ------------------------------------------------------------------------------------------------
# 1. Free surface of a homogeneous half-space
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("vp_vs", [2.0, math.sqrt(3.0)])
def test_free_surface_amplitudes_of_oblique_p_and_sv_match_the_closed_form(vp_vs):
    hs = ff.HalfSpace(vp=1500.0 * vp_vs, vs=1500.0, rho=2400.0)
    alone = ff.Profile((), hs)
    crit = math.degrees(math.asin(1 / vp_vs))
    worst = 0.0
    for kind, closed, angles in (("P", ref.free_surface_p, (5, 20, 40, 60, 80)),
                                 ("SV", ref.free_surface_sv, (5, 15, 25, crit - 2))):
        for angle in angles:
            wave = ff.PlaneWave(kind, angle, 30.0)
            e_r, e_t = wave.directions()
            H = ff.transfer(alone, wave, [0.0, 2.0, 17.0], [0.0])[0]  # the same at every frequency
            ur, uz = closed(hs.vp, hs.vs, angle)
            for h in H:
                for got, want in ((h @ e_r, ur), (h[2], uz)):
                    assert abs(got - want) <= 0.01 * abs(want) + 1e-12, (kind, angle, got, want)
                    worst = max(worst, abs(got - want) / max(abs(want), 1e-12))
                assert abs(h @ e_t) < 1e-12
    print(f"free surface, Vp/Vs {vp_vs:.3f}: largest relative error {worst:.2e}")


@pytest.mark.parametrize("angle, azimuth", [(0.0, 0.0), (30.0, 45.0), (70.0, 120.0)])
def test_sh_at_the_free_surface_doubles(angle, azimuth):
    wave = ff.PlaneWave("SH", angle, azimuth)
    H = ff.transfer(ff.Profile((), ROCK), wave, [0.0, 5.0], [0.0])[0]
    np.testing.assert_allclose(H, 2 * np.outer(np.ones(2), wave.directions()[1]), atol=1e-12)


# ------------------------------------------------------------------------------------------------
# 2. Layers
# ------------------------------------------------------------------------------------------------
def test_vertical_sh_through_one_layer_is_kramers_closed_form():
    layer = ff.Layer(thickness=30.0, vp=900.0, vs=400.0, rho=2000.0, damping=0.05)
    f = np.linspace(0.05, 25.0, 500)
    wave = ff.PlaneWave("SH", 0.0, 90.0)
    H = ff.transfer(ff.Profile((layer,), ROCK), wave, f, [0.0])[0] @ wave.directions()[1]
    surface_over_outcrop = H / ff.outcrop_factor(ff.Profile((layer,), ROCK), wave)
    exact = ref.layer_transfer_function(f, 30.0, 400.0, 0.05, 2000.0, ROCK.rho, ROCK.vs)
    err = np.max(np.abs(np.abs(surface_over_outcrop) / np.abs(exact) - 1))
    print(f"one layer, vertical SH: largest relative error of |surface/outcrop| {err:.2e}")
    assert err < 0.01
    np.testing.assert_allclose(surface_over_outcrop, exact, rtol=1e-9)


@pytest.mark.parametrize("kind", ["SH", "P"])
def test_vertical_waves_through_two_layers_follow_the_layer_recursion(kind):
    layers = (ff.Layer(12.0, 700.0, 300.0, 1900.0, 0.04), ff.Layer(25.0, 1400.0, 700.0, 2200.0, 0.02))
    f = np.linspace(0.0, 30.0, 301)
    wave = ff.PlaneWave("SV" if kind == "SH" else "P", 0.0, 0.0)  # vertical SV is SH turned by 90 deg
    H = ff.transfer(ff.Profile(layers, ROCK), wave, f, [0.0])[0] @ wave.record_direction()
    speed = (lambda m: m.vs) if kind == "SH" else (lambda m: m.vp)
    exact = ref.sh_layers_transfer_function(f, [(m.thickness, speed(m), m.rho, m.damping) for m in layers],
                                            (speed(ROCK), ROCK.rho))
    err = np.max(np.abs(H / exact - 1))
    print(f"two layers, vertical {kind}: largest relative error {err:.2e}")
    assert err < 0.01


def test_oblique_sv_meets_the_free_surface_and_interface_conditions():
    # the fast second layer makes the P wave evanescent there (p = sin 25 / 1500 > 1/4000)
    layers = (ff.Layer(15.0, 900.0, 450.0, 1900.0, 0.05), ff.Layer(20.0, 4000.0, 1800.0, 2600.0, 0.01))
    prof = ff.Profile(layers, ROCK)
    wave = ff.PlaneWave("SV", 25.0, 60.0)
    assert wave.slowness(prof) > 1 / 4000.0
    f = np.linspace(0.0, 25.0, 126)
    surf = ff.motion_stress(prof, wave, f, 0.0)
    scale = ROCK.rho * ROCK.vs  # traction / (-i w) per unit displacement
    top_traction = np.max(np.abs(surf[:, 2:])) / scale
    jumps = []
    for d in (15.0, 35.0):
        above = ff.motion_stress(prof, wave, f, d, side="above")
        below = ff.motion_stress(prof, wave, f, d, side="below")
        jumps.append(np.max(np.abs(above - below) / np.array([1, 1, scale, scale])))
    print(f"oblique SV: surface traction {top_traction:.1e}, interface jumps {jumps[0]:.1e}, {jumps[1]:.1e} "
          "(per unit incident displacement)")
    assert top_traction < 1e-10 and max(jumps) < 1e-10
    assert np.max(np.abs(surf[:, :2])) > 0.5  # the surface moves


# ------------------------------------------------------------------------------------------------
# 3. Time domain
# ------------------------------------------------------------------------------------------------
T0, TAU, DT = 0.4, 0.02, 1.0e-3


def _pulse(t):
    return np.exp(-(((t - T0) / TAU) ** 2))


def _pulse_acc(t):
    s = (t - T0) / TAU
    return (4 * s * s - 2) / TAU**2 * np.exp(-s * s)


def test_vertical_sv_pulse_at_depth_is_incident_plus_reflected():
    vs = 500.0
    prof = ff.Profile((), ff.HalfSpace(vp=1000.0, vs=vs, rho=2000.0), surface=100.0)
    t = np.arange(int(1.0 / DT)) * DT
    depths = np.array([0.0, 10.0, 50.0, 120.0])
    pts = np.stack([np.full(4, 3.0), np.full(4, -7.0), prof.surface - depths], axis=1)
    field = ff.free_field(prof, [(ff.PlaneWave("SV", 0.0, 90.0), _pulse_acc(t))], DT, pts, origin=(0.0, 0.0))
    worst = 0.0
    for i, d in enumerate(depths):
        exact = ref.free_field_1d(_pulse, -d, t, 0.0, vs)  # u0(t + d/vs) + u0(t - d/vs)
        err = np.max(np.abs(field.u[i, :, 0] - exact)) / np.max(np.abs(exact))
        worst = max(worst, err)
        assert np.max(np.abs(field.u[i, :, 1:])) < 1e-9
    print(f"vertical SV pulse: largest error {100 * worst:.3f} % of the peak")
    assert worst < 0.01


def test_oblique_sh_pulse_carries_the_horizontal_delay():
    vs, angle, az = 600.0, 35.0, 45.0
    prof = ff.Profile((), ff.HalfSpace(vp=1200.0, vs=vs, rho=2000.0))
    wave = ff.PlaneWave("SH", angle, az)
    e_r, e_t = wave.directions()
    t = np.arange(int(1.2 / DT)) * DT
    pts = np.array([[-40.0, -40.0, -5.0], [0.0, 0.0, -30.0], [60.0, 20.0, -80.0], [100.0, 100.0, 0.0]])
    field = ff.free_field(prof, [(wave, _pulse_acc(t))], DT, pts)  # origin: the first point reached
    p, eta = math.sin(math.radians(angle)) / vs, math.cos(math.radians(angle)) / vs
    r = pts @ e_r
    worst = 0.0
    for i, (rr, z) in enumerate(zip(r, pts[:, 2], strict=True)):
        lag = p * (rr - r.min())
        exact = _pulse(t - lag + eta * (-z)) + _pulse(t - lag - eta * (-z))
        err = np.max(np.abs(field.u[i] - np.outer(exact, e_t))) / 2.0
        worst = max(worst, err)
    print(f"oblique SH pulse: largest error {100 * worst:.3f} % of the peak")
    assert worst < 0.01


def test_oblique_p_pulse_at_depth_is_incident_plus_reflected_p_and_converted_s():
    alpha, beta, angle = 1000.0, 500.0, 25.0
    prof = ff.Profile((), ff.HalfSpace(vp=alpha, vs=beta, rho=2000.0))
    wave = ff.PlaneWave("P", angle, 0.0)
    t = np.arange(int(1.2 / DT)) * DT
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -40.0], [0.0, 30.0, -90.0]])
    field = ff.free_field(prof, [(wave, _pulse_acc(t))], DT, pts, origin=(0.0, 0.0))
    pp, ps = ref.free_surface_reflection_p(alpha, beta, angle)
    si, ci = math.sin(math.radians(angle)), math.cos(math.radians(angle))
    p = si / alpha
    sj = p * beta
    cj = math.sqrt(1 - sj * sj)
    xi, eta = ci / alpha, cj / beta
    worst = 0.0
    for k, (_, y, z) in enumerate(pts):
        d, lag = -z, p * y
        inc, rp, rs = _pulse(t - lag + xi * d), pp * _pulse(t - lag - xi * d), ps * _pulse(t - lag - eta * d)
        exact_y = si * inc + si * rp - cj * rs
        exact_z = ci * inc - ci * rp - sj * rs
        err = max(np.max(np.abs(field.u[k, :, 1] - exact_y)), np.max(np.abs(field.u[k, :, 2] - exact_z)))
        worst = max(worst, err / max(np.abs(exact_y).max(), np.abs(exact_z).max()))
    print(f"oblique P pulse: largest error {100 * worst:.3f} % of the peak")
    assert worst < 0.01


# ------------------------------------------------------------------------------------------------
# 4. Records and refusals
# ------------------------------------------------------------------------------------------------
def _record(n=800, seed=3):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.005
    return rng.standard_normal(n) * np.exp(-(((t - 1.5) / 0.6) ** 2))


def test_outcrop_records_at_vertical_incidence_are_halved_as_in_motion_py():
    rec = _record()
    prof = ff.Profile((ff.Layer(20.0, 800.0, 350.0, 1900.0, 0.05),), ROCK)
    for wave, comp in ((ff.PlaneWave("SV", 0.0, 90.0), "x"), (ff.PlaneWave("SV", 0.0, 0.0), "y"),
                       (ff.PlaneWave("P", 0.0, 0.0), "z")):
        got = ff.incident_motion({comp: rec}, 0.005, wave, prof, "outcrop")
        np.testing.assert_array_equal(got, _incident(rec, "outcrop"))
    wave = ff.PlaneWave("SV", 20.0, 45.0)
    ur, _ = ref.free_surface_sv(ROCK.vp, ROCK.vs, 20.0)
    c = math.sqrt(0.5)
    got = ff.incident_motion({"x": c * rec, "y": c * rec}, 0.005, wave, prof, "outcrop")
    np.testing.assert_allclose(got, rec / ur, rtol=1e-9, atol=1e-12)


def test_a_within_record_is_deconvolved_back_to_the_incident_wave():
    prof = ff.Profile((ff.Layer(20.0, 800.0, 350.0, 1900.0, 0.08),), ROCK)
    wave = ff.PlaneWave("SV", 15.0, 0.0)
    dt = 0.005
    inc = _record()
    base = np.array([[0.0, 0.0, prof.surface - prof.depth]])
    within = ff.free_field(prof, [(wave, inc)], dt, base, origin=(0.0, 0.0)).a[0] @ wave.record_direction()
    back = ff.incident_motion(within, dt, wave, prof, "within")
    err = np.max(np.abs(back - inc)) / np.max(np.abs(inc))
    print(f"within record deconvolved: error {100 * err:.3f} % of the peak")
    assert err < 0.01


def test_a_vanishing_within_motion_is_refused():
    prof = ff.Profile((ff.Layer(20.0, 800.0, 350.0, 1900.0, 0.0),), ff.HalfSpace(4000.0, 2000.0, 2700.0))
    with pytest.raises(ff.FreeFieldError, match=r"nearly vanishes at .* Hz"):
        ff.incident_motion(_record(), 0.005, ff.PlaneWave("SH", 0.0, 0.0), prof, "within")


def test_sv_past_the_critical_angle_is_refused_with_the_reason():
    with pytest.raises(ff.FreeFieldError) as e:
        ff.incident_motion(_record(), 0.005, ff.PlaneWave("SV", 31.0, 0.0), ff.Profile((), ROCK), "incident")
    msg = str(e.value)
    assert "critical angle asin(Vs/Vp) = 30.00 deg" in msg and "reflected P wave is evanescent" in msg, msg
    ff.PlaneWave("P", 31.0).slowness(ff.Profile((), ROCK))  # P and SH have no such limit
    ff.PlaneWave("SH", 80.0).slowness(ff.Profile((), ROCK))
    with pytest.raises(ff.FreeFieldError, match=r"must lie in \[0, 90\)"):
        ff.PlaneWave("SV", 90.0)


def test_a_record_missing_a_component_the_wave_needs_is_refused():
    with pytest.raises(ff.FreeFieldError) as e:
        ff.record_component({"x": _record()}, ff.PlaneWave("SV", 20.0, 45.0))
    assert "needs components x, y; the record has no y" in str(e.value), str(e.value)
    with pytest.raises(ff.FreeFieldError, match="needs component z; the record has no z"):
        ff.record_component({"x": _record(), "y": _record()}, ff.PlaneWave("P", 10.0))
    with pytest.raises(ff.FreeFieldError, match="asks for components x, y, z; the record has no z"):
        ff.vertical_waves({"x": _record(), "y": _record()})
    assert len(ff.vertical_waves({"x": _record(), "y": _record()}, ("x", "y"))) == 2


def test_a_point_above_the_ground_is_refused():
    with pytest.raises(ff.FreeFieldError, match="lies above the ground surface at z = 10 m"):
        ff.free_field(ff.Profile((), ROCK, surface=10.0), [(ff.PlaneWave("P"), _record())], 0.005, [[0, 0, 12.0]])


# ------------------------------------------------------------------------------------------------
# 5. H5DRM
# ------------------------------------------------------------------------------------------------
def _drm_layer():
    """The nodes of a one-element DRM layer (2 m elements, open at the ground surface) around a
    4 m x 8 m x 6 m region, the inner shell flagged internal; a corner at the origin."""
    xs, ys, zs = np.arange(0.0, 8.1, 2.0), np.arange(0.0, 12.1, 2.0), np.arange(-8.0, 0.1, 2.0)
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    x, y, z = pts.T
    inner = (x >= 2) & (x <= 6) & (y >= 2) & (y <= 10) & (z >= -6)
    core = (x > 2) & (x < 6) & (y > 2) & (y < 10) & (z > -6)
    keep = ~core
    return pts[keep], inner[keep]


@pytest.fixture(scope="module")
def layer_field():
    prof = ff.Profile((ff.Layer(5.0, 700.0, 300.0, 1900.0, 0.05),), ROCK)
    nodes, internal = _drm_layer()
    t = np.arange(300) * 0.004
    acc = np.exp(-(((t - 0.4) / 0.05) ** 2)) * np.sin(2 * np.pi * 6 * t)
    field = ff.free_field(prof, [(ff.PlaneWave("SV", 20.0, 30.0), acc), (ff.PlaneWave("P", 10.0, 200.0), 0.5 * acc)],
                          0.004, nodes)
    return nodes, internal, field


def _hand_built(path, nodes, internal, field, coord_scale=1.0):
    """An H5DRM file written directly with h5py: stations in reverse order, located through
    data_location, an origin offset drmbox_x0, motion rows (u_x, u_y, -u_z)."""
    n, nt = nodes.shape[0], field.time.size
    order = np.arange(n)[::-1]
    x0 = np.array([1000.0, 2000.0, 50.0])
    loc = np.empty(n, dtype=np.int32)
    with h5py.File(path, "w") as f:
        f["DRM_Data/xyz"] = (nodes[order] + x0) * coord_scale
        f["DRM_Data/internal"] = internal[order]
        disp = np.zeros((3 * n, nt))
        acc = np.zeros((3 * n, nt))
        for k, i in enumerate(order):
            loc[k] = 3 * k
            for c, sign in enumerate((1.0, 1.0, -1.0)):
                disp[3 * k + c] = sign * field.u[i, :, c]
                acc[3 * k + c] = sign * field.a[i, :, c]
        f["DRM_Data/data_location"] = loc
        f["DRM_Data/displacement"] = disp
        f["DRM_Data/acceleration"] = acc
        f["DRM_Metadata/dt"] = field.dt
        f["DRM_Metadata/tstart"] = float(field.time[0])
        f["DRM_Metadata/tend"] = float(field.time[-1])
        f["DRM_Metadata/drmbox_x0"] = x0 * coord_scale
    return path


def test_a_hand_built_h5drm_file_gives_the_tools_own_free_field(tmp_path, layer_field):
    nodes, internal, field = layer_field
    path = _hand_built(tmp_path / "hand.h5drm", nodes, internal, field)
    got = ff.read_h5drm(path, nodes, internal=internal)
    for key in ("u", "a"):
        np.testing.assert_allclose(getattr(got, key), getattr(field, key), rtol=0, atol=1e-12 * np.abs(
            getattr(field, key)).max())
    np.testing.assert_allclose(got.time, field.time, atol=1e-12)
    assert np.abs(field.u).max() > 0 and np.abs(field.u[:, :, 1]).max() > 0  # all three components move
    # the tool's own writer round-trips
    own = ff.read_h5drm(ff.write_h5drm(tmp_path / "own.h5drm", field, internal), nodes, internal=internal)
    for key in ("u", "v", "a"):
        np.testing.assert_array_equal(getattr(own, key), getattr(field, key))
    with h5py.File(tmp_path / "own.h5drm") as f:
        assert f["DRM_Data/displacement"].shape == (3 * nodes.shape[0], field.time.size)
        np.testing.assert_array_equal(f["DRM_Data/displacement"][2], -field.u[0, :, 2])
        assert float(f["DRM_Metadata/tend"][()]) == pytest.approx(field.time[-1])


def test_an_h5drm_file_in_mm_is_refused_naming_the_count_and_the_distance(tmp_path, layer_field):
    nodes, internal, field = layer_field
    path = _hand_built(tmp_path / "mm.h5drm", nodes, internal, field, coord_scale=1000.0)
    with pytest.raises(ff.FreeFieldError) as e:
        ff.read_h5drm(path, nodes)  # drmbox_x0 read from the file, in mm too: one node lands on a point
    msg = str(e.value)
    n = nodes.shape[0]
    assert f"1 of {n} DRM layer nodes match a file point within 0.001 m" in msg, msg
    assert "largest distance from a node to its nearest file point is" in msg and "a unit error?" in msg, msg
    # with the scale given, it reads
    got = ff.read_h5drm(path, nodes, scale=1e-3)
    np.testing.assert_allclose(got.u, field.u, atol=1e-12 * np.abs(field.u).max())


def test_a_shakermaker_style_file_reads_through_its_transformation(tmp_path, layer_field):
    # positions (North, East, depth) in km, motion rows (East, North, down): a model with x East,
    # y North and z up reads it with scale 1000 and the axes swapped and z turned
    nodes, internal, field = layer_field
    n, nt = nodes.shape[0], field.time.size
    x0_km = np.array([5.0, 7.0, 0.0])
    ned = np.stack([nodes[:, 1], nodes[:, 0], -nodes[:, 2]], axis=1) / 1000.0 + x0_km
    rows = np.zeros((3 * n, nt))
    rows[0::3], rows[1::3], rows[2::3] = field.u[:, :, 0], field.u[:, :, 1], -field.u[:, :, 2]
    with h5py.File(tmp_path / "sm.h5drm", "w") as f:
        f["DRM_Data/xyz"] = ned
        f["DRM_Data/internal"] = internal
        f["DRM_Data/data_location"] = np.arange(n, dtype=np.int32) * 3
        f["DRM_Data/displacement"] = rows
        f["DRM_Data/acceleration"] = rows  # not compared here
        f["DRM_Metadata/dt"] = field.dt
        f["DRM_Metadata/tstart"] = 0.0
        f["DRM_Metadata/drmbox_x0"] = x0_km
    got = ff.read_h5drm(tmp_path / "sm.h5drm", nodes, scale=1000.0,
                        transform=[[0, 1, 0], [1, 0, 0], [0, 0, -1]])
    np.testing.assert_allclose(got.u, field.u, atol=1e-12 * np.abs(field.u).max())
    with pytest.raises(ff.FreeFieldError, match=r"of 166 DRM layer nodes match a file point"):
        ff.read_h5drm(tmp_path / "sm.h5drm", nodes, scale=1000.0)  # the axes left unswapped


def test_inner_and_outer_flags_must_agree_with_the_model(tmp_path, layer_field):
    nodes, internal, field = layer_field
    path = _hand_built(tmp_path / "hand.h5drm", nodes, internal, field)
    with pytest.raises(ff.FreeFieldError, match=r"\d+ of \d+ DRM layer nodes are inner nodes in the model"):
        ff.read_h5drm(path, nodes, internal=~internal)
