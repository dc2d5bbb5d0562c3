"""A record suite on Slurm (docs/user_guide.md "Record suites", docs/reliability.md "Slurm"): the job
array `tunnelquake run --slurm` writes, submitted to a stand-in `sbatch` (slurm_standin.py: it reads
the #SBATCH lines as sbatch does and runs the array tasks here, as Slurm starts them) from a case
folder whose path holds blanks, quotes, a `#` and a `%`.

The reference of the requeued member is the same member's uninterrupted run in the same job: its
results file must be equal byte for byte (wall-clock figures aside, compare.results_differences), as
for any resumed run (docs/reliability.md "Restart")."""
from __future__ import annotations

import json
import math
import re
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
import slurm_standin as SB
from test_suite import _env, _records, _suite_case, _tq

from tunnelquake.compare import results_differences

#: shaking simulated, s, and a checkpoint every INTERVAL s of it
END, INTERVAL = 0.4, 0.1

SUITE_2 = """suite:
  records:
    - {glob: "records/r*.txt", units: g}
  scaling: pga
  pga: 1.5 m/s^2
"""


def _case(folder: Path, extra: str = "") -> Path:
    """A two-member suite of the example slice: no_water only, END s of shaking, a checkpoint
    every INTERVAL s."""
    _records(folder / "records", 2)
    case = _suite_case(folder, SUITE_2 + extra, end_time=f"{END} s")
    text = case.read_text().replace("conditions: [no_water, static_water]", "conditions: [no_water]")
    assert text.count("\noutput:\n") == 1
    case.write_text(text.replace("\noutput:\n", f"\noutput:\n  checkpoint_interval: {INTERVAL} s\n"))
    return case


def _stand_in(tmp_path: Path) -> dict:
    """PATH with the stand-in `sbatch` first; its spool folder away from the case."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    sbatch = bin_dir / "sbatch"
    sbatch.write_text(f"#!/bin/sh\nexec {shlex.quote(sys.executable)} {shlex.quote(SB.__file__)} sbatch \"$@\"\n")
    sbatch.chmod(0o755)
    env = _env()
    env["PATH"] = f"{bin_dir}:{env['PATH']}"
    env["SLURM_STANDIN_SPOOL"] = str(tmp_path / "spool")
    return env


def _files(folder: Path, but: Path) -> dict[str, int]:
    """Every file under `folder` outside `but`, with its modification time."""
    return {str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file() and but not in p.parents}


def _checkpoint_time(member: Path) -> float | None:
    try:
        return float(json.loads((member / "no_water" / "checkpoint" / "checkpoint.json").read_text())["time"])
    except (OSError, ValueError, KeyError):
        return None


def _status(res: Path) -> str:
    with h5py.File(res, "r") as f:
        s = f.attrs["status"]
    return s.decode() if isinstance(s, bytes) else str(s)


def test_slurm_array_from_a_path_with_blanks_completes_and_a_requeued_member_resumes(tmp_path):
    """The job array of a two-member suite in a folder named with blanks, quotes, `#` and `%`,
    submitted as the message says: both tasks complete within their --time (2 x check's estimate
    + 10 min) and write nothing outside the results folder. Then member r1 runs again, is killed
    with every process it started after its first checkpoint (a lost node), and its task is started
    again as Slurm requeues one (SLURM_RESTART_COUNT=1): it continues from that checkpoint and ends
    equal to its uninterrupted run. The suite report lists both members completed."""
    from tunnelquake.case import load_case
    from tunnelquake.scene import runtime_estimate

    site = tmp_path / "site A's \"tunnels\" #1 (50%)"
    folder = site / "tun nel"
    case = _case(folder)
    env = _stand_in(tmp_path)
    submit_dir = tmp_path / "submit here"
    submit_dir.mkdir()
    written = _tq("run", case, "--slurm", "--no-post")
    assert written.returncode == 0, written.stdout[-3000:] + written.stderr[-3000:]
    res = folder / "results"
    script = res / "suite.slurm"
    before = {**_files(site, res), **_files(submit_dir, res)}

    # the whole job, submitted from another folder
    t0 = time.monotonic()
    out = subprocess.run(["sbatch", str(script)], cwd=submit_dir, env=env, capture_output=True, text=True,
                         timeout=600)
    took = time.monotonic() - t0
    assert out.returncode == 0, out.stdout + out.stderr + "".join(
        p.read_text()[-2000:] for p in (res / "members").glob("*/run.log"))
    assert "(time limit)" not in out.stderr
    job_id = int(re.search(r"Submitted batch job (\d+)", out.stdout).group(1))
    for m in ("r0", "r1"):
        assert _status(res / "members" / m / "results_no_water.h5") == "completed"
        assert json.loads((res / "members" / m / "member.json").read_text())["status"] == "completed"
        task_out = (res / "members" / f"slurm-{job_id}_{m[1]}.out").read_text()
        assert f"member {m}: completed (exit 0)" in task_out, task_out
    assert {**_files(site, res), **_files(submit_dir, res)} == before, "files written outside the results folder"
    # --time: check's estimate of one member with the margin, which the tasks kept within
    est = runtime_estimate(load_case(case)).wall
    job = SB.submit(script, spool=tmp_path / "spool")
    assert job.time_limit == 60 * math.ceil((2 * est + 600) / 60), job.opts
    assert took < job.time_limit
    assert job.opts["requeue"] is True and job.workdir == res / "members"
    # the message's command submits this script, pasted into a shell
    command = re.search(r"\(`(sbatch [^`]+)`\)", written.stdout).group(1)
    assert shlex.split(command) == ["sbatch", str(script)], command
    reference = tmp_path / "r1_uninterrupted.h5"
    shutil.copy(res / "members" / "r1" / "results_no_water.h5", reference)

    # r1 again, killed after its first checkpoint with every process it started
    job = SB.submit(script, spool=tmp_path / "spool", submit_dir=submit_dir)
    task = job.start(1, env=env)
    member = res / "members" / "r1"
    deadline = time.monotonic() + 300
    try:
        while (_checkpoint_time(member) or 0.0) < INTERVAL - 1e-9:
            assert task.proc.poll() is None and time.monotonic() < deadline, task.output.read_text()[-3000:]
            time.sleep(0.02)
    finally:
        task.kill()
    t_ck = _checkpoint_time(member)
    assert t_ck is not None and t_ck < END - 1e-6 and _status(member / "results_no_water.h5") != "completed"

    # requeued: the same task with SLURM_RESTART_COUNT=1
    again = job.start(1, restart_count=1, env=env)
    assert again.wait() == 0, again.output.read_text()[-3000:]
    task_out = again.output.read_text()
    assert "SLURM_RESTART_COUNT=1" in task_out and "member r1: completed (exit 0)" in task_out, task_out
    log = (member / "run.log").read_text()
    killed, resumed = log.split("--resume\n")  # the killed attempt's log is kept, the resumed one after it
    assert "condition no_water: running the solid" in killed and "tq-solid: completed" not in killed, killed[-3000:]
    assert f"resume: no_water continues from its checkpoint at t = {t_ck:.6g} s" in resumed, resumed[-3000:]
    assert "tq-solid: resumed from checkpoint 1 at t = " in resumed, resumed[-3000:]
    assert results_differences(reference, member / "results_no_water.h5") == []

    report = _tq("post", case)
    assert report.returncode == 0, report.stdout[-3000:] + report.stderr[-3000:]
    assert (res / "suite_report.md").read_text().count("| completed |") == 2


def test_slurm_time_from_the_case_key(tmp_path):
    """suite.slurm_time sets each task's --time (rounded up to whole minutes); below a minute
    `check` refuses it naming the key."""
    case = _case(tmp_path / "a b", "  slurm_time: 1.5 h\n")
    out = _tq("run", case, "--slurm")
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    job = SB.submit(case.parent / "results" / "suite.slurm", spool=tmp_path / "spool")
    assert job.opts["time"] == "01:30:00" and job.time_limit == 5400.0
    case.write_text(case.read_text().replace("slurm_time: 1.5 h", "slurm_time: 30 s"))
    bad = _tq("check", case)
    assert bad.returncode == 1 and "suite.slurm_time = '30 s': must be >= 60" in bad.stderr, bad.stderr


@pytest.mark.parametrize("line, expect", [
    (' --output="/a b/slurm-%A_%a.out"', ["--output=/a b/slurm-%A_%a.out"]),
    (" --chdir='/it''s' # a comment", ["--chdir=/its"]),
    (' --job-name="a \\"q\\" #1" --requeue', ['--job-name=a "q" #1', "--requeue"]),
    (" --chdir=/a\\ b#c", ["--chdir=/a b"]),
])
def test_the_stand_in_splits_sbatch_lines_as_sbatch_does(line, expect):
    """The stand-in's reading of an #SBATCH line, against sbatch's own rules (src/sbatch/opt.c
    _get_argument: quotes group, a backslash escapes, an unquoted # ends the line)."""
    assert SB.words(line) == expect
