"""benchmarks.cost_error's analysis on hand-made runs: the worst relative peak difference against the
reference, the Pareto front of (CPU, error), and the cheaper points within 0.1 % (hand-computed)."""
import math

from benchmarks.cost_error import analyse, energy_ratio, errors


def _run(name, cpu, s3, p, n, role="", cond="dynamic_water"):
    return {"name": name, "condition": cond, "role": role, "completed": True, "cpu_s": cpu, "wall_s": cpu,
            "peaks": {"a": {"max_tension": s3, "min_sigma1": -2.0e6, "hydrodynamic_pressure_peak": p,
                            "max_ux": 0.01, "max_uz": 0.02, "max_damage": 0.0},
                      "b": {"max_tension": 1.0e6, "min_sigma1": -1.0e6, "max_ux": 0.01, "max_uz": 0.02}},
            "rings": {"N": n, "M": 1.0e5}}


def test_worst_difference_names_the_quantity():
    ref = _run("ref", 100.0, 1.0e6, 2.0e5, 2.0e6, "reference")
    r = _run("x", 10.0, 1.002e6, 2.01e5, 2.0e6)  # sigma3 +0.2 %, pressure +0.5 %
    e = errors(r, ref)
    assert math.isclose(e["each"]["sigma3"], 0.002, rel_tol=1e-9)
    assert math.isclose(e["each"]["pressure"], 0.005, rel_tol=1e-9)
    assert e["worst_of"] == "pressure" and math.isclose(e["worst"], 0.005, rel_tol=1e-9)
    assert e["each"]["ring N"] == 0.0 and e["damage"] == 0.0  # equal peaks: no difference


def test_front_and_cheaper_points_within_target():
    runs = [_run("ref", 100.0, 1.0e6, 2.0e5, 2.0e6, "reference"),
            _run("default", 20.0, 1.0e6, 2.004e5, 2.0e6, "default"),  # 0.2 %
            _run("cheap_ok", 15.0, 1.0005e6, 2.0e5, 2.0e6),  # 0.05 %: cheaper and within 0.1 %
            _run("cheap_bad", 10.0, 1.0e6, 2.1e5, 2.0e6),  # 5 %: cheapest, on the front
            _run("dear_bad", 30.0, 1.0e6, 2.1e5, 2.0e6)]  # dominated by every other
    a = analyse(runs)["dynamic_water"]
    assert a["front"] == ["cheap_bad", "cheap_ok"]
    assert a["default_on_front"] is False
    assert a["cheaper_within_target"] == ["cheap_ok"]


def test_the_3d_ladder_lays_the_variant_under_each_points_keys(tmp_path):
    """--variant 3d: every point is the case file's `3d` variant (its mesh mode, subcycling, closed
    ends, coupling) with the point's own keys on top, one thread, condition 3 alone, and each written
    case is a valid case file."""
    import yaml

    from benchmarks.cost_error import DEFAULT_CASE, points_3d, write_point
    from benchmarks.paper import slug
    from tunnelquake.case import load_case

    base = yaml.safe_load(DEFAULT_CASE.read_text())
    variant = base["variants"]["3d"]
    pts = points_3d()
    assert [p.role for p in pts].count("reference") == 1 and [p.role for p in pts].count("default") == 1
    for p in pts:
        d = yaml.safe_load((write_point(p, base, DEFAULT_CASE.parent, tmp_path, 0.5, "3d") / "case.yaml").read_text())
        assert d["mesh"]["mode"] == "3d" and d["water"]["ends"] == variant["water"]["ends"]
        assert d["parallel"]["threads"] == 1 and d["conditions"] == ["dynamic_water"] and "variants" not in d
        assert d["time"]["subcycling"] == p.overrides.get("time.subcycling", variant["time"]["subcycling"])
        assert d["coupling"]["tolerance"] == p.overrides.get("coupling.tolerance", variant["coupling"]["tolerance"])
        assert d["coupling"]["window_force_weight"] == p.overrides.get("coupling.window_force_weight",
                                                                       variant["coupling"]["window_force_weight"])
        assert d["coupling"].get("scheme", "implicit") == p.overrides.get("coupling.scheme", "implicit")
        load_case(tmp_path / p.condition / slug(p.name) / "case.yaml")  # each a valid case (check's rules)
    default = next(p for p in pts if p.role == "default")
    assert set(default.overrides) == {"parallel.threads"}  # the variant's own settings
    tol = f"{float(variant['coupling']['tolerance']):.0e}".replace("e-0", "e-")
    assert f"tol {tol}," in default.name  # the default's name states the variant's tolerance


def test_every_point_of_the_slice_ladder_and_the_paper_ladder_is_a_valid_case(tmp_path):
    """Each point written on the example (its coupling keys on top of the case file's, e.g. the
    explicit scheme over a case that names an implicit-only predictor) passes check's rules."""
    import yaml

    from benchmarks import paper
    from benchmarks.cost_error import DEFAULT_CASE, points, write_point
    from tunnelquake.case import load_case

    base = yaml.safe_load(DEFAULT_CASE.read_text())
    for p in points():
        load_case(write_point(p, base, DEFAULT_CASE.parent, tmp_path / "ladder", 0.5) / "case.yaml")
    for v in paper.variants(0.5):
        d = paper.write_variant(v, base, DEFAULT_CASE.parent, tmp_path / "paper", 0.5)
        load_case(d if d.suffix == ".yaml" else d / "case.yaml")


def test_energy_ratio_is_the_coupling_energy_over_the_interface_work():
    """|coupling_energy| / interface_work_peak of the run's /coupling record (hand-computed: a
    -0.0073 J energy error against 326.5 J of interface work is 2.24e-5); NaN without the record."""
    r = {"coupling": {"coupling_energy": -0.0073, "interface_work_peak": 326.5}}
    assert math.isclose(energy_ratio(r), 0.0073 / 326.5, rel_tol=1e-12)
    assert math.isnan(energy_ratio({"coupling": {"coupling_energy": 1.0}}))
    assert math.isnan(energy_ratio({}))


def test_a_suffix_that_cannot_name_a_file_is_refused_before_anything_runs(tmp_path, capsys):
    import pytest

    from benchmarks.cost_error import main

    with pytest.raises(SystemExit) as e:
        main([str(tmp_path), "--suffix", "../x", "--tabulate-only"])
    assert e.value.code == 2 and "--suffix" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
