"""`tunnelquake run` does post's per-condition work beside the condition still running
(post_early.py): the solid-only conditions' monitors CSV and ParaView files are made, and the
motion's figure drawn, before the coupled condition ends; nothing of it is in place before post; and
every output of the run is byte for byte what `tunnelquake post` makes afterwards from the same
results files, with a failed condition as without the early work.

The solvers are stood in for: the results files of one real run (the example on the coarse mesh,
0.02 s of shaking, `--no-post`) are put in place by stand-ins of launch.run_solid_condition and
launch.run_coupled_condition, the coupled one ending only once the early work is done, so the
order is the same on every machine."""
from __future__ import annotations

import shutil
import threading
from pathlib import Path

import pytest
import yaml

from conftest import COARSE_EXAMPLE_MESH, EXAMPLE, coupled_run_missing
from tunnelquake import launch, post_early
from tunnelquake.cli import main

pytestmark = pytest.mark.skipif(coupled_run_missing() is not None, reason=str(coupled_run_missing()))

CONDITIONS = ("no_water", "static_water", "dynamic_water")
#: s the coupled stand-in waits for the early work at most (it takes about 2 s)
EARLY_WAIT_S = 300.0


def _case_text() -> str:
    data = yaml.safe_load(EXAMPLE.read_text())
    data["mesh"].update(COARSE_EXAMPLE_MESH)
    data["time"]["end_time"] = "0.02 s"
    gm = data["ground_motion"]
    gm["file"] = str((EXAMPLE.parent / gm["file"]).resolve())
    data.pop("variants", None)
    return yaml.safe_dump(data, sort_keys=False)


@pytest.fixture(scope="module")
def ran(tmp_path_factory) -> Path:
    """A case folder whose results folder holds one real run's results files, without post."""
    folder = tmp_path_factory.mktemp("ran")
    (folder / "case.yaml").write_text(_case_text())
    assert main(["run", str(folder / "case.yaml"), "--no-post"]) == 0
    return folder


def _outputs(results: Path) -> dict[str, bytes]:
    """Every file of a results folder by its path in it (the run lock, which names its holder, left out)."""
    return {str(p.relative_to(results)): p.read_bytes() for p in sorted(results.rglob("*"))
            if p.is_file() and p.name != ".tunnelquake-run.lock"}


def _stood_in_run(ran: Path, folder: Path, monkeypatch, *options: str, failing: str | None = None):
    """`tunnelquake run` in `folder` (a copy of `ran` without its results files, its motion made
    again) with the solvers stood in for; `failing`: a solid-only condition whose stand-in exits 3
    (its complete results file in place). Returns (exit code, what the folder held when the coupled
    condition's stand-in ended, the printed text)."""
    shutil.copytree(ran, folder)
    out = folder / "results"
    for f in out.glob("results_*.h5"):
        f.unlink()
    (out / "motion.json").unlink()  # the motion made again: its figure is drawn beside the conditions
    (out / "figures" / "fig03_input_motion.png").unlink()

    def put(cond: str) -> Path:
        res = out / f"results_{cond}.h5"
        shutil.copyfile(ran / "results" / res.name, res)
        return res

    def solid_only(case, cond, motion_file, prefix=False, resume=False, ranks=1):
        return (3 if cond == failing else 0), put(cond)

    idle_done = threading.Event()
    original_idle = post_early.EarlyPost.idle

    def idle(self, completed, first=None):
        try:
            original_idle(self, completed, first)
        finally:
            idle_done.set()

    seen: dict = {}

    def coupled(case, cond, motion_file, share=1, resume=False, solid_ranks=1):
        if "--no-post" in options:  # no early work: wait for the motion's figure beside it instead
            fig = out / "figures" / "fig03_input_motion.png"
            for _ in range(int(EARLY_WAIT_S / 0.05)):
                if fig.is_file() and all((out / f"results_{c}.h5").is_file() for c in CONDITIONS[:2]):
                    break
                threading.Event().wait(0.05)
        else:
            assert idle_done.wait(EARLY_WAIT_S)
        seen.update(_outputs(out))
        seen["staging exists"] = (out / post_early.STAGING).is_dir()
        return 0, put(cond), "stood in"

    monkeypatch.setattr(launch, "run_solid_condition", solid_only)
    monkeypatch.setattr(launch, "run_coupled_condition", coupled)
    monkeypatch.setattr(launch, "concurrent_conditions", lambda: 2)
    monkeypatch.setattr(launch, "solver_status", lambda: {"solid": None, "fluid": None})
    monkeypatch.setattr(post_early.EarlyPost, "idle", idle)
    rc = main(["run", str(folder / "case.yaml"), *options])
    return rc, seen


def _post_afterwards(folder: Path, tmp_path: Path) -> dict[str, bytes]:
    """The outputs `tunnelquake post` makes from a copy of `folder`'s results files and inputs."""
    again = tmp_path / "post_afterwards"
    shutil.copytree(folder, again)
    out = again / "results"
    for p in list(out.rglob("*")):
        if p.is_file() and (p.suffix in (".csv", ".png", ".xdmf", ".md") or p.parent.name == "paraview"
                            or p.name == "post_inputs.json") and p.name != "fig03_input_motion.png":
            p.unlink()
    assert main(["post", str(again / "case.yaml")]) == 0
    return _outputs(out)


def test_early_work_beside_the_coupled_condition(ran, tmp_path, monkeypatch, capsys):
    rc, seen = _stood_in_run(ran, tmp_path / "run", monkeypatch)
    text = capsys.readouterr().out
    assert rc == 0, text[-3000:]
    staged = f"{post_early.STAGING}/"
    # before the coupled condition ended: the motion's figure drawn, the solid-only conditions'
    # monitors CSV and ParaView files made in the staging folder, none of post's outputs in place
    assert "figures/fig03_input_motion.png" in seen and "motion.json" in seen
    for cond in CONDITIONS[:2]:
        for name in (f"monitors_{cond}.csv", f"paraview/{cond}.xdmf", f"paraview/{cond}.h5"):
            assert staged + name in seen
            assert name not in seen
        assert f"post: {cond}'s monitors, ParaView file and design quantities made beside" in text
    assert not any(k.startswith(staged) and "dynamic_water" in k for k in seen)
    assert "report.md" not in seen and "monitors_dynamic_water.csv" not in seen
    # after: every output is what post makes afterwards from the same results, byte for byte; the
    # staged files are the ones in place
    out = tmp_path / "run" / "results"
    assert not (out / post_early.STAGING).exists()
    made = _outputs(out)
    for cond in CONDITIONS[:2]:
        for name in (f"monitors_{cond}.csv", f"paraview/{cond}.xdmf", f"paraview/{cond}.h5"):
            assert made[name] == seen[staged + name]
    afterwards = _post_afterwards(tmp_path / "run", tmp_path)
    assert made.keys() == afterwards.keys()
    assert [k for k in made if made[k] != afterwards[k]] == []
    assert any(k.startswith("figures/design_") for k in made) and "paraview/dynamic_water.xdmf" in made


def test_a_failed_condition_is_post_processed_as_without_early_work(ran, tmp_path, monkeypatch, capsys):
    rc, seen = _stood_in_run(ran, tmp_path / "run", monkeypatch, failing="static_water")
    text = capsys.readouterr().out
    assert rc == 1 and "static_water (solid): tq-solid stopped (exit 3)" in text
    staged = f"{post_early.STAGING}/"
    assert staged + "monitors_no_water.csv" in seen  # the completed one early, the failed one in post
    assert not any(k.startswith(staged) and "static_water" in k for k in seen)
    made = _outputs(tmp_path / "run" / "results")
    afterwards = _post_afterwards(tmp_path / "run", tmp_path)
    assert made.keys() == afterwards.keys()
    assert [k for k in made if made[k] != afterwards[k]] == []
    assert "monitors_static_water.csv" in made and "paraview/static_water.xdmf" in made


def test_no_post_does_no_post_work(ran, tmp_path, monkeypatch, capsys):
    rc, seen = _stood_in_run(ran, tmp_path / "run", monkeypatch, "--no-post")
    assert rc == 0
    assert "figures/fig03_input_motion.png" in seen and not seen["staging exists"]
    made = _outputs(tmp_path / "run" / "results")
    assert not [k for k in made if k.endswith((".csv", ".xdmf", ".md")) or k.startswith(("paraview/", "figures/fig0",
                                                                                          "figures/design"))
                and k != "figures/fig03_input_motion.png"]
    assert "post:" not in capsys.readouterr().out
