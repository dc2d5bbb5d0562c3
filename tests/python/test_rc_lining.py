"""A reinforced-concrete lining in the analysis (docs/solid_solver.md "Reinforced concrete lining"):
the case's one definition of the bars (design.reinforcement, the keys the design check reads) and
of the concrete (design.concrete) reaches tq-solid's `reinforced_concrete` lining with the ring's
geometry, and tq-solid builds it.

1. The lining region is written with fc = fck, fct = fctm (EN 1992-1-1 Table 3.1 from fck when not
   given: 0.30 fck^(2/3) = 2.896 MPa for C30), eps_c2/eps_cu2 of Table 3.1, the bar areas and axis
   distance of design.reinforcement, and the ring's centre, inner radius (excavated radius minus
   thickness), thickness and elements through it; the rock region gets none of them.
2. tq-solid accepts the file (`--check`).
3. A reinforced_concrete lining without the design block's fck or hoop bars is refused by the case
   check naming the key to add.
"""
from __future__ import annotations

import subprocess

import h5py
import pytest
from case_texts import synthetic_motion, tunnel

from tunnelquake import paths
from tunnelquake.case import load_case
from tunnelquake.meshing import build_tunnel_mesh
from tunnelquake.motion import from_case
from tunnelquake.prepare import write_motion
from tunnelquake.schema import CaseError
from tunnelquake.solid_input import write_solid_input

CASE = tunnel("rc_lining", [-30.0, 30.0], [0.0, 10.0], [-25.0, 40.0], centre_z=10.0, radius=3.5, lining=0.4,
              mode="slice", lining_elements_through=4) + """materials:
  rock: {model: elastic, youngs_modulus: 20 GPa, poisson_ratio: 0.25, density: 2650}
  lining: {model: reinforced_concrete, youngs_modulus: 33 GPa, poisson_ratio: 0.2, density: 2500}
interface: {model: bonded}
water: {head: 0 m, model: compressible}
""" + synthetic_motion("0.1 g", 0, 1.0) + """in_situ: {kx: 1.0, ky: 1.0, kz: 1.0}
time: {end_time: 0.01}
DESIGN
"""
DESIGN = """design:
  concrete: {fck: 30 MPa}
  reinforcement: {fyk: 500 MPa, As_inner: 1005 mm^2/m, As_outer: 1005 mm^2/m, As_inner_axial: 565 mm^2/m,
                  As_outer_axial: 565 mm^2/m, axis_distance: 60 mm}
"""


def _write(tmp_path, design=DESIGN):
    p = tmp_path / "case.yaml"
    p.write_text(CASE.replace("DESIGN", design))
    case = load_case(p)
    build_tunnel_mesh(case.data["geometry"], case.data["mesh"], tmp_path)
    motion, _ = from_case(case.data["ground_motion"], case.dir)
    write_motion(motion, tmp_path / "motion.h5")
    return write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", "no_water", tmp_path / "s.h5")


def test_the_design_blocks_bars_and_concrete_reach_the_lining(tmp_path):
    out = _write(tmp_path)
    with h5py.File(out) as f:
        a, rock = f["materials/lining"].attrs, f["materials/rock"].attrs
        assert a["model"] == "reinforced_concrete"
        assert a["fc"] == pytest.approx(30e6, rel=1e-12)
        assert a["fct"] == pytest.approx(0.30 * 30 ** (2 / 3) * 1e6, rel=1e-12)
        assert (a["eps_c2"], a["eps_cu2"]) == pytest.approx((2.0e-3, 3.5e-3), rel=1e-12)
        assert a["fy"] == pytest.approx(500e6) and a["Es"] == pytest.approx(200e9)
        assert a["As_inner_hoop"] == pytest.approx(1.005e-3) and a["As_outer_hoop"] == pytest.approx(1.005e-3)
        assert a["As_inner_axial"] == pytest.approx(5.65e-4) and a["As_outer_axial"] == pytest.approx(5.65e-4)
        assert a["axis_distance"] == pytest.approx(0.06)
        assert (a["ring_centre_x"], a["ring_centre_z"]) == pytest.approx((0.0, 10.0))
        assert a["ring_inner_radius"] == pytest.approx(3.1) and a["ring_thickness"] == pytest.approx(0.4)
        assert a["ring_layers"] == 4
        assert not {"fc", "eps_c2", "As_inner_hoop", "ring_inner_radius", "ring_layers"} & set(rock.keys())
    exe = paths.solid_executable()
    if exe is None:
        pytest.skip("tq-solid is not built")
    run = subprocess.run([str(exe), str(out), "--check", "--threads", "1"], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.mark.parametrize("design, key", [("", "design.concrete.fck"),
                                         ("design:\n  concrete: {fck: 30 MPa}\n", "design.reinforcement.As_inner")])
def test_a_reinforced_lining_needs_the_design_blocks_concrete_and_bars(tmp_path, design, key):
    with pytest.raises(CaseError) as e:
        _write(tmp_path, design=design)
    assert key in str(e.value) and "reinforced_concrete" in str(e.value)


def test_the_bars_of_a_reinforced_lining_are_in_its_results_fingerprint(tmp_path):
    """The bars and the concrete shape a reinforced_concrete lining's analysis, so they are in the
    conditions' input fingerprint (a `--resume` after a change of bars runs again, `post` refuses);
    with an elastic lining the same keys are the design check's only (post-only: a re-post)."""
    from tunnelquake.fingerprint import condition_inputs

    def digests(text):
        p = tmp_path / "case.yaml"
        p.write_text(text)
        case = load_case(p)
        return condition_inputs(case, "no_water")["digest"], condition_inputs(case, "no_water", post_only=True)["digest"]

    more_bars = DESIGN.replace("As_inner: 1005 mm^2/m", "As_inner: 1340 mm^2/m")
    rc, rc_more = digests(CASE.replace("DESIGN", DESIGN)), digests(CASE.replace("DESIGN", more_bars))
    assert rc[0] != rc_more[0] and rc[1] == rc_more[1]
    elastic = CASE.replace("model: reinforced_concrete", "model: elastic")
    el, el_more = digests(elastic.replace("DESIGN", DESIGN)), digests(elastic.replace("DESIGN", more_bars))
    assert el[0] == el_more[0] and el[1] != el_more[1]


@pytest.mark.parametrize("through, warned", [(4, True), (10, False)])
def test_check_warns_when_a_reinforced_linings_rows_cannot_reach_its_bending_resistance(tmp_path, through, warned):
    """With one stress per element row, the lining's bending resistance from its stresses stays below
    the section's M_Rd with few rows (a plane-section strip of 4 one-point rows reaches 0.87 of it, of
    10 0.989; the ring pushed in bending in the analysis: 0.83–0.87 with 4, 1.004 with 10,
    docs/solid_solver.md): the case check says so, naming the key and the fix; an elastic lining with
    4 rows gets no such warning."""
    p = tmp_path / "case.yaml"
    text = CASE.replace("DESIGN", DESIGN).replace("lining_elements_through: 4", f"lining_elements_through: {through}")
    p.write_text(text)
    said = [w for w in load_case(p).warnings if w.startswith("mesh.lining_elements_through")]
    assert bool(said) == warned
    if warned:
        assert "reinforced_concrete" in said[0] and "mesh.lining_elements_through: 10 or more" in said[0]
    p.write_text(text.replace("model: reinforced_concrete", "model: elastic"))
    assert not [w for w in load_case(p).warnings if w.startswith("mesh.lining_elements_through")]


@pytest.mark.parametrize("refine", [1, 2])
def test_the_bars_rows_are_the_meshs_rows(tmp_path, refine):
    """tq-solid places each bar layer in the lining's element rows by ring_layers (rc_law::steelRatio:
    rows of thickness / ring_layers from the inner radius), so ring_layers must be the mesh's rows
    through the thickness: mesh.lining_elements_through x mesh.refinement_factor (4 and 8 here), counted
    on the written mesh as the lining nodes' distinct radii less one. With refinement 2 the count of
    elements_through alone (4) put two mesh rows in each of tq-solid's, the bars smeared over twice
    their row."""
    import numpy as np

    p = tmp_path / "case.yaml"
    p.write_text(CASE.replace("DESIGN", DESIGN).replace("lining_elements_through: 4",
                                                        f"lining_elements_through: 4\n  refinement_factor: {refine}"))
    case = load_case(p)
    assert case.data["mesh"]["refinement_factor"] == refine
    build_tunnel_mesh(case.data["geometry"], case.data["mesh"], tmp_path)
    motion, _ = from_case(case.data["ground_motion"], case.dir)
    write_motion(motion, tmp_path / "motion.h5")
    out = write_solid_input(case, tmp_path / "mesh.h5", tmp_path / "motion.h5", "no_water", tmp_path / "s.h5")
    with h5py.File(tmp_path / "mesh.h5") as f:
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in f["elements"].attrs["regions"]]
        conn = f["elements/connectivity"][()][f["elements/region"][()] == names.index("lining")]
        x = f["nodes/coordinates"][()][np.unique(conn)]
    radii = np.unique(np.round(np.hypot(x[:, 0], x[:, 2] - 10.0), 6))
    with h5py.File(out) as f:
        assert f["materials/lining"].attrs["ring_layers"] == len(radii) - 1 == 4 * refine


def test_checks_step_takes_the_bars_stiffening_as_tq_solid(tmp_path):
    """tq-solid takes a reinforced_concrete lining's stable step at its concrete's moduli times
    1 + rho_max Es / M (rho_max the largest row steel ratio, hoop or axial: the 1005 mm^2/m hoop bars at
    60 mm in rows of 0.1 m: 1.0493 here). check's step (the case's mesh, scene.solid_frequencies with
    case.reinforced_lining_step_scale) is tq-solid's `--check` step to 1e-9; at the concrete's moduli
    alone it would be 1/sqrt(1.0493) = 0.976 of it too long, a step tq-solid refuses."""
    from conftest import solid_with
    from tunnelquake.case import reinforced_lining_step_scale
    from tunnelquake.scene import runtime_estimate
    from tunnelquake.solid_input import solid_step

    exe = solid_with("staged-seismic")
    if exe is None:
        pytest.skip("tq-solid with staged-seismic is not built")
    out = _write(tmp_path)
    case = load_case(tmp_path / "case.yaml")
    scale = reinforced_lining_step_scale(case.data)
    rho = 1.005e-3 * (1 - (0.06 / 0.1 - 0.5)) / 0.1  # the inner bars' share of the first row
    assert scale == pytest.approx(1 + rho * 200e9 / (33e9 * 0.8 / (1.2 * 0.6)), rel=1e-12)
    est = runtime_estimate(case, corrected=False, measure_if_missing=False).dt
    got = solid_step(exe, out)
    print(f"step: check {est:.9g} s, tq-solid {got:.9g} s, the bars' factor {scale:.5f}")
    assert est == pytest.approx(got, rel=1e-9)
