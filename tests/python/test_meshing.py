"""Tests of tunnelquake.meshing: geometry, topology and file layout of the tunnel meshes.

Most tests use a coarse parameter set (a fraction of a second per build); one builds the paper's
default 3D mesh and checks its counts and build time.

Discretisation error used below: every node on the circles r = a (lining inner face) and r = b
(excavation) sits at equal angular steps 2 pi / n (n = elements around), so each circle is
replaced by the inscribed regular n-gon of area (n/2) r^2 sin(2 pi/n). The meshed volumes are
therefore *exactly* (to round-off) lining L (n/2) sin(2 pi/n) (b^2 - a^2), water
L (n/2) sin(2 pi/n) a^2 and rock block - L (n/2) sin(2 pi/n) b^2, and they fall short of the
circular values by the relative amount 1 - sin(t)/t <= t^2/6, t = 2 pi/n (0.29 % for n = 48).
"""

from __future__ import annotations

import json
import math
import time

import h5py
import meshio
import numpy as np
import pytest

from tunnelquake.meshing import (
    MESH_DEFAULTS,
    MESH_DOC,
    PAPER_GEOMETRY,
    MeshInputError,
    build_tunnel_mesh,
    check_element_size,
    hexmesh,
)

GEOM = dict(PAPER_GEOMETRY)
A = GEOM["excavated_radius"] - GEOM["lining_thickness"]  # 4.5 m
B = GEOM["excavated_radius"]  # 5.25 m
XC, ZC = GEOM["tunnel_centre_x"], GEOM["tunnel_centre_z"]
LY = GEOM["y_range"][1] - GEOM["y_range"][0]
BLOCK = (120.0, LY, 182.7)

COARSE = {
    "max_element_size": 30.0,
    "lining_elements_around": 16,
    "lining_elements_through": 2,
    "elements_along_axis": 4,
    "water_ring_divisions": 2,
    "near_field_radial_divisions": 4,
}
ROUNDOFF = 1e-9  # relative, for quantities that are exact up to floating-point round-off
#: the block's six outer faces
BLOCK_FACES = ("bottom", "top", "xmin", "xmax", "ymin", "ymax")


def polygon_area(r: float, n: int) -> float:
    return 0.5 * n * r * r * math.sin(2.0 * math.pi / n)


def read_solid(path):
    with h5py.File(path, "r") as f:
        return {
            "attrs": dict(f.attrs),
            "x": f["nodes/coordinates"][...],
            "conn": f["elements/connectivity"][...],
            "region": f["elements/region"][...],
            "regions": [str(s) for s in f["elements"].attrs["regions"]],
            "faces": {k: f["faces"][k][...] for k in f["faces"]},
            "pairs": f["interfaces/rock_lining"][...],
            "dtypes": {
                "x": f["nodes/coordinates"].dtype,
                "conn": f["elements/connectivity"].dtype,
                "region": f["elements/region"].dtype,
                "pairs": f["interfaces/rock_lining"].dtype,
            },
        }


def read_water(path):
    m = meshio.read(path)
    phys = m.cell_data_dict["gmsh:physical"]
    names = {name: int(tag) for name, (tag, _dim) in m.field_data.items()}
    quads = m.cells_dict["quad"]
    return {
        "x": m.points,
        "hexes": m.cells_dict["hexahedron"],
        "patches": {n: quads[phys["quad"] == names[n]] for n in ("interface", "end_ymin", "end_ymax")},
        "names": names,
    }


@pytest.fixture(scope="module")
def coarse3d(tmp_path_factory):
    out = tmp_path_factory.mktemp("coarse3d")
    summary = build_tunnel_mesh(GEOM, COARSE, out)
    return summary, read_solid(out / "mesh.h5"), read_water(out / "water.msh"), out


@pytest.fixture(scope="module")
def coarse_slice(tmp_path_factory):
    out = tmp_path_factory.mktemp("coarse_slice")
    summary = build_tunnel_mesh(GEOM, {**COARSE, "mode": "slice"}, out)
    return summary, read_solid(out / "mesh.h5"), read_water(out / "water.msh"), out


def test_every_parameter_documented():
    assert set(MESH_DOC) == set(MESH_DEFAULTS)
    for key in ("max_element_size", "near_field_half_width", "slice_thickness"):
        assert "m;" in MESH_DOC[key]  # lengths state their unit
    assert MESH_DEFAULTS["max_element_size"] == 6.75
    assert (
        MESH_DEFAULTS["lining_elements_around"],
        MESH_DEFAULTS["lining_elements_through"],
        MESH_DEFAULTS["elements_along_axis"],
    ) == (48, 3, 44)


def test_paper_default_mesh_counts_and_time(tmp_path):
    """The default 3D mesh: the paper's counts (within 15 %; rock and lining exact), all edges
    <= 6.75 m, 48 x 45 interface pairs, built in < 30 s (measured ~2 s here)."""
    t0 = time.perf_counter()
    s = build_tunnel_mesh(GEOM, {}, tmp_path)
    elapsed = time.perf_counter() - t0
    assert elapsed < 30.0
    c = s["counts"]
    assert (c["rock"], c["lining"], c["water"]) == (58080, 6336, 14784)
    for region, paper in (("rock", 58080), ("lining", 6336), ("water", 14256)):
        assert abs(c[region] / paper - 1.0) <= 0.15
    assert s["max_element_size"] <= 6.75
    assert s["interface_pairs"] == 48 * 45
    assert s["min_jacobian"] > 0
    # quality: the O-grid's worst corner is the 135-degree block corner, scaled Jacobian 0.707
    assert min(s["min_scaled_jacobian"].values()) > 0.7
    json.dumps(s)  # the summary is plain data (the CLI may print or store it)


def test_volumes_match_polygonal_discretisation(coarse3d):
    s, solid, water, _ = coarse3d
    n = COARSE["lining_elements_around"]
    vol = hexmesh.volumes(solid["x"][solid["conn"]])
    v_rock, v_lining = vol[solid["region"] == 0].sum(), vol[solid["region"] == 1].sum()
    v_water = hexmesh.volumes(water["x"][water["hexes"]]).sum()
    exact_lining = LY * (polygon_area(B, n) - polygon_area(A, n))
    exact_water = LY * polygon_area(A, n)
    exact_rock = np.prod(BLOCK) - LY * polygon_area(B, n)
    assert v_lining == pytest.approx(exact_lining, rel=ROUNDOFF)
    assert v_water == pytest.approx(exact_water, rel=ROUNDOFF)
    assert v_rock == pytest.approx(exact_rock, rel=ROUNDOFF)
    # against the circular geometry: short by at most t^2/6, t = 2 pi / n
    bound = (2 * math.pi / n) ** 2 / 6
    circ_lining = math.pi * (B**2 - A**2) * LY
    assert 0 < 1 - v_lining / circ_lining <= bound
    assert 0 < 1 - v_water / (math.pi * A**2 * LY) <= bound
    assert 0 < v_rock - (np.prod(BLOCK) - math.pi * B**2 * LY) <= bound * math.pi * B**2 * LY


def test_all_corner_jacobians_positive(coarse3d, coarse_slice):
    for _, solid, water, _ in (coarse3d, coarse_slice):
        for x, conn in ((solid["x"], solid["conn"]), (water["x"], water["hexes"])):
            detj, _ = hexmesh.corner_jacobians(x[conn])
            assert (detj > 0).all()


def test_rock_lining_pairs(coarse3d):
    _, solid, _, _ = coarse3d
    pairs, x = solid["pairs"], solid["x"]
    n, along = COARSE["lining_elements_around"], COARSE["elements_along_axis"]
    assert pairs.shape == (n * (along + 1), 2)
    assert np.abs(x[pairs[:, 0]] - x[pairs[:, 1]]).max() <= 1e-9
    r = np.hypot(x[pairs[:, 0], 0] - XC, x[pairs[:, 0], 2] - ZC)
    assert np.abs(r - B).max() <= 1e-9 * B
    rock_nodes = np.unique(solid["conn"][solid["region"] == 0])
    lining_nodes = np.unique(solid["conn"][solid["region"] == 1])
    assert np.intersect1d(rock_nodes, lining_nodes).size == 0  # duplicated: no shared node
    assert np.isin(pairs[:, 0], rock_nodes).all() and np.isin(pairs[:, 1], lining_nodes).all()
    assert len(np.unique(pairs[:, 0])) == len(pairs) == len(np.unique(pairs[:, 1]))


def test_face_groups_orientation_and_areas(coarse3d):
    _, solid, _, _ = coarse3d
    x, faces = solid["x"], solid["faces"]
    n = COARSE["lining_elements_around"]
    lx, ly, lz = BLOCK
    expected = {  # outward unit normal, total area (m^2)
        "bottom": ((0, 0, -1), lx * ly),
        "top": ((0, 0, 1), lx * ly),
        "xmin": ((-1, 0, 0), lz * ly),
        "xmax": ((1, 0, 0), lz * ly),
        "ymin": ((0, -1, 0), lx * lz - polygon_area(A, n)),
        "ymax": ((0, 1, 0), lx * lz - polygon_area(A, n)),
    }
    for name, (normal, area) in expected.items():
        nrm = hexmesh.face_normals(x, faces[name])
        assert (nrm @ np.array(normal, float) > 1 - 1e-12).all(), name
        assert quad_areas(x, faces[name]).sum() == pytest.approx(area, rel=ROUNDOFF), name
    # curved faces: unit radial direction at each face centre, normal along -/+ it
    chord = {"lining_inner": (A, -1), "rock_hole": (B, -1), "lining_outer": (B, +1)}
    for name, (r, sign) in chord.items():
        nrm = hexmesh.face_normals(x, faces[name])
        c = x[faces[name]].mean(axis=1)
        radial = np.stack([c[:, 0] - XC, np.zeros(len(c)), c[:, 2] - ZC], axis=1)
        radial /= np.linalg.norm(radial, axis=1, keepdims=True)
        assert (sign * np.einsum("ij,ij->i", nrm, radial) > 1 - 1e-9).all(), name
        perimeter = n * 2 * r * math.sin(math.pi / n)
        assert quad_areas(x, faces[name]).sum() == pytest.approx(perimeter * ly, rel=ROUNDOFF)
    # the groups together are exactly the solid's boundary
    bnd, _ = hexmesh.boundary_faces(solid["conn"].astype(np.int64))
    got = np.concatenate(list(faces.values()))
    assert len(got) == len(bnd)
    assert set(map(tuple, np.sort(got, axis=1))) == set(map(tuple, np.sort(bnd, axis=1)))


def quad_areas(x, faces):
    p = x[faces]
    return 0.5 * np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1)


def test_water_mesh_interface_and_ends(coarse3d):
    _, solid, water, _ = coarse3d
    assert set(water["names"]) == {"water", "interface", "end_ymin", "end_ymax"}
    wx, patches = water["x"], water["patches"]
    # interface points coincide bit for bit with the lining_inner nodes
    wi = np.unique(wx[np.unique(patches["interface"])], axis=0)
    li = np.unique(solid["x"][np.unique(solid["faces"]["lining_inner"])], axis=0)
    assert wi.shape == li.shape and np.array_equal(wi, li)
    assert len(patches["interface"]) == len(solid["faces"]["lining_inner"])
    # patches face out of the water: interface away from the axis, ends along -y / +y
    nrm = hexmesh.face_normals(wx, patches["interface"])
    c = wx[patches["interface"]].mean(axis=1)
    assert (nrm[:, 0] * (c[:, 0] - XC) + nrm[:, 2] * (c[:, 2] - ZC) > 0).all()
    for name, (y, sign) in {"end_ymin": (0.0, -1), "end_ymax": (LY, 1)}.items():
        assert np.abs(wx[patches[name], 1] - y).max() == 0.0
        assert (sign * hexmesh.face_normals(wx, patches[name])[:, 1] > 1 - 1e-12).all()
    n, along = COARSE["lining_elements_around"], COARSE["elements_along_axis"]
    assert len(water["hexes"]) == along * ((n // 4) ** 2 + n * COARSE["water_ring_divisions"])


def test_slice_mode_one_element_thick(coarse_slice, coarse3d):
    s, solid, water, _ = coarse_slice
    s3, _, _, _ = coarse3d
    along = COARSE["elements_along_axis"]
    assert solid["attrs"]["slice"] == 1 and s["mode"] == "slice"
    t = LY / along  # default thickness: the 3D axial element length, centred on y = 40
    for x in (solid["x"], water["x"]):
        ys = np.unique(x[:, 1])
        assert ys == pytest.approx([LY / 2 - t / 2, LY / 2 + t / 2], abs=1e-12)
    for region in ("rock", "lining", "water"):
        assert s["counts"][region] * along == s3["counts"][region]
    assert len(water["patches"]["end_ymin"]) == len(water["hexes"]) == len(water["patches"]["end_ymax"])
    assert s["interface_pairs"] == 2 * COARSE["lining_elements_around"]


def test_slice_thickness_parameter(tmp_path):
    s = build_tunnel_mesh(GEOM, {**COARSE, "mode": "slice", "slice_thickness": 1.0}, tmp_path)
    assert s["y_extent"] == pytest.approx([39.5, 40.5], abs=1e-12)


def test_hdf5_layout(coarse3d):
    _, solid, _, _ = coarse3d
    a = solid["attrs"]
    assert a["format"] == "tunnelquake-solid-mesh" and a["version"] == 1 and a["slice"] == 0
    assert solid["regions"] == ["rock", "lining"]
    d = solid["dtypes"]
    assert (d["x"], d["conn"], d["region"], d["pairs"]) == (np.float64, np.int32, np.int32, np.int32)
    assert set(solid["faces"]) == {*BLOCK_FACES, "lining_inner", "rock_hole", "lining_outer"}
    assert all(f.dtype == np.int32 and f.shape[1] == 4 for f in solid["faces"].values())
    # every node is used by an element
    assert np.unique(solid["conn"]).size == len(solid["x"])


def test_model_msh_physical_groups(coarse3d):
    s, _, _, out = coarse3d
    m = meshio.read(out / "model.msh")
    names = set(m.field_data)
    assert {"rock", "lining", "water", *BLOCK_FACES, "rock_lining", "lining_inner", "end_ymin", "end_ymax"} <= names
    phys = np.concatenate(
        [d for d, blk in zip(m.cell_data["gmsh:physical"], m.cells, strict=True) if blk.type == "hexahedron"]
    )
    for region in ("rock", "lining", "water"):
        assert (phys == m.field_data[region][0]).sum() == s["counts"][region]


def test_refinement_factor_scales_counts(tmp_path):
    base = build_tunnel_mesh(GEOM, {**COARSE, "mode": "slice"}, tmp_path / "k1")
    fine = build_tunnel_mesh(GEOM, {**COARSE, "mode": "slice", "refinement_factor": 2}, tmp_path / "k2")
    for region in ("rock", "lining", "water"):
        assert fine["counts"][region] == 4 * base["counts"][region]  # 2 x 2 in the section
    assert fine["y_extent"][1] - fine["y_extent"][0] == pytest.approx(LY / 8)


def test_outer_growth_grades_away_from_box(tmp_path):
    hmax = 6.75
    s = build_tunnel_mesh(GEOM, {"mode": "slice", "outer_growth": 1.3}, tmp_path)
    solid = read_solid(tmp_path / "mesh.h5")
    xb = np.unique(solid["x"][np.unique(solid["faces"]["bottom"]), 0])
    left = np.diff(xb[xb <= XC - 14.0 + 1e-9])[::-1]  # sizes from the box outwards
    # first = box side spacing x growth; gmsh places progression points to ~1e-8 relative
    assert left[0] == pytest.approx(28.0 / 12 * 1.3, rel=1e-6)
    assert (np.diff(left) > -1e-6).all()  # sizes never decrease away from the box
    assert left.max() <= hmax and s["max_element_size"] <= hmax
    assert len(left) == s["divisions"]["left"]


def test_check_element_size():
    assert check_element_size(6.75, 1080.0, 20.0) is None  # the paper's 6.75 m = 1080/(8 x 20)
    msg = check_element_size(6.8, 1080.0, 20.0)
    assert msg is not None and "6.750" in msg and "max_element_size" in msg
    with pytest.raises(ValueError):
        check_element_size(1.0, 0.0, 20.0)


@pytest.mark.parametrize(
    "mesh, words",
    [
        ({"bogus": 1}, ["bogus"]),
        ({"lining_elements_around": 50}, ["lining_elements_around", "50"]),
        ({"mode": "2d"}, ["mode"]),
        ({"near_field_half_width": 65.0}, ["near_field_half_width", "x_range"]),
        ({"max_element_size": 1.0}, ["max_element_size"]),
        ({"outer_growth": 0.8}, ["outer_growth"]),
    ],
)
def test_bad_input_is_explained(tmp_path, mesh, words):
    with pytest.raises(MeshInputError) as err:
        build_tunnel_mesh(GEOM, mesh, tmp_path)
    for w in words:
        assert w in str(err.value)


def test_bad_geometry_is_explained(tmp_path):
    with pytest.raises(MeshInputError, match="lining_thickness"):
        build_tunnel_mesh({**GEOM, "lining_thickness": 6.0}, COARSE, tmp_path)
    with pytest.raises(MeshInputError, match="x_range"):
        build_tunnel_mesh({**GEOM, "x_range": [60.0, -60.0]}, COARSE, tmp_path)


def test_other_geometry_off_centre(tmp_path):
    """A shifted, asymmetric block (tunnel off-centre, y not starting at 0, other radii)."""
    geom = {
        "x_range": [-40.0, 70.0],
        "y_range": [10.0, 50.0],
        "z_range": [-50.0, 60.0],
        "tunnel_centre_x": 5.0,
        "tunnel_centre_z": 3.0,
        "excavated_radius": 3.0,
        "lining_thickness": 0.4,
    }
    mesh = {**COARSE, "near_field_half_width": 9.0, "lining_elements_around": 24}
    s = build_tunnel_mesh(geom, mesh, tmp_path)
    solid = read_solid(tmp_path / "mesh.h5")
    vol = hexmesh.volumes(solid["x"][solid["conn"]])
    n, ly, a, b = 24, 40.0, 2.6, 3.0
    assert vol[solid["region"] == 1].sum() == pytest.approx(
        ly * (polygon_area(b, n) - polygon_area(a, n)), rel=ROUNDOFF
    )
    assert vol.sum() == pytest.approx(110.0 * ly * 110.0 - ly * polygon_area(a, n), rel=ROUNDOFF)
    assert (hexmesh.corner_jacobians(solid["x"][solid["conn"]])[0] > 0).all()
    x, p = solid["x"], solid["pairs"]
    assert np.abs(x[p[:, 0]] - x[p[:, 1]]).max() <= 1e-9 and len(p) == n * 5
    assert s["max_element_size"] <= COARSE["max_element_size"]
