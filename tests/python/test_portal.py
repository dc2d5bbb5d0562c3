"""A portal (geology.portal): the tunnel leaves a slope through a face across its axis.

1. `check` passes the shipped inlet portal (cases/portal: a 35 deg slope, the face at y = 20 m) and
   keeps it in 3D; it refuses, each naming the key and the fix, a portal slope steeper than the block
   allows, a station outside the tunnel, a cover thinner than the mesh allows, a portal with a second
   slope, in a slice, with plugged tunnel ends, with coupled water.
2. The mesh, on a block unlike the shipped case's (a 3 m tunnel off the block's middle, a 28 deg slope
   skewed 20 deg, a dipping layer): no element in front of the face above the bench; the lining and
   the water begin at the face; the ground surface behind the face follows the slope to round-off
   (z_s = z_top - min(max(d, 0) tan a, z_top - z_h), d the distance past the crest along the descent);
   the volume removed equals the analytic cut (the block in front of the face above the bench, plus the
   ground above the slope behind it); the bare faces are the bench and the face; check's counts per
   region equal the mesh's, and every element keeps a positive Jacobian.
3. The shipped case runs (`tunnelquake run`, 0.2 s of its record) and its report gives the lining's axial
   force and bending along the axis, from the face inwards; the free end at the face carries less than
   half the axial force the lining takes further in.
"""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from case_edits import check_edited
from case_texts import synthetic_motion, tunnel
from test_solid_input import _solid_with_stages

from conftest import ran_case
from tunnelquake.case import case_geology, ground_layers, load_case
from tunnelquake.meshing import build_tunnel_mesh, hexmesh
from tunnelquake.meshing.params import element_counts, resolve
from tunnelquake.paths import ROOT
from tunnelquake.scene import assess_slice

CASE = (ROOT / "cases" / "portal" / "case.yaml").read_text()


def test_the_portal_case_passes_check_and_stays_3d(tmp_path, capsys):
    rc, out, err = check_edited(tmp_path, capsys, CASE)
    assert rc == 0, err
    assert "geology.portal: the tunnel leaves a 35 deg slope through a face at y = 20 m" in out + err
    assert "mesh.mode: slice gives the same answer" not in out + err
    assert "mesh: 3,528 rock + 528 lining" in out + err  # 14 x 11 layers behind the face less the cut's
    # the same portal in a slice is no slice model: assess_slice says why
    case = load_case(tmp_path / "case.yaml")
    case.data["mesh"] = dict(case.data["mesh"], mode="slice")
    verdict = assess_slice(case)
    assert not verdict.valid and any("geology.portal" in r for r in verdict.reasons)


@pytest.mark.parametrize("edits, key, message, fix", [
    # 40 deg: the axial edges (6.364 m behind the face) lean to 6.364 / cos 40 = 8.31 m > 8 m
    (("slope_deg: 35}", "slope_deg: 40}"), "geology.portal.slope_deg",
     "is steeper than the block allows: the axial elements (6.364 m) lean with the slope to 8.307 m > "
     "max_element_size 8 m", "use slope_deg <= 37.3 deg with this mesh, or mesh.elements_along_axis >= 15"),
    # a head 4.5 m under the top: the 35 deg slope would cross it in 6.4 m, one axial element
    (("station: 20.0,", "station: 20.0, cover: 22 m,"), "geology.portal.slope_deg",
     "is steeper than the block allows: the slope rises 4.5 m from the face's head (z = 25.5 m) to the block's top "
     "over 6.427 m along the axis, less than two of its 6.364 m axial elements", "use slope_deg <= 19.4 deg"),
    (("station: 20.0", "station: 95.0"), "geology.portal.station",
     "lies outside the tunnel, which runs along y 0..90 m here", "give a station between 6.429 and 83.57 m"),
    (("station: 20.0,", "station: 20.0, cover: 4 m,"), "geology.portal.cover",
     "is less than the block allows", "give cover >= 8.5 m"),
    (("station: 20.0,", "station: 20.0, cover: 30 m,"), "geology.portal.cover",
     "puts the face's head at z = 33.5 m, at or above the block's top 30 m", "give cover < 26.5 m"),
    (("  portal: {", "  slope: {angle: 20, dip_direction: 180, crest: [0, 60]}\n  portal: {"), "geology.slope.angle",
     "a portal makes its own ground surface", "remove geology.slope"),
    (("  mode: 3d", "  mode: slice"), "geology.portal.station", "a slice holds one section across the tunnel",
     "use mesh.mode: 3d with a portal"),
    (("  mode: 3d", "  mode: 3d\n  tunnel_end_plugs: 1"), "mesh.tunnel_end_plugs",
     "the tunnel ends at the portal's face", "use tunnel_end_plugs: 0 with a portal"),
    (("conditions: [no_water]", "conditions: [dynamic_water]"), "conditions",
     "dynamic_water with geology.portal", "run the portal with no_water or static_water"),
    (("slope_deg: 35}", "cover: 9 m}"), "geology.portal.slope_deg", "is required with a portal", "add 'slope_deg:"),
])
def test_input_errors_name_the_key_and_the_fix(tmp_path, capsys, edits, key, message, fix):
    rc, _, err = check_edited(tmp_path, capsys, CASE, *edits)
    assert rc == 1
    assert f"{key} = " in err and message in err, err
    assert fix in err, err


# A block unlike the shipped case's: a 3 m tunnel 4 m off the block's middle across it, under weathered
# rock whose bottom dips 15 deg towards the portal; the face at y = 24 m, the slope at 28 deg skewed 20 deg;
# cover 10 m (the least here 9.5 m).
X0, X1, Y0, Y1, Z0, ZT = -30.0, 40.0, 0.0, 80.0, -30.0, 30.0
XC, ZC, B, L = 4.0, -2.0, 1.5, 4.0
STATION, ANGLE, SKEW, COVER = 24.0, 28.0, 20.0, 10.0
SKEWED = tunnel("skewed_portal", [X0, X1], [Y0, Y1], [Z0, ZT], centre_x=XC, centre_z=ZC, radius=f"{B} m",
                lining="0.3 m", max_element_size="5 m", lining_elements_around=16, near_field_half_width=L,
                near_field_radial_divisions=3, elements_along_axis=20) + f"""materials:
  rock: {{model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.25, density: 2600}}
  weathered: {{model: elastic, youngs_modulus: 2 GPa, poisson_ratio: 0.3, density: 2300}}
  lining: {{model: elastic, youngs_modulus: 30 GPa, poisson_ratio: 0.2, density: 2500}}
geology:
  dipping_layers:
    - {{material: weathered, dip: 15, dip_direction: 180, point: [0, 40, 12]}}
  portal: {{station: {STATION:g}, slope_deg: {ANGLE:g}, skew_deg: {SKEW:g}, cover: {COVER:g} m}}
interface: {{model: bonded}}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + """in_situ: {kx: 0.7, ky: 0.6}
conditions: [no_water]
time: {end_time: 0.01}
"""
HEAD = ZC + B + COVER  # 9.5 m
BENCH = ZC - L  # -6 m


def _surface(x, y):
    """The ground behind the face: falling at ANGLE towards azimuth 180 + SKEW down to the head, whose toe
    line passes through (XC, STATION)."""
    b = math.radians(180.0 + SKEW)
    d = (np.asarray(x) - XC) * math.sin(b) + (np.asarray(y) - STATION) * math.cos(b)  # past the toe line
    run = (ZT - HEAD) / math.tan(math.radians(ANGLE))
    return ZT - np.clip((d + run) * math.tan(math.radians(ANGLE)), 0.0, ZT - HEAD)


@pytest.fixture(scope="module")
def skewed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("portal")
    (tmp / "case.yaml").write_text(SKEWED)
    d = load_case(tmp / "case.yaml").data
    summary = build_tunnel_mesh(d["geometry"], d["mesh"], tmp, ground_layers(d), case_geology(d))
    with h5py.File(tmp / "mesh.h5") as f:
        mesh = {k: f[k][...] for k in ("nodes/coordinates", "elements/connectivity", "elements/region")}
        faces = {k: f[f"faces/{k}"][...] for k in f["faces"]}
    return d, summary, mesh, faces


def test_the_cut_removes_the_ground_in_front_of_the_face_and_the_tunnel_ends_there(skewed):
    d, summary, mesh, faces = skewed
    x, conn, region = mesh["nodes/coordinates"], mesh["elements/connectivity"], mesh["elements/region"]
    c = x[conn].mean(axis=1)
    front = c[:, 1] < STATION
    print(f"elements in front of the face: {int(front.sum())}, highest centroid z {c[front, 2].max():.2f} m "
          f"(bench {BENCH} m); lining from y = {x[conn[region == 1]][:, :, 1].min():.3f} m")
    assert front.any() and (c[front, 2] < BENCH).all()
    assert x[conn[region == 1]][:, :, 1].min() == pytest.approx(STATION)
    assert (hexmesh.corner_jacobians(x[conn])[0] > 0).all()
    # the bare faces: the bench (z = BENCH in front) and the face (y = STATION, from the bench up)
    po = x[faces["portal"]]
    on_bench = np.abs(po[:, :, 2] - BENCH).max(axis=1) < 1e-9
    on_face = np.abs(po[:, :, 1] - STATION).max(axis=1) < 1e-9
    assert (on_bench | on_face).all() and on_bench.any() and on_face.any()
    assert (po[on_face][:, :, 2] >= BENCH - 1e-9).all()
    # the lining's end ring is on the face
    lining_nodes = np.unique(conn[region == 1])
    end_ring = np.abs(x[lining_nodes, 1] - STATION) < 1e-9
    assert end_ring.any() and set(np.flatnonzero(np.isin(lining_nodes, np.unique(faces["portal"])))) >= set(
        np.flatnonzero(end_ring))


def test_the_surface_behind_the_face_follows_the_skewed_slope(skewed):
    d, summary, mesh, faces = skewed
    x = mesh["nodes/coordinates"]
    top = x[np.unique(faces["top"])]
    dev = np.abs(top[:, 2] - _surface(top[:, 0], top[:, 1])).max()
    at_face = top[np.abs(top[:, 1] - STATION) < 1e-9]
    print(f"top nodes {len(top)}: largest distance from the slope {dev:.3g} m; the head at the face "
          f"z {at_face[:, 2].min():.3f} .. {at_face[:, 2].max():.3f} m (skewed)")
    assert dev < 1e-9
    assert top[:, 1].min() == pytest.approx(STATION)
    assert at_face[:, 2].min() == pytest.approx(HEAD) and at_face[:, 2].max() > HEAD + 1.0  # the skew


def test_the_removed_volume_is_the_cut(skewed, tmp_path):
    d, summary, mesh, faces = skewed
    x, conn = mesh["nodes/coordinates"], mesh["elements/connectivity"]
    # the same block with no portal (flat, the tunnel through): its solid less this one's
    flat = build_tunnel_mesh(d["geometry"], d["mesh"], tmp_path, ground_layers(d))
    with h5py.File(tmp_path / "mesh.h5") as f:
        x0, conn0 = f["nodes/coordinates"][...], f["elements/connectivity"][...]
    v_flat = hexmesh.volumes(x0[conn0]).sum()
    bore = ((X1 - X0) * (Y1 - Y0) * (ZT - Z0) - v_flat) / (Y1 - Y0)  # the meshed bore's section, m^2
    removed = v_flat - hexmesh.volumes(x[conn]).sum()
    # in front: the whole width above the bench less the bore; behind: the ground above the slope, by
    # quadrature of the drop over the plan (the mesh's surface is bilinear over each element: exact but
    # where the crest and the toe line cross an element)
    gx, gy = np.meshgrid(np.linspace(X0, X1, 1401), np.linspace(STATION, Y1, 1121), indexing="ij")
    drop = np.trapezoid(np.trapezoid(ZT - _surface(gx, gy), gy[0], axis=1), gx[:, 0])
    exact = ((X1 - X0) * (ZT - BENCH) - bore) * (STATION - Y0) + drop
    print(f"removed {removed:.1f} m^3, analytic {exact:.1f} m^3 ({100 * (removed / exact - 1):+.3f} %); water "
          f"{summary['counts']['water']} cells against {flat['counts']['water']} through the block")
    assert removed == pytest.approx(exact, rel=0.005)
    assert summary["counts"]["water"] * (Y1 - Y0) == flat["counts"]["water"] * (Y1 - STATION)


def test_checks_counts_are_the_meshs(skewed):
    d, summary, _, _ = skewed
    est = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    print("check:", {k: est[k] for k in ("rock", "lining", "water", "solid_nodes")}, est["regions"])
    print("mesh:", summary["counts"])
    for k in ("rock", "lining", "water", "solid_nodes", "regions"):
        assert est[k] == summary["counts"][k], k
    assert summary["counts"]["regions"]["weathered"] > 0


def test_a_node_map_would_flatten_the_bore(tmp_path):
    """The alternative to the cut: the shipped case's flat block with its nodes above the bench mapped
    vertically (z' = z_f + (z - z_f) r, r = (z_g - z_f) / (z_top - z_f)) so the ground in front of the face
    lies at z_g, ramped back to the top over the first axial element behind it. With the ground 0.5 m over
    the crown the 7 m lining in front is 1.94 m tall, and the elements' smallest scaled Jacobian falls
    from the cut's (the flat block's) 0.707 (rock) and 0.991 (lining) to 0.19 and 0.38; the bench itself
    (under the invert) is out of reach: r = 0 there."""
    d = load_case(ROOT / "cases" / "portal" / "case.yaml").data
    summary = build_tunnel_mesh(d["geometry"], d["mesh"], tmp_path / "cut", ground_layers(d), case_geology(d))
    flat = build_tunnel_mesh(d["geometry"], dict(d["mesh"], elements_along_axis=15), tmp_path / "flat",
                             ground_layers(d))
    with h5py.File(tmp_path / "flat" / "mesh.h5") as f:
        x, conn, region = f["nodes/coordinates"][...], f["elements/connectivity"][...], f["elements/region"][...]
    zf, zt, zg = -6.0, 30.0, 3.5 + 0.5
    y = x[:, 1]
    target = np.where(y <= 20.0, zg, np.where(y < 26.0, zg + (y - 20.0) / 6.0 * (zt - zg), zt))
    mapped = x.copy()
    up = mapped[:, 2] > zf
    mapped[up, 2] = zf + (mapped[up, 2] - zf) * (target[up] - zf) / (zt - zf)
    _, scaled = hexmesh.corner_jacobians(mapped[conn])
    lining = region == 1
    front = mapped[conn].mean(axis=1)[:, 1] < 20.0
    bore = mapped[conn[lining & front]][:, :, 2]
    cut = summary["min_scaled_jacobian"]
    print(f"node map: the lining in front {bore.max() - bore.min():.2f} m tall, min scaled Jacobian rock "
          f"{scaled[~lining].min():.3f}, lining {scaled[lining].min():.3f}; the cut: rock {cut['rock']:.3f}, lining "
          f"{cut['lining']:.3f}; the flat block: {flat['min_scaled_jacobian']['rock']:.3f}, "
          f"{flat['min_scaled_jacobian']['lining']:.3f}")
    assert bore.max() - bore.min() == pytest.approx(7.0 * (zg - zf) / (zt - zf), rel=1e-6)
    assert cut["rock"] == pytest.approx(flat["min_scaled_jacobian"]["rock"])
    assert cut["lining"] == pytest.approx(flat["min_scaled_jacobian"]["lining"])
    assert scaled[~lining].min() < 0.5 * cut["rock"] and scaled[lining].min() < 0.5 * cut["lining"]


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_the_portal_case_runs_and_reports_the_lining_along_the_axis(tmp_path):
    """0.2 s of the shipped case's record (about 20 s): the run completes, and its report's table of the
    lining along the axis and lining_axis_no_water.csv start at the face's first layer."""
    out = ran_case(tmp_path, CASE.replace("conditions: [no_water]", "conditions: [no_water]\ntime: {end_time: 0.2}"))
    report = (out / "results" / "report.md").read_text()
    assert "## The lining along the axis" in report
    assert ("- portal: the tunnel leaves the hillside through a face at y = 20 m, looking towards -y; in front of it "
            "the ground cut down to the bench z = -6 m and the lining ended; the face's head 8.5 m over the crown") in report
    rows = np.genfromtxt(out / "results" / "lining_axis_no_water.csv", delimiter=",", names=True)
    print("lining along the axis, the face's first layers: " + "; ".join(
        f"y {r['y_m']:.1f} m: N {r['N_maxabs_N'] / 1e3:.1f} kN, M_v {r['M_v_maxabs_Nm'] / 1e3:.1f} kN m, "
        f"M_h {r['M_h_maxabs_Nm'] / 1e3:.1f} kN m" for r in rows[:4]))
    assert rows["y_m"].min() > 20.0 and rows["y_m"].min() < 20.0 + 6.4
    assert len(rows) == 11  # one per axial layer behind the face
    assert np.isfinite(rows["N_maxabs_N"]).all() and (np.abs(rows["M_v_maxabs_Nm"]) > 0).all()
    # the lining's end at the face is free: its first layer carries a fraction of the axial force inside
    assert rows["N_maxabs_N"][0] < 0.5 * rows["N_maxabs_N"].max()
