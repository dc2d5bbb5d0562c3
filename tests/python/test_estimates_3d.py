"""`check`'s estimates for a 3D case with a fault offset imposed before the shaking (scene.runtime_estimate,
meshing.params.memory_estimate; docs/benchmarks.md "check's estimates on the 3D cases").

References: the estimate's parts against the counts they are made of (the mesh's element counts,
fault_offset.increments, the measured multiples in rates.py), and against tq-solid's own counts and
memory on a case unlike cases/fault_crossing (a coarser mesh, a smaller slip in fewer increments):
the relaxation steps it took for the fault offset (a count, not a time) and its peak resident
memory (its VmHWM), each within the 30 % the estimates claim."""
from __future__ import annotations

import copy
import subprocess
import time
from pathlib import Path

import pytest

from conftest import EXAMPLE
from tunnelquake import rates as R

FAULT_CASE = EXAMPLE.parents[1] / "fault_crossing" / "case.yaml"
GIVEN = R.MachineRates(0.5, "test", "given")


def _case(tmp_path, replace: dict[str, str], end: float = 0.05):
    """cases/fault_crossing with lines replaced (by their start) and `end` s of shaking."""
    text = FAULT_CASE.read_text().splitlines()
    for i, line in enumerate(text):
        for start, new in replace.items():
            if line.lstrip().startswith(start):
                text[i] = line[: len(line) - len(line.lstrip())] + new
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "case.yaml").write_text("\n".join(text) + f"\ntime:\n  end_time: {end} s\n")
    from tunnelquake.case import load_case

    return load_case(tmp_path / "case.yaml")


def _counts(case):
    from tunnelquake.case import case_geology, ground_layers
    from tunnelquake.meshing.params import element_counts, resolve

    d = case.data
    return element_counts(resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d)))


def test_fault_offset_statics_and_the_shaking_after_it_are_the_counted_parts(tmp_path):
    """The static offset costs increments x RELAX_STEPS_PER_INCREMENT relaxation steps of every solid
    element at RELAX_STEP_FACTOR times the shaking's rate, once per condition; the shaking after it is
    YIELDED_SHAKING_FACTOR dearer in ground that yields and not in elastic ground; an offset during
    the shaking (a rise time) has no static stage."""
    from tunnelquake.scene import runtime_estimate

    case = _case(tmp_path / "a", {})
    n = sum(_counts(case)[k] for k in ("rock", "lining"))
    est = runtime_estimate(case, rates=GIVEN)
    inc = case.data["fault_offset"]["increments"]
    assert est.statics_steps == inc * R.RELAX_STEPS_PER_INCREMENT
    assert est.statics == pytest.approx(n * est.statics_steps * R.SOLID_PER_PROBE_S * 0.5 * R.RELAX_STEP_FACTOR,
                                        rel=1e-12)
    shaking = n * est.steps * R.SOLID_PER_PROBE_S * 0.5
    assert est.seconds == pytest.approx({c: shaking * R.YIELDED_SHAKING_FACTOR for c in case.data["conditions"]},
                                        rel=1e-12)
    # the solid-only conditions one after another, each with its own static stages
    assert est.wall == pytest.approx(sum(est.seconds.values()) + len(est.seconds) * est.statics, rel=1e-12)
    assert "fault offset's static stage" in est.line()

    elastic = copy.deepcopy(case)
    for m in elastic.data["materials"].values():
        m["model"] = "elastic"
    e = runtime_estimate(elastic, rates=GIVEN)
    assert e.statics == pytest.approx(est.statics, rel=1e-12)
    assert e.seconds["no_water"] == pytest.approx(shaking, rel=1e-12)

    during = copy.deepcopy(case)
    during.data["fault_offset"]["rise_time"] = 0.5
    e = runtime_estimate(during, rates=GIVEN)
    assert e.statics == 0 and e.statics_steps == 0 and e.seconds["no_water"] == pytest.approx(shaking, rel=1e-12)
    assert "the static stages come on top" in e.line()


def test_run_memory_counts_the_driver_and_each_solver(tmp_path):
    """'run' is the Python driver, one tq-solid (base + bytes per element) per solid process at once,
    and OpenFOAM's base and cells only with the coupled condition, beside which a second tq-solid runs."""
    from tunnelquake.meshing import params as P

    counts = {"rock": 1000, "lining": 200, "water": 300, "regions": {}}
    solo = P.memory_estimate(counts, ["no_water", "static_water"])["run"]
    assert solo == pytest.approx(P.DRIVER_BYTES + P.SOLID_BASE_BYTES + 1200 * P.SOLID_BYTES_PER_ELEMENT)
    both = P.memory_estimate(counts, ["no_water", "dynamic_water"])["run"]
    assert both == pytest.approx(P.DRIVER_BYTES + 2 * (P.SOLID_BASE_BYTES + 1200 * P.SOLID_BYTES_PER_ELEMENT)
                                 + P.WATER_BASE_BYTES + 300 * P.WATER_BYTES_PER_CELL)


def test_a_coarser_fault_crossing_takes_the_estimated_relaxation_steps_and_memory(tmp_path):
    """A fault crossing unlike the shipped one (12 m elements, 10 axial ones, a 0.3 m slip in 4
    increments, no_water alone): tq-solid's relaxation steps for the offset within 30 % of the
    estimate's, and its peak resident memory within 30 % of one tq-solid's in memory_estimate."""
    import h5py

    from tunnelquake import paths
    from tunnelquake.meshing import params as P
    from tunnelquake.prepare import make_mesh, make_motion, mesh_dir
    from tunnelquake.scene import runtime_estimate
    from tunnelquake.solid_input import write_solid_input

    exe = paths.solid_executable()
    if not exe.is_file():
        pytest.skip("tq-solid is not built")
    case = _case(tmp_path / "c", {"max_element_size:": "max_element_size: 12 m",
                                  "elements_along_axis:": "elements_along_axis: 10",
                                  "magnitude:": "magnitude: 0.3 m", "increments:": "increments: 4",
                                  "conditions:": "conditions: [no_water]"}, end=0.001)
    make_mesh(case)
    _, motion_h5 = make_motion(case)
    inp = write_solid_input(case, mesh_dir(case) / "mesh.h5", motion_h5, "no_water", tmp_path / "in.h5")
    out = tmp_path / "out.h5"
    proc = subprocess.Popen([str(exe), str(inp), "-o", str(out), "--threads", "1"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    # its peak resident memory: the kernel's high-water mark of its own image (VmHWM), read until it
    # ends (ru_maxrss would keep this Python process's from before the exec)
    hwm = 0
    while proc.poll() is None:
        try:
            for line in Path(f"/proc/{proc.pid}/status").read_text().splitlines():
                if line.startswith("VmHWM:"):
                    hwm = max(hwm, int(line.split()[1]))
        except OSError:
            pass
        time.sleep(0.02)
    assert proc.returncode == 0, proc.stderr.read().decode()[-2000:]
    with h5py.File(out, "r") as f:
        steps = int(next(f["stages"][k].attrs["steps"] for k in f["stages"] if k.endswith("fault_offset")))
    est = runtime_estimate(case, rates=GIVEN)
    counts = _counts(case)
    solid = P.SOLID_BASE_BYTES + (counts["rock"] + counts["lining"]) * P.SOLID_BYTES_PER_ELEMENT
    rss = hwm * 1024.0
    print(f"relaxation steps {steps} against {est.statics_steps}; tq-solid {rss / 2**20:.1f} MiB against "
          f"{solid / 2**20:.1f} MiB")
    assert abs(est.statics_steps / steps - 1) < 0.30, (est.statics_steps, steps)
    assert abs(solid / rss - 1) < 0.30, (solid, rss)
