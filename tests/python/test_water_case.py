"""The water case of condition dynamic_water (fluid_case.water_case -> water_case.dictionaries): the
dictionaries written, read back (foam_dict.parse), carry the case's water.

References, exact unless said: the case file's numbers and the definitions the water solvers use
(docs/water.md): the free surface z = tunnel centre z + head; the loads' density rhoInf = the
water's density; nu = mu / rho; the perfect fluid R T0 rho0 = K (to 1e-15 relative: one division
and one product of doubles); one water step a coupling window (deltaT = window size, endTime =
windows x window size); the end patches: empty in a slice, walls for closed 3D ends, p = 0 with
inflow/outflow for open ones; a domain without an open end solves p to an absolute 1e-6, an open
one to 5 % of its residual; the remainder's bulk modulus 2.2 GPa for incompressible water in a
closed section and at most 2.2 GPa for compressible water with the volume law in the solid
(fluid_case.REMAINDER_BULK_MODULUS).
"""
from __future__ import annotations

import pytest

from conftest import EXAMPLE
from tunnelquake import fluid_case as fc
from tunnelquake import water_case as wc
from tunnelquake.case import load_case
from tunnelquake.foam_dict import Dimensions, Uniform, parse

WINDOW = 16 * 6.3006e-05
K_REMAINDER = fc.REMAINDER_BULK_MODULUS

#: The example's 3D variants mesh half of their symmetric block (mesh.symmetry: mid_length): their
#: end_ymax is the plane of symmetry.
#: name: (variant, water overrides, coupling overrides,
#:        expected: solver, end kind, closed domain, K in OpenFOAM (None: the case's), subtractMeanPressure)
CASES = {
    "slice, compressible": (None, {}, {}, ("rhoPimpleFoam", "empty", True, None, True)),
    "slice, incompressible (the remainder compressible)": (
        None, {"model": "incompressible"}, {}, ("rhoPimpleFoam", "empty", True, K_REMAINDER, True)),
    "slice, stiff water, law in the solid": (
        None, {"bulk_modulus": 22e9}, {}, ("rhoPimpleFoam", "empty", True, K_REMAINDER, True)),
    "slice, law in the water": (None, {"bulk_modulus": 22e9}, {"volume_law": "water"},
                                ("rhoPimpleFoam", "empty", True, None, False)),
    "3d, closed ends": ("3d_solid_law", {}, {}, ("rhoPimpleFoam", ("wall", "symmetry"), True, None, True)),
    "3d, closed ends, incompressible": ("3d_incompressible", {}, {},
                                        ("rhoPimpleFoam", ("wall", "symmetry"), True, K_REMAINDER, True)),
    "3d, open ends": ("3d_open", {}, {}, ("rhoPimpleFoam", ("open", "symmetry"), False, None, False)),
    # the remainder of incompressible water (its volume held by tq-solid) in compressible water
    "3d, open ends, incompressible": ("3d_open_incompressible", {}, {},
                                      ("rhoPimpleFoam", ("open", "symmetry"), False, K_REMAINDER, False)),
    "3d, open ends, incompressible, whole pressure exchanged": (
        "3d_open_incompressible", {}, {"volume_law": "water"}, ("pimpleFoam", ("open", "symmetry"), False, None, False)),
    # not the example's water: sea water, another head and tunnel depth
    "3d, closed, sea water": ("3d", {"density": 1025.0, "viscosity": 1.08e-3, "bulk_modulus": 2.34e9,
                                     "head": 41.5}, {}, ("rhoPimpleFoam", ("wall", "symmetry"), True, None, False)),
}


def _files(name, tmp_path, centre_z=None):
    variant, water, coupling, expected = CASES[name]
    case = load_case(EXAMPLE, variant)
    case.data["water"].update(water)
    case.data["coupling"].update(coupling)
    if centre_z is not None:
        case.data["geometry"]["tunnel_centre_z"] = centre_z
    s = fc.coupling_settings(case, WINDOW, tmp_path / "wall.addr", "ab" * 16, t_end=0.05)
    w = fc.water_case(case, s, slice_mode=case.data["mesh"]["mode"] == "slice")
    return case, s, w, {path: parse(text) for path, text in wc.dictionaries(w).items()}, expected


@pytest.mark.parametrize("name", list(CASES))
def test_the_case_water_is_written(name, tmp_path):
    case, s, w, f, (solver, kind, closed, k_openfoam, subtract) = _files(name, tmp_path,
                                                                          centre_z=12.25 if "sea" in name else None)
    water, geometry = case.data["water"], case.data["geometry"]
    rho, mu = water["density"], water["viscosity"]
    compressible = solver == "rhoPimpleFoam"
    cd = f["system/controlDict"]
    interface = cd["functions"]["interface"]
    assert cd["application"] == solver
    # one water step a coupling window, to the end of the last window
    assert cd["deltaT"] == s["window_size"] == WINDOW
    assert cd["endTime"] == s["windows"] * WINDOW and s["windows"] == 50  # ceil(0.05 / 1.008e-3)
    assert cd["writeInterval"] == max(cd["endTime"], 0.1)
    assert interface["rhoInf"] == rho
    assert interface["rho"] == ("rho" if compressible else "rhoInf")
    assert interface["hydrostatic"]["freeSurfaceLevel"] == geometry["tunnel_centre_z"] + water["head"]
    assert interface["hydrostatic"]["g"] == [0, 0, -9.81]
    assert ("subtractMeanPressure" in interface) == subtract
    # the two sides agree (one fluid_case.water_split): OpenFOAM sends its pressure less its mean exactly
    # where tq-solid's /coupling carries a uniform pressure (a volume law in a closed section)
    assert (s["volume_law"] != "none" and s["water_ends"] == "closed") == subtract
    assert interface["exchange"] == fc.exchange_dict(s)
    # water.log: brief (the default): the interval's passes, no residual lines
    assert interface["logInterval"] == 0.01 and interface["quietSolver"] == "yes"
    assert cd["DebugSwitches"]["SolverPerformance"] == 0
    # the water's viscosity and state
    nu = mu / rho
    assert f["constant/transportProperties"]["nu"] == nu
    if compressible:
        assert interface["nu"] == nu
    mixture = f["constant/thermophysicalProperties"]["mixture"]
    k = water["bulk_modulus"] if k_openfoam is None else k_openfoam
    assert mixture["equationOfState"]["R"] * wc.T0 * rho == pytest.approx(k, rel=1e-15)
    assert mixture["equationOfState"]["rho0"] == rho and mixture["transport"]["mu"] == mu
    model = f["constant/turbulenceProperties"]["laminar"]["laminarModel"]
    assert model == "tqNewtonian"
    # the ends (one kind for both, or the kinds of end_ymin and end_ymax)
    kinds = kind if isinstance(kind, tuple) else (kind, kind)
    ends = {"empty": {"U": "empty", "p": "empty", "T": "empty", "pointDisplacement": "empty"},
            "wall": {"U": "tqInterfaceVelocity", "p": "fixedFluxExtrapolatedPressure", "T": "zeroGradient",
                     "pointDisplacement": "calculated"},
            "open": {"U": "pressureInletOutletVelocity", "p": "fixedValue", "T": "zeroGradient",
                     "pointDisplacement": "calculated"},
            "symmetry": {"U": "symmetryPlane", "p": "symmetryPlane", "T": "symmetryPlane",
                         "pointDisplacement": "calculated"}}
    assert ("0/T" in f) == compressible
    for field in ends["wall"]:
        if f"0/{field}" not in f:
            continue
        bf = f[f"0/{field}"]["boundaryField"]
        for patch, k in zip(("end_ymin", "end_ymax"), kinds, strict=True):
            entry = bf.get(patch) or bf["end_y(min|max)"]
            assert entry["type"] == ends[k][field], (field, patch)
        assert set(bf) - {"interface"} in ({"end_y(min|max)"}, {"end_ymin", "end_ymax"})
    if "open" in kinds:
        bf = f["0/p"]["boundaryField"]
        assert (bf.get("end_ymin") or bf["end_y(min|max)"])["value"] == Uniform(0)  # hydrodynamic p = 0
    assert f["0/p"]["dimensions"] == (Dimensions([1, -1, -2, 0, 0, 0, 0]) if compressible  # Pa
                                      else Dimensions([0, 2, -2, 0, 0, 0, 0]))  # Pa / rho
    assert f["0/U"]["boundaryField"]["interface"]["type"] == "tqInterfaceVelocity"
    patch = {"empty": "empty", "wall": "wall", "open": "patch", "symmetry": "symmetryPlane"}
    assert wc.patch_types(w) == {"interface": "wall", "end_ymin": patch[kinds[0]], "end_ymax": patch[kinds[1]]}
    # the pressure controls: absolute in a closed domain, relative with an open end
    for p in ("p", "pFinal"):
        controls = f["system/fvSolution"]["solvers"][p]
        assert (controls["tolerance"], controls["relTol"]) == ((1e-6, 0) if closed else (0, 0.05)), p
        # compressible water's p equation is well conditioned (psi/dt^2 on its diagonal): PCG inside
        assert controls["inner"]["solver"] == ("PCG" if compressible else "GAMG"), p
    # the structured all-hex meshes of tunnelquake.meshing need no non-orthogonal correction
    assert f["system/fvSolution"]["PIMPLE"]["nNonOrthogonalCorrectors"] == 0


def test_verbose_log_and_write_interval(tmp_path):
    case = load_case(EXAMPLE)
    case.data["water"]["log"] = "verbose"
    s = fc.coupling_settings(case, WINDOW, tmp_path / "wall.addr", "ab" * 16, t_end=0.05)
    cd = parse(wc.dictionaries(fc.water_case(case, s, True, write_interval=0.02))["system/controlDict"])
    assert cd["writeInterval"] == 0.02
    assert cd["functions"]["interface"]["logInterval"] == 0 and cd["functions"]["interface"]["quietSolver"] == "no"
    assert cd["DebugSwitches"]["SolverPerformance"] == 1


def test_mixed_ends_and_the_closed_domain_rule():
    """Each end its own kind: named entries when they differ; closed unless an end is open."""
    base = dict(model="incompressible", density=1000.0, viscosity=1e-3, bulk_modulus=2.2e9, delta_t=1e-3,
                end_time=0.01, write_interval=0.1, free_surface_level=0.0)
    half_tube = wc.WaterCase(ends=("symmetry", "open"), **base)
    f = {path: parse(text) for path, text in wc.dictionaries(half_tube).items()}
    assert not half_tube.closed and half_tube.mode == "3d"
    p = f["0/p"]["boundaryField"]
    assert p["end_ymin"] == {"type": "symmetryPlane"}
    assert p["end_ymax"] == {"type": "fixedValue", "value": Uniform(0)}
    # the mesh does not move on either end: one pattern entry
    assert f["0/pointDisplacement"]["boundaryField"]["end_y(min|max)"]["type"] == "calculated"
    assert f["system/fvSolution"]["solvers"]["p"]["relTol"] == 0.05
    assert wc.patch_types(half_tube)["end_ymin"] == "symmetryPlane"
    prism = wc.WaterCase(ends=("symmetry", "symmetry"), volume_change_tolerance=0.05, **base)
    f = {path: parse(text) for path, text in wc.dictionaries(prism).items()}
    assert prism.closed
    assert (f["system/fvSolution"]["solvers"]["p"]["tolerance"], f["system/fvSolution"]["solvers"]["p"]["relTol"]) \
        == (1e-6, 0)
    assert f["system/controlDict"]["functions"]["interface"]["volumeChangeTolerance"] == 0.05
    with pytest.raises(wc.WaterCaseError, match="both ends empty"):
        wc.WaterCase(ends=("empty", "wall"), **base)
    with pytest.raises(wc.WaterCaseError, match="ends"):
        wc.WaterCase(ends=("open", "inlet"), **base)


def test_restart_entries_are_part_of_the_description(tmp_path):
    """The restart checkpoints' entries of tqInterface (docs/formats.md "Restart checkpoints") come
    from the description, none by default; a folder without a period (or the reverse) is refused."""
    case = load_case(EXAMPLE)
    s = fc.coupling_settings(case, WINDOW, tmp_path / "wall.addr", "ab" * 16, t_end=0.05)

    def interface(**restart):
        w = fc.water_case(case, s, True, restart=restart or None)
        return parse(wc.dictionaries(w)["system/controlDict"])["functions"]["interface"]

    assert not {"restartDir", "restartWindows", "restartFrom"} & set(interface())
    every = interface(restart_dir=str(tmp_path / "ck"), restart_windows=40)
    assert (every["restartDir"], every["restartWindows"]) == (str(tmp_path / "ck"), 40)
    assert "restartFrom" not in every
    resumed = interface(restart_dir=str(tmp_path / "ck"), restart_windows=40,
                        restart_from=str(tmp_path / "ck" / "fluid-000000040.bin"))
    assert resumed["restartFrom"] == str(tmp_path / "ck" / "fluid-000000040.bin")
    with pytest.raises(wc.WaterCaseError, match="restart_windows 0 and restart_dir"):
        fc.water_case(case, s, True, restart={"restart_dir": str(tmp_path)})
    with pytest.raises(wc.WaterCaseError, match="restart_from"):
        fc.water_case(case, s, True, restart={"restart_from": "x.bin"})
