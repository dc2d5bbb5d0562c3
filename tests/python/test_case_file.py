"""The case file: the example validates, and bad inputs are rejected with a message naming the key,
the value, the line and a fix."""
from __future__ import annotations

import math
import re

import pytest
from case_texts import small_slice, synthetic_motion

from conftest import EXAMPLE, solid_with
from tunnelquake.case import load_case
from tunnelquake.schema import CaseError


def test_example_case_is_valid_and_in_si():
    case = load_case(EXAMPLE)
    rock, lining = case["materials"]["rock"], case["materials"]["lining"]
    # Paper Table 1, converted from the units written in the file to SI.
    assert rock["youngs_modulus"] == pytest.approx(8.0e9, rel=1e-12)
    assert rock["density"] == pytest.approx(2700.0)
    assert lining["cohesion"] == pytest.approx(1.8e6)
    assert lining["friction_angle"] == pytest.approx(40.0)
    assert case["interface"]["cohesion"] == pytest.approx(0.5e6)
    assert case["ground_motion"]["pga"] == pytest.approx(1.575)
    assert case["geometry"]["excavated_radius"] == pytest.approx(5.25)
    assert case["water"]["viscosity"] == pytest.approx(1.308e-3)


def test_unit_conversions():
    from tunnelquake import units as U

    assert U.parse_quantity("2.7 g/cm^3", U.MASS_DENSITY).value == pytest.approx(2700.0)
    assert U.parse_quantity("0.16 g", U.ACCELERATION).value == pytest.approx(0.16 * 9.80665)
    assert U.parse_quantity("1.308e-3 Pa*s", U.DYNAMIC_VISCOSITY).value == pytest.approx(1.308e-3)
    assert U.parse_quantity("0.5 rad", U.ANGLE).value == pytest.approx(math.degrees(0.5))
    assert U.parse_quantity("150 gal", U.ACCELERATION).value == pytest.approx(1.5)
    with pytest.raises(U.UnitError, match="length"):
        U.parse_quantity("8 m", U.PRESSURE)


def _mutate(text: str, *pairs: str) -> str:
    """Replace each (old, new) pair of `pairs` once."""
    for old, new in zip(pairs[::2], pairs[1::2], strict=True):
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


# Each bad input: (description, edit of the example, key that the message must name, words it must contain)
BAD_INPUTS = [
    ("unknown key", ("  density: 1000 kg/m^3\n", "  density: 1000 kg/m^3\n  colour: blue\n"),
     "water.colour", "not a known key"),
    ("misspelt key gets a suggestion", ("    poisson_ratio: 0.27\n", "    poison_ratio: 0.27\n"),
     "materials.rock.poison_ratio", "did you mean 'poisson_ratio'"),
    ("missing required key", ("    youngs_modulus: 28.0 GPa\n", ""),
     "materials.lining.youngs_modulus", "is missing"),
    ("negative density", ("    density: 2700 kg/m^3\n", "    density: -2700 kg/m^3\n"),
     "materials.rock.density", "> 0"),
    ("Poisson ratio 0.5", ("    poisson_ratio: 0.17\n", "    poisson_ratio: 0.5\n"),
     "materials.lining.poisson_ratio", "incompressible"),
    ("wrong units", ("    youngs_modulus: 8.0 GPa\n", "    youngs_modulus: 8.0 m\n"),
     "materials.rock.youngs_modulus", "length"),
    ("unknown unit", ("  pga: 1.575 m/s^2\n", "  pga: 1.575 furlongs\n"),
     "ground_motion.pga", "unknown unit"),
    ("record file missing", ("  if_missing: synthetic ", "  if_missing: error "),
     "ground_motion.file", "file not found"),
    ("bad choice", ("  model: compressible\n", "  model: gaseous\n"),
     "water.model", "use one of"),
    ("dynamic friction above static", ("  dynamic_friction: 0.6\n", "  dynamic_friction: 0.8\n"),
     "interface.dynamic_friction", "exceeds the static friction"),
    ("tunnel outside the block", ("  tunnel_centre_z: 32.0\n", "  tunnel_centre_z: 152.0\n"),
     "geometry.tunnel_centre_z", "does not fit"),
    ("lining thicker than the radius", ("  lining_thickness: 0.75 m\n", "  lining_thickness: 6 m\n"),
     "geometry.lining_thickness", "smaller than the excavated radius"),
    ("decreasing range", ("  x_range: [-60.0, 60.0]", "  x_range: [60.0, -60.0]"),
     "geometry.x_range", "increasing"),
    ("stages out of order", ("[in_situ, excavation, lining, hydrostatic, seismic]",
                             "[in_situ, lining, excavation, hydrostatic, seismic]"),
     "stages.sequence", "out of order"),
    ("incompressible water in a closed slice left to the water solver",
     ("  model: compressible\n  bulk_modulus: 2.2 GPa\n  ends: open\n",
      "  model: incompressible\n  bulk_modulus: 2.2 GPa\n  ends: open\n",
      "  scheme: implicit\n", "  scheme: implicit\n  volume_law: water\n"),
     "coupling.volume_law", "cannot change its volume"),
    ("incompressible water with closed ends in 3D left to the water solver",
     ("  model: compressible\n  bulk_modulus: 2.2 GPa\n  ends: open\n",
      "  model: incompressible\n  bulk_modulus: 2.2 GPa\n  ends: closed\n",
      "  mode: slice ", "  mode: 3d ", "  scheme: implicit\n", "  scheme: implicit\n  volume_law: water\n"),
     "coupling.volume_law", "cannot change its volume"),
    ("monitor outside", ("    top_arch:    [0.0, 40.0, 36.5]", "    top_arch:    [0.0, 40.0, 500.0]"),
     "output.monitors.top_arch", "outside the model"),
    ("friction angle of 90 degrees", ("    friction_angle: 37 deg\n", "    friction_angle: 90 deg\n"),
     "materials.rock.friction_angle", "[0, 90)"),
    ("negative damping ratio", ("  ratio: 0.05\n", "  ratio: -0.05\n"),
     "damping.ratio", "[0, 1)"),
    ("unknown condition", ("conditions: [no_water, static_water, dynamic_water]",
                           "conditions: [no_water, frozen_water]"),
     "conditions[1]", "use one of"),
    ("duplicated key", ("  ends: open\n", "  ends: open\n  ends: open\n"),
     "<yaml>", "appears twice"),
    ("coupling window of several steps with the paper scheme",
     ("  scheme: implicit\n", "  scheme: paper\n"),
     "coupling.window", "needs scheme explicit or implicit"),
    ("window force weight with the explicit scheme",
     ("  scheme: implicit\n", "  scheme: explicit\n  window_force_weight: 0.75\n"),
     "coupling.window_force_weight", "would have no effect"),
    ("window force weight with one-step windows",
     ("  window: 16\n", "  window: 1\n  window_force_weight: 0.75\n"),
     "coupling.window_force_weight", "window-end force alone"),
    ("defect correction with one-step windows",
     ("  window: 16\n", "  window: 1\n  defect_correction: 0.5\n"),
     "coupling.defect_correction", "none to carry"),
    ("MPI transport with OpenFOAM", ("  scheme: implicit\n", "  scheme: implicit\n  transport: mpi\n"),
     "coupling.transport", "cannot be one application of an MPMD mpirun job"),
    ("no OpenFOAM rank", ("stages:\n", "parallel:\n  fluid_ranks: 0\n\nstages:\n"),
     "parallel.fluid_ranks", "must be >= 1"),
    ("a fraction of an OpenFOAM rank", ("stages:\n", "parallel:\n  fluid_ranks: 1.5\n\nstages:\n"),
     "parallel.fluid_ranks", "whole number"),
]


@pytest.mark.parametrize("desc,edit,key,words", BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_input_is_rejected_naming_the_key(example_text, write_case, desc, edit, key, words):
    text = _mutate(example_text, *edit)
    if desc == "record file missing":
        text = text.replace("IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2", "no_such_record.AT2")
    path = write_case(text)
    with pytest.raises(CaseError) as err:
        load_case(path)
    msg = str(err.value)
    assert key in msg, msg
    assert words in msg, msg
    # every problem names a line of the file, so the user can go straight to it
    assert re.search(rf"{re.escape(str(path))}:\d+: ", msg), msg
    assert "Fix:" in msg


def test_all_problems_reported_at_once(example_text, write_case):
    text = _mutate(example_text, "    poisson_ratio: 0.27\n", "    poisson_ratio: 0.7\n")
    text = _mutate(text, "    density: 2500 kg/m^3\n", "    density: 0\n")
    with pytest.raises(CaseError) as err:
        load_case(write_case(text))
    paths = {i.path for i in err.value.issues}
    assert {"materials.rock.poisson_ratio", "materials.lining.density"} <= paths


def test_record_that_does_not_parse(example_text, write_case, tmp_path):
    bad = tmp_path / "broken.AT2"
    bad.write_text("header\nheader\nunits g\nno counts here\n 0.1 0.2\n")
    text = example_text.replace("../../../shared/data/ground_motions/IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2",
                                str(bad)).replace("if_missing: synthetic", "if_missing: error")
    with pytest.raises(CaseError) as err:
        load_case(write_case(text))
    assert "ground_motion.file" in str(err.value) and "NPTS" in str(err.value)


def test_synthetic_fallback_is_a_warning(example_text, write_case):
    text = example_text.replace("IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2", "absent.AT2")
    case = load_case(write_case(text))
    assert any("synthetic" in w for w in case.warnings)


def test_coarse_mesh_warns_about_wavelength(example_text, write_case):
    text = _mutate(example_text, "  max_element_size: 6.75 m", "  max_element_size: 10 m")
    case = load_case(write_case(text))
    # cs = sqrt(E / (2 (1 + nu) rho)) = 1080 m/s for the paper's rock; lambda_min / 8 at 20 Hz = 6.75 m
    assert any("lambda_min/8" in w and "6.75" in w for w in case.warnings), case.warnings


def test_user_guide_key_table_matches_the_schema():
    from conftest import ROOT
    from tunnelquake.docgen import BEGIN, END, table

    doc = (ROOT / "docs" / "user_guide.md").read_text()
    current = doc[doc.index(BEGIN) + len(BEGIN):doc.index(END)].strip()
    assert current == table().strip(), "run: python -m tunnelquake.docgen --write"


def test_water_ranks_are_accepted_and_too_many_warned(example_text, write_case):
    """parallel.fluid_ranks N > 1 runs the water decomposed (tests/python/test_fluid_ranks.py); more
    ranks than this process's cores is a warning naming the key and the fix, as is a value that
    no condition uses."""
    import os

    cores = len(os.sched_getaffinity(0))
    two = load_case(write_case(example_text.replace("stages:\n", "parallel:\n  fluid_ranks: 2\n\nstages:\n")))
    assert two["parallel"]["fluid_ranks"] == 2
    assert not any("fluid_ranks" in w for w in two.warnings) or cores < 2
    many = load_case(write_case(example_text.replace("stages:\n", f"parallel:\n  fluid_ranks: {cores + 1}\n\n"
                                                                     "stages:\n")))
    msg = [w for w in many.warnings if "parallel.fluid_ranks" in w]
    assert msg and f"use fluid_ranks <= {cores}" in msg[0], many.warnings
    dry = load_case(write_case(example_text.replace("stages:\n", "parallel:\n  fluid_ranks: 2\n\nstages:\n")
                               .replace("conditions: [no_water, static_water, dynamic_water]",
                                        "conditions: [no_water, static_water]")))
    assert any("has no effect" in w for w in dry.warnings), dry.warnings


def test_the_example_3d_variant_is_the_measured_3d_run_and_leaves_the_slice_alone():
    """`--variant 3d` lays the case file's `variants: 3d:` keys over the example: the settings of the
    full 3D run measured over the whole record (docs/benchmarks.md "The full 3D run"), its
    results beside the slice's, never over them."""
    base, v = load_case(EXAMPLE), load_case(EXAMPLE, "3d")
    assert base.variant is None and v.variant == "3d"
    assert base["mesh"]["mode"] == "slice" and v["mesh"]["mode"] == "3d"
    # keys the variant does not name keep the file's values (a merge, not a replacement)
    assert v["mesh"]["max_element_size"] == base["mesh"]["max_element_size"] == pytest.approx(6.75)
    assert v["water"]["bulk_modulus"] == base["water"]["bulk_modulus"]
    assert v["water"]["ends"] == "closed" and base["water"]["ends"] == "open"
    assert v["time"]["subcycling"] == 3 and base["time"]["subcycling"] == {"static_water": 3, "dynamic_water": 3}
    assert v["coupling"]["tolerance"] == pytest.approx(1e-4) and base["coupling"]["tolerance"] == pytest.approx(1e-3)
    assert v["coupling"]["window_force_weight"] == pytest.approx(0.75)
    assert v["coupling"]["window"] == base["coupling"]["window"] == 16
    assert v["conditions"] == ["dynamic_water"]
    assert v.output_dir == base.output_dir.with_name(base.output_dir.name + "_3d")


def test_a_bad_key_in_any_variant_is_said_before_a_run(example_text, write_case):
    """A variant not chosen is checked against the schema on every read: its problems are warnings
    naming the variant, the key and its line; choosing it makes them errors."""
    text = _mutate(example_text, "    coupling: {tolerance: 1e-4, window_force_weight: 0.75, volume_law: water",
                   "    coupling: {tolerence: 1e-4, window_force_weight: 0.75, volume_law: water")
    path = write_case(text)
    warned = [w for w in load_case(path).warnings if w.startswith("variant 3d would not run")]
    assert len(warned) == 1 and "coupling.tolerence" in warned[0], warned
    assert re.search(r"\(variant 3d\):\d+: ", warned[0]), warned
    with pytest.raises(CaseError) as err:
        load_case(path, "3d")
    msg = str(err.value)
    assert "(variant 3d)" in msg and "coupling.tolerence" in msg and "did you mean 'tolerance'" in msg, msg


def test_the_checks_across_sections_stop_only_the_variant_they_concern(example_text, write_case):
    """Incompressible water in the base file (a slice) is valid; the 3d variant leaves the volume law
    to the water solver (volume_law: water), which incompressible water cannot have: only a run of
    that variant is refused."""
    path = write_case(example_text.replace("  model: compressible\n", "  model: incompressible\n"))
    assert load_case(path)["water"]["model"] == "incompressible"
    with pytest.raises(CaseError) as err:
        load_case(path, "3d")
    msg = str(err.value)
    assert "(variant 3d)" in msg and "coupling.volume_law" in msg and "use volume_law: solid" in msg, msg


def test_an_unknown_variant_names_the_ones_there(write_case, example_text):
    path = write_case(example_text)
    with pytest.raises(CaseError) as err:
        load_case(path, "2d")
    msg = str(err.value)
    assert "--variant" in msg and "'2d'" in msg and "it has: 3d" in msg, msg


def test_a_variant_may_choose_its_own_results_folder_and_must_be_a_mapping(example_text, write_case):
    text = example_text + "  mine:\n    output: {directory: elsewhere}\n"
    case = load_case(write_case(text), "mine")
    assert case.output_dir.name == "elsewhere"
    with pytest.raises(CaseError, match="variants.broken.*must be a mapping of case sections"):
        load_case(write_case(example_text + "  broken: 3\n"))


@pytest.mark.parametrize("value", ["1.5", "-0.2"])
def test_check_refuses_a_release_fraction_outside_0_1(example_text, write_case, capsys, value):
    """stages.release_fraction is a fraction of the excavation load: `tunnelquake check` refuses a
    value outside [0, 1], naming the key and its line."""
    from tunnelquake.cli import main

    text = _mutate(example_text, "stages:\n", f"stages:\n  release_fraction: {value}\n")
    path = write_case(text)
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"stages.release_fraction = {value}" in err, err
    assert "must lie in [0, 1]" in err and "Fix:" in err, err
    assert re.search(rf"{re.escape(str(path))}:\d+: ", err), err


def test_release_fraction_needs_the_lining_stage(example_text, write_case):
    text = _mutate(example_text, "[in_situ, excavation, lining, hydrostatic, seismic]",
                   "[in_situ, excavation, hydrostatic, seismic]\n  release_fraction: 0.5")
    with pytest.raises(CaseError) as err:
        load_case(write_case(text))
    assert "stages.release_fraction" in str(err.value) and "lining" in str(err.value)


def test_check_refuses_the_largest_residual_scale_without_the_implicit_scheme(example_text, write_case, capsys):
    """coupling.residual_scale largest changes the implicit scheme's convergence test: with the explicit
    scheme (which tests none) `tunnelquake check` refuses it, naming the key, its value and the fix."""
    from tunnelquake.cli import main

    text = re.sub(r"\n  predictor: \w+\n", "\n  predictor: auto\n  residual_scale: largest\n", example_text)
    text = _mutate(text, "  scheme: implicit\n", "  scheme: explicit\n")
    assert main(["check", str(write_case(text))]) == 1
    err = capsys.readouterr().err
    assert "coupling.residual_scale = 'largest'" in err, err
    assert "the residual scale is the implicit scheme's convergence test; the explicit scheme tests none" in err, err
    assert "use residual_scale: current, or scheme: implicit" in err, err


def test_check_refuses_one_pass_a_window_for_the_implicit_scheme(example_text, write_case, capsys):
    """coupling.max_iterations 1 with the implicit scheme is refused by tq-solid's coupling configuration
    (it needs a pass to compare and one to correct), which reads it only after the static stages:
    `tunnelquake check` refuses it first, naming the key, its value, its line and the fix; 2 passes."""
    from tunnelquake.cli import main

    text = _mutate(example_text, "  scheme: implicit\n", "  scheme: implicit\n  max_iterations: 1\n")
    path = write_case(text)
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert "coupling.max_iterations = 1" in err, err
    assert "tq-solid refuses fewer than 2" in err and "set max_iterations: 2 or more" in err, err
    assert re.search(rf"{re.escape(str(path))}:\d+: ", err), err
    two = load_case(write_case(_mutate(example_text, "  scheme: implicit\n", "  scheme: implicit\n  max_iterations: 2\n")))
    assert two["coupling"]["max_iterations"] == 2


@pytest.mark.parametrize("predictor", ["linear", "damped"])
def test_check_refuses_an_extrapolating_predictor_without_the_implicit_scheme(example_text, write_case, capsys,
                                                                              predictor):
    """coupling.predictor linear and damped start the implicit scheme's passes: with the explicit scheme
    `tunnelquake check` refuses either, naming the key, its value and the fix."""
    from tunnelquake.cli import main

    text = re.sub(r"\n  predictor: \w+\n", f"\n  predictor: {predictor}\n", example_text)
    text = _mutate(text, "  scheme: implicit\n", "  scheme: explicit\n")
    assert main(["check", str(write_case(text))]) == 1
    err = capsys.readouterr().err
    assert f"coupling.predictor = '{predictor}'" in err, err
    assert f"the {predictor} predictor starts the iterations of the implicit scheme" in err, err
    assert "use predictor: auto (or constant), or scheme: implicit" in err, err


def _check_error(text: str, write_case, capsys) -> tuple[str, str]:
    """`tunnelquake check` of `text`: (the path written, its error output), asserting it failed."""
    from tunnelquake.cli import main

    path = write_case(text)
    assert main(["check", str(path)]) == 1
    return str(path), capsys.readouterr().err


def test_check_refuses_a_bar_axis_beyond_the_linings_mid_thickness(example_text, write_case, capsys):
    """A reinforced_concrete lining's design.reinforcement.axis_distance at or beyond half the lining's
    thickness is refused by tq-solid's material when the run builds the lining: `tunnelquake check`
    refuses it first, naming the key, its value, its line and the fix; a value below half passes."""
    def case(a):
        return _mutate(example_text, "  lining:\n    model: mohr_coulomb_damage\n",
                       "  lining:\n    model: reinforced_concrete\n",
                       "\nreference:\n", "\ndesign:\n  concrete: {fck: 30 MPa}\n  reinforcement:\n"
                       "    As_inner: 1005 mm2/m\n    As_outer: 1005 mm2/m\n"
                       f"    axis_distance: {a}\n\nreference:\n")

    path, err = _check_error(case("0.375 m"), write_case, capsys)
    assert "design.reinforcement.axis_distance = 0.375" in err, err
    assert "needs 0 < axis_distance < lining_thickness / 2" in err, err
    assert "give design.reinforcement.axis_distance below 0.375 m" in err, err
    line = case("0.375 m").splitlines().index("    axis_distance: 0.375 m") + 1
    assert f"{path}:{line}: " in err, err
    assert load_case(write_case(case("0.3 m")))["design"]["reinforcement"]["axis_distance"] == pytest.approx(0.3)


def test_check_refuses_a_time_step_above_the_stable_step(example_text, write_case, capsys):
    """time.dt above safety_factor x the solid's critical step is refused by tq-solid when it builds its
    solver (the example: 0.9 x 7.00074e-5 s, element 31634 of the lining, its `--check`): `tunnelquake
    check` refuses a step above that bound (the lining's innermost hexahedra, 0.25 m thick between
    chords of 48 around, 3470 m/s), naming the key, its value, its line and the fix, also one just above
    it (6.35e-5 s, which the thickness alone, 6.48e-5 s, let through to the run); a step below passes."""
    def case(dt):
        return _mutate(example_text, "\ntime:\n", f"\ntime:\n  dt: {dt}\n")

    path, err = _check_error(case("1e-3 s"), write_case, capsys)
    assert "time.dt = 0.001" in err and "is above the solid's stable step, about 6.3e-05 s" in err, err
    assert "leave time.dt out (the stable step x safety_factor), or give at most 6.3e-05 s" in err, err
    line = case("1e-3 s").splitlines().index("  dt: 1e-3 s") + 1
    assert f"{path}:{line}: " in err, err
    _, err = _check_error(case("6.35e-5 s"), write_case, capsys)
    assert "time.dt = 6.35e-05" in err, err
    assert load_case(write_case(case("6.3e-5 s")))["time"]["dt"] == pytest.approx(6.3e-5)


@pytest.mark.skipif(solid_with("staged-seismic") is None, reason="tq-solid with staged-seismic is not built")
@pytest.mark.parametrize("refine", [1, 2])
def test_checks_critical_step_is_tq_solids_on_another_lining(refine, tmp_path):
    """check's critical step (case.critical_step: the lining's hexahedra, volume over largest face) is
    tq-solid's own (`--check --json`, safety x its stable step) to round-off on a lining unlike the
    paper's: a 3 m tunnel with a 0.4 m lining of 32 GPa, 16 elements around and 2 through, 1 m thick
    slice (mass-proportional damping: no cut), and with mesh.refinement_factor 2 (32 around, 4
    through), which the lining's thickness over mesh.lining_elements_through alone missed by 2x. The
    inner layer's hexahedra set it: their hoop chords and the chords' distance make L 0.946x the
    layer's thickness at 16 around."""
    from conftest import solid_input
    from tunnelquake.case import _mesh_plan, critical_step
    from tunnelquake.solid_input import solid_step

    p = tmp_path / "case.yaml"
    p.write_text(small_slice("step_test").replace("near_field_radial_divisions: 3\n",
                                                  "near_field_radial_divisions: 3\n  slice_thickness: 1 m\n"
                                                  f"  refinement_factor: {refine}\n")
                 + synthetic_motion("1 m/s^2", 0.5, "0.5 s"))
    case = load_case(p)
    d = case.data
    assert d["mesh"]["refinement_factor"] == refine
    ours = d["time"]["safety_factor"] * critical_step(d, _mesh_plan(d))
    got = solid_step(solid_with("staged-seismic"), solid_input(case, tmp_path))
    print(f"refinement {refine}: check {ours:.9g} s, tq-solid {got:.9g} s")
    assert ours == pytest.approx(got, rel=1e-9)
    h1 = 0.4 / (2 * refine)  # the layer's thickness at the lining's 3771.2 m/s
    assert ours < 0.99 * d["time"]["safety_factor"] * h1 / 3771.2


@pytest.mark.skipif(solid_with("staged-seismic") is None, reason="tq-solid with staged-seismic is not built")
def test_checks_step_is_the_meshs_where_the_rock_sets_it(tmp_path, capsys):
    """Stiff rock (60 GPa) with 30 graded divisions across the near field: its first ring's hexahedra,
    not the lining's, set the stable step, 8x shorter than the lining's (tq-solid's `--check` 5.46e-6 s
    against the lining's 4.5e-5 s). check takes the step from the case's mesh (scene.solid_frequencies,
    each region's hexahedra's largest 2 c_p / L): its run-time estimate's step is tq-solid's to 1e-9;
    time.dt 1e-5 s, which the mesh plan's estimate let through, is refused, naming the key, the limit,
    the region and the fix; 5e-6 s passes."""
    from conftest import solid_input
    from tunnelquake.cli import main
    from tunnelquake.scene import runtime_estimate
    from tunnelquake.solid_input import solid_step

    text = (small_slice("rock_step").replace("near_field_radial_divisions: 3\n",
                                             "near_field_radial_divisions: 30\n  slice_thickness: 1 m\n")
            .replace("youngs_modulus: 12 GPa", "youngs_modulus: 60 GPa") + synthetic_motion("1 m/s^2", 0.5, "0.5 s"))
    p = tmp_path / "case.yaml"
    p.write_text(text)
    case = load_case(p)
    got = solid_step(solid_with("staged-seismic"), solid_input(case, tmp_path / "solid"))
    est = runtime_estimate(case, corrected=False, measure_if_missing=False).dt
    print(f"step: check {est:.9g} s, tq-solid {got:.9g} s")
    assert est == pytest.approx(got, rel=1e-9)
    p.write_text(text + "time:\n  dt: 1e-5 s\n")
    assert main(["check", str(p)]) == 1
    err = capsys.readouterr().err
    assert f"time.dt = 1e-05 s is above the solid's stable step on this mesh, {got:.4g} s" in err, err
    assert "in region 'rock'" in err and f"Fix: leave time.dt out (the stable step x safety_factor), or give at " \
        f"most {got:.4g} s" in err, err
    p.write_text(text + "time:\n  dt: 5e-6 s\n")
    assert main(["check", str(p)]) == 0, capsys.readouterr().err


def test_check_refuses_a_relaxation_tolerance_of_one(example_text, write_case, capsys):
    """stages.relaxation_tolerance 1 is outside the (0, 1) solid_input.h5 takes (the run stopped writing
    it): `tunnelquake check` refuses it, naming the key, its value, its line and the fix; 0.5 passes."""
    def case(tol):
        return _mutate(example_text, "\nstages:\n", f"\nstages:\n  relaxation_tolerance: {tol}\n")

    path, err = _check_error(case("1.0"), write_case, capsys)
    assert "stages.relaxation_tolerance = 1.0: must lie in (0, 1)" in err, err
    assert "Fix: give a value in (0, 1)" in err, err
    line = case("1.0").splitlines().index("  relaxation_tolerance: 1.0") + 1
    assert f"{path}:{line}: " in err, err
    assert load_case(write_case(case("0.5")))["stages"]["relaxation_tolerance"] == pytest.approx(0.5)


def test_check_refuses_open_water_ends_on_fewer_than_three_planes(example_text, write_case, capsys):
    """With water.ends open and the volume law in the solid, tq-solid's open-ends law needs three planes
    of wet nodes along the axis (two axial elements along the lining) and refused fewer only when it
    connected to the water, after the static stages: `tunnelquake check` refuses the half block of
    elements_along_axis 2 (one element along its lining), naming the key, its value, its line and the
    fix; 4 (two) passes."""
    def case(n):
        text = _mutate(example_text, "  y_range: [0.0, 80.0] ", "  y_range: [0.0, 10.0] ",
                       "  mode: slice ", f"  mode: 3d\n  symmetry: mid_length\n  elements_along_axis: {n}\n  # ",
                       "conditions: [no_water, static_water, dynamic_water]", "conditions: [dynamic_water]",
                       "  subcycling: {static_water: 3, dynamic_water: 3}", "  subcycling: 0")
        return re.sub(r"(\[-?[\d.]+, )40\.0(, [\d.]+\])", r"\g<1>2.0\g<2>", text)

    path, err = _check_error(case(2), write_case, capsys)
    assert "mesh.elements_along_axis = 2: leaves the lining 1 axial element in the half block" in err, err
    assert "has 2 planes of nodes along the axis" in err and "tq-solid needs at least 3" in err, err
    assert "give more elements_along_axis" in err and "or water.ends: closed" in err, err
    line = case(2).splitlines().index("  elements_along_axis: 2") + 1
    assert f"{path}:{line}: " in err, err
    assert load_case(write_case(case(4)))["mesh"]["elements_along_axis"] == 4


def _plugged_axial_case(geology: str, materials: str = "") -> str:
    """A small 3D block (the axial-wave case's ground and tunnel, no incident wave) with its tunnel's ends
    plugged and a motion along the axis (azimuth 90): its y faces take the first side's column."""
    return f"""name: shared_column
geometry:
  x_range: [-40.0, 40.0]
  y_range: [0.0, 48.0]
  z_range: [-40.0, 30.0]
  tunnel_centre_z: 0.0
  excavated_radius: 3.5 m
  lining_thickness: 0.35 m
mesh:
  mode: 3d
  max_element_size: 8 m
  lining_elements_around: 16
  lining_elements_through: 1
  elements_along_axis: 6
  near_field_half_width: 10 m
  near_field_radial_divisions: 3
  water_ring_divisions: 1
  tunnel_end_plugs: 1
materials:
  rock: {{model: elastic, youngs_modulus: 20 GPa, poisson_ratio: 0.25, density: 2600 kg/m^3}}
  lining: {{model: elastic, youngs_modulus: 30 GPa, poisson_ratio: 0.2, density: 2500 kg/m^3}}
{materials}geology:
{geology}
interface: {{model: bonded}}
ground_motion:
  source: synthetic
  pga: 0.2 g
  azimuth: 90
  vertical_ratio: 0
  cutoff_frequency: 15 Hz
  synthetic: {{duration: 2 s, dt: 0.005 s}}
stages: {{sequence: [seismic]}}
conditions: [no_water]
time: {{end_time: 0.05 s}}
"""


SOFT = "  soft: {model: elastic, youngs_modulus: 2 GPa, poisson_ratio: 0.3, density: 2300 kg/m^3}\n"


@pytest.mark.parametrize("geology,materials,key,value,words,valid", [
    ("  slope: {angle: 12, dip_direction: 90, crest: [10.0, 0.0]}", "", "geology.slope.angle", "12.0",
     "leaves the ground at the ymin face's corner x = -40 m at z = 30 m, above the top of the column, z = 23.62 m",
     "  slope: {angle: 12, dip_direction: 270, crest: [10.0, 0.0]}"),
    ("  fault_zone: {material: soft, width: 10 m, strike: 60, dip: 70, point: [0, 24, 0]}", SOFT,
     "geology.fault_zone.material", "'soft'", "makes the ground at the ymin face near x = ",
     "  fault_zone: {material: soft, width: 10 m, strike: 90, dip: 90, point: [0, 24, 0]}"),
    ("  dipping_layers: [{material: soft, dip: 20, dip_direction: 90, point: [0.0, 24.0, 18.0]}]", SOFT,
     "geology.dipping_layers[0].material", "'soft'", "makes the ground at the ymin face near x = ", None),
])
def test_check_refuses_a_geology_the_y_faces_shared_column_does_not_follow(write_case, capsys, geology, materials,
                                                                         key, value, words, valid):
    """A motion along the axis in a 3D model with plugged ends drives its y faces by the first side's
    free-field column, shared (with geology the xmax side's first strip): tq-solid refused, when the shaking
    started, a y face whose ground rises above that column (a slope rising from xmax: the node at z = 30 m
    outside the column's -40 .. 23.62 m) or is not of the column's material at its height (a fault
    zone or a dipping layer reaching the y faces otherwise than that strip). `tunnelquake check` refuses
    it first, naming the key, its value, its line and the fix; the slope descending away from xmax, and the
    fault zone square to the axis clear of the end layers, pass."""
    text = _plugged_axial_case(geology, materials)
    path, err = _check_error(text, write_case, capsys)
    assert f"{key} = {value}: " in err and words in err, err
    assert "share the free-field column of the first strip of the xmax side" in err, err
    assert "or use a motion across the tunnel and vertical only (azimuth 0 or 180, no second_horizontal)" in err, err
    line = text.splitlines().index(geology) + 1
    assert f"{path}:{line}: " in err, err
    if valid is not None:
        assert load_case(write_case(_plugged_axial_case(valid, materials)))["ground_motion"]["azimuth"] == 90
