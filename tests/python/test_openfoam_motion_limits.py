"""Stress test: a fluid mesh pushed toward inversion stops cleanly, before any NaN.

The fake solid (replay exchange) drives the wall of a water-filled open pipe (R 4.5 m, L 1 m,
blockMesh O-grid, pimpleFoam) with the inextensional ovaling mode n = 2 growing at 5 m/s:
radial uo cos 2θ, tangential −uo/2 sin 2θ, uo = 5 t (4.5 m = R at t = 0.9 s, where the wall
itself reaches the axis: the mesh cannot survive that).

- Moving mesh (tqInterpolatedDisplacement): before the mesh moves, every cell's sub-volumes
  (face pyramids) of the new points are compared with the reference ones; the run must stop with
  a FatalError naming the time, the smallest ratio (below minVolumeRatio 0.1 and above 0: the
  refused state has no degenerate or inverted cell), the cell, the cause and the fixes, with
  every written field finite and the last written mesh valid (checkMesh: all volumes > 0).
- Transpiration (static mesh): the first-order interface must refuse a displacement larger
  than transpirationLimit (1) times the wall-cell thickness h_w = 2 n.(C_f − C_cell); the stop
  must come at the step where uo first exceeds h_w of a wall face (within one step; h_w of this
  mesh's wall faces computed here from the blockMesh points).
- Earthquake-size motion is still accepted: the mesh-motion check's 10 cm sideways plus 10 cm radial
  contraction runs to the end with both interface motions (the moving-mesh quality for it is
  asserted in test_openfoam_mesh_motion.py).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from benchmarks.fluid_common import foamcase as fc
from benchmarks.fluid_common import pipe

_reason = fc.openfoam_missing_reason()
pytestmark = pytest.mark.skipif(_reason is not None, reason=str(_reason))

R = 4.5
DT = 0.01
RATE = 5.0  # m/s: ovaling amplitude uo = RATE t
END = 1.0
MESH = dict(R=R, L=1.0, nq=8, nr=6, ny=2, two_d=False, open_ends=True)


def _growing_ovaling(motion: Path) -> None:
    t = np.arange(0, END + 3 * DT, DT)
    z = np.zeros((t.size, 3))
    pipe.write_motion(motion, t, z, z, None, None, RATE * t, np.full_like(t, RATE))


def _run_expecting_stop(case: Path) -> str:
    """pimpleFoam must end with a FOAM FATAL ERROR (returns the log)."""
    with pytest.raises(RuntimeError):
        fc.run(case, "pimpleFoam")
    log = (case / "log.pimpleFoam").read_text()
    assert "FOAM FATAL ERROR" in log, log[-3000:]
    # a clean stop, not a trapped floating-point exception or a crash (those print a stack)
    assert "sigHandler" not in log and "printStack" not in log, log[-3000:]
    return log


def _time_dirs(case: Path) -> list[Path]:
    return sorted((p for p in case.iterdir() if re.fullmatch(r"[0-9.eE+-]+", p.name) and p.is_dir()),
                  key=lambda p: float(p.name))


def _assert_no_nan(case: Path, log: str) -> None:
    assert not re.search(r"\bnan\b|\binf\b", log, re.IGNORECASE), "non-finite value in the log"
    for d in _time_dirs(case):
        for name in ("U", "p"):
            f = d / name
            if f.exists():
                text = f.read_text()
                assert not re.search(r"\bnan\b|\binf\b", text, re.IGNORECASE), f"non-finite value in {f}"


def test_moving_mesh_pushed_toward_inversion_stops_before_any_cell_degenerates(tmp_path):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = tmp_path / "case"
    motion = pipe.make_pipe_case(case, dt=DT, end_time=END, write_interval=DT, **MESH)
    _growing_ovaling(motion)
    fc.run(case, "blockMesh")
    log = _run_expecting_stop(case)

    m = re.search(
        r"the mesh motion at t = ([0-9.eE+-]+) s would shrink (\d+) cell\(s\) below minVolumeRatio "
        r"([0-9.eE+-]+) of their reference volume: smallest sub-volume ratio ([0-9.eE+-]+) in cell (\d+)",
        log,
    )
    assert m, log[-3000:]
    t_stop, n_below, limit, ratio = float(m.group(1)), int(m.group(2)), float(m.group(3)), float(m.group(4))
    assert limit == pytest.approx(0.1)
    assert n_below >= 1
    # The refused state is still valid (ratio > 0: nothing degenerate, nothing inverted) and the
    # run stopped well before the wall itself collapses onto the axis (uo = R at 0.9 s).
    assert 0 < ratio < limit
    assert t_stop < R / RATE
    for words in ("Likely cause", "smaller wall motion", "interfaceMotion transpiration", "finer/better mesh"):
        assert words in log, f"message lacks {words!r}"

    # Everything written is finite and the last accepted mesh is valid.
    _assert_no_nan(case, log)
    last = _time_dirs(case)[-1].name
    assert float(last) == pytest.approx(t_stop - DT)
    check = fc.run(case, "checkMesh", "-time", last, log="checkMesh.last")
    vmin = float(re.search(r"Min volume = ([0-9.eE+-]+?)\.?\s", check).group(1))
    assert vmin > 0
    print(f"moving mesh, ovaling uo = {RATE:g} t: stopped at t = {t_stop:g} s (uo = {RATE * t_stop:.3f} m), "
          f"{n_below} cells below {limit:g}, smallest sub-volume ratio {ratio:.4f}; last written t = {last}, "
          f"min cell volume {vmin:.3e} m^3")


def _wall_cell_thickness(case: Path) -> np.ndarray:
    """h_w = 2 n.(C_f − C_cell) of the interface faces, from the written mesh (writeCellCentres-free:
    the wall cells of this O-grid are hexahedra, so the cell centre is the mean of its 8 points)."""
    poly = case / "constant" / "polyMesh"
    pts = _read_list(poly / "points", 3)
    faces = _read_faces(poly / "faces")
    owner = _read_labels(poly / "owner")
    boundary = (poly / "boundary").read_text()
    b = re.search(r"interface\s*\{[^}]*nFaces\s+(\d+);\s*startFace\s+(\d+);", boundary)
    n, start = int(b.group(1)), int(b.group(2))
    cell_pts: dict[int, set[int]] = {}
    for fi, f in enumerate(faces):
        cell_pts.setdefault(owner[fi], set()).update(f)
    h = []
    for fi in range(start, start + n):
        f = pts[faces[fi]]
        cf = f.mean(axis=0)
        nrm = np.cross(f[1] - f[0], f[2] - f[0])
        nrm /= np.linalg.norm(nrm)
        cc = pts[sorted(cell_pts[owner[fi]])].mean(axis=0)
        h.append(2 * abs(np.dot(nrm, cf - cc)))
    return np.array(h)


def _strip(path: Path) -> str:
    text = re.sub(r"/\*.*?\*/", "", path.read_text(), flags=re.S)
    text = re.sub(r"//.*", "", text)
    return text[text.index("}", text.index("FoamFile")) + 1:]


def _read_list(path: Path, width: int) -> np.ndarray:
    body = _strip(path)
    m = re.search(r"(\d+)\s*\(", body)
    inner = body[m.end(): body.rindex(")")]
    return np.array([float(x) for x in re.sub(r"[()]", " ", inner).split()]).reshape(-1, width)


def _read_faces(path: Path) -> list[list[int]]:
    body = _strip(path)
    m = re.search(r"(\d+)\s*\(", body)
    return [[int(x) for x in g.split()] for g in re.findall(r"\d+\(([^)]*)\)", body[m.end():])]


def _read_labels(path: Path) -> list[int]:
    body = _strip(path)
    m = re.search(r"(\d+)\s*\(", body)
    return [int(x) for x in body[m.end(): body.rindex(")")].split()]


def test_transpiration_refuses_a_wall_displacement_beyond_its_wall_cell(tmp_path):
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = tmp_path / "case"
    motion = pipe.make_pipe_case(case, dt=DT, end_time=END, write_interval=DT, interface_motion="transpiration",
                                 **MESH)
    _growing_ovaling(motion)
    fc.run(case, "blockMesh")
    log = _run_expecting_stop(case)
    m = re.search(
        r"the received wall displacement at t = ([0-9.eE+-]+) s is too large for the transpiration interface's "
        r"linearisation: \|u\| = ([0-9.eE+-]+) m at face (\d+) of patch interface .*? h_w = ([0-9.eE+-]+) m thick: "
        r"\|u\|/h_w = ([0-9.eE+-]+) > transpirationLimit ([0-9.eE+-]+)",
        log, re.S,
    )
    assert m, log[-3000:]
    t_stop, u, hw, ratio, limit = (float(m.group(i)) for i in (1, 2, 4, 5, 6))
    assert limit == 1
    assert ratio > limit and math.isclose(ratio, u / hw, rel_tol=1e-4)
    for words in ("Likely cause", "interfaceMotion meshMotion", "Fix"):
        assert words in log
    # Reference: the largest point displacement of the n = 2 mode is uo (at θ = 0, 90°, ...; the
    # wall points there are on the mesh), and h_w of this mesh's wall faces. The stop is the
    # first received step whose uo exceeds the thinnest wall cell's h_w within a step's growth.
    h = _wall_cell_thickness(case)
    uo = RATE * t_stop
    assert u <= uo * (1 + 1e-9)
    assert uo > h.min()
    assert RATE * (t_stop - DT) <= h.max()
    _assert_no_nan(case, log)
    print(f"transpiration, ovaling uo = {RATE:g} t: refused at t = {t_stop:g} s: |u| = {u:.4f} m at a face with "
          f"h_w = {hw:.4f} m (ratio {ratio:.3f} > {limit:g}); wall cells of this mesh {h.min():.3f}-{h.max():.3f} m")


@pytest.mark.parametrize("interface_motion", ["meshMotion", "transpiration"])
def test_ten_cm_motion_is_accepted_by_both_interface_motions(tmp_path, interface_motion):
    """The mesh-motion check's motion (10 cm sideways + 10 cm radial contraction, ramped over 10 steps)."""
    assert fc.LIBRARY.exists(), f"{fc.LIBRARY} not built"
    case = tmp_path / "case"
    n = 10
    motion = pipe.make_pipe_case(case, dt=DT, end_time=n * DT, R=R, L=9.0, nq=12, nr=8, ny=6, two_d=False,
                                 open_ends=True, interface_motion=interface_motion)
    t = np.arange(0, (n + 3) * DT, DT)
    s = np.minimum(t / (n * DT), 1.0)
    z = np.zeros_like(t)
    u = np.column_stack([0.10 * s, z, z])
    v = np.column_stack([np.full_like(t, 0.10 / (n * DT)), z, z])
    pipe.write_motion(motion, t, u, v, -0.10 * s, np.full_like(t, -0.10 / (n * DT)))
    fc.run(case, "blockMesh")
    log = fc.run(case, "pimpleFoam")
    assert float(_time_dirs(case)[-1].name) == pytest.approx(n * DT)
    _assert_no_nan(case, log)
