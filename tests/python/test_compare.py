"""`tunnelquake compare`: two runs' results are equal only when every result byte is; wall-clock
figures (/timings, attributes in seconds of wall time), the runs' paths and report lines quoting wall
time are not results. Reference: the definition of bitwise equality (no tolerance)."""
from __future__ import annotations

import h5py
import numpy as np

from tunnelquake.cli import main
from tunnelquake.compare import compare_runs


def _run(folder, value=1.0, wall=3.0, report_wall="12 s"):
    folder.mkdir(parents=True)
    with h5py.File(folder / "results_no_water.h5", "w") as f:
        f.attrs["status"] = "completed"
        f.attrs["wall_s"] = wall
        f.attrs["input"] = str(folder / "solid_input.h5")
        g = f.create_group("monitors/top")
        g["u"] = np.array([0.0, 1e-3, value * 2e-3])
        f.create_group("timings").attrs["loop_s"] = wall
    (folder / "monitors_no_water.csv").write_text("t,u\n0,0\n")
    (folder / "report.md").write_text(f"# report\npeak 2.0 mm\ncoupled wall time {report_wall}\n"
                                      f"results in {folder.resolve()}/results_no_water.h5\n")
    return folder


def test_runs_that_differ_only_in_wall_clock_figures_and_paths_are_equal(tmp_path):
    a = _run(tmp_path / "a")
    b = _run(tmp_path / "b", wall=7.5, report_wall="31 s")
    c = compare_runs(a, b)
    assert c.equal and c.compared == ["results_no_water.h5", "monitors_no_water.csv", "report.md"]
    assert main(["compare", str(a), str(b)]) == 0


def test_a_report_line_with_another_result_is_a_difference(tmp_path):
    a = _run(tmp_path / "a")
    b = _run(tmp_path / "b")
    (b / "report.md").write_text((b / "report.md").read_text().replace("peak 2.0 mm", "peak 2.1 mm"))
    c = compare_runs(a, b)
    assert c.differences == {"report.md": ["-peak 2.0 mm", "+peak 2.1 mm"]}


def test_one_value_one_ulp_apart_is_a_difference(tmp_path, capsys):
    a = _run(tmp_path / "a")
    b = _run(tmp_path / "b", value=np.nextafter(1.0, 2.0))
    c = compare_runs(a, b)
    assert not c.equal
    assert list(c.differences) == ["results_no_water.h5"]
    assert c.differences["results_no_water.h5"][0].startswith("monitors/top/u: values differ")
    assert main(["compare", str(a), str(b)]) == 1
    assert "monitors/top/u: values differ" in capsys.readouterr().out


def test_a_folder_without_results_is_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    assert main(["compare", str(tmp_path / "empty"), str(_run(tmp_path / "b"))]) == 2


def _holding(folder, *, run_lock: bool):
    """A process that holds `folder`/results_no_water.h5 open for writing (HDF5's lock, as a
    running solver does) and, with `run_lock`, the folder's run lock (as `tunnelquake run` does)."""
    import subprocess
    import sys

    code = ("import sys, time, h5py, contextlib\n"
            "from tunnelquake.runlock import run_lock\n"
            "folder = sys.argv[1]\n"
            "with contextlib.ExitStack() as s:\n"
            "    if sys.argv[2] == '1':\n"
            "        s.enter_context(run_lock(__import__('pathlib').Path(folder), 'tunnelquake run case.yaml'))\n"
            "    f = s.enter_context(h5py.File(folder + '/results_no_water.h5', 'a'))\n"
            "    print('ready', flush=True)\n"
            "    time.sleep(60)\n")
    proc = subprocess.Popen([sys.executable, "-c", code, str(folder), "1" if run_lock else "0"],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    return proc


def test_a_folder_being_written_is_refused_naming_the_run_and_a_locked_file_naming_the_lock(tmp_path, capsys):
    """compare on a folder that `tunnelquake run` holds (its solver writing results_no_water.h5)
    says so with the run's pid and exit 2 (on today's main: BlockingIOError traceback); a file an
    orphaned solver still holds (no run lock) is refused as locked. Once released, it compares."""
    a = _run(tmp_path / "a")
    b = _run(tmp_path / "b")
    for with_lock, words in ((True, "is being written by a running tunnelquake command (pid "),
                             (False, "is locked by the process writing it")):
        proc = _holding(b, run_lock=with_lock)
        try:
            for args in ((a, b), (a / "results_no_water.h5", b / "results_no_water.h5")):
                rc = main(["compare", *map(str, args)])
                out = capsys.readouterr()
                assert rc == 2 and "Traceback" not in out.out + out.err
                assert words in out.out, out.out
                if with_lock:
                    assert f"pid {proc.pid}" in out.out and "tunnelquake run case.yaml" in out.out
        finally:
            proc.kill()
            proc.wait()
    assert main(["compare", str(a), str(b)]) == 0


def test_two_results_files_are_compared_alone_and_a_file_against_a_folder_s_file_of_its_name(tmp_path, capsys):
    """`compare A/results_x.h5 B/results_x.h5` (on today's main: UnicodeDecodeError, the file read
    as a case) compares the two files: equal -> 0; one value one ulp apart -> 1 naming it. A file
    against a folder compares it with the folder's file of that name; a file that is neither HDF5
    nor a case file is refused in one line."""
    a = _run(tmp_path / "a")
    b = _run(tmp_path / "b", wall=9.0)
    c = _run(tmp_path / "c", value=np.nextafter(1.0, 2.0))
    fa, fb, fc = (x / "results_no_water.h5" for x in (a, b, c))
    assert main(["compare", str(fa), str(fb)]) == 0
    assert "results_no_water.h5: equal" in capsys.readouterr().out
    assert main(["compare", str(fa), str(fc)]) == 1
    assert "monitors/top/u: values differ" in capsys.readouterr().out
    assert main(["compare", str(fa), str(c)]) == 1
    capsys.readouterr()
    (tmp_path / "junk.bin").write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    rc = main(["compare", str(tmp_path / "junk.bin"), str(fa)])
    out = capsys.readouterr()
    assert rc == 2 and "Traceback" not in out.out + out.err
    assert "junk.bin: neither a results folder" in out.out and "not UTF-8" in out.out, out.out
