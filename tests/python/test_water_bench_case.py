"""The water benchmark and the water tests run the case the product writes.

`benchmarks.fluid_common.tunnel.make_case` with no knob set must write, file for file, the
dictionaries `fluid_case.water_case` writes for the example's 3D model with open ends,
incompressible water and the whole pressure exchanged (pimpleFoam: the water the stock set-up
solves too), apart from what the run itself sets (the step, the end, the writes, the log's
interval, the exchange partner: a fake solid instead of the coupler). Each other variant is the
same case with a few entries set otherwise: the stock set-up (benchmarks/water_step, STOCK) sets
OpenFOAM's tutorial entries and no other. The pipe of the water tests (`pipe.make_pipe_case`)
takes the water case's numerics unless a test sets them. Exact comparisons of the parsed
dictionaries (foam_dict.parse); no OpenFOAM run.
"""
from __future__ import annotations

import pytest

from benchmarks.fluid_common import pipe, tunnel
from benchmarks.water_step import benchmark as bench
from conftest import EXAMPLE
from tunnelquake import fluid_case
from tunnelquake import water_case as wc
from tunnelquake.case import load_case
from tunnelquake.foam_dict import FoamDictError, parse

WINDOW = 1e-4
#: controlDict entries the run sets: its step, end and writes
RUN_ENTRIES = ("endTime", "deltaT", "writeInterval")
#: tqInterface entries the run sets: the exchange partner, the log's interval, the free surface
RUN_INTERFACE = ("exchange", "logInterval", "hydrostatic")


def _fake_polymesh(folder, end_type: str):
    """A polyMesh folder whose boundary file has the tunnel mesh's patches (make_case reads only
    the end types from it)."""
    poly = folder / "constant" / "polyMesh"
    poly.mkdir(parents=True)
    (poly / "boundary").write_text(
        "3\n(\n    interface\n    {\n        type wall;\n    }\n"
        + "".join(f"    {e}\n    {{\n        type {end_type};\n    }}\n" for e in ("end_ymin", "end_ymax"))
        + ")\n")
    return poly


def _parsed(text: str):
    """The dictionary, or the text where it holds a form parse does not read (the stock
    `diffusivity inverseDistance (interface)`)."""
    try:
        return parse(text)
    except FoamDictError:
        return text


def _read(case) -> dict:
    return {str(p.relative_to(case)): _parsed(p.read_text()) for p in case.rglob("*")
            if p.is_file() and p.parts[-2] in ("system", "constant", "0") and p.name != "boundary"}


def _product(tmp_path) -> dict:
    case = load_case(EXAMPLE, "3d_open_incompressible")
    case.data["coupling"]["volume_law"] = "water"
    # the whole tube, as the benchmark's mesh (the variant meshes the half of its symmetric block, whose
    # end_ymax is then the plane of symmetry; every other entry the same)
    case.data["mesh"]["symmetry"] = "none"
    s = fluid_case.coupling_settings(case, WINDOW, tmp_path / "wall.addr", "ab" * 16, t_end=0.01)
    w = fluid_case.water_case(case, s, slice_mode=False)
    assert (w.solver, w.ends) == ("pimpleFoam", ("open", "open"))
    return {path: parse(text) for path, text in wc.dictionaries(w).items()}


def _without_run_entries(files: dict) -> dict:
    out = {k: v for k, v in files.items()}
    cd = {k: v for k, v in out["system/controlDict"].items() if k not in RUN_ENTRIES}
    cd["functions"] = {"interface": {k: v for k, v in cd["functions"]["interface"].items() if k not in RUN_INTERFACE}}
    out["system/controlDict"] = cd
    return out


def test_the_benchmark_case_is_the_product_case(tmp_path):
    poly = _fake_polymesh(tmp_path / "mesh", "patch")
    tunnel.make_case(tmp_path / "ours", poly, {})
    ours = _read(tmp_path / "ours")
    product = _product(tmp_path)
    assert set(ours) == set(product)
    assert _without_run_entries(ours) == _without_run_entries(product)
    # the benchmark's 'ours' (the ladder's last rung, the one --pair times) sets no knob
    for closed in (False, True):
        assert {name: s for name, _what, s in bench.variants(closed)}[bench.OURS] == {}


def test_the_stock_variant_sets_the_stock_entries_only(tmp_path):
    poly = _fake_polymesh(tmp_path / "mesh", "patch")
    stock = {name: s for name, _what, s in bench.variants()}["stock"]
    tunnel.make_case(tmp_path / "ours", poly, {})
    tunnel.make_case(tmp_path / "stock", poly, stock)
    ours, st = _read(tmp_path / "ours"), _read(tmp_path / "stock")
    changed = {path for path in ours if ours[path] != st[path]}
    assert changed == {"system/controlDict", "system/fvSolution", "system/fvSchemes", "constant/dynamicMeshDict",
                       "constant/turbulenceProperties", "0/U", "0/p", "0/pointDisplacement"}
    pimple = st["system/fvSolution"]["PIMPLE"]
    assert (pimple["nOuterCorrectors"], pimple["nCorrectors"], pimple["momentumPredictor"], pimple["correctPhi"]) \
        == (2, 1, "yes", "yes")
    assert st["system/fvSolution"]["solvers"]["p"]["solver"] == "GAMG"
    assert st["system/fvSolution"]["solvers"]["U(Final)?"]["tolerance"] == 1e-5
    assert "motionSolver    displacementLaplacian;" in st["constant/dynamicMeshDict"]
    assert "tqInterpolatedDisplacement" not in st["constant/dynamicMeshDict"]
    assert st["0/U"]["boundaryField"]["interface"]["type"] == "movingWallVelocity"
    assert st["0/p"]["boundaryField"]["interface"]["type"] == "fixedFluxPressure"
    assert st["constant/turbulenceProperties"]["laminar"]["laminarModel"] == "Stokes"
    assert st["system/controlDict"]["runTimeModifiable"] == "yes"
    assert st["system/controlDict"]["functions"]["interface"]["interfaceMotion"] == "meshMotion"
    # the rest of the numerics: the product's (time scheme, the pressure Laplacian, the ends)
    assert st["system/fvSchemes"]["ddtSchemes"] == ours["system/fvSchemes"]["ddtSchemes"]
    assert st["0/p"]["boundaryField"]["end_y(min|max)"] == ours["0/p"]["boundaryField"]["end_y(min|max)"]


@pytest.mark.parametrize("two_d", [True, False])
def test_the_pipe_takes_the_water_case_numerics(tmp_path, two_d):
    pipe.make_pipe_case(tmp_path / "c", dt=1e-3, end_time=1e-2, two_d=two_d, interface_motion="transpiration")
    got = _read(tmp_path / "c")
    w = wc.WaterCase(model="incompressible", ends=("empty",) * 2 if two_d else ("wall",) * 2, density=pipe.RHO,
                     viscosity=pipe.RHO * pipe.NU, bulk_modulus=pipe.K_WATER, delta_t=1e-3, end_time=1e-2,
                     write_interval=1e-2, free_surface_level=0.0)
    want = {path: parse(text) for path, text in wc.dictionaries(w).items()}
    for path in ("system/fvSolution", "system/fvSchemes", "constant/turbulenceProperties", "0/U", "0/p"):
        assert got[path] == want[path], path
    assert got["system/blockMeshDict"]["boundary"][3]["type"] == ("empty" if two_d else "wall")
    # a tight pressure solve is the test's own override, the rest stays
    pipe.make_pipe_case(tmp_path / "t", dt=1e-3, end_time=1e-2, two_d=two_d, p_tol=1e-10)
    tight = _read(tmp_path / "t")["system/fvSolution"]
    assert tight["solvers"]["p"] == {"solver": "PCG", "preconditioner": "DIC", "tolerance": 1e-10, "relTol": 0}
    assert tight["PIMPLE"] == want["system/fvSolution"]["PIMPLE"]
