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
