"""Benchmark: a static, elastic fault offset of a lined tunnel, tq-solid against CalculiX on the same mesh.

Not a test (tests/python/test_fault_offset.py runs the coarsest level against CalculiX); prints the
markdown table of docs/verification.md "Fault offset against CalculiX".

The model (`CASE`): a 24 x 24 x 24 m block, a tunnel of radius 2 m with a 0.3 m lining (bonded to
the rock), crossed at mid-length by a 3 m fault zone (strike 60, dip 70: oblique to the axis in plan
and in section), 1 GPa in the band, 8 GPa around it, a 28 GPa lining; a slip of 0.05 m at rake 45
(oblique: the hanging wall moves along strike and up dip). The product's own pieces make the input:
the case is validated by `tunnelquake.case`, meshed by `tunnelquake.meshing` (the fault zone's axial
refinement included), and the prescribed displacements of the block's faces but the top are
`tunnelquake.solid_input.fault_offset_displacements` (hanging wall moved by the slip, footwall held,
the band linear across its thickness). tq-solid runs only its `fault_offset` stage (no gravity, no
in-situ stress): the slip in one increment, relaxed to `TOLERANCE`, then writes the static state.

CalculiX (Debian's calculix-ccx) gets the same nodes and hexahedra (the rock-lining pairs, which
tq-solid ties, merged into one node), the same materials and the same prescribed displacements,
and solves the linear static problem directly (*STATIC). Two element pairs:

* tq-solid `full_integration` (2x2x2 Gauss trilinear hex) against CalculiX C3D8 (the same element):
  the codes' answers on the same discrete problem, which must agree to the relaxation's tolerance;
* tq-solid's default one-point assumed-strain hex8 against CalculiX C3D8I (incompatible modes): two
  elements made to bend without locking; they differ by the discretisation, which the ladder shows
  shrinking.

The compared quantities are the lining's axial strain and its curvatures in the horizontal and the
vertical plane along the axis, from each code's nodal displacements through the same function
(`tunnelquake.lining_axis.axis_profile`: plane sections fitted to the lining nodes of each station):
per quantity max over the stations |tq - ccx| / max |ccx|. The ladder (`mesh.refinement_factor` 1,
2, 3) gives the peaks of each quantity per level and the observed order from the three levels
(`three_level_order`, against the shortest lining element along the axis).

Usage (from the repository root): TQ_BUILD_DIR=build .venv/bin/python -m benchmarks.fault_offset
[--levels 1 1.5 2] [--workdir /tmp/tq-fault]
"""
from __future__ import annotations

import argparse
import datetime
import math
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from tunnelquake.case import case_geology, load_case
from tunnelquake.lining_axis import AxisProfile, axis_profile, lining_nodes
from tunnelquake.meshing import build_tunnel_mesh
from tunnelquake.solid_input import fault_offset_displacements
from tunnelquake.solver_input_schema import FORMAT, MATERIALS, VERSION, entries, put, write_schema

from .common import machine

ROOT = Path(__file__).resolve().parents[1]
#: The agreement asked of the two codes on each quantity (max over stations / peak).
TOLERANCE_AGREE = 0.01
#: tq-solid's relaxation tolerance (the stage's out-of-balance force relative to its start).
TOLERANCE = 1e-8

CASE = """
name: fault_offset_benchmark
geometry:
  x_range: [-12.0, 12.0]
  y_range: [0.0, 24.0]
  z_range: [-12.0, 12.0]
  tunnel_centre_z: 0.0
  excavated_radius: 2.0
  lining_thickness: 0.3
mesh:
  max_element_size: 6.0
  lining_elements_around: 16
  lining_elements_through: 2
  near_field_half_width: 5.0
  near_field_radial_divisions: 3
  elements_along_axis: 6
  refinement_factor: {level}
materials:
  rock: {{model: elastic, youngs_modulus: 8 GPa, poisson_ratio: 0.27, density: 2700}}
  fault: {{model: elastic, youngs_modulus: 1 GPa, poisson_ratio: 0.3, density: 2200}}
  lining: {{model: elastic, youngs_modulus: 28 GPa, poisson_ratio: 0.17, density: 2500}}
geology:
  fault_zone: {{material: fault, width: 3 m, strike: 60, dip: 70, point: [0, 12, 0], elements_across: 2}}
fault_offset: {{magnitude: 0.05 m, rake: 45, increments: 1}}
interface: {{model: bonded}}
ground_motion: {{source: synthetic, pga: 1.0 m/s^2, vertical_ratio: 0.5, synthetic: {{duration: 1.0}}}}
in_situ: {{kx: 1.0, ky: 1.0}}
conditions: [no_water]
"""

#: (tq-solid formulation, CalculiX element) pairs compared.
PAIRS = (("full_integration", "C3D8"), ("one_point_assumed_strain", "C3D8I"))


class BenchError(RuntimeError):
    """The comparison could not be run (a program missing or failing)."""


def missing_reason(build: Path) -> str | None:
    """Why the comparison cannot run here (None: it can)."""
    if shutil.which("ccx") is None:
        return "ccx (CalculiX) not found on PATH: install Debian's calculix-ccx (scripts/bootstrap.sh installs it)"
    exe = build / "solid_solver" / "tq-solid"
    if not exe.is_file():
        return f"{exe} not found: build it (cmake --build {build} --target tq-solid) or set TQ_BUILD_DIR"
    out = subprocess.run([str(exe), "--capabilities"], capture_output=True, text=True, timeout=30)
    if "fault-offset" not in out.stdout:
        return f"{exe} has no fault_offset stage (capability 'fault-offset'): rebuild it"
    return None


@dataclass
class Model:
    """One mesh level: the validated case, the mesh file and the prescribed displacements."""

    level: float
    dir: Path
    data: dict
    mesh_h5: Path
    nodes: np.ndarray
    displacement: np.ndarray
    elements: int = 0
    lining_axial_length: float = 0.0


def make_model(level: float, workdir: Path) -> Model:
    d = workdir / f"level{level:g}"
    d.mkdir(parents=True, exist_ok=True)
    (d / "case.yaml").write_text(CASE.format(level=level))
    case = load_case(d / "case.yaml")
    data = case.data
    build_tunnel_mesh(data["geometry"], data["mesh"], d, None, case_geology(data))
    nodes, disp = fault_offset_displacements(data, d / "mesh.h5")
    with h5py.File(d / "mesh.h5") as f:
        conn = f["elements/connectivity"][...]
        region = f["elements/region"][...]
        names = [r.decode() if isinstance(r, bytes) else str(r) for r in f["elements"].attrs["regions"]]
        xyz = f["nodes/coordinates"][...]
    lin = conn[region == names.index("lining")]
    ys = np.unique(np.round(xyz[lin][:, :, 1].ravel(), 9))
    return Model(level, d, data, d / "mesh.h5", nodes, disp, elements=len(conn),
                 lining_axial_length=float(np.diff(ys).min()))


def write_tq_input(m: Model, formulation: str, out: Path, history: dict | None = None) -> Path:
    """tq-solid's input for the offset alone: the fault_offset stage, no gravity, bonded lining.
    With ``history`` ({start_time, rise_time, t_end, alpha, snapshot_times}) the slip during a
    seismic stage instead (no motion, no absorbing boundary, mass-proportional damping alpha)."""
    table = entries()
    with h5py.File(out, "w") as f:
        def w(obj, group, name, value):
            put(obj, group, name, value, table)

        w(f, "/", "format", FORMAT)
        w(f, "/", "version", VERSION)
        w(f, "/", "mesh", os.path.relpath(m.mesh_h5.resolve(), out.parent.resolve()))
        s = f.create_group("solver")
        w(s, "/solver", "t_end", history["t_end"] if history else 1.0)
        w(s, "/solver", "formulation", formulation)
        with h5py.File(m.mesh_h5) as mf:
            regions = [r.decode() if isinstance(r, bytes) else str(r) for r in mf["elements"].attrs["regions"]]
        for region in regions:
            mat = m.data["materials"][region]
            g = f.create_group(f"materials/{region}")
            w(g, MATERIALS, "model", "elastic")
            w(g, MATERIALS, "E", mat["youngs_modulus"])
            w(g, MATERIALS, "nu", mat["poisson_ratio"])
            w(g, MATERIALS, "rho", mat["density"])
        st = f.create_group("stages")
        w(st, "/stages", "sequence", "seismic" if history else "fault_offset")
        w(st, "/stages", "relaxation_tolerance", TOLERANCE)
        w(st, "/stages", "relaxation_max_steps", 2_000_000)
        fo = f.create_group("fault_offset")
        w(fo, "/fault_offset", "nodes", m.nodes)
        w(fo, "/fault_offset", "displacement", m.displacement)
        w(fo, "/fault_offset", "increments", 1)
        if history:
            w(fo, "/fault_offset", "rise_time", history["rise_time"])
            w(fo, "/fault_offset", "start_time", history["start_time"])
            dm = f.create_group("damping")
            w(dm, "/damping", "alpha", history["alpha"])
        w(f.create_group("interfaces/rock_lining"), "/interfaces/rock_lining", "model", "bonded")
        o = f.create_group("output")
        w(o, "/output", "ring_forces", 0)
        if history:
            w(o, "/output", "snapshot_times", np.asarray(history["snapshot_times"], float))
        write_schema(f, table)
    return out


def run_tq(build: Path, m: Model, formulation: str) -> tuple[np.ndarray, float, str]:
    """Displacements [N, 3] of tq-solid's static state, its wall time (s) and its stage line."""
    inp = write_tq_input(m, formulation, m.dir / f"tq_{formulation}.h5")
    res = m.dir / f"tq_{formulation}_results.h5"
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
    t0 = time.perf_counter()
    out = subprocess.run([str(build / "solid_solver" / "tq-solid"), str(inp), "-o", str(res), "--threads", "1"],
                         capture_output=True, text=True, env=env, timeout=3600)
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        raise BenchError(f"tq-solid failed on {inp} ({out.returncode}):\n{(out.stdout + out.stderr)[-3000:]}")
    line = next((ln.strip() for ln in out.stdout.splitlines() if "stage fault_offset: equilibrium" in ln), "")
    with h5py.File(res) as r:
        return r["snapshots/0/u"][...], wall, line


def _num(v) -> str:
    """A number as CalculiX reads it: at most 20 characters a field (13 significant digits)."""
    return f"{float(v):.12e}"


def _ccx_node_id(m: Model) -> np.ndarray:
    """Mesh node -> CalculiX node (1-based; a lining node of a bonded pair is its rock partner)."""
    with h5py.File(m.mesh_h5) as f:
        n = f["nodes/coordinates"].shape[0]
        pairs = f["interfaces/rock_lining"][...]
    node_id = np.arange(1, n + 1)
    node_id[pairs[:, 1]] = pairs[:, 0] + 1
    return node_id


def _reused_model(level: float, workdir: Path) -> Model:
    d = workdir / f"level{level:g}"
    data = load_case(d / "case.yaml").data
    nodes, disp = fault_offset_displacements(data, d / "mesh.h5")
    with h5py.File(d / "mesh.h5") as f:
        conn, region = f["elements/connectivity"][...], f["elements/region"][...]
        names = [r.decode() if isinstance(r, bytes) else str(r) for r in f["elements"].attrs["regions"]]
        xyz = f["nodes/coordinates"][...]
    ys = np.unique(np.round(xyz[conn[region == names.index("lining")]][:, :, 1].ravel(), 9))
    return Model(level, d, data, d / "mesh.h5", nodes, disp, elements=len(conn),
                 lining_axial_length=float(np.diff(ys).min()))


def write_ccx_deck(m: Model, element: str, out: Path) -> np.ndarray:
    """The CalculiX deck of the same problem; returns the map mesh node -> CalculiX node (1-based;
    a lining node of a bonded pair is its rock partner)."""
    with h5py.File(m.mesh_h5) as f:
        xyz = f["nodes/coordinates"][...]
        conn = f["elements/connectivity"][...]
        region = f["elements/region"][...]
        names = [r.decode() if isinstance(r, bytes) else str(r) for r in f["elements"].attrs["regions"]]
        pairs = f["interfaces/rock_lining"][...]
    node_id = np.arange(1, len(xyz) + 1)
    node_id[pairs[:, 1]] = pairs[:, 0] + 1  # merged: the tie
    used = np.unique(node_id[conn])
    lines = ["*HEADING", "fault offset benchmark (benchmarks/fault_offset.py)", "*NODE, NSET=NALL"]
    lines += [f"{i}, {_num(xyz[i - 1, 0])}, {_num(xyz[i - 1, 1])}, {_num(xyz[i - 1, 2])}" for i in used]
    for k, name in enumerate(names):
        sel = np.flatnonzero(region == k)
        if not len(sel):
            continue
        lines.append(f"*ELEMENT, TYPE={element}, ELSET=E_{name}")
        lines += [f"{e + 1}, " + ", ".join(str(int(n)) for n in node_id[conn[e]]) for e in sel]
    for name in names:
        mat = m.data["materials"][name]
        lines += [f"*MATERIAL, NAME=M_{name}", "*ELASTIC",
                  f"{_num(mat['youngs_modulus'])}, {_num(mat['poisson_ratio'])}",
                  f"*SOLID SECTION, ELSET=E_{name}, MATERIAL=M_{name}"]
    lines += ["*STEP", "*STATIC", "*BOUNDARY"]
    seen = set()
    for n, u in zip(m.nodes, m.displacement, strict=True):
        cid = int(node_id[n])
        if cid in seen:
            continue
        seen.add(cid)
        lines += [f"{cid}, {d + 1}, {d + 1}, {_num(u[d])}" for d in range(3)]
    lines += ["*NODE PRINT, NSET=NALL", "U", "*END STEP", ""]
    out.write_text("\n".join(lines))
    return node_id


def run_ccx(m: Model, element: str) -> tuple[np.ndarray, float]:
    deck = m.dir / f"ccx_{element}.inp"
    node_id = write_ccx_deck(m, element, deck)
    env = dict(os.environ)
    for k in ("OMP_NUM_THREADS", "CCX_NPROC_RESULTS", "CCX_NPROC_EQUATION_SOLVER", "NUMBER_OF_CPUS"):
        env[k] = "1"
    t0 = time.perf_counter()
    out = subprocess.run(["ccx", "-i", deck.stem], cwd=deck.parent, capture_output=True, text=True, env=env,
                         timeout=3600)
    wall = time.perf_counter() - t0
    if out.returncode != 0 or "*ERROR" in out.stdout:
        raise BenchError(f"CalculiX failed on {deck}:\n{out.stdout[-2000:]}\n{out.stderr[-2000:]}")
    return read_ccx(deck, node_id), wall


def read_ccx(deck: Path, node_id: np.ndarray) -> np.ndarray:
    """The displacements [N, 3] of the mesh's nodes from CalculiX's .dat beside ``deck``."""
    u_by_id = {}
    for ln in deck.with_suffix(".dat").read_text().splitlines():
        if re.match(r"^\s*\d+\s+\S+\s+\S+\s+\S+\s*$", ln):
            p = ln.split()
            u_by_id[int(p[0])] = [float(v) for v in p[1:]]
    return np.array([u_by_id.get(int(i), [np.nan] * 3) for i in node_id])


@dataclass
class Level:
    level: float
    elements: int
    axial_length: float
    profiles: dict = field(default_factory=dict)  # (code, element) -> AxisProfile
    walls: dict = field(default_factory=dict)
    notes: dict = field(default_factory=dict)


QUANTITIES = (("strain", "axial strain"), ("kappa_h", "curvature, horizontal plane (1/m)"),
              ("kappa_v", "curvature, vertical plane (1/m)"))


def difference(a: AxisProfile, b: AxisProfile, q: str) -> float:
    """max over the stations |a - b| / max |b| of quantity q."""
    x, y = getattr(a, q), getattr(b, q)
    return float(np.max(np.abs(x - y)) / np.max(np.abs(y)))


def run_level(build: Path, level: float, workdir: Path, pairs=PAIRS, reuse: bool = False) -> Level:
    """Run both codes on one level (with ``reuse``: read what an earlier run left in ``workdir``
    instead, the wall times then unknown)."""
    m = make_model(level, workdir) if not reuse else _reused_model(level, workdir)
    with h5py.File(m.mesh_h5) as f:
        xyz = f["nodes/coordinates"][...]
        conn = f["elements/connectivity"][...]
        region = f["elements/region"][...]
        names = [r.decode() if isinstance(r, bytes) else str(r) for r in f["elements"].attrs["regions"]]
    nodes = lining_nodes(conn, region, names.index("lining"))
    g = m.data["geometry"]
    centre = (float(g["tunnel_centre_x"]), float(g["tunnel_centre_z"]))
    out = Level(level, m.elements, m.lining_axial_length)
    for formulation, element in pairs:
        if reuse:
            with h5py.File(m.dir / f"tq_{formulation}_results.h5") as r:
                u = r["snapshots/0/u"][...]
            out.profiles[("tq-solid", formulation)] = axis_profile(xyz, nodes, u, centre)
            out.walls[("tq-solid", formulation)] = out.walls[("CalculiX", element)] = math.nan
            deck = m.dir / f"ccx_{element}.inp"
            out.profiles[("CalculiX", element)] = axis_profile(xyz, nodes, read_ccx(deck, _ccx_node_id(m)), centre)
            continue
        u, wall, line = run_tq(build, m, formulation)
        out.profiles[("tq-solid", formulation)] = axis_profile(xyz, nodes, u, centre)
        out.walls[("tq-solid", formulation)] = wall
        out.notes[("tq-solid", formulation)] = line
        u, wall = run_ccx(m, element)
        if np.isnan(u).any():
            raise BenchError(f"CalculiX printed no displacement for some nodes ({m.dir})")
        out.profiles[("CalculiX", element)] = axis_profile(xyz, nodes, u, centre)
        out.walls[("CalculiX", element)] = wall
    return out


def three_level_order(h: list[float], q: list[float]) -> float | None:
    """The order p of q(h) = q* + C h^p through three (h, q) pairs of any refinement ratios: the
    root of (q1 - q0)/(q2 - q1) = (h1^p - h0^p)/(h2^p - h1^p) in (0.05, 20), by bisection; None where
    the differences change sign (not in the asymptotic range) or no root lies there."""
    d0, d1 = q[1] - q[0], q[2] - q[1]
    if d0 == 0 or d1 == 0 or (d0 > 0) != (d1 > 0):
        return None
    target = d0 / d1

    def f(p):
        return (h[1] ** p - h[0] ** p) / (h[2] ** p - h[1] ** p) - target

    lo, hi = 0.05, 20.0
    if f(lo) * f(hi) > 0:
        return None
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(lo) * f(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def markdown(levels: list[Level], pairs=PAIRS) -> str:
    from .common import observed_orders

    rows = ["| level (refinement_factor) | hex8 | shortest lining element along the axis (m) | pair | "
            "axial strain: max \\|tq − ccx\\| / peak | κ_h | κ_v | tq-solid s | CalculiX s |",
            "|---|---:|---:|---|---:|---:|---:|---:|---:|"]
    for lv in levels:
        for formulation, element in pairs:
            a, b = lv.profiles[("tq-solid", formulation)], lv.profiles[("CalculiX", element)]
            diffs = " | ".join(f"{100 * difference(a, b, q):.3g} %" for q, _ in QUANTITIES)
            rows.append(f"| {lv.level:g} | {lv.elements:,} | {lv.axial_length:.3f} | {formulation} / {element} | "
                        f"{diffs} | {lv.walls[('tq-solid', formulation)]:.1f} | "
                        f"{lv.walls[('CalculiX', element)]:.1f} |")
    sizes = [lv.axial_length for lv in levels]
    if len(levels) >= 2:
        rows += ["", "Observed order of the pairs' difference between successive levels (benchmarks.common."
                 "observed_orders against the shortest lining element along the axis):", "",
                 "| pair | " + " | ".join(label for _, label in QUANTITIES) + " |", "|---|" + "---:|" * len(QUANTITIES)]
        for formulation, element in pairs:
            cells = []
            for q, _ in QUANTITIES:
                diffs = [difference(lv.profiles[("tq-solid", formulation)], lv.profiles[("CalculiX", element)], q)
                         for lv in levels]
                cells.append(", ".join("–" if o is None else f"{o:.2f}" for o in observed_orders(sizes, diffs)[1:]))
            rows.append(f"| {formulation} / {element} | " + " | ".join(cells) + " |")
    rows += ["", "Peaks along the axis (max over the stations of \\|q\\|) per level, and the observed order "
             "p of the last three levels (three_level_order: q = q* + C h^p through all three, h the shortest "
             "lining element along the axis):", "",
             "| code, element | quantity | " + " | ".join(f"level {lv.level:g}" for lv in levels) + " | order |",
             "|---|---|" + "---:|" * (len(levels) + 1)]
    for code in [k for lv in levels[:1] for k in lv.profiles]:
        for q, label in QUANTITIES:
            peaks = [float(np.max(np.abs(getattr(lv.profiles[code], q)))) for lv in levels]
            order = "–"
            if len(levels) >= 3:
                p = three_level_order(sizes[-3:], peaks[-3:])
                order = "–" if p is None else f"{p:.2f}"
            rows.append(f"| {code[0]} {code[1]} | {label} | " + " | ".join(f"{p:.4e}" for p in peaks) +
                        f" | {order} |")
    return "\n".join(rows)


def figure(levels: list[Level], out: Path, pairs=PAIRS) -> Path:
    """The lining's axial strain and curvatures along the axis: per level tq-solid's default element
    (lines) and CalculiX's C3D8I (markers)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    formulation, element = pairs[-1]
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.0), sharex=True)
    for k, lv in enumerate(levels):
        a, b = lv.profiles[("tq-solid", formulation)], lv.profiles[("CalculiX", element)]
        for ax, (q, label) in zip(axes, QUANTITIES, strict=True):
            ax.plot(a.y, getattr(a, q), color=f"C{k}", label=f"tq-solid {formulation}, level {lv.level:g}")
            ax.plot(b.y, getattr(b, q), "o", color=f"C{k}", mfc="none", ms=4,
                    label=f"CalculiX {element}, level {lv.level:g}")
            ax.set_ylabel(label, fontsize=8)
            ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6, ncol=2)
    axes[-1].set_xlabel("y along the tunnel axis (m)")
    fig.suptitle("Static fault offset: the lining along the axis", fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/tq-fault"))
    ap.add_argument("--reuse", action="store_true", help="read the outputs an earlier run left in --workdir")
    ap.add_argument("--figure", type=Path, help="write the profiles' figure there (e.g. docs/bench/fault_offset.png)")
    args = ap.parse_args()
    build = Path(os.environ.get("TQ_BUILD_DIR", ROOT / "build"))
    reason = missing_reason(build)
    if reason:
        sys.exit(reason)
    levels = []
    for lv in args.levels:
        try:
            levels.append(run_level(build, lv, args.workdir, reuse=args.reuse))
        except BenchError as e:
            sys.exit(str(e))
        print(f"level {lv:g} done", file=sys.stderr, flush=True)
    ver = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "calculix-ccx"], capture_output=True,
                         text=True).stdout.strip()
    print(f"date {datetime.date.today()}, machine {machine()}, calculix-ccx {ver or '?'}, 1 thread each\n")
    print(markdown(levels))
    if args.figure:
        print(f"\nfigure: {figure(levels, args.figure)}")
    bad = [lv.level for lv in levels for f, e in PAIRS[:1]
           if max(difference(lv.profiles[("tq-solid", f)], lv.profiles[("CalculiX", e)], q) for q, _ in QUANTITIES)
           > TOLERANCE_AGREE]
    if bad:
        sys.exit(f"the same element disagrees by more than {100 * TOLERANCE_AGREE:g} % at level(s) {bad}")


if __name__ == "__main__":
    main()
