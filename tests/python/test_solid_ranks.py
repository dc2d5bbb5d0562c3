"""The solid on MPI ranks, the Python side: `--ranks N` of `tunnelquake check` and `run` refuses,
before anything runs, what tq-solid cannot run on ranks yet (an incident wave's DRM layer, a fault
offset, a motion along the axis), naming it and the fix, and accepts the rest (the staged
analysis, the seismic boundaries, the dynamic contact, damage, the water coupling, subcycling); a run on ranks
killed mid-run and resumed on its ranks (`--resume`) ends as the run never stopped; and the
mpirun command line of a run on ranks (oversubscribed only where the cores are short). The ranks
themselves are tested in tests/cpp/test_ranks.cpp (tq-solid on 1-8 ranks against one process,
the staged tunnel with contact and damage among them, and the coupled ring with the water's volume
law against the fake water)."""
from __future__ import annotations

import shutil

import pytest
from case_edits import edited, with_time

from conftest import EXAMPLE
from tunnelquake.cli import main
from tunnelquake.solid_ranks import solid_command

needs_mpirun = pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")


def test_check_with_one_rank_is_the_plain_check(capsys):
    assert main(["check", str(EXAMPLE), "--ranks", "1"]) == 0
    assert "is valid" in capsys.readouterr().out


#: the example's time.subcycling (static_water and dynamic_water subcycled)
SINGLE_RATE = ("  subcycling: {static_water: 3, dynamic_water: 3}\n", "  subcycling: 0\n")


@needs_mpirun
def test_the_water_coupling_is_accepted_on_ranks(capsys):
    """The example as it is, its three conditions, dynamic_water among them (the water coupling
    runs on the solid's ranks: each rank exchanges its part of the wetted face, test_coupled_ranks.py
    checks its results) and its subcycled conditions (stepped on ranks as one process does)."""
    assert main(["check", str(EXAMPLE), "--ranks", "3"]) == 0
    captured = capsys.readouterr()
    assert "is valid" in captured.out and "--ranks" not in captured.err
    assert "the solid on 3 MPI ranks" in captured.out


@needs_mpirun
@pytest.mark.parametrize("subcycling", [0, 3])
def test_the_staged_case_without_water_coupling_is_accepted_on_ranks(write_case, example_text, capsys, subcycling):
    """With and without subcycling (tq-solid's ranks step it as one process does, bitwise:
    tests/cpp/test_ranks.cpp, RankRuns.SubcycledThreeDimensionalTunnelWithContactAndDamageBitwiseOnOneToEightRanks)."""
    case = write_case(edited(example_text, "conditions: [no_water, static_water, dynamic_water]",
                             "conditions: [no_water, static_water]", SINGLE_RATE[0], f"  subcycling: {subcycling}\n"))
    assert main(["check", str(case), "--ranks", "4"]) == 0
    captured = capsys.readouterr()
    assert "is valid" in captured.out and "--ranks" not in captured.err
    assert "the solid on 4 MPI ranks" in captured.out
    assert "memory on 4 ranks: about " in captured.out and "MiB on each other rank" in captured.out


def test_the_memory_per_rank_estimate_is_the_measured_one_and_divides_every_rank_but_0():
    """memory_per_rank against the 2,000,376-element box on 2 ranks it is measured from
    (docs/benchmarks.md: rank 0 3,117 MiB, rank 1 1,314 MiB; within 1 %: the estimate takes rank 0's
    mirror from an earlier build's 1,811 MiB, this one's 1,803), then on more ranks: the other ranks'
    share falls as 1/N toward the whole mesh each reads, rank 0 keeps the whole model."""
    from tunnelquake.solid_ranks import memory_per_rank

    mib = 2.0**20
    first, other = memory_per_rank(2_000_376, 2)
    assert first / mib == pytest.approx(3117, rel=0.01) and other / mib == pytest.approx(1314, abs=1)
    first8, other8 = memory_per_rank(2_000_376, 8)
    assert other8 < other and other8 / mib == pytest.approx(1314 - (1811 + 144 * 2) * (1 / 2 - 1 / 8), abs=1)
    assert first8 - other8 == pytest.approx(first - other)  # rank 0's mirror: the whole model on any count


@needs_mpirun
@pytest.mark.parametrize("edit,named", [
    (("ground_motion:\n", "ground_motion:\n  azimuth: 30 deg\n"), "a motion along the tunnel's axis"),
])
def test_what_does_not_run_on_ranks_is_refused_by_name(write_case, example_text, capsys, edit, named):
    text = example_text.replace("conditions: [no_water, static_water, dynamic_water]", "conditions: [no_water]")
    if edit[0] not in text:
        text += "\n" + edit[0]
    case = write_case(text.replace(edit[0], edit[1], 1))
    assert main(["check", str(case), "--ranks", "2"]) == 1
    err = capsys.readouterr().err
    assert named in err and "without --ranks" in err, err


#: shaking simulated by the resume test, s; a checkpoint every INTERVAL s of it
END, INTERVAL = 0.2, 0.05


@needs_mpirun
def test_a_run_on_ranks_whose_rank_is_killed_resumes_on_its_ranks_bitwise_equal(tmp_path, capsys, monkeypatch):
    """`run --ranks 2` with restart checkpoints, rank 1 killed (SIGKILL, as a lost node: the test hook
    TQ_RANK_FAULT) at 70 % of the shaking: the run stops with the results file's status written and the
    checkpoint of 0.1 s kept; `run --ranks 2 --resume` continues from it and ends with every dataset and
    attribute of the results (all but the wall-clock figures) byte for byte those of the run on 2 ranks
    that was never stopped (reference; tolerance 0: the same partition sums in the same order, so a
    state the checkpoint misses shows as a difference)."""
    import h5py

    from tunnelquake.compare import results_differences

    text = "\n".join("conditions: [no_water]" if ln.startswith("conditions:") else ln
                     for ln in EXAMPLE.read_text().splitlines())
    text = text.replace("output:\n", f"output:\n  checkpoint_interval: {INTERVAL} s\n", 1)
    text = with_time(text, end_time=f"{END} s")
    ref = tmp_path / "reference"
    ref.mkdir()
    (ref / "case.yaml").write_text(text)
    assert main(["run", str(ref / "case.yaml"), "--ranks", "2", "--no-post"]) == 0
    with h5py.File(ref / "results" / "results_no_water.h5", "r") as f:
        steps = int(f["timings"].attrs["steps"])
    case = tmp_path / "case"
    (case / "results").mkdir(parents=True)
    (case / "case.yaml").write_text(text)
    shutil.copytree(ref / "results" / "mesh", case / "results" / "mesh")
    shutil.copy(ref / "results" / "motion.h5", case / "results" / "motion.h5")
    capsys.readouterr()

    monkeypatch.setenv("TQ_RANK_FAULT", f"1:{int(0.7 * steps)}")
    assert main(["run", str(case / "case.yaml"), "--ranks", "2", "--no-post"]) != 0
    monkeypatch.delenv("TQ_RANK_FAULT")
    res = case / "results" / "results_no_water.h5"
    with h5py.File(res, "r") as f:
        status = f.attrs["status"]
    assert status.startswith("stopped: the run on ranks was ended by signal"), status
    capsys.readouterr()

    assert main(["run", str(case / "case.yaml"), "--ranks", "2", "--resume", "--no-post"]) == 0
    out = capsys.readouterr().out
    assert "resume: no_water continues from its checkpoint at t = 0.1" in out, out[-3000:]
    assert "--checkpoint-dir" in out and "--resume" in out
    assert results_differences(ref / "results" / "results_no_water.h5", res) == []
    assert not (case / "results" / "no_water" / "checkpoint" / "checkpoint.json").exists()


def test_ranks_below_one_are_refused(capsys):
    assert main(["check", str(EXAMPLE), "--ranks", "0"]) == 1
    assert "give 1 or more" in capsys.readouterr().err


def test_one_rank_is_the_plain_command_line():
    assert solid_command("tq-solid", "in.h5", "r.h5", 2, 1) == ["tq-solid", "in.h5", "-o", "r.h5", "--threads", "2"]


@needs_mpirun
def test_ranks_run_under_mpirun_oversubscribed_only_where_the_cores_are_short():
    fits = solid_command("tq-solid", "in.h5", "r.h5", 1, 2, cores=2)
    assert fits[1:3] == ["-np", "2"] and fits[-1] == "--distributed" and "--oversubscribe" not in fits
    assert fits[fits.index("tq-solid"):-1] == ["tq-solid", "in.h5", "-o", "r.h5", "--threads", "1"]
    short = solid_command("tq-solid", "in.h5", "r.h5", 1, 4, cores=2)
    assert "--oversubscribe" in short and short[short.index("-np") + 1] == "4"


@needs_mpirun
def test_a_reinforced_lining_is_refused_on_ranks(capsys):
    """The reinforced lining's section share pairs each element with its face rows among the lining's
    elements, which a partition splits: refused by name, the material to use instead named."""
    assert main(["check", str(EXAMPLE.parents[1] / "headrace_tunnel" / "case.yaml"), "--ranks", "2"]) == 1
    err = capsys.readouterr().err
    assert "the reinforced_concrete material (materials.lining" in err and "use mohr_coulomb_damage" in err, err


def test_more_ranks_than_the_solids_elements_are_refused_by_check(capsys):
    """tq-solid's partition gives every rank one element at least, and refused more ranks than the
    mesh's elements only once every rank had started and read its input (the meshing and the motion
    done): `check --ranks N` refuses them first, naming --ranks, its value, the element count (the
    example's 1,320 rock + 144 lining) and the fix. The count itself passes the count test (mpirun
    aside, which the other refusals name)."""
    from tunnelquake.case import load_case
    from tunnelquake.solid_ranks import ranks_refusal, solid_elements

    assert solid_elements(load_case(EXAMPLE).data) == 1464
    assert main(["check", str(EXAMPLE), "--ranks", "1465"]) == 1
    err = capsys.readouterr().err
    assert "--ranks 1465: the solid's mesh has 1,464 elements (rock and lining)" in err, err
    assert "give --ranks 1464 or fewer, or a finer mesh" in err, err
    assert not any("elements" in r for r in ranks_refusal(load_case(EXAMPLE), 1464))


def test_the_solids_element_count_is_the_built_meshs_with_plugged_ends(tmp_path):
    """The count the ranks are held to is the built mesh's rock and lining, the water's hexahedra of
    the plugged end layers among them (the mesher fills them with rock; meshing.params.element_counts
    lists them as water): the axial-wave case's mesh, 3 layers plugged at each end."""
    from tunnelquake.case import load_case
    from tunnelquake.meshing import build_tunnel_mesh
    from tunnelquake.solid_ranks import solid_elements

    d = load_case(EXAMPLE.parent.parent / "axial_wave" / "case.yaml").data
    built = build_tunnel_mesh(d["geometry"], d["mesh"], tmp_path / "mesh")["counts"]
    assert solid_elements(d) == built["rock"] + built["lining"], built
