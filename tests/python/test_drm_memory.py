"""`check`'s memory estimate with a domain-reduction field (scene.drm_field_bytes, scene.with_drm_memory;
docs/benchmarks.md "check's estimates on the 3D cases").

1. The DRM layer's nodes counted on the mesh plan (scene.drm_layer_nodes) against the layer the mesh
   gets (incident_wave.drm_layer through drm_input), exactly, at drm_offset 1 and 2.
2. A short run of a case unlike cases/axial_wave (the joint test's tunnel: a 5 m tunnel in soft rock,
   a Ricker record, 6 m elements, an SV wave at 20 deg): the peak resident memory (VmHWM) of
   `tunnelquake run`'s own process and of its tq-solid, each against its part of check's 'run'
   estimate (the driver's base and its copies of the field, tq-solid's base, its elements and its
   copies of the field) within the 30 % the estimates claim, and the sum against 'run'.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from case_texts import pulse_case, wave_tunnel

from tunnelquake import paths
from tunnelquake.case import load_case

h5py = pytest.importorskip("h5py")

CASE = wave_tunnel("drm_memory") + """    ground: [10.0, 63.0, 0.0]
time:
  end_time: 0.05 s
"""


def _plan(case):
    from tunnelquake.case import case_geology, ground_layers
    from tunnelquake.meshing.params import resolve

    d = case.data
    return resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))


@pytest.mark.parametrize("offset", [1, 2])
def test_the_layers_nodes_counted_without_meshing_are_the_meshs(tmp_path, offset):
    from tunnelquake.drm_input import _layer
    from tunnelquake.prepare import make_mesh, mesh_dir
    from tunnelquake.scene import drm_field_bytes, drm_layer_nodes

    text = CASE.replace("  azimuth: 0\n", f"  azimuth: 0\n  drm_offset: {offset}\n")
    text = text.replace("tunnel_end_plugs: 3", f"tunnel_end_plugs: {offset + 2}")
    case = load_case(pulse_case(tmp_path, text))
    make_mesh(case)
    _, nodes, _ = _layer(case.data, mesh_dir(case) / "mesh.h5")
    assert drm_layer_nodes(_plan(case), offset) == nodes.size
    # u, v, a over the record's 310 samples (case_texts.ricker_pulse_file), 8 bytes a value
    assert drm_field_bytes(case) == 3 * nodes.size * 310 * 3 * 8


def _peak(pid: int) -> int:
    """VmHWM of process `pid` in bytes (0 once it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _solid_children(pid: int) -> list[int]:
    """The tq-solid processes among `pid`'s children (not the Python helpers it forks, whose
    high-water mark counts the pages they share with it)."""
    out = []
    try:
        kids = [int(c) for t in Path(f"/proc/{pid}/task").iterdir() for c in (t / "children").read_text().split()]
    except OSError:
        return out
    for c in kids:
        try:
            if Path(f"/proc/{c}/comm").read_text().strip() == "tq-solid":
                out.append(c)
        except OSError:
            pass
    return out


@pytest.mark.skipif(paths.solid_executable() is None, reason="tq-solid is not built (set TQ_BUILD_DIR)")
def test_a_short_drm_run_peaks_within_30_percent_of_the_estimate(tmp_path):
    from tunnelquake import scene
    from tunnelquake.meshing import params as P

    path = pulse_case(tmp_path, CASE)
    case = load_case(path)
    plan = _plan(case)
    counts = P.element_counts(plan)
    field_bytes = scene.drm_field_bytes(case, plan)
    need = scene.with_drm_memory(P.memory_estimate(counts, case.data["conditions"]), case, plan)
    driver_est = P.DRIVER_BYTES + scene.DRIVER_DRM_COPIES * field_bytes
    solid_est = (P.SOLID_BASE_BYTES + (counts["rock"] + counts["lining"]) * P.SOLID_BYTES_PER_ELEMENT
                 + scene.SOLID_DRM_COPIES * field_bytes)
    assert need["run"] == pytest.approx(driver_est + solid_est, rel=1e-12)

    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "tunnelquake", "run", str(path), "--no-post"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    driver = solid = 0
    while proc.poll() is None:
        driver = max(driver, _peak(proc.pid))
        for c in _solid_children(proc.pid):
            solid = max(solid, _peak(c))
        time.sleep(0.01)
    assert proc.returncode == 0, proc.stderr.read().decode()[-2000:]
    # tq-solid alone on the same input, its high-water mark read until it ends (the run's own may end
    # between two reads of the driver's children)
    inp = tmp_path / "results" / "no_water" / "solid_input.h5"
    s = subprocess.Popen([str(paths.solid_executable()), str(inp), "-o", str(tmp_path / "again.h5"), "--threads",
                          "1"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    while s.poll() is None:
        solid = max(solid, _peak(s.pid))
        time.sleep(0.005)
    assert s.returncode == 0, s.stderr.read().decode()[-2000:]
    mib = 2.0**20
    print(f"DRM field {field_bytes / mib:.1f} MiB; driver {driver / mib:.1f} MiB against {driver_est / mib:.1f}, "
          f"tq-solid {solid / mib:.1f} MiB against {solid_est / mib:.1f}, run {(driver + solid) / mib:.1f} MiB "
          f"against {need['run'] / mib:.1f} ({need['run'] / (driver + solid) - 1:+.1%})")
    assert abs(driver_est / driver - 1) < 0.30, (driver_est, driver)
    assert abs(solid_est / solid - 1) < 0.30, (solid_est, solid)
    assert abs(need["run"] / (driver + solid) - 1) < 0.30
