"""Benchmark: a tunnel in an SV wave travelling along it, its curvature against the free field's
closed form as the hole's ends come nearer, and a concrete lining beside the flexible bound.

Not a test (tests/python/test_incident_wave.py holds the 240 m block to 1 %); prints the figures of
docs/verification.md's travelling-wave row ("The hole's ends ...") and of its paragraph on the
concrete lining.

The model is the test's (`CASE`): a 5 m tunnel (0.3 m lining, 16 elements round it) 20 m deep in a
soft rock (E 5 GPa, nu 0.3, Vs 914 m/s), axial elements of 6 m, its ends plugged with 3 elements of
rock, the DRM layer one ring in; an SV Ricker pulse (2.5 Hz) 20 deg from the vertical at azimuth 0
(along the axis) or 45 deg. Each run goes through the product (`load_case`, `prepare`,
`write_solid_input`) and tq-solid. At every axial node plane in the block's middle 40 % the ring's
mean deflection (crown, invert, springlines of the inner face) and the rock's nodes 7 m below and
7 m beside the axis are monitored. Per run, at the middle plane:

* the curvature kappa = (u(y - h) - 2 u(y) + u(y + h)) / h^2 of the ring and of the rock points,
  h = 12 m, against the free field's closed form (p cos az)^2 a(t) at the axis (peak and L2 error);
  the same difference of the free field itself (the stencil's own truncation);
* the axial strain (u_y(y + h/2) - u_y(y - h/2)) / h of the ring against the same difference of the
  free field at the same nodes.

Configurations (`RUNS`): the block's length (the planes' middle 42, 72, 102, 162 m from the hole's
ends), the plugs lengthened in the 240 m block (the hole's ends 42 m away again, the block's faces
120 m away), and the lining of concrete (E 30 GPa, nu 0.2, rho 2500 kg/m^3) in the 240 m block.

Usage (from the repository root): TQ_BUILD_DIR=build .venv/bin/python -m benchmarks.travelling_wave
[--runs len120 len240 ...] [--workdir /tmp/tq-travelling]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from tunnelquake import incident_wave as iw
from tunnelquake.case import ground_layers, load_case
from tunnelquake.freefield import free_field, incident_motion
from tunnelquake.paths import solid_executable
from tunnelquake.prepare import make_mesh, make_motion, mesh_dir
from tunnelquake.solid_input import write_solid_input

from .common import machine

ROCK = "{model: elastic, youngs_modulus: 5 GPa, poisson_ratio: 0.3, density: 2300 kg/m^3}"
CONCRETE = "{model: elastic, youngs_modulus: 30 GPa, poisson_ratio: 0.2, density: 2500 kg/m^3}"

CASE = """\
name: travelling_wave
geometry:
  x_range: [-30.0, 30.0]
  y_range: [0.0, {length}]
  z_range: [-30.0, 20.0]
  tunnel_centre_x: 0.0
  tunnel_centre_z: 0.0
  excavated_radius: 2.5 m
  lining_thickness: 0.3 m
mesh:
  mode: 3d
  max_element_size: 6 m
  lining_elements_around: 16
  lining_elements_through: 1
  elements_along_axis: {axial}
  near_field_half_width: 7 m
  near_field_radial_divisions: 2
  water_ring_divisions: 1
  tunnel_end_plugs: {plugs}
materials:
  rock: {rock}
  lining: {lining}
interface: {{model: bonded}}
ground_motion:
  source: file
  file: pulse.txt
  format: two_column
  units: m/s^2
  pga: 1.0 m/s^2
  vertical_ratio: 0
  cutoff_frequency: 12 Hz
  baseline_correction: false
  convention: incident
incident_wave:
  type: SV
  angle: 20
  azimuth: {azimuth}
stages: {{sequence: [seismic]}}
conditions: [no_water]
damping: {{ratio: 0}}
output:
  monitors:
"""

#: the monitored ring nodes' radius (the lining's inner face) and the rock points' distance
R_INNER, ROCK_OFFSET = 2.2, 7.0
#: the axial element length (m) and the curvature's plane spacing
DY, H = 6.0, 12.0


@dataclass(frozen=True)
class Run:
    length: float
    azimuth: float = 0.0
    plugs: int = 3
    lining: str = ROCK

    @property
    def hole_end_distance(self) -> float:
        return self.length / 2 - self.plugs * DY


RUNS = {
    "len120": Run(120.0), "len120_az45": Run(120.0, 45.0), "len180": Run(180.0), "len240": Run(240.0),
    "len240_az45": Run(240.0, 45.0), "len360": Run(360.0), "len240_plugs13": Run(240.0, plugs=13),
    "concrete": Run(240.0, lining=CONCRETE), "concrete_az45": Run(240.0, 45.0, lining=CONCRETE),
}


def ricker(path: Path, fc: float = 2.5, dt: float = 0.004, n: int = 310) -> None:
    t = np.arange(n) * dt
    a = (np.pi * fc * (t - 1.5 / fc)) ** 2
    np.savetxt(path, np.column_stack([t, (1 - 2 * a) * np.exp(-a)]))


def _monitors(run: Run) -> tuple[dict, list[float]]:
    ys = [float(y) for y in np.arange(0.0, run.length + 1e-9, DY) if 0.3 * run.length <= y <= 0.7 * run.length]
    points = {}
    for y in ys:
        for a in (0, 90, 180, 270):
            points[f"n{y:g}_{a}"] = [round(R_INNER * float(np.cos(np.radians(a))), 6) + 0.0, y,
                                     round(R_INNER * float(np.sin(np.radians(a))), 6) + 0.0]
        points[f"r{y:g}_below"] = [0.0, y, -ROCK_OFFSET]
        points[f"r{y:g}_beside"] = [-ROCK_OFFSET, y, 0.0]
    return points, ys


def _rel(model: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """Peak error (signed) and L2 error of `model` against `ref`."""
    return (float(np.abs(model).max() / np.abs(ref).max() - 1),
            float(np.sqrt(np.sum((model - ref) ** 2) / np.sum(ref ** 2))))


def run_one(name: str, run: Run, work: Path) -> dict:
    work.mkdir(parents=True, exist_ok=True)
    points, ys = _monitors(run)
    text = CASE.format(length=run.length, axial=int(round(run.length / DY)), plugs=run.plugs, rock=ROCK,
                       lining=run.lining, azimuth=f"{run.azimuth:g}")
    text += "".join(f"    {k}: {v}\n" for k, v in points.items())
    ricker(work / "pulse.txt")
    (work / "case.yaml").write_text(textwrap.dedent(text))
    case = load_case(work / "case.yaml")
    make_mesh(case)
    _, motion_h5 = make_motion(case)
    inp = write_solid_input(case, mesh_dir(case) / "mesh.h5", motion_h5, "no_water", work / "solid_input.h5")
    t0 = time.perf_counter()
    out = subprocess.run([str(solid_executable()), str(inp), "-o", str(work / "r.h5"), "--threads", "1"],
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{name}: tq-solid failed\n{out.stdout[-2000:]}{out.stderr[-2000:]}")
    seconds = time.perf_counter() - t0
    with h5py.File(motion_h5) as m:
        rec, dt = m["incident_ax"][...], float(m.attrs["dt"])
    with h5py.File(inp) as f, h5py.File(mesh_dir(case) / "mesh.h5") as m:
        xyz = m["nodes/coordinates"][...]
        layer = xyz[f["drm/nodes"][...]]
    with h5py.File(work / "r.h5") as r:
        t = r[f"monitors/{next(iter(points))}/time"][:, 0]
        u = {k: r[f"monitors/{k}/u"][...] - r[f"monitors/{k}/u"][0] for k in points}
    nodes = {k: xyz[np.argmin(np.sum((xyz - v) ** 2, axis=1))] for k, v in points.items()}
    d = case.data
    profile, wave = iw.ground_profile(d, ground_layers(d)), iw.plane_wave(d)
    inc = incident_motion(rec, dt, wave, profile, "incident")
    keys = list(points)
    mid = ys[len(ys) // 2]
    ff = free_field(profile, [(wave, inc)], dt, np.vstack([layer, [nodes[k] for k in keys], [[0.0, mid, 0.0]]]),
                    times=t)
    n0 = len(layer)
    fu = {k: ff.u[n0 + i] for i, k in enumerate(keys)}
    fa = {k: ff.a[n0 + i] for i, k in enumerate(keys)}
    q = wave.slowness(profile) * wave.directions()[0][1]
    ref_k = q ** 2 * ff.a[-1]

    def ring(field, y):
        return np.mean([field[f"n{y:g}_{a}"] for a in (0, 90, 180, 270)], axis=0)

    def second(f, y):
        return (f(y - H) - 2 * f(y) + f(y + H)) / H ** 2

    out = {"name": name, "run": run, "seconds": seconds}
    for c, plane in ((0, "h"), (2, "v")):
        if np.abs(ref_k[:, c]).max() == 0:
            continue
        out[f"kappa_{plane}"] = _rel(second(lambda y: ring(u, y), mid)[:, c], ref_k[:, c])
        out[f"stencil_{plane}"] = _rel(second(lambda y: ring(fu, y), mid)[:, c], ref_k[:, c])
        for where in ("below", "beside"):
            rock = second(lambda y, w=where: u[f"r{y:g}_{w}"], mid)[:, c]
            out[f"rock_{where}_{plane}"] = _rel(rock, q ** 2 * fa[f"r{mid:g}_{where}"][:, c])
    strain = (ring(u, mid + H / 2) - ring(u, mid - H / 2))[:, 1] / H
    strain_ff = (ring(fu, mid + H / 2) - ring(fu, mid - H / 2))[:, 1] / H
    out["strain"] = _rel(strain, strain_ff)
    return out


def _pct(pair) -> str:
    return f"{100 * pair[0]:+.2f} % / {100 * pair[1]:.2f} %" if pair is not None else "–"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", nargs="+", choices=list(RUNS), default=list(RUNS))
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/tq-travelling"))
    args = ap.parse_args(argv)
    if solid_executable() is None:
        sys.exit("tq-solid is not built (set TQ_BUILD_DIR)")
    print(f"machine: {machine()}")
    print("| run | block (m) | azimuth | lining | hole's ends from the planes' middle (m) | κ_v ring (peak / L2) | "
          "κ_v rock below | κ_v rock beside | κ_h ring | the 12 m stencil's own (κ_v) | axial strain vs the free "
          "field's difference | tq-solid s |")
    print("|---|---:|---:|---|---:|---|---|---|---|---|---|---:|")
    for name in args.runs:
        run = RUNS[name]
        r = run_one(name, run, args.workdir / name)
        print(f"| {name} | {run.length:g} | {run.azimuth:g} | {'concrete' if run.lining == CONCRETE else 'rock'} | "
              f"{run.hole_end_distance:g} | {_pct(r.get('kappa_v'))} | {_pct(r.get('rock_below_v'))} | "
              f"{_pct(r.get('rock_beside_v'))} | {_pct(r.get('kappa_h'))} | {_pct(r.get('stencil_v'))} | "
              f"{_pct(r['strain'])} | {r['seconds']:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
