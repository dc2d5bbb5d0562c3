"""tunnelquake.fluid_case: both sides' coupling configuration from one set of settings (the
coupler's handshake compares every item), and the water model chosen from the case."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import EXAMPLE
from tunnelquake import fluid_case as fc
from tunnelquake import water_case
from tunnelquake.case import load_case
from tunnelquake.foam_dict import parse


def _settings(tmp_path, **kw):
    case = load_case(EXAMPLE)
    return case, fc.coupling_settings(case, 6.3006e-05, tmp_path / "wall.addr", "ab" * 16, t_end=0.02, **kw)


def _written_exchange(case, s) -> dict:
    """The `exchange` dictionary of the water case's system/controlDict, as written and read back."""
    text = water_case.dictionaries(fc.water_case(case, s, slice_mode=True))["system/controlDict"]
    return parse(text)["functions"]["interface"]["exchange"]


def test_both_sides_get_the_same_configuration(tmp_path):
    case, s = _settings(tmp_path)
    solid = fc.solid_coupling_attrs(s)
    # the exchange as the fluid reads it: written into its controlDict and read back
    fluid = _written_exchange(case, s)
    # windows: ceil(0.02 / 6.3006e-5) = 318, the rule tq-solid applies, pinned on both sides
    assert solid["windows"] == 318 and fluid["windows"] == 318
    assert fluid["windowSize"] == solid["window_size"] == 6.3006e-05
    pairs = {"scheme": "scheme", "tolerance": "tolerance", "max_iterations": "maxIterations",
             "acceleration": "acceleration", "initial_relaxation": "initialRelaxation",
             "predictor": "predictor", "mesh": "mesh",
             "map": "map", "map_tolerance": "mapTolerance", "timeout": "timeout", "address_file": "addressFile"}
    for k, f in pairs.items():
        assert fluid[f] == solid[k], k
    # the fluid is the second participant, the solid maps, and the fluid reads what the solid writes,
    # in the solid's order
    assert fluid["participant"] == solid["partner"] == "fluid"
    assert fluid["partner"] == solid["participant"] == "solid"
    assert fluid["mappingSide"] == "solid"
    assert fluid["readFields"] == solid["write_fields"].split(",")
    assert solid["write_fields"] == "velocity,displacement"
    # the case's choices went through (the example: the implicit scheme with iqn-ils)
    assert solid["scheme"] == case.data["coupling"]["scheme"] == "implicit"
    assert solid["acceleration"] == "iqn-ils"
    # the example's predictor (damped), on both sides; auto -> linear for the implicit scheme
    assert solid["predictor"] == "damped" and fluid["predictor"] == "damped"
    assert fc.coupling_predictor({"scheme": "implicit", "predictor": "auto"}) == "linear"
    assert fc.coupling_predictor({"scheme": "explicit", "predictor": "auto"}) == "constant"
    # the secret is not written into the OpenFOAM case
    assert "ab" * 16 not in str(fluid) and fluid["tokenEnv"] == fc.TOKEN_ENV


def test_refusals_name_the_fix(tmp_path):
    case, s = _settings(tmp_path)
    with pytest.raises(fc.FluidCaseError, match="tcp"):
        fc.exchange_dict({**s, "transport": "mpi"})
    case.data["water"]["model"] = "incompressible"
    # settings made for another water: the two sides would carry different parts
    with pytest.raises(fc.FluidCaseError, match="volume_law 'compressible'.*'incompressible'"):
        fc.build_fluid_case(case, tmp_path / "water.msh", tmp_path / "fluid", s, slice_mode=True)
    # incompressible water in a slice with the whole pressure in the water: nothing can change the section
    case.data["coupling"]["volume_law"] = "water"
    s = fc.coupling_settings(case, s["window_size"], tmp_path / "wall.addr", "ab" * 16, t_end=0.05)
    with pytest.raises(fc.FluidCaseError, match="incompressible water in a closed slice needs the volume law"):
        fc.build_fluid_case(case, tmp_path / "water.msh", tmp_path / "fluid", s, slice_mode=True)


def test_absolute_tolerances_reach_both_sides(tmp_path):
    """The absolute convergence floors (coupling_scales.py) go to both sides alike."""
    case, s = _settings(tmp_path)
    solid = fc.solid_coupling_attrs(s)
    theirs = _written_exchange(case, s)["absoluteTolerance"]
    for name in ("velocity", "displacement", "force"):
        assert theirs[name] == solid[f"absolute_tolerance_{name}"] > 0, name
    # the scale rule: tolerance x PGA x window (m/s), x window again (m)
    pga, tol = case.data["ground_motion"]["pga"], s["tolerance"]
    assert solid["absolute_tolerance_velocity"] == pytest.approx(tol * pga * 6.3006e-05, rel=1e-12)
    assert solid["absolute_tolerance_displacement"] == pytest.approx(tol * pga * 6.3006e-05**2, rel=1e-12)


def test_force_floor_uses_a_wetted_nodes_tributary_area(tmp_path):
    """The force floor is tolerance x rho_w a_ref r_in x A, A a wetted node's tributary area: in the
    example's slice (48 around, 80 m / 44 thick, two node planes) A = (2 pi 4.5 / 48) x (80 / 44) / 2 =
    0.5355 m^2, the area tq-solid itself reports for the monitors' wetted nodes (post: 0.534-0.535)."""
    import math

    from tunnelquake.coupling_scales import wetted_node_area

    case, s = _settings(tmp_path)
    area = 2 * math.pi * 4.5 / 48 * (80 / 44) / 2
    assert wetted_node_area(case) == pytest.approx(area, rel=1e-12)
    pga, tol = case.data["ground_motion"]["pga"], s["tolerance"]
    assert s["absolute_tolerance"]["force"] == pytest.approx(tol * 1000 * pga * 4.5 * area, rel=1e-12)


def test_decomposition_cuts_the_least_area():
    """parallel.fluid_ranks: the simple method's n (x y z) with the least cut area, the water as a box
    (cut normal to x costs Ly Lz, ...). Paper tunnel: water 9 m across, 80 m long in 3D (a cross
    cut 81 m^2 against 720 m^2 along the axis: measured with decomposePar, 336 processor faces cut
    across the axis against 880 along it, docs/coupler.md); the slice is never cut along y."""
    slab = (9.0, 80.0 / 44, 9.0)
    assert fc.simple_split(1, slab, slice_mode=True) == (1, 1, 1)
    assert fc.simple_split(2, slab, slice_mode=True) == (2, 1, 1)
    assert fc.simple_split(4, slab, slice_mode=True) == (2, 1, 2)
    assert fc.simple_split(3, slab, slice_mode=True) in ((3, 1, 1), (1, 1, 3))
    tube = (9.0, 80.0, 9.0)
    assert fc.simple_split(2, tube, slice_mode=False) == (1, 2, 1)
    assert fc.simple_split(8, tube, slice_mode=False) == (1, 8, 1)
    # a short, wide water is cut along its width instead
    assert fc.simple_split(2, (9.0, 2.0, 9.0), slice_mode=False) in ((2, 1, 1), (1, 1, 2))


def test_too_many_ranks_for_the_cells_are_refused(tmp_path):
    owner = tmp_path / "constant" / "polyMesh" / "owner"
    owner.parent.mkdir(parents=True)
    owner.write_bytes(b'FoamFile\n{\n    note        "nPoints:722  nCells:84  nFaces:1368  nInternalFaces:648";\n}\n'
                      b"\x00\x01binary")
    assert fc.water_cells(tmp_path) == 84
    with pytest.raises(fc.FluidCaseError, match=r"parallel\.fluid_ranks = 5 .*use fluid_ranks: 1 \(at most 4"):
        fc.decompose(tmp_path, 5, (9.0, 1.0, 9.0), slice_mode=True)


def test_mpirun_command_carries_the_environment_and_yields(monkeypatch):
    monkeypatch.setattr(fc.shutil, "which", lambda name: f"/usr/bin/{name}")
    env = {fc.TOKEN_ENV: "x", "LD_LIBRARY_PATH": "/lib", "WM_PROJECT_DIR": "/usr/share/openfoam"}
    cmd = fc.mpirun_command(2, "rhoPimpleFoam", Path("/tmp/fluid"), env)
    assert cmd[:3] == ["/usr/bin/mpirun", "-np", "2"]
    assert cmd[-4:] == ["rhoPimpleFoam", "-parallel", "-case", "/tmp/fluid"]
    text = " ".join(cmd)
    assert "--mca mpi_yield_when_idle 1" in text
    for var in env:
        assert f"-x {var}" in text
    monkeypatch.setattr(fc.shutil, "which", lambda name: None)
    with pytest.raises(fc.FluidCaseError, match=r"parallel\.fluid_ranks > 1 needs mpirun"):
        fc.mpirun_command(2, "rhoPimpleFoam", Path("/tmp/fluid"), env)


@pytest.mark.skipif(not sys.platform.startswith("linux") or shutil.which("chrt") is None,
                    reason="the batch policy is Linux's (chrt: util-linux)")
def test_water_runs_under_the_batch_policy(monkeypatch):
    """The water's command starts its program under SCHED_BATCH (mpirun's ranks inherit it): the
    program reads its own policy as batch; TQ_WATER_BATCH=0 leaves the command as it was."""
    probe = [sys.executable, "-c", "import os; print(os.sched_getscheduler(0))"]
    monkeypatch.delenv(fc.BATCH_ENV, raising=False)
    cmd = fc.batch_scheduled(probe)
    assert cmd[-len(probe):] == probe
    policy = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    assert int(policy) == os.SCHED_BATCH
    if os.sched_getscheduler(0) != os.SCHED_BATCH:  # the policy is the command's, not inherited from here
        assert int(subprocess.run(probe, capture_output=True, text=True, check=True).stdout) != os.SCHED_BATCH
    monkeypatch.setenv(fc.BATCH_ENV, "0")
    assert fc.batch_scheduled(probe) == probe
