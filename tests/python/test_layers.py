"""Layered ground: the case's `layers:`, the mesher's regions and counts, and tq-solid's layered
in-situ stress.

1. Misuse is refused naming the key: a layer's material missing, or rock/lining, or used twice; a
   material no layer names; bottoms out of order; a layer reaching into the near-field box; a
   layer thinner than an element; bottom and thickness both or neither.
2. The mesh (a slice of the paper's block under a 24.7 m weathered layer): regions rock, lining,
   weathered in mesh.h5; every ground element wholly on its side of the interface; the counts
   equal params.element_counts' estimate from the divisions.
3. End to end (solid only, a wide slice so that the tunnel's disturbance at the monitors is below
   0.1 %): the vertical stress at the seismic start at a monitor in each layer against the
   layered overburden sigma_z = -g (rho_w (z_top - max(z, z_b)) + rho_r max(z_b - z, 0)) at the
   monitored element's centre, within 1 %. Runs only when tq-solid is built.
"""
from __future__ import annotations

import h5py
import pytest
from case_texts import synthetic_motion, tunnel
from test_solid_input import _solid_with_stages

from conftest import run_solid, solid_input
from tunnelquake.case import ground_layers, load_case
from tunnelquake.cli import main
from tunnelquake.meshing import build_tunnel_mesh
from tunnelquake.meshing.params import element_counts, resolve

CASE = tunnel("layers_test", "[XMIN, XMAX]", [0.0, 80.0], [-28.0, 154.7], centre_z=32.0, radius=5.25, lining=0.75,
              mode="slice") + """materials:
  rock: {model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.27, density: 2700}
  weathered: {model: elastic, youngs_modulus: 2 GPa, poisson_ratio: 0.3, density: 2100}
  lining: {model: elastic, youngs_modulus: 28 GPa, poisson_ratio: 0.17, density: 2500}
layers:
  - material: weathered
    thickness: 24.7 m
interface: {model: bonded}
""" + synthetic_motion("1.0 m/s^2", 0.6666666666666666, 1.0) + """in_situ: {kx: 1.1, ky: 0.8, kz: 1.0}
stages:
  sequence: [in_situ, excavation, lining, seismic]
  relaxation_tolerance: 1.0e-6
  relaxation_max_steps: 100000
conditions: [no_water]
time: {end_time: 0.002}
output:
  monitors:
    in_weathered: [MX, 40.0, 142.0]
    in_rock: [MX, 40.0, 100.0]
"""
Z_TOP, Z_B, RHO_W, RHO_R, G = 154.7, 130.0, 2100.0, 2700.0, 9.81


def _write(tmp_path, *edits, xmin=-60.0, xmax=60.0, mx=-50.0, name="case.yaml"):
    text = CASE.replace("XMIN", str(xmin)).replace("XMAX", str(xmax)).replace("MX", str(mx))
    for old, new in zip(edits[::2], edits[1::2], strict=True):
        assert old in text, old
        text = text.replace(old, new, 1)
    p = tmp_path / name
    p.write_text(text)
    return p


def _check(capsys, path) -> tuple[int, str]:
    rc = main(["check", str(path)])
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err
    return rc, out.err


def test_the_example_layers_pass_check_and_resolve_to_a_bottom(tmp_path, capsys):
    p = _write(tmp_path)
    rc, err = _check(capsys, p)
    assert rc == 0, err
    assert ground_layers(load_case(p).data) == [("weathered", pytest.approx(Z_B))]


@pytest.mark.parametrize("edits, message", [
    (("material: weathered", "material: clay"),
     "layers[0].material = 'clay': is not a material of the case. Fix: add materials.clay"),
    (("material: weathered", "material: rock"),
     "layers[0].material = 'rock': is the region below the layers, not a layer's"),
    (("    thickness: 24.7 m\n", "    thickness: 24.7 m\n  - material: weathered\n    thickness: 10 m\n"),
     "layers[1].material = 'weathered': names the material of another layer"),
    (("layers:\n  - material: weathered\n    thickness: 24.7 m\n", ""),
     "materials.weathered = 'weathered': is not a region of the mesh: no entry of layers names it"),
    (("    thickness: 24.7 m\n", "    bottom: 130 m\n    thickness: 24.7 m\n"),
     "layers[0].bottom = 130.0: give the layer's bottom elevation or its thickness, one of the two"),
    (("    thickness: 24.7 m\n", "    bottom: 160 m\n"),
     "layers[0].bottom = 160.0: must lie below the ground surface (geometry.z_range[1]) at z = 154.7 m"),
    (("    thickness: 24.7 m\n", "    thickness: 120 m\n"),
     "layers[0].thickness = 120.0: its bottom at z = 34.7 m reaches below the top of the near-field box"),
    (("    thickness: 24.7 m\n", "    thickness: 1 m\n"),
     "thinner than one element of the near-field box"),
])
def test_misused_layers_are_refused_naming_the_key(tmp_path, capsys, edits, message):
    rc, err = _check(capsys, _write(tmp_path, *edits))
    assert rc == 1
    assert message in err, err


def test_a_layer_into_the_near_field_box_is_refused(tmp_path, capsys):
    rc, err = _check(capsys, _write(tmp_path, "    thickness: 24.7 m\n", "    bottom: 40 m\n"))
    assert rc == 1
    assert ("layers[0].bottom = 40.0: reaches below the top of the near-field box around the tunnel at z = 46 m"
            in err), err


def test_bottoms_out_of_order_are_refused(tmp_path, capsys):
    text = ("    thickness: 24.7 m\n", "    bottom: 130 m\n  - material: soft\n    bottom: 140 m\n",
            "  lining: {", "  soft: {model: elastic, youngs_modulus: 1 GPa, poisson_ratio: 0.3, density: 2000}\n"
            "  lining: {")
    rc, err = _check(capsys, _write(tmp_path, *text))
    assert rc == 1
    assert "layers[1].bottom = 140.0: must lie below the bottom of layer 0 at z = 130 m" in err, err


@pytest.fixture(scope="module")
def layered_mesh(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("layers_mesh")
    case = load_case(_write(tmp))
    d = case.data
    summary = build_tunnel_mesh(d["geometry"], d["mesh"], tmp, ground_layers(d))
    return tmp, case, summary


def test_the_layer_is_a_mesh_region_between_grid_lines(layered_mesh):
    tmp, case, summary = layered_mesh
    with h5py.File(tmp / "mesh.h5") as f:
        names = [r.decode() if isinstance(r, bytes) else str(r) for r in f["elements"].attrs["regions"]]
        assert names == ["rock", "lining", "weathered"]
        region = f["elements/region"][...]
        x = f["nodes/coordinates"][...][f["elements/connectivity"][...]]
    zlo, zhi = x[:, :, 2].min(axis=1), x[:, :, 2].max(axis=1)
    w = region == 2
    assert w.any() and (zlo[w] >= Z_B - 1e-9).all()
    assert (zhi[region == 0] <= Z_B + 1e-9).all()
    # The weathered layer spans the block's width: nx columns times its rows.
    d = case.data
    est = element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d)))
    assert est["regions"] == summary["counts"]["regions"] == {"rock": int((region == 0).sum()),
                                                               "weathered": int(w.sum())}
    assert est["rock"] == summary["counts"]["rock"] == int((region != 1).sum())
    assert est == {k: summary["counts"][k] for k in est}




@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_tq_solid_in_situ_stress_is_the_layered_overburden(tmp_path):
    exe = _solid_with_stages()
    case = load_case(_write(tmp_path, xmin=-300.0, xmax=300.0, mx=-280.0))
    inp = solid_input(case, tmp_path, ground_layers(case.data))
    res = tmp_path / "results.h5"
    run_solid(exe, inp, res, timeout=300)
    with h5py.File(res) as r:
        assert r.attrs["status"] == "completed"
        coords = r["mesh/coordinates"][...]
        for name, layer in (("in_weathered", "weathered"), ("in_rock", "rock")):
            g = r[f"monitors/{name}"]
            elem = int(g.attrs["element"])
            z = float(coords[r["mesh/connectivity"][elem]][:, 2].mean())
            hand = -G * (RHO_W * (Z_TOP - max(z, Z_B)) + RHO_R * max(Z_B - z, 0.0))
            got = float(g["stress"][0][2])
            print(f"{name} ({layer}, z = {z:.2f} m): sigma_z {got / 1e6:.4f} MPa, layered hand value "
                  f"{hand / 1e6:.4f} MPa, {100 * (got / hand - 1):+.3f} %")
            assert got == pytest.approx(hand, rel=0.01), (name, got, hand)
