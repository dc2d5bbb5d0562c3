"""A sloping ground surface (geology.slope) over dipping layers: the mesh, check's input errors, and
the static in-situ stress under the slope against CalculiX.

1. The mesh follows the surface: every node of the `top` face lies on z_s(x, y) (to round-off), the
   solid and water volume equals the block's less the ground the slope removes (the integral of the
   drop over the plan), every element keeps a positive Jacobian, and check's counts per region
   (nothing meshed) equal the mesh's with a dipping layer cut by the slope.
2. Input errors, each a `check` error naming the key and the fix: a slope steeper than the block
   allows (the surface would fall into the ground the tunnel's near-field box needs), a toe below
   it, a crest the block lies behind, a slope along the axis in a slice, a slope without an angle.
3. tq-solid's static state under a slope (in_situ stage: the overburden of the flat block's top,
   then relaxed with gravity to equilibrium, so the slope is cut into a stressed ground) against
   CalculiX (an independent solver, Debian's calculix-ccx) on a 2D plane-strain model of the same
   section with quadratic elements (CPE8R, 2 m): the same start, the overburden of the flat top,
   with its traction on the slope released and the dipping layer's density difference applied as
   gravity, elastic. Compared at monitors under the crest, the face, the toe and away from them.
"""
from __future__ import annotations

import math
import shutil

import h5py
import numpy as np
import pytest
from case_edits import check_edited
from case_texts import record_motion, ricker_pulse_file, synthetic_motion, tunnel, wave_tunnel
from static_section import ccx_section_stress, monitors_against_section
from test_solid_input import _solid_with_stages

from conftest import checked_input, run_solid
from tunnelquake.case import case_geology, ground_layers, load_case
from tunnelquake.cli import main
from tunnelquake.meshing import build_tunnel_mesh, hexmesh
from tunnelquake.meshing.params import element_counts, resolve

# A block unlike the paper's: 80 x 30 x 60 m, a 2 m tunnel 10 m below mid-height, a 30 deg slope
# descending across the tunnel towards +x from a crest at x = -10 m, 15 m high.
CASE = tunnel("slope", [-40.0, 40.0], [0.0, 30.0], [-30.0, 30.0], centre_z=-10.0, radius="2.0 m", lining="0.3 m",
              max_element_size="5 m", lining_elements_around=16, near_field_half_width=6.0,
              near_field_radial_divisions=3, elements_along_axis=6) + """materials:
  rock: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.27, density: 2700}
  sand: {model: elastic, youngs_modulus: 1 GPa, poisson_ratio: 0.3, density: 2000}
  lining: {model: elastic, youngs_modulus: 30 GPa, poisson_ratio: 0.2, density: 2500}
geology:
  slope: {angle: 30, dip_direction: 90, crest: [-10, 0], height: 15 m}
  dipping_layers:
    - {material: sand, dip: 20, dip_direction: 200, point: [0, 15, 5]}
interface: {model: bonded}
in_situ: {kx: 0.6, ky: 0.5}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + """conditions: [no_water]
time: {end_time: 0.01}
"""
TAN30 = math.tan(math.radians(30.0))


def _surface(x, y=0.0):
    return 30.0 - np.clip((np.asarray(x) + 10.0) * TAN30, 0.0, 15.0)


@pytest.fixture(scope="module")
def sloped(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("slope")
    p = tmp / "case.yaml"
    p.write_text(CASE)
    d = load_case(p).data
    summary = build_tunnel_mesh(d["geometry"], d["mesh"], tmp, ground_layers(d), case_geology(d))
    return d, summary, tmp


def test_the_mesh_follows_the_surface_and_keeps_the_volume(sloped, tmp_path):
    d, summary, tmp = sloped
    with h5py.File(tmp / "mesh.h5") as f:
        x = f["nodes/coordinates"][...]
        conn = f["elements/connectivity"][...]
        top = f["faces/top"][...]
    pts = x[np.unique(top)]
    dev = np.abs(pts[:, 2] - _surface(pts[:, 0])).max()
    print(f"top face: {len(top)} quads, largest distance from the surface {dev:.3g} m")
    assert dev < 1e-9
    assert pts[:, 2].min() == pytest.approx(15.0) and pts[:, 2].max() == pytest.approx(30.0)
    assert (hexmesh.corner_jacobians(x[conn])[0] > 0).all()
    # The same block with a flat top: the solid's volume less the slope's is the ground the slope
    # removes, 30 m x (the wedge 15 x 15 / tan 30 / 2 + the toe's flat 15 m deep over x 15.98 .. 40 m).
    flat = build_tunnel_mesh(d["geometry"], d["mesh"], tmp_path, ground_layers(d))
    with h5py.File(tmp_path / "mesh.h5") as f:
        x0, conn0 = f["nodes/coordinates"][...], f["elements/connectivity"][...]
    # (the slope's x bands have more divisions: their edges lean with it and stay <= max_element_size)
    assert summary["max_element_size"] <= 5.0 < flat["max_element_size"] * math.sqrt(1 + TAN30**2)
    removed = hexmesh.volumes(x0[conn0]).sum() - hexmesh.volumes(x[conn]).sum()
    run = 15.0 / TAN30
    exact = 30.0 * (0.5 * run * 15.0 + (40.0 - (-10.0 + run)) * 15.0)
    print(f"removed volume {removed:.2f} m^3, analytic {exact:.2f} m^3 ({100 * (removed / exact - 1):+.3f} %)")
    # the mesh's surface is bilinear over each element's plan: exact but for the elements the crest and
    # the toe line cross, 0.5 h tan(30) deep over a strip h wide at most
    assert removed == pytest.approx(exact, rel=0.01)


def test_check_counts_the_regions_on_the_slope(sloped):
    d, summary, _ = sloped
    est = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    print("check:", est["regions"], "mesh:", summary["counts"]["regions"])
    assert est["regions"] == summary["counts"]["regions"]
    assert summary["counts"]["regions"]["sand"] > 0


def _check(tmp_path, capsys, *edits):
    return check_edited(tmp_path, capsys, CASE, *edits)


def test_the_case_passes_check(tmp_path, capsys):
    rc, out, err = _check(tmp_path, capsys)
    assert rc == 0, err


@pytest.mark.parametrize("edits, message", [
    # no toe: descending at 30 deg from x = -10 m, the surface would reach 30 - 50 tan 30 = 1.13 m at the
    # block's edge, but the ground above the near-field box (top z = -4 m) must keep a quarter of its 34 m
    (("height: 15 m}", "}"),
     "geology.slope.angle = 30.0: is steeper than the block allows: descending from the crest through [-10.0, 0.0], "
     "the surface falls 28.87 m by (40, 0), to z = 1.132 m, but the ground above z = -4 m"),
    (("height: 15 m}", "}"), "use angle <= 27.0 deg with this crest, or give height <= 25.5 m"),
    (("height: 15 m", "height: 30 m"), "geology.slope.height = 30.0: drops the surface 30 m, to z = 0 m"),
    (("crest: [-10, 0]", "crest: [45, 0]"), "geology.slope.crest = [45.0, 0.0]: the crest line through [45.0, 0.0] "
                                            "leaves the whole block x -40..40, y 0..30 behind it"),
    (("angle: 30, ", ""), "geology.slope.angle = None: is missing: dip_direction, crest, height describe a slope of no "
                          "angle"),
    (("angle: 30", "angle: 90"), "geology.slope.angle = 90: must lie in (0, 90)"),
    (("crest: [-10, 0], ", ""), "geology.slope.crest = None: is required with a slope"),
    (("dip_direction: 90, crest: [-10, 0]", "dip_direction: 180, crest: [0, 30]"),
     "mesh.elements_along_axis = 6: axial elements 5 m long lean with the slope (angle 30 deg) to 5.774 m > "
     "max_element_size 5 m"),
])
def test_input_errors_name_the_key(tmp_path, capsys, edits, message):
    rc, _, err = _check(tmp_path, capsys, *edits)
    assert rc == 1
    assert message in err, err


def test_a_slope_along_the_axis_in_a_slice_is_refused(tmp_path, capsys):
    rc, _, err = _check(tmp_path, capsys, "  elements_along_axis: 6\n", "  elements_along_axis: 6\n  mode: slice\n",
                        "dip_direction: 90, crest", "dip_direction: 180, crest", "crest: [-10, 0]", "crest: [0, 10]",
                        "    - {material: sand, dip: 20, dip_direction: 200, point: [0, 15, 5]}\n", "",
                        "  dipping_layers:\n", "")
    assert rc == 1
    assert "geology.slope.dip_direction = 180.0: a slice holds one section across the tunnel" in err, err
    assert "use dip_direction 90 or 270" in err


def test_an_incident_wave_under_a_slope_is_refused(tmp_path, capsys):
    """The DRM layer's free field is that of horizontal layers with a flat surface."""
    ricker_pulse_file(tmp_path / "pulse.txt")
    text = wave_tunnel("slope_drm").replace("interface: {model: bonded}\n", "interface: {model: bonded}\ngeology:\n  "
                                            "slope: {angle: 20, dip_direction: 90, crest: [0, 0], height: 5 m}\n")
    (tmp_path / "case.yaml").write_text(text + "    crown: [0.0, 60.0, 2.8]\n")
    assert main(["check", str(tmp_path / "case.yaml")]) == 1
    err = capsys.readouterr().err
    assert "geology.slope = 'a sloping surface': the free field of a plane wave is computed for a flat ground " \
           "surface only" in err, err


# ------------------------------------------------------------------------------------------------
# tq-solid's static state under a slope against CalculiX (plane strain, the same section)
# ------------------------------------------------------------------------------------------------
# A section 300 m wide and 140 m deep: a 30 m high slope at 30 deg descending towards +x from a
# crest at x = -30 m (the toe at x = 21.96 m), over a soft layer whose bottom dips 10 deg towards -x
# (z = -35 m at x = 0); a 1 m tunnel deep under the flat ground at x = 100 m, far from every monitor.
G = 9.81
X0, X1, Z0, Z_TOP = -150.0, 150.0, -100.0, 40.0
CREST, ANGLE, HEIGHT = -30.0, 30.0, 30.0
RHO = {"rock": 2400.0, "soft": 2100.0}
ELASTIC = {"rock": (6e9, 0.3), "soft": (1.5e9, 0.28)}
KX, KY = 0.6, 0.5
DIP_TAN, DIP_Z0 = math.tan(math.radians(10.0)), -35.0
STATIC = tunnel("slope_static", [X0, X1], [0.0, 4.0], [Z0, Z_TOP], centre_x=100.0, centre_z=-80.0, radius="1.0 m",
                lining="0.2 m", mode="slice", max_element_size="4 m", lining_elements_around=16,
                near_field_half_width=3.0, near_field_radial_divisions=2) + f"""materials:
  rock: {{model: elastic, youngs_modulus: 6 GPa, poisson_ratio: 0.3, density: {RHO['rock']:g}}}
  soft: {{model: elastic, youngs_modulus: 1.5 GPa, poisson_ratio: 0.28, density: {RHO['soft']:g}}}
  lining: {{model: elastic, youngs_modulus: 6 GPa, poisson_ratio: 0.3, density: {RHO['rock']:g}}}
geology:
  slope: {{angle: {ANGLE:g}, dip_direction: 90, crest: [{CREST:g}, 0], height: {HEIGHT:g} m}}
  dipping_layers:
    - {{material: soft, dip: 10, dip_direction: 270, point: [0, 2, {DIP_Z0:g}]}}
interface: {{model: bonded}}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + f"""in_situ: {{kx: {KX:g}, ky: {KY:g}, kz: 1.0}}
stages:
  sequence: [in_situ, seismic]
  relaxation_tolerance: 1.0e-8
  relaxation_max_steps: 400000
conditions: [no_water]
time: {{end_time: 0.001}}
output:
  monitors:
    behind_crest: [-100.0, 2.0, 10.0]
    under_crest: [-30.0, 2.0, 20.0]
    under_face: [-5.0, 2.0, 10.0]
    under_toe: [22.0, 2.0, -5.0]
    in_front: [70.0, 2.0, -10.0]
    deep_under_face: [-5.0, 2.0, -70.0]
"""


def _static_surface(x):
    return Z_TOP - np.clip((np.asarray(x, float) - CREST) * math.tan(math.radians(ANGLE)), 0.0, HEIGHT)


def _sigma0(z):
    """The in_situ stage's start, the overburden of the flat top z = 40 m: (sigma_x, sigma_z), Pa."""
    sv = -RHO["rock"] * G * (Z_TOP - np.asarray(z, float))
    return KX * sv, sv


def _ccx_plane_strain(work, h=2.0):
    """CalculiX's elastic response of the section (CPE8R, elements about h, x horizontal, y up in its
    plane) to what tq-solid's relaxation carries: the start's traction on the slope released
    (consistent nodal forces, 3-point Gauss on each quadratic edge) and the soft layer's density less
    the start's as gravity; the base fixed, the sides on rollers, as tq-solid's static supports. Returns
    the elements' centroids [E, 2] and their mean stress (sigma_x, sigma_z, tau_xz) [E, 3], the start's
    added."""
    nx, nz = round((X1 - X0) / h), round((Z_TOP - Z0) / h)
    xi = np.linspace(X0, X1, 2 * nx + 1)
    zt = _static_surface(xi)
    t = np.linspace(0.0, 1.0, 2 * nz + 1)
    X = np.repeat(xi[:, None], 2 * nz + 1, axis=1)
    Z = Z0 + t[None, :] * (zt[:, None] - Z0)
    nid = np.full(X.shape, -1, int)
    corner = (np.arange(X.shape[0])[:, None] % 2 == 1) & (np.arange(X.shape[1])[None, :] % 2 == 1)
    used = ~corner  # the 8-node serendipity elements leave the cells' centres out
    nid[used] = np.arange(1, used.sum() + 1)
    elems, cents, soft = [], [], []
    for a in range(nx):
        for b in range(nz):
            i, j = 2 * a, 2 * b
            e = [nid[i, j], nid[i + 2, j], nid[i + 2, j + 2], nid[i, j + 2], nid[i + 1, j], nid[i + 2, j + 1],
                 nid[i + 1, j + 2], nid[i, j + 1]]
            elems.append(e)
            c = np.array([X[[i, i + 2, i + 2, i], [j, j, j + 2, j + 2]].mean(), Z[[i, i + 2, i + 2, i],
                                                                                  [j, j, j + 2, j + 2]].mean()])
            cents.append(c)
            soft.append(c[1] > DIP_Z0 + DIP_TAN * c[0])  # above the dipping bottom: the soft layer
    elems, cents, soft = np.array(elems), np.array(cents), np.array(soft)
    # released traction: -sigma0 . n on the top edges below z_top, n the outward normal
    force = np.zeros((used.sum() + 1, 2))
    gp, gw = np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)]), np.array([5.0, 8.0, 5.0]) / 9.0
    top = X.shape[1] - 1
    for a in range(nx):
        ids = [nid[2 * a, top], nid[2 * a + 1, top], nid[2 * a + 2, top]]
        px, pz = X[2 * a:2 * a + 3, top], Z[2 * a:2 * a + 3, top]
        for s, w in zip(gp, gw, strict=True):
            n_ = np.array([0.5 * s * (s - 1), 1 - s * s, 0.5 * s * (s + 1)])
            dn = np.array([s - 0.5, -2 * s, s + 0.5])
            tx, tz = dn @ px, dn @ pz  # tangent (d/ds), |.| the length factor
            normal = np.array([-tz, tx])  # outward (up) normal times the length factor
            sx, sz = _sigma0(n_ @ pz)
            traction = -np.array([sx * normal[0], sz * normal[1]])  # -sigma0 . n (sigma0 diagonal)
            for k in range(3):
                force[ids[k]] += w * n_[k] * traction
    # (CalculiX reads numbers of at most 20 characters)
    lines = ["*HEADING", "slope section, plane strain", "*NODE"]
    lines += [f"{nid[i, j]}, {X[i, j]:.12e}, {Z[i, j]:.12e}" for i in range(X.shape[0]) for j in range(X.shape[1])
              if used[i, j]]
    for name, mask in (("EROCK", ~soft), ("ESOFT", soft)):
        lines.append(f"*ELEMENT, TYPE=CPE8R, ELSET={name}")
        lines += [f"{k + 1}, " + ", ".join(map(str, elems[k])) for k in np.flatnonzero(mask)]
    for name in ("rock", "soft"):
        e, nu = ELASTIC[name]
        lines += [f"*MATERIAL, NAME={name.upper()}", "*ELASTIC", f"{e!r}, {nu!r}", "*DENSITY",
                  f"{float(abs(RHO[name] - RHO['rock']) or 1.0)!r}",
                  f"*SOLID SECTION, ELSET=E{name.upper()}, MATERIAL={name.upper()}", "1."]
    base = nid[:, 0]
    sides = np.concatenate([nid[0, :][used[0, :]], nid[-1, :][used[-1, :]]])
    lines += ["*BOUNDARY"] + [f"{n}, 1, 2" for n in base] + [f"{n}, 1, 1" for n in sides]
    lines += ["*STEP", "*STATIC", "*CLOAD"]
    lines += [f"{n}, {d + 1}, {force[n, d]:.12e}" for n in np.flatnonzero(np.abs(force).sum(axis=1)) for d in (0, 1)]
    # the soft layer weighs (rho_soft - rho_rock) g more than the start's overburden assumed: upwards here
    lines += ["*DLOAD", f"ESOFT, GRAV, {G!r}, 0., {1.0 if RHO['soft'] < RHO['rock'] else -1.0}, 0."]
    lines += ["*EL PRINT, ELSET=EROCK", "S", "*EL PRINT, ELSET=ESOFT", "S", "*END STEP"]
    return cents, ccx_section_stress(work, "slope", lines, len(elems), _sigma0(cents[:, 1]))


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed")
def test_static_stress_under_the_slope_matches_calculix(tmp_path, capsys):
    from scipy.interpolate import LinearNDInterpolator

    exe = _solid_with_stages()
    _, inp = checked_input(tmp_path, STATIC, capsys)
    res = tmp_path / "results.h5"
    run_solid(exe, inp, res, timeout=300)
    cents, ccx = _ccx_plane_strain(tmp_path)
    at = LinearNDInterpolator(cents, ccx)
    worst = monitors_against_section(res, ("behind_crest", "under_crest", "under_face", "under_toe", "in_front",
                                           "deep_under_face"), at, 0, (0, 2, 5), ("sx", "sz", "txz"), _sigma0,
                                     lambda x, z: f", depth {_static_surface(x) - z:.1f} m")
    assert worst < 0.01


# ------------------------------------------------------------------------------------------------
# tq-solid's motion away from the slope against the layered free field (freefield.py)
# ------------------------------------------------------------------------------------------------
# A section 1000 m wide: a soft layer (Vs 400 m/s) 40 m thick over rock (Vs 1000 m/s), both on the
# rock half-space under the base 100 m down; a 20 m high slope at 30 deg cuts the layer from a crest at
# x = -20 m (toe at x = 14.6 m), so the layer is 40 m thick behind the crest and 20 m in front of the
# toe; under the layer behind the crest a dipping layer of hard rock (Vs 1400 m/s) whose bottom dips
# 60 deg towards -x from x = -100 m at z = 0 (x = -134.6 m at the base): the column behind is soil
# over hard rock, the one in front soil over rock, each on a half-space of its lowest layer. A vertically incident SV Ricker pulse (2.5 Hz), undamped; no static stage, a 2.5 m bore 40 m
# under the slope (ka < 0.04 in the rock up to 5 Hz). Far from the slope each side is a 1D layered
# column: its motion is freefield.free_field of that column's profile, until the waves the slope
# scatters arrive (through the rock at its S speed, about 0.1 s later for every 100 m further away).
VS_SOIL, VS_ROCK = 400.0, 1000.0
DYNAMIC = tunnel("slope_wave", [-500.0, 500.0], [0.0, 2.5], [-60.0, 40.0], centre_x=0.0, centre_z=-40.0,
                 radius="2.5 m", lining="0.5 m", mode="slice", max_element_size="2.5 m", lining_elements_around=16,
                 lining_elements_through=1, water_ring_divisions=1, near_field_half_width=4.0,
                 near_field_radial_divisions=2, elements_along_axis=1) + """materials:
  rock: {model: elastic, youngs_modulus: 6.25 GPa, poisson_ratio: 0.25, density: 2500}
  soil: {model: elastic, youngs_modulus: 0.832 GPa, poisson_ratio: 0.3, density: 2000}
  hard: {model: elastic, youngs_modulus: 12.74 GPa, poisson_ratio: 0.25, density: 2600}
  lining: {model: elastic, youngs_modulus: 6.25 GPa, poisson_ratio: 0.25, density: 2500}
layers:
  - {material: soil, thickness: 40 m}
geology:
  slope: {angle: 30, dip_direction: 90, crest: [-20, 0], height: 20 m}
  dipping_layers:
    - {material: hard, dip: 60, dip_direction: 270, point: [-100, 1.25, 0]}
interface: {model: bonded}
""" + record_motion("pulse.txt", units="m/s^2", pga="1.0 m/s^2", vertical_ratio=0, cutoff_frequency="12 Hz",
                    baseline_correction="false", convention="incident") + """stages: {sequence: [seismic]}
conditions: [no_water]
damping: {ratio: 0}
time: {end_time: 1.0}
output:
  monitors:
"""
#: monitors 20 m deep on each side: (x, z), the surface there
FAR = {"behind_400": (-400.0, 20.0, 40.0), "front_400": (400.0, 0.0, 20.0), "behind_250": (-250.0, 20.0, 40.0),
       "front_250": (250.0, 0.0, 20.0), "behind_400_deep": (-400.0, -40.0, 40.0)}


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_motion_away_from_the_slope_is_the_layered_free_field(tmp_path, capsys):
    """Over the first second (the pulse through the layer and its first reverberation), 400 m from
    the slope and 300 m from the dipping interface on either side, u_x within 2 % of the peak of the
    free field of that side's column. (The base under each side follows that side's column: its
    springs, dashpots and input; with one column for the whole base the far side is 8-20 % off.)"""
    from tunnelquake.freefield import HalfSpace, Layer, PlaneWave, Profile, free_field

    exe = _solid_with_stages()
    ricker_pulse_file(tmp_path / "pulse.txt")
    _, inp = checked_input(tmp_path, DYNAMIC + "".join(f"    {k}: [{x}, 1.25, {z}]\n" for k, (x, z, _) in FAR.items()),
                           capsys)
    res = tmp_path / "results.h5"
    run_solid(exe, inp, res, timeout=600)
    with h5py.File(tmp_path / "motion.h5") as f:
        inc, dt = f["incident_ax"][...], float(f.attrs["dt"])
    rock = dict(vp=VS_ROCK * math.sqrt(3.0), vs=VS_ROCK, rho=2500.0)  # nu 0.25
    soil = dict(vp=VS_SOIL * math.sqrt(2.0 * (1 - 0.3) / (1 - 2 * 0.3)), vs=VS_SOIL, rho=2000.0)  # nu 0.3
    hard = dict(vp=1400.0 * math.sqrt(3.0), vs=1400.0, rho=2600.0)  # nu 0.25: E 12.74 GPa
    errors = {}
    with h5py.File(res) as r:
        assert r.attrs["status"] == "completed"
        coords = r["mesh/coordinates"][...]
        for name, (_, _, surface) in FAR.items():
            g = r[f"monitors/{name}"]
            x, y, z = coords[int(g.attrs["node"])]
            t, u = g["time"][...][:, 0], g["u"][...]
            # the half-space under the base continues each column's lowest layer (tq-solid's base under
            # each side takes that side's column's: assignBaseColumns)
            under = hard if x < 0 else rock
            profile = Profile([Layer(surface, **soil), Layer(60.0, **under)], HalfSpace(**under), surface=surface)
            ff = free_field(profile, [(PlaneWave("SV", 0.0, 90.0), inc)], dt, [[x, y, z]], times=t).u[0]
            peak = np.abs(ff[:, 0]).max()
            errors[name] = np.abs(u[:, 0] - ff[:, 0]).max() / peak
            print(f"{name} (x = {x:.1f}, z = {z:.1f} m, depth {surface - z:.1f} m): peak u_x {np.abs(u[:, 0]).max():.4g} "
                  f"m, free field {peak:.4g} m; largest difference {100 * errors[name]:.2f} % of its peak, u_z "
                  f"{100 * np.abs(u[:, 2]).max() / peak:.2f} %")
    assert errors["behind_400"] < 0.02 and errors["front_400"] < 0.02 and errors["behind_400_deep"] < 0.02
    # nearer the slope its scattered waves arrive within the second
    assert errors["behind_250"] > errors["behind_400"] and errors["front_250"] > errors["front_400"]
