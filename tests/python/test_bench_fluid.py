"""`tunnelquake bench --fluid`: the arithmetic of its tables, not the heavy runs.

The benchmark's figures are not tests. Tested here: the reference-free (Richardson) order of a
known power law (exact), the rigid-pipe error measures on the closed form itself
(p = p0 − ρ a R cos θ, F = ρπR²L a: Batchelor 1967 §6.4; tests/verification/fluid_rigid_pipe),
the per-round ratio summary, the target-accuracy pick, and that --update-docs touches only the
fluid section of a page that also has the solid one.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import fluid as bf
from benchmarks.solid import BEGIN as SOLID_BEGIN
from benchmarks.solid import END as SOLID_END


def test_difference_order_of_a_power_law_is_its_exponent_without_the_limit():
    # v = v* + C s^p with a constant ratio r: (v0 − v1)/(v1 − v2) = r^p exactly, whatever v* is.
    for p in (1.0, 2.0, 1.6):
        for r in (2.0, 1.5):
            s = [0.1 / r**i for i in range(5)]
            v = [7.3 - 0.4 * x**p for x in s]
            orders = bf.difference_orders(s, v)
            assert orders[:2] == [None, None]
            for o in orders[2:]:
                assert math.isclose(o, p, rel_tol=1e-9)
    # differences that change sign (no asymptotic range) or a ratio that is not constant: None
    assert bf.difference_orders([4.0, 2.0, 1.0], [1.0, 2.0, 1.5])[2] is None
    assert bf.difference_orders([4.0, 2.0, 0.5], [1.0, 0.5, 0.25])[2] is None
    assert bf.difference_orders([1.0, 0.5], [1.0, 0.5]) == [None, None]


def test_observed_order_against_the_reference():
    s = [0.4, 0.2, 0.1]
    orders = bf.observed_orders(s, [-3.0 * x**2 for x in s])
    assert orders[0] is None and all(math.isclose(o, 2.0, rel_tol=1e-12) for o in orders[1:])
    assert bf.observed_orders([2.0, 1.0], [0.04, -0.01])[1] is None


def test_pipe_errors_are_zero_on_the_closed_form_and_scale_with_it():
    rho, R, L, a0 = 1000.0, 4.5, 1.0, 1.0
    omega, dt = 2 * math.pi, 0.02
    t = np.arange(0, 1.0 + dt / 2, dt)
    fx = -rho * math.pi * R**2 * L * a0 * np.cos(omega * (t - dt))  # one step of lag, as the solver
    theta = np.linspace(-math.pi, math.pi, 64, endpoint=False) + 0.01
    a_last = 0.9
    p = 12.5 - rho * a_last * R * np.cos(theta)  # any level p0: a closed domain's is a convention
    e = bf.pipe_errors(t, fx, omega, theta, p, a_last)
    assert abs(e["force_error"]) < 1e-12 and abs(e["pressure_error"]) < 1e-12 and e["pressure_dev"] < 1e-12
    e = bf.pipe_errors(t, 0.98 * fx, omega, theta, 12.5 - 1.01 * rho * a_last * R * np.cos(theta), a_last)
    assert math.isclose(e["force_error"], -0.02, abs_tol=1e-12)
    assert math.isclose(e["pressure_error"], 0.01, abs_tol=1e-12)
    # the largest deviation: 1 % of ρ a R times the largest |cos θ| of the sampled faces
    assert math.isclose(e["pressure_dev"], 0.01 * np.abs(np.cos(theta)).max(), rel_tol=1e-9)


def test_ratio_summary_is_the_median_of_the_rounds():
    st, ou, ratio, ratios = bf.ratio_summary([10.0, 30.0, 12.0], [2.0, 3.0, 4.0])
    assert (st, ou) == (12.0, 3.0)
    assert ratios == [5.0, 10.0, 3.0] and ratio == 5.0
    with pytest.raises(ValueError, match="rounds of both"):
        bf.ratio_summary([1.0], [])


def _ladder():
    lad = bf.Ladder("pipe", ("force_error", "pressure_error"), ("F", "p"), value_key="force_error")
    lad.runs = [
        {"setting": "coarse", "size": 0.5, "force_error": 0.04, "pressure_error": -0.002, "wall_s": 1.0},
        {"setting": "medium", "size": 0.25, "force_error": 0.01, "pressure_error": -0.0005, "wall_s": 4.0},
        {"setting": "fine", "size": 0.125, "force_error": 0.0025, "pressure_error": -0.000125, "wall_s": 16.0},
    ]
    return lad


def test_pick_takes_the_cheapest_run_within_each_target_and_the_table_its_orders():
    text = bf.pick([_ladder()], targets=(0.05, 0.01, 0.001))
    row = text.splitlines()[-1]
    assert row == "| pipe | coarse, 1.00 s | medium, 4.00 s | not reached |"
    table = bf.ladder_table([_ladder()])
    assert "| pipe | fine | F +0.250 % | p -0.013 % | 2.00 / 2.00 | 2.00 | 16.00 | – |" in table


def test_update_docs_replaces_only_the_fluid_section():
    solid = f"{SOLID_BEGIN}\nsolid table\n{SOLID_END}"
    new = f"{bf.FLUID_BEGIN}\nnew fluid\n{bf.FLUID_END}"
    doc = f"# Benchmarks\n\n{solid}\n\n{bf.FLUID_BEGIN}\nold fluid\n{bf.FLUID_END}\n\nafter\n"
    out = bf.update_docs(doc, new)
    assert out == f"# Benchmarks\n\n{solid}\n\n{new}\n\nafter\n"
    assert bf.update_docs(out, new) == out
    appended = bf.update_docs(f"# Benchmarks\n\n{solid}\n", new)
    assert appended == f"# Benchmarks\n\n{solid}\n\n{new}\n"
    sec = bf.section([_ladder()], [], "tunnelquake bench X --fluid", "2026-01-01 00:00", "here", "fluid.png")
    assert sec.startswith(bf.FLUID_BEGIN) and sec.endswith(bf.FLUID_END) and sec.count(bf.FLUID_BEGIN) == 1


# ------------------------------------------------------------------------------------------------
# The 3D rung: closed pipe, its mesh sizes, its docs block
# ------------------------------------------------------------------------------------------------
def test_pipe3d_mesh_refines_by_two_in_all_three_directions():
    sizes = [bf.pipe_cells(n, bf.pipe3d_axial(n)) for n in bf.PIPE3D_N]
    assert [bf.pipe3d_axial(n) for n in bf.PIPE3D_N] == [3, 6, 12]
    assert sizes[0] == (4, 3, (16 + 48) * 3)
    for (q0, r0, c0), (q1, r1, c1) in zip(sizes, sizes[1:], strict=False):
        assert (q1, r1, c1) == (2 * q0, 2 * r0, 8 * c0)  # so the mesh ladder has a constant ratio 2
    assert bf.pipe_cells(64) == (16, 12, 16 * 16 + 4 * 16 * 12)  # the 2D slice: one cell thick
    with pytest.raises(bf.BenchError, match="multiple of 16"):
        bf.pipe3d_axial(40)
    with pytest.raises(bf.BenchError, match="N = 30"):
        bf.pipe_cells(30)


def test_closed_ends_are_recognised_from_the_polymesh_boundary():
    from benchmarks.fluid_common.tunnel import ends_are_walls

    def boundary(kind_min, kind_max):
        return (f"3\n(\n    interface\n    {{\n        type            wall;\n        nFaces 32;\n    }}\n"
                f"    end_ymin\n    {{\n        type            {kind_min};\n        inGroups 1(x);\n    }}\n"
                f"    end_ymax\n    {{\n        type            {kind_max};\n    }}\n)\n")

    assert ends_are_walls(boundary("wall", "wall"))
    assert not ends_are_walls(boundary("patch", "patch"))  # gmshToFoam's open ends
    assert not ends_are_walls(boundary("wall", "patch"))
    assert not ends_are_walls("1\n(\n    interface { type wall; }\n)\n")


def test_summarise_rounds_keeps_the_errors_and_takes_medians_of_times_and_ratios():
    def run(ms, cpu, f):
        return {"force_error": f, "pressure_error": -f, "wall_s": ms / 10, "ms_per_step": ms,
                "cpu_ms_per_step": cpu, "dt": 0.005, "steps": 201}

    rounds = {"stock": [run(10.0, 9.0, 0.02), run(30.0, 27.0, 0.02), run(12.0, 12.0, 0.02)],
              "ours": [run(2.0, 2.0, -0.01), run(3.0, 3.0, -0.01), run(4.0, 4.0, -0.01)]}
    runs, pair = bf.summarise_rounds(rounds, "mesh3d", "N = 16", 192, 1 / 16)
    assert runs["stock"]["ms_per_step"] == 12.0 and runs["ours"]["ms_per_step"] == 3.0
    assert runs["ours"]["size"] == 1 / 16 and runs["ours"]["cells"] == 192
    assert bf.summarise_rounds(rounds, "step", "s", 1, None)[0]["ours"]["size"] == 0.005  # the step
    assert pair["ratios"] == [5.0, 10.0, 3.0] and pair["ratio"] == 5.0
    assert pair["cpu_ratios"] == [4.5, 9.0, 3.0] and pair["cpu_ratio"] == 4.5
    assert (pair["stock_force_error"], pair["ours_pressure_error"]) == (0.02, 0.01)


def test_pipe3d_block_goes_right_after_the_fluid_section_and_only_it_is_replaced():
    fluid = f"{bf.FLUID_BEGIN}\n2D figures\n{bf.FLUID_END}"
    paper = "<!-- bench:paper -->\npaper\n<!-- /bench:paper -->"
    doc = f"# Benchmarks\n\n{fluid}\n\n{paper}\n"
    block = f"{bf.PIPE3D_BEGIN}\n3D v1\n{bf.PIPE3D_END}"
    out = bf.update_docs_pipe3d(doc, block)
    assert out == f"# Benchmarks\n\n{fluid}\n\n{block}\n\n{paper}\n"
    block2 = f"{bf.PIPE3D_BEGIN}\n3D v2\n{bf.PIPE3D_END}"
    assert bf.update_docs_pipe3d(out, block2) == f"# Benchmarks\n\n{fluid}\n\n{block2}\n\n{paper}\n"
    # a new 2D section leaves the 3D block where it is
    again = bf.update_docs(out, f"{bf.FLUID_BEGIN}\nnew 2D\n{bf.FLUID_END}")
    assert again == f"# Benchmarks\n\n{bf.FLUID_BEGIN}\nnew 2D\n{bf.FLUID_END}\n\n{block}\n\n{paper}\n"
    # no fluid section: appended
    assert bf.update_docs_pipe3d("# B\n", block) == f"# B\n\n{block}\n"


def test_a_pipe3d_only_json_renders_only_its_block(tmp_path, monkeypatch):
    import argparse

    lad = _ladder()
    data = {"date": "2026-01-01 00:00", "machine": "here", "note": "", "command": "tunnelquake bench X --fluid",
            "pairs": [], "ladders": [{"name": "rigid pipe 3D, mesh, ours", "runs": lad.runs}]}
    args = argparse.Namespace(folder=tmp_path, from_json=None, update_docs=False)
    assert bf._render(args, data) == 0
    text = (tmp_path / "fluid.md").read_text()
    assert text.startswith(bf.PIPE3D_BEGIN) and bf.FLUID_BEGIN not in text and "{reading3d}" not in text
    assert not (tmp_path / "fluid.png").exists()  # the 2D figure (docs/bench/fluid.png) is not redrawn
    assert bf.is_pipe3d("rigid pipe 3D, mesh, stock") and not bf.is_pipe3d("rigid pipe 2D, mesh, stock")
