"""Shared fixtures: paths of the repository, the example case and the shared data; the inputs of
a tq-solid run written from a case as `tunnelquake run` writes them, and the run itself."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

# The tests' runs (two workers side by side, cases cut short) are not this machine's measure:
# `run` keeps no measured-against-estimated ratio for check's later estimates (rates.record_run)
os.environ.setdefault("TQ_RATES_RECORD", "0")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "cases" / "paper_tunnel" / "case.yaml"
SHARED = ROOT.parent / "shared"
EL_CENTRO = SHARED / "data" / "ground_motions" / "elCentro_1940_NS_Peknold_dt0.02.AT2"
EL_CENTRO_PEER = SHARED / "data" / "ground_motions" / "IELC180_PEER_1940_ElCentro9_180_dt0.01.AT2"

#: the example's mesh coarsened for the coupled tests: one lining element through (0.75 m), 24
#: around, 4 rock rings, 2 water rings, 13.5 m outer elements
COARSE_EXAMPLE_MESH = {"lining_elements_around": 24, "lining_elements_through": 1, "near_field_radial_divisions": 4,
                       "water_ring_divisions": 2, "max_element_size": "13.5 m"}


def coupled_run_missing(mpirun: bool = False) -> str | None:
    """What a coupled run (with `mpirun`: on several water ranks) lacks on this machine, as a skip
    reason; None when nothing is missing."""
    from tunnelquake import paths

    missing = (paths.solid_executable() is None or paths.openfoam_library() is None
               or not Path("/usr/share/openfoam").is_dir() or (mpirun and not Path("/usr/bin/mpirun").exists()))
    if not missing:
        return None
    return ("tq-solid, libtqFoam.so, OpenFOAM v1912 or mpirun missing (set TQ_BUILD_DIR)" if mpirun
            else "tq-solid, libtqFoam.so or OpenFOAM v1912 missing (set TQ_BUILD_DIR)")


@pytest.fixture
def example_text() -> str:
    return EXAMPLE.read_text()


@pytest.fixture
def write_case(tmp_path):
    """Write a case text into a temporary folder and return its path."""

    def _write(text: str, name: str = "case.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p

    return _write


def mesh_and_motion(case, folder: Path, layers=None, geology=None) -> None:
    """A loaded case's mesh (mesh.h5, with `layers` and `geology` as the mesher takes them) and
    ground motion (motion.h5) in `folder`."""
    from tunnelquake.meshing import build_tunnel_mesh
    from tunnelquake.motion import from_case
    from tunnelquake.prepare import write_motion

    d = case.data
    build_tunnel_mesh(d["geometry"], d["mesh"], folder, layers, geology)
    motion, _ = from_case(d["ground_motion"], case.dir)
    write_motion(motion, folder / "motion.h5")


def solid_input(case, folder: Path, layers=None, geology=None) -> Path:
    """mesh_and_motion and the condition no_water's tq-solid input from them (in.h5 in `folder`);
    returns the input's path."""
    from tunnelquake.solid_input import write_solid_input

    mesh_and_motion(case, folder, layers, geology)
    return write_solid_input(case, folder / "mesh.h5", folder / "motion.h5", "no_water", folder / "in.h5")


def checked_input(folder: Path, text: str, capsys):
    """The case `text` written to folder/case.yaml, passed by `tunnelquake check` (asserted), loaded,
    and its no_water tq-solid input made with the case's ground layers and geology (solid_input);
    returns (the case, the input's path)."""
    from tunnelquake.case import case_geology, ground_layers, load_case
    from tunnelquake.cli import main

    p = folder / "case.yaml"
    p.write_text(text)
    assert main(["check", str(p)]) == 0, capsys.readouterr().err
    case = load_case(p)
    return case, solid_input(case, folder, ground_layers(case.data), case_geology(case.data))


def solid_with(*capabilities: str):
    """The built tq-solid when its --capabilities lists each of `capabilities`, else None."""
    from tunnelquake import paths

    exe = paths.solid_executable()
    if exe is None:
        return None
    out = subprocess.run([str(exe), "--capabilities"], capture_output=True, text=True, timeout=10)
    return exe if out.returncode == 0 and all(c in out.stdout for c in capabilities) else None


def run_solid(exe, inp: Path, res: Path, timeout: float) -> subprocess.CompletedProcess:
    """tq-solid `exe` on one thread from `inp` to `res`; asserts that it exited 0 and returns the
    run (its printed lines)."""
    run = subprocess.run([str(exe), str(inp), "-o", str(res), "--threads", "1"], capture_output=True, text=True,
                         timeout=timeout)
    assert run.returncode == 0, run.stdout + run.stderr
    return run


def ran_case(folder: Path, text: str, *options: str) -> Path:
    """`tunnelquake run` (with `options`) of the case `text` written to folder/case.yaml, asserted to
    end with exit status 0; returns `folder`."""
    from tunnelquake.cli import main

    (folder / "case.yaml").write_text(text)
    assert main(["run", str(folder / "case.yaml"), *options]) == 0
    return folder


#: The tests that measure this machine's speed (the rates' probes, the threads' speed-up; whole files),
#: time a child against a grace period (whole file), or bound a wall-clock time (a stop within its
#: bound, a timeout kept: those tests alone). ./Alltest runs them after the rest, one at a time, so
#: that no other test shares the cores with them; the rest runs on two pytest-xdist workers, each file
#: on one of them. Marked `serial` here, in one place.
SERIAL_FILES = frozenset({"test_thread_speedup.py", "test_size_class.py", "test_rates.py", "test_failure_blame.py"})
SERIAL_TESTS = {
    "test_drawing.py": {"test_a_helper_that_hangs_is_stopped_and_its_jobs_drawn_here"},
    "test_slurm.py": {"test_slurm_array_from_a_path_with_blanks_completes_and_a_requeued_member_resumes"},
    "test_solid_coupling.py": {"test_killed_fluid_stops_the_solid_with_a_clear_message",
                               "test_hung_fluid_stops_the_solid_after_the_timeout"},
    "test_solid_coupling_mpi.py": {"test_fluid_dying_under_mpirun_stops_the_solid_with_a_clear_message",
                                   "test_hung_fluid_under_mpirun_ends_the_job_after_the_timeout"},
    "test_suite.py": {"test_ctrl_c_stops_every_member_in_bounded_time_and_resume_runs_only_the_rest"},
    "test_reliability_input.py": {"test_yaml_alias_bomb_is_refused_at_once"},
    "test_checkpoint_integrity.py": {"test_damaged_solid_checkpoint_is_detected_and_the_resume_falls_back",
                                     "test_damaged_water_checkpoint_is_detected_before_the_water_starts",
                                     "test_damaged_water_checkpoint_given_to_the_water_stops_the_run_at_once_with_its_cause"},
    "test_restart.py": {"test_run_on_ranks_stopped_by_ctrl_c_after_a_checkpoint_resumes_bitwise_equal"},
    "test_water_ranks_resume.py": {
        "test_solid_and_water_on_2_ranks_each_a_rank_lost_stops_whole_and_resumes_bitwise_equal"},
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        name = item.path.name
        if name in SERIAL_FILES or item.originalname in SERIAL_TESTS.get(name, ()):
            item.add_marker(pytest.mark.serial)


@pytest.fixture
def probe_runs_back_to_back(monkeypatch):
    """check's thread probe without the pause between its runs (rates.THREAD_PROBE_GAP_S spaces them
    against a VM's passing spells), for tests whose probe figures do not drift."""
    from tunnelquake import rates

    monkeypatch.setattr(rates, "THREAD_PROBE_GAP_S", 0.0)
