"""Regions bounded by planes (geology: a fault zone, dipping layers): the mesh's regions, the axial
refinement across the band, check's estimates, input errors, and tq-solid's in-situ stress.

1. A fault zone (4 m, strike 60, dip 70) and a dipping layer in a small 3D block: every ground
   element's centroid satisfies its region's plane inequalities; the band's element volume
   against the analytic one, (A_xz - A_hole) w / |n_y| (every line parallel to the axis crosses the
   band over w / |n_y| inside the block), converging as the elements shrink (refinement_factor 1
   and 2); the band has at least elements_across elements along the axis where it crosses the
   near-field box; check's counts (params.element_counts, nothing meshed) equal the mesh's.
2. End to end (tq-solid, static stages only, a slice): a horizontal cover over a layer dipping
   across the tunnel; far from where the dipping plane crosses the block, the vertical stress at
   the seismic start equals the overburden integral g sum(rho_i t_i) along the vertical, within 1 %.
3. The side faces in strips one element wide, each its own free-field column (tq-solid needs one
   material per row of a column's face): on a ground of one material they give the histories of
   the single column to round-off, and with the band and the layer crossing them the seismic
   stage runs.
4. Each input error is a `check` error naming the key: a fault plane missing the block, a band
   wider than the block, a dip outside (0, 90], a region material not defined, a dipping layer's
   bottom plane leaving the block.
"""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from case_edits import check_edited
from case_texts import synthetic_motion, tunnel
from test_solid_input import _solid_with_stages

from conftest import checked_input, mesh_and_motion, run_solid, solid_input
from tunnelquake import meshing
from tunnelquake.case import case_geology, ground_layers, load_case
from tunnelquake.meshing import build_tunnel_mesh, hexmesh
from tunnelquake.meshing.geology import from_case, plane_normal
from tunnelquake.meshing.params import element_counts, resolve
from tunnelquake.solid_input import write_solid_input

GEOMETRY = {"x_range": [-20.0, 20.0], "y_range": [0.0, 80.0], "z_range": [-20.0, 20.0], "tunnel_centre_x": 0.0,
            "tunnel_centre_z": 0.0, "excavated_radius": 3.0, "lining_thickness": 0.5}
MESH = {"max_element_size": 6.0, "lining_elements_around": 16, "near_field_half_width": 8.0,
        "near_field_radial_divisions": 4, "elements_along_axis": 16}
FAULT = {"material": "fault", "width": 4.0, "strike": 60.0, "dip": 70.0, "point": [0.0, 40.0, 0.0],
         "elements_across": 3}
DIPPING = {"material": "sand", "dip": 25.0, "dip_direction": 300.0, "point": [0.0, 40.0, 10.0]}


def _mesh(tmp, k):
    geo = from_case({"fault_zone": FAULT, "dipping_layers": [DIPPING]})
    mesh = dict(MESH, refinement_factor=k)
    summary = build_tunnel_mesh(GEOMETRY, mesh, tmp, None, geo)
    with h5py.File(tmp / "mesh.h5") as f:
        names = [r.decode() if isinstance(r, bytes) else str(r) for r in f["elements"].attrs["regions"]]
        x = f["nodes/coordinates"][...][f["elements/connectivity"][...]]
        region = f["elements/region"][...]
    return geo, mesh, summary, names, x, region


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    return {k: _mesh(tmp_path_factory.mktemp(f"geology{k}"), k) for k in (1, 2)}


def test_every_centroid_satisfies_its_regions_plane_inequalities(meshes):
    geo, _, _, names, x, region = meshes[1]
    assert names == ["rock", "lining", "sand", "fault"]
    c = x.mean(axis=1)
    d_layer = geo.dipping[0].bottom.distance(c)
    d_fault = np.abs(geo.fault.plane.distance(c))
    half = 0.5 * FAULT["width"]
    fault, sand, rock = region == 3, region == 2, region == 0
    assert fault.sum() > 0 and sand.sum() > 0 and rock.sum() > 0
    assert (d_fault[fault] <= half).all()
    assert (d_fault[sand | rock] > half).all()
    assert (d_layer[sand] > 0).all() and (d_layer[rock] <= 0).all()
    # the plane's normal from the convention: dip 25 towards azimuth 300 (from +y towards -x)
    n = geo.dipping[0].bottom.normal
    assert n == pytest.approx((math.sin(math.radians(25)) * math.sin(math.radians(300)),
                               math.sin(math.radians(25)) * math.cos(math.radians(300)), math.cos(math.radians(25))))


def test_the_bands_volume_converges_to_the_analytic_one(meshes):
    errors = []
    for k in (1, 2):
        geo, _, _, _, x, region = meshes[k]
        vol = hexmesh.volumes(x[region == 3]).sum()
        around = MESH["lining_elements_around"]
        hole = 0.5 * around * GEOMETRY["excavated_radius"] ** 2 * math.sin(2 * math.pi / around)  # the n-gon
        exact = (40.0 * 40.0 - hole) * geo.fault.axial_length
        errors.append(abs(vol / exact - 1))
        print(f"refinement {k}: fault zone {vol:.2f} m^3 against {exact:.2f} m^3, {100 * (vol / exact - 1):+.3f} %")
    assert errors[0] < 0.03
    assert errors[1] < 0.6 * errors[0]  # the staircase error of the centroid rule shrinks with h


def test_the_band_has_elements_across_along_the_axis(meshes):
    for k in (1, 2):
        geo, mesh, _, _, x, region = meshes[k]
        plan = resolve(GEOMETRY, mesh, None, geo)
        y = np.asarray(plan.y_levels)
        # where the band's centre plane meets the tunnel axis (x = 0, z = 0): y = 40
        lo, hi = 40.0 - 0.5 * geo.fault.axial_length, 40.0 + 0.5 * geo.fault.axial_length
        inside = (0.5 * (y[1:] + y[:-1]) > lo) & (0.5 * (y[1:] + y[:-1]) < hi)
        assert inside.sum() >= FAULT["elements_across"] * k
        assert np.diff(y)[inside].max() <= geo.fault.axial_length / (FAULT["elements_across"] * k) + 1e-9
        assert np.diff(y).max() <= 80.0 / (MESH["elements_along_axis"] * k) + 1e-9


def test_check_counts_the_refined_mesh_before_meshing(meshes):
    for k in (1, 2):
        geo, mesh, summary, _, _, _ = meshes[k]
        est = element_counts(resolve(GEOMETRY, mesh, None, geo))
        assert est == {key: summary["counts"][key] for key in est}
        uniform = element_counts(resolve(GEOMETRY, mesh))
        assert est["rock"] > uniform["rock"]  # the refinement is counted


# ------------------------------------------------------------------------------------------------
# check: the case keys and their errors
# ------------------------------------------------------------------------------------------------
CASE = tunnel("geology_test", [-20.0, 20.0], [0.0, 80.0], [-20.0, 20.0], centre_z=0.0, radius=3.0, lining=0.5,
              max_element_size=6.0, lining_elements_around=16, near_field_half_width=8.0,
              near_field_radial_divisions=4, elements_along_axis=16) + """materials:
  rock: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.27, density: 2700}
  fault: {model: elastic, youngs_modulus: 1 GPa, poisson_ratio: 0.3, density: 2200}
  sand: {model: elastic, youngs_modulus: 3 GPa, poisson_ratio: 0.3, density: 2400}
  lining: {model: elastic, youngs_modulus: 28 GPa, poisson_ratio: 0.17, density: 2500}
geology:
  fault_zone: {material: fault, width: 4 m, strike: 60, dip: 70, point: [0, 40, 0], elements_across: 3}
  dipping_layers:
    - {material: sand, dip: 25, dip_direction: 90, point: [0, 40, 10]}
interface: {model: bonded}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + """in_situ: {kx: 1.0, ky: 1.0}
conditions: [no_water]
time: {end_time: 0.01}
"""


def _check(tmp_path, capsys, *edits):
    return check_edited(tmp_path, capsys, CASE, *edits)


def test_the_case_passes_check_with_the_refined_counts(tmp_path, capsys):
    rc, out, err = _check(tmp_path, capsys)
    assert rc == 0, err
    d = load_case(tmp_path / "case.yaml").data
    est = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))
    uniform = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d)))
    assert est["rock"] > uniform["rock"]
    assert (f"mesh: {est['rock']:,} ground (rock {est['regions']['rock']:,}, sand {est['regions']['sand']:,}, "
            f"fault {est['regions']['fault']:,}) + {est['lining']:,} lining + {est['water']:,} water hexahedra") in out
    assert "keep mesh.mode: 3d" in out  # no advice to use a slice


@pytest.mark.parametrize("edits, message", [
    (("point: [0, 40, 0]", "point: [0, 40, 400]"),
     "geology.fault_zone.point = [0.0, 40.0, 400.0]: the band (4 m wide about the plane through [0.0, 40.0, 400.0]) "
     "misses the block"),
    (("width: 4 m", "width: 70 m"),
     "geology.fault_zone.width = 70.0: the band, 70 m wide, is 86.02 m long along the tunnel axis"),
    (("dip: 70", "dip: 95"), "geology.fault_zone.dip = 95: must lie in (0, 90]"),
    (("dip: 70", "dip: 0"), "geology.fault_zone.dip = 0: must lie in (0, 90]"),
    (("dip: 25", "dip: -5"), "geology.dipping_layers[0].dip = -5: must lie in (0, 90]"),
    (("material: fault,", "material: gouge,"),
     "geology.fault_zone.material = 'gouge': is not a material of the case. Fix: add materials.gouge"),
    (("material: sand,", "material: clay,"),
     "geology.dipping_layers[0].material = 'clay': is not a material of the case. Fix: add materials.clay"),
    (("point: [0, 40, 10]", "point: [0, 40, 60]"),
     "geology.dipping_layers[0].point = [0.0, 40.0, 60.0]: its bottom plane (dip and dip_direction through "
     "[0.0, 40.0, 60.0]) passes above the block, leaving it without cutting it: the layer is empty"),
    (("point: [0, 40, 10]", "point: [0, 40, -60]"), "passes below the block, leaving it without cutting it: the "
                                                    "whole block is the layer"),
    (("material: sand,", "material: fault,"), "geology.fault_zone.material = 'fault': names a region the mesh has "
                                              "already"),
])
def test_input_errors_name_the_key(tmp_path, capsys, edits, message):
    rc, _, err = _check(tmp_path, capsys, *edits)
    assert rc == 1
    assert message in err, err


def test_a_fault_zone_in_a_slice_is_refused(tmp_path, capsys):
    rc, _, err = _check(tmp_path, capsys, "mesh:\n", "mesh:\n  mode: slice\n")
    assert rc == 1
    assert "geology.fault_zone.material = 'fault': a slice is one element thick along the axis" in err, err


def test_the_keys_are_documented_with_their_convention():
    from tunnelquake.docgen import table

    text = table()
    for key in ("geology.fault_zone", "geology.dipping_layers[].dip", "geology.dipping_layers[].dip_direction"):
        assert f"`{key}`" in text, key
    assert "`strike` (number): direction of the fault's horizontal trace, degrees in plan from the tunnel axis +y, " \
           "clockwise seen from above (towards +x)" in text
    assert meshing.geology.plane_normal(90.0, 90.0) == (1.0, 0.0, 0.0)  # vertical, facing +x
    assert plane_normal(30.0, 180.0)[1] < 0  # dipping towards -y: the normal leans to -y


# ------------------------------------------------------------------------------------------------
# tq-solid: the in-situ stress of a dipping layer under a horizontal cover
# ------------------------------------------------------------------------------------------------
STATIC = tunnel("dipping_static", [-400.0, 400.0], [0.0, 10.0], [-60.0, 100.0], centre_z=-20.0, radius=2.0,
                lining=0.3, mode="slice", max_element_size=8.0, near_field_half_width=8.0,
                lining_elements_around=16, near_field_radial_divisions=3) + """materials:
  rock: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.25, density: 2700}
  cover: {model: elastic, youngs_modulus: 1 GPa, poisson_ratio: 0.3, density: 1900}
  weak: {model: elastic, youngs_modulus: 3 GPa, poisson_ratio: 0.3, density: 2200}
  lining: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.25, density: 2700}
layers:
  - {material: cover, thickness: 10 m}
geology:
  dipping_layers:
    - {material: weak, dip: 20, dip_direction: 90, point: [0, 5, 40]}
interface: {model: bonded}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + """in_situ: {kx: 0.8, ky: 0.8, kz: 1.0}
stages:
  sequence: [in_situ, seismic]
  relaxation_tolerance: 1.0e-7
  relaxation_max_steps: 200000
conditions: [no_water]
time: {end_time: 0.002}
output:
  monitors:
    right_weak: [380.0, 5.0, 40.0]
    right_cover: [380.0, 5.0, 95.0]
    left_rock: [-380.0, 5.0, 40.0]
    middle: [60.0, 5.0, 40.0]
    middle_rock: [60.0, 5.0, 0.0]
"""
G = 9.81
Z_TOP, Z_COVER, TAN = 100.0, 90.0, math.tan(math.radians(20.0))
RHO = {"rock": 2700.0, "cover": 1900.0, "weak": 2200.0}


def _overburden(x, z):
    """g times the integral of rho along the vertical from the surface down to z at x: the cover
    to z = 90 m, then the weak layer down to its bottom plane z_b(x) = 40 - tan(20) x, then rock."""
    zb = 40.0 - TAN * x
    s, top = 0.0, Z_TOP
    for lo, rho in ((Z_COVER, RHO["cover"]), (zb, RHO["weak"]), (-1e9, RHO["rock"])):
        lo = max(lo, z)
        if top > lo:
            s += rho * (top - lo)
            top = lo
    return G * s


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_tq_solid_vertical_stress_is_the_overburden_far_from_the_dip(tmp_path, capsys):
    """The weak layer (dip 20 towards +x) meets the cover at x = -137 m and the base at x = 275 m:
    at x = -380 and +380 m the ground is laterally uniform over more than 100 m (the block is 160 m
    deep), so sigma_z = -g int rho dz is the equilibrium there. In the middle (x = 60 m) the
    vertical of the point below the interface (x = 60, z = 0 m) crosses it: printed, not asserted (the local column's integral
    is not the exact stress of a laterally varying ground)."""
    exe = _solid_with_stages()
    _, inp = checked_input(tmp_path, STATIC, capsys)
    with h5py.File(inp) as f:
        assert float(f["in_situ"].attrs["density"]) == RHO["rock"]  # the stress starts from one density
    res = tmp_path / "results.h5"
    run_solid(exe, inp, res, timeout=300)
    with h5py.File(res) as r:
        assert r.attrs["status"] == "completed"
        coords, conn = r["mesh/coordinates"][...], r["mesh/connectivity"][...]
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in r["mesh"].attrs["regions"]]
        region = r["mesh/region"][...]
        for name, region_name in (("right_weak", "weak"), ("right_cover", "cover"), ("left_rock", "rock"),
                                  ("middle", None), ("middle_rock", None)):
            g = r[f"monitors/{name}"]
            elem = int(g.attrs["element"])
            x, _, z = coords[conn[elem]].mean(axis=0)
            hand = -_overburden(x, z)
            got = float(g["stress"][0][2])
            print(f"{name} ({names[region[elem]]}, x = {x:.1f}, z = {z:.2f} m): sigma_z {got / 1e6:.4f} MPa, "
                  f"overburden {hand / 1e6:.4f} MPa, {100 * (got / hand - 1):+.3f} %")
            if region_name is not None:
                assert names[region[elem]] == region_name
                assert got == pytest.approx(hand, rel=0.01), (name, got, hand)


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_side_strips_reproduce_the_single_column_and_carry_the_band(tmp_path):
    exe = _solid_with_stages()
    text = (CASE.replace("end_time: 0.01", "end_time: 0.02")
            + "stages: {sequence: [in_situ, seismic], relaxation_tolerance: 1.0e-5}\n"
            + "output:\n  monitors:\n    crown: [0.0, 40.0, 3.0]\n    side: [-20.0, 20.0, 10.0]\n")
    histories = {}
    for name, fault in (("uniform", "  fault: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.27, "
                                    "density: 2700}\n  sand: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: "
                                    "0.27, density: 2700}\n"),
                        ("band", None)):
        run_dir = tmp_path / name
        run_dir.mkdir()
        t = text
        if fault is not None:
            start = t.index("  fault: {")
            end = t.index("  lining: {")
            t = t[:start] + fault + t[end:]
        (run_dir / "case.yaml").write_text(t)
        case = load_case(run_dir / "case.yaml")
        d = case.data
        mesh_and_motion(case, run_dir, ground_layers(d), case_geology(d))
        variants = {"strips": run_dir / "mesh.h5"}
        if name == "uniform":  # the same mesh with the whole side faces: one column each
            import shutil

            shutil.copy(run_dir / "mesh.h5", run_dir / "whole.h5")
            with h5py.File(run_dir / "whole.h5", "a") as f:
                for k in [k for k in f["faces"] if "_strip" in k]:
                    del f["faces"][k]
            variants["whole"] = run_dir / "whole.h5"
        for label, mesh_h5 in variants.items():
            inp = write_solid_input(case, mesh_h5, run_dir / "motion.h5", "no_water", run_dir / f"{label}.in.h5")
            with h5py.File(inp) as f:
                faces = f["boundaries/free_field"].attrs["faces"]
                faces = faces.decode() if isinstance(faces, bytes) else str(faces)
                assert (faces == "xmin,xmax") == (label == "whole"), faces
            res = run_dir / f"{label}.h5"
            run_solid(exe, inp, res, timeout=300)
            with h5py.File(res) as r:
                assert r.attrs["status"] == "completed"
                histories[(name, label)] = {m: r[f"monitors/{m}/u"][...] for m in ("crown", "side")}
    for m in ("crown", "side"):
        a, b = histories[("uniform", "strips")][m], histories[("uniform", "whole")][m]
        scale = np.abs(b).max()
        print(f"{m}: peak |u| {scale:.4g} m, strips against one column: max difference {np.abs(a - b).max():.3g} m")
        assert scale > 0
        assert np.abs(a - b).max() <= 1e-9 * scale
        band = histories[("band", "strips")][m]
        print(f"{m}: with the band and the layer, peak |u| {np.abs(band).max():.4g} m")
        assert np.isfinite(band).all()


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_check_times_the_step_of_a_thin_bands_elements(tmp_path):
    """A 0.2 m vertical band across the axis, 4 elements across: its 0.05 m axial elements (the band's
    and the lining's hexahedra in that stretch), not the lining's 0.17 m layer, set the stable step.
    check's run-time estimate takes it (case.axial_step, case.lining_layer_step) and is tq-solid's
    own step (--check) to round-off; the lining's layer alone would give 3.3x longer."""
    from tunnelquake.case import lining_layer_step, p_wave_speed
    from tunnelquake.scene import runtime_estimate
    from tunnelquake.solid_input import solid_step

    p = tmp_path / "case.yaml"
    p.write_text(CASE.replace("width: 4 m, strike: 60, dip: 70", "width: 0.2 m, strike: 90, dip: 90")
                 .replace("elements_across: 3", "elements_across: 4"))
    case = load_case(p)
    d = case.data
    inp = solid_input(case, tmp_path, ground_layers(d), case_geology(d))
    est, got = runtime_estimate(case).dt, solid_step(_solid_with_stages(), inp)
    lining = d["time"]["safety_factor"] * lining_layer_step(d)[0] / p_wave_speed(d["materials"]["lining"])
    print(f"step: estimated {est:.4g} s, tq-solid {got:.4g} s, the lining's layer alone {lining:.4g} s")
    assert est == pytest.approx(got, rel=1e-9)
    assert lining > 2 * got
