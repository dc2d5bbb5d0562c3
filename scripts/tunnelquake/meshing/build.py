"""`build_tunnel_mesh`: gmsh model -> model.msh, the solid mesh.h5 and the water water.msh.

Steps:
  1. validate the inputs and derive the block divisions (params.resolve);
  2. build and mesh the structured all-hex gmsh model (gmsh_model.build_model), write model.msh;
  3. solid: rock + lining hexes, lining nodes on the rock-lining interface duplicated and paired,
     with lining joints the lining's nodes on each joint plane duplicated again and paired,
     elements oriented to positive volume, boundary quads named, written as mesh.h5
     (docs/formats.md);
  4. water: its hexes and wall/end quads written as gmsh 2.2 ASCII for gmshToFoam;
  5. quality checks (corner Jacobians > 0, longest edge <= max_element_size) and a summary.

The three files are written to temporary files beside them and put in place together once all are
complete and the checks pass (tunnelquake.files.atomic_path): a failure, a kill or a full disk
leaves the previous files, never a partial one under a final name. A full disk raises
tunnelquake.files.DiskFull naming the file and the space the three need.

gmsh's FLTK, linked into it, rewrites its preference files (~/.fltk/..., /etc/fltk/...) when gmsh
starts; `_gmsh_session` points it at a private folder instead.
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import shutil
import tempfile
import time

import gmsh
import h5py
import numpy as np

from ..files import DiskFull, atomic_path, h5_in_memory
from . import hexmesh
from .geology import assign
from .gmsh_model import LINING, ROCK, WATER, build_model
from .params import (
    MeshInputError,
    MeshPlan,
    layer_of,
    lining_extent,
    plug_levels,
    portal_bench,
    portal_cut,
    resolve,
    slope_base,
    surface_nodes,
)

SOLID_FACE_NAMES = ("bottom", "top", "xmin", "xmax", "ymin", "ymax", "lining_inner", "rock_hole", "lining_outer")
#: the face group of the lining's joint faces (both sides of every joint)
JOINT_FACES = "lining_joints"
WATER_GROUPS = ("water", "interface", "end_ymin", "end_ymax")

#: The paper's element counts (§3.1), for the summary's comparison.
PAPER_COUNTS = {"rock": 58080, "lining": 6336, "water": 14256}


def region_names(plan: MeshPlan) -> list[str]:
    """The solid's regions in mesh.h5 order: rock, lining, then the ground layers from the top."""
    return [ROCK, LINING] + [name for name, _ in plan.layers] + (plan.geology.materials if plan.geology else [])


def build_tunnel_mesh(geometry: dict, mesh: dict, out_dir: pathlib.Path, layers=None, geology=None,
                      joint_spacing: float | None = None) -> dict:
    """Mesh the tunnel and write model.msh, mesh.h5 and water.msh into ``out_dir``.

    geometry: keys x_range, y_range, z_range ([min, max], m), tunnel_centre_x, tunnel_centre_z,
    excavated_radius, lining_thickness (m). mesh: MESH_DEFAULTS keys (missing ones take the
    default; unknown ones are rejected). layers: the ground's horizontal layers from the surface
    down, [(region name, z of its bottom)] (params.resolve). geology: regions bounded by planes
    (geology.Geology: dipping layers, a fault zone), each element by its centroid. joint_spacing: the
    lining's ring length (m), joints every spacing from the lining's start (joint_levels), each a plane
    of axial element layers. Returns a summary dict (see format_summary).
    Raises MeshInputError for bad input, RuntimeError if a quality check fails.
    """
    t0 = time.perf_counter()
    plan = resolve(geometry, mesh, layers, geology)
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = {"model": out_dir / "model.msh", "solid": out_dir / "mesh.h5", "water": out_dir / "water.msh"}
    needed = None
    try:
        with contextlib.ExitStack() as placed:  # each temporary file goes in place when all is done
            tmp = {k: placed.enter_context(atomic_path(p, suffix=".msh" if p.suffix == ".msh" else ".part"))
                   for k, p in files.items()}
            own_session = not gmsh.isInitialized()
            with _gmsh_session() if own_session else contextlib.nullcontext():
                try:
                    gmsh.option.setNumber("General.Terminal", 0)
                    gmsh.option.setNumber("General.NumThreads", 1)
                    model = build_model(plan, name="tunnelquake")
                    t_gmsh = time.perf_counter() - t0
                    coords, hexes = _extract(model["volumes"])
                    needed = _bytes_needed(coords, hexes)
                    _snap_layers(plan, coords)
                    _slope_nodes(plan, coords)
                    gmsh.option.setNumber("Mesh.SaveAll", 0)
                    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
                    gmsh.option.setNumber("Mesh.Binary", 0)
                    _write_model(tmp["model"])
                finally:
                    if not own_session:
                        gmsh.model.remove()

            hexes = _portal_cut(plan, coords, _plug_ends(plan, coords, hexes))
            solid = _solid_mesh(plan, coords, hexes, joint_levels(plan, joint_spacing))
            _write_solid(tmp["solid"], solid, plan.slice, region_names(plan))
            water = _water_mesh(plan, coords, hexes[WATER])
            _write_gmsh22(tmp["water"], water)

            h = max(solid["max_edge"], water["max_edge"])
            if h > plan.max_element_size * (1 + 1e-9):
                raise RuntimeError(
                    f"longest element edge {h:.4f} m > max_element_size {plan.max_element_size} m; "
                    "refine the mesh (more divisions) or raise max_element_size"
                )
    except DiskFull as e:
        if needed is None:
            raise
        raise DiskFull(e.path, needed) from None
    return {
        "mode": "slice" if plan.slice else "3d",
        "counts": {
            ROCK: int((solid["region"] != 1).sum()),
            "regions": {name: int((solid["region"] == i).sum())
                        for i, name in enumerate(region_names(plan)) if name != LINING},
            LINING: int((solid["region"] == 1).sum()),
            WATER: len(water["hexes"]),
            "solid_nodes": len(solid["coords"]),
            "water_nodes": len(water["coords"]),
        },
        "paper_counts": dict(PAPER_COUNTS),
        "faces": {k: len(v) for k, v in solid["faces"].items()},
        "water_faces": {k: len(v) for k, v in water["faces"].items()},
        "interface_pairs": len(solid["pairs"]),
        "joints": len(solid["joint_y"]),
        "joint_pairs": len(solid["joint_pairs"]),
        "max_element_size": h,
        "max_element_size_limit": plan.max_element_size,
        "min_jacobian": min(solid["min_detj"], water["min_detj"]),
        "min_scaled_jacobian": {
            ROCK: solid["min_scaled"][0],
            LINING: solid["min_scaled"][1],
            WATER: water["min_scaled"],
        },
        "y_extent": [plan.ymin, plan.ymax],
        "divisions": _divisions(plan),
        "files": {k: str(v) for k, v in files.items()},
        "time_s": {"gmsh": t_gmsh, "total": time.perf_counter() - t0},
    }


@contextlib.contextmanager
def _gmsh_session():
    """gmsh.initialize ... gmsh.finalize with FLTK's preference files kept out of the home folder
    and /etc: HOME is a private folder (removed after) while gmsh starts, and a root process
    starts it with the file-system uid of nobody (this thread only), so that /etc/fltk, which
    FLTK writes as root, is refused to it; reading is unchanged."""
    home = tempfile.mkdtemp(prefix="tunnelquake-gmsh-home-")
    old_home = os.environ.get("HOME")
    os.environ["HOME"] = home
    fsuid = _drop_fsuid() if os.geteuid() == 0 else None
    try:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    finally:
        if fsuid is not None:
            fsuid(0)
        if old_home is None:
            os.environ.pop("HOME", None)
        else:
            os.environ["HOME"] = old_home
        shutil.rmtree(home, ignore_errors=True)
    try:
        yield
    finally:
        gmsh.finalize()


def _drop_fsuid():
    """Set this thread's file-system uid to nobody (65534); returns setfsuid, None if unavailable."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.setfsuid(65534)
    except (OSError, AttributeError):
        return None
    return libc.setfsuid


def _bytes_needed(coords: np.ndarray, hexes: dict) -> int:
    """Disk space of model.msh, mesh.h5 and water.msh (measured on the example slice: about 230 B,
    135 B and 220 B a hexahedron), with a margin."""
    n = sum(len(h) for h in hexes.values())
    return int(1.2 * (230 * n + 135 * (n - len(hexes[WATER])) + 220 * len(hexes[WATER]))) + 65536


def _write_model(path: pathlib.Path) -> None:
    """gmsh.write, which does not report a failed write: a file that does not end with the last
    section's end line was cut short (a full disk)."""
    gmsh.write(str(path))
    with open(path, "rb") as fh:
        fh.seek(max(0, path.stat().st_size - 64))
        complete = fh.read().rstrip().endswith(b"$EndElements")
    if not complete:
        import errno

        from ..files import free_bytes

        # gmsh stops writing silently when a write fails; with no room left that is the cause
        code = errno.ENOSPC if free_bytes(path) < 65536 else errno.EIO
        raise OSError(code, f"gmsh could not write all of {path}: {os.strerror(code)}")


def format_summary(s: dict) -> str:
    """Human-readable lines of a build_tunnel_mesh summary (what `tunnelquake mesh` prints)."""
    c = s["counts"]
    lines = [f"mesh mode: {s['mode']}  (y {s['y_extent'][0]:g} .. {s['y_extent'][1]:g} m)"]
    for region in (ROCK, LINING, WATER):
        paper = s["paper_counts"][region]
        note = "" if s["mode"] != "3d" else f"  (paper {paper}, {100 * (c[region] / paper - 1):+.1f} %)"
        lines.append(f"  {region:7s} hexahedra: {c[region]:7d}{note}")
    if len(c.get("regions", {})) > 1:
        lines.append("  ground regions: " + ", ".join(f"{k} {v}" for k, v in c["regions"].items()))
    lines += [
        f"  solid nodes {c['solid_nodes']}, water nodes {c['water_nodes']}",
        f"  rock-lining node pairs: {s['interface_pairs']}",
        *([f"  lining joints: {s['joints']} ({s['joint_pairs']} node pairs)"] if s.get("joints") else []),
        f"  longest edge: {s['max_element_size']:.3f} m (limit {s['max_element_size_limit']:g} m)",
        f"  min corner det J: {s['min_jacobian']:.4g} m^3; min scaled Jacobian: "
        + ", ".join(f"{k} {v:.3f}" for k, v in s["min_scaled_jacobian"].items()),
        f"  built in {s['time_s']['total']:.2f} s (gmsh {s['time_s']['gmsh']:.2f} s)",
    ]
    lines += [f"  wrote {v}" for v in s["files"].values()]
    return "\n".join(lines)


def _divisions(p: MeshPlan) -> dict:
    return {
        "around": 4 * p.quarter.count,
        "lining_through": p.lining.count,
        "water_ring": p.water_ring.count,
        "water_core": p.quarter.count,
        "near_field_radial": p.near_field.count,
        **{band: sum(div.count for _, div in getattr(p, band)) for band in ("left", "right", "bottom", "top")},
        "axial": p.axial.count,
    }


def _extract(volumes: dict) -> tuple[np.ndarray, dict]:
    """All node coordinates (indexed by gmsh node tag) and the hex connectivity per region."""
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    coords = np.full((int(tags.max()) + 1, 3), np.nan)
    coords[tags.astype(np.int64)] = xyz.reshape(-1, 3)
    hexes = {}
    for region, vols in volumes.items():
        blocks = []
        for v in vols:
            types, _, nodes = gmsh.model.mesh.getElements(3, v)
            if list(types) != [5]:
                raise RuntimeError(f"gmsh volume {v} ({region}) has non-hex elements {list(types)}")
            blocks.append(np.asarray(nodes[0], dtype=np.int64).reshape(-1, 8))
        hexes[region] = np.concatenate(blocks)
    return coords, hexes


def _slope_nodes(plan: MeshPlan, coords: np.ndarray) -> None:
    """With a sloping surface (geology.slope), move the nodes above z_b onto it (params.surface_nodes),
    in the gmsh model too, so model.msh shows the same mesh."""
    if plan.geology is None or plan.geology.slope is None:
        return
    ok = np.isfinite(coords[:, 2]) & (coords[:, 2] > slope_base(plan))
    moved = surface_nodes(plan, coords[ok])
    for tag, xyz in zip(np.flatnonzero(ok).tolist(), moved.tolist(), strict=True):
        gmsh.model.mesh.setNode(tag, xyz, [])
    coords[ok] = moved


def _snap_layers(plan: MeshPlan, coords: np.ndarray) -> None:
    """Put every node exactly on its extrusion layer y_k = ymin + k (ymax - ymin) / n.

    gmsh's transfinite interpolation of the base surface leaves y = ymin + O(1e-15) when ymin != 0;
    the plane-strain slice and the face tests want the layers exact. Moves are <= 1e-12 m. With a
    refined axial grid the layers are plan.y_levels.
    """
    levels = np.asarray(plan.y_levels, float)
    ok = np.isfinite(coords[:, 1])
    k = np.clip(np.searchsorted(levels, coords[ok, 1]), 1, len(levels) - 1)
    k = np.where(np.abs(coords[ok, 1] - levels[k - 1]) < np.abs(coords[ok, 1] - levels[k]), k - 1, k)
    y = levels[k]
    if np.abs(y - coords[ok, 1]).max(initial=0.0) > 1e-9 * max(1.0, abs(plan.ymax)):
        raise RuntimeError("gmsh placed nodes off the extrusion layers")
    coords[ok, 1] = y


def _radius(plan: MeshPlan, x: np.ndarray) -> np.ndarray:
    return np.hypot(x[..., 0] - plan.xc, x[..., 2] - plan.zc)


def _tolerance(plan: MeshPlan) -> float:
    return 1e-6 * max(plan.xmax - plan.xmin, plan.zmax - plan.zmin)


def _quality(conn: np.ndarray, coords: np.ndarray, what: str) -> tuple[float, float, float]:
    detj, scaled = hexmesh.corner_jacobians(coords[conn])
    if (detj <= 0).any():
        bad = int((detj <= 0).any(axis=1).sum())
        raise RuntimeError(f"{what}: {bad} hexahedra have a non-positive corner Jacobian")
    return float(detj.min()), float(scaled.min()), hexmesh.max_edge_length(coords[conn])


#: the face group of the plugs' faces towards the tunnel (mesh.tunnel_end_plugs)
PLUG_FACES = "tunnel_ends"
#: the face group of the lining's end faces on the y faces in a block crossed by a fault zone: not part of
#: ymin/ymax, so neither their rollers nor a fault offset hold the lining's ends, which follow the rock
#: through the rock-lining interface (docs/solid_solver.md "Fault offset")
LINING_END_FACES = "lining_ends"


def _plug_ends(plan: MeshPlan, gcoords: np.ndarray, hexes: dict) -> dict:
    """With plugged ends (mesh.tunnel_end_plugs) the water and lining hexes of the end stretches
    become rock, listed after the rock's own under the key 'plug' (their nodes are not split from
    the rock's: the lining's ends are bonded to the plugs)."""
    ends = plug_levels(plan)
    if ends is None:
        return hexes
    out = dict(hexes)
    plug = []
    for region in (LINING, WATER):
        y = gcoords[hexes[region]][:, :, 1].mean(axis=1)
        inside = (y > ends[0]) & (y < ends[1])
        plug.append(hexes[region][~inside])
        out[region] = hexes[region][inside]
    out["plug"] = np.concatenate(plug)
    return out


#: the face group of what a portal's cut lays bare: the bench in front of the face, the face itself
#: (the headwall, through which the bore opens) and the lining's end there
PORTAL_FACES = "portal"


def _portal_cut(plan: MeshPlan, gcoords: np.ndarray, hexes: dict) -> dict:
    """With a portal (geology.portal) every hexahedron of every region whose centroid lies in front
    of the face above the bench is removed (params.portal_cut); model.msh keeps the uncut block."""
    if plan.geology is None or plan.geology.portal is None:
        return hexes
    return {region: h[~portal_cut(plan, gcoords[h].mean(axis=1))] for region, h in hexes.items()}


def joint_levels(plan: MeshPlan, spacing: float | None) -> list[float]:
    """The joints' planes y: every `spacing` from the lining's start (the first plug's end, or the
    block's ymin face) to before its end; each snapped to the axial element layer it lies on.
    Raises MeshInputError when the rings are not whole or a joint falls between layers (the case
    check says the same before anything runs)."""
    if not spacing:
        return []
    if plan.slice:
        raise MeshInputError("lining joints need a 3D mesh (mesh.mode: 3d)", key="lining_joints")
    y0, y1 = lining_extent(plan)
    n = (y1 - y0) / spacing
    tol = 1e-6 * (y1 - y0)
    if round(n) < 2 or abs(n - round(n)) > 1e-6 * n:
        raise MeshInputError(f"lining_joints.spacing {spacing:g} m does not cut the lining's {y1 - y0:g} m into two "
                             "or more whole rings", key="lining_joints.spacing")
    levels = np.asarray(plan.y_levels, float)
    out = []
    for k in range(1, round(n)):
        i = int(np.abs(levels - (y0 + k * spacing)).argmin())
        if abs(levels[i] - (y0 + k * spacing)) > tol:
            raise MeshInputError(f"lining joint {k} at y = {y0 + k * spacing:g} m is not on an axial element layer",
                                 key="lining_joints.spacing")
        out.append(float(levels[i]))
    return out


def _quad_areas(coords: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Areas of planar quads [F, 4]: half the cross product of the diagonals."""
    x = coords[quads]
    return 0.5 * np.linalg.norm(np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1]), axis=1)


def _split_joints(plan: MeshPlan, coords: np.ndarray, conn: np.ndarray, lining: np.ndarray, joints: list[float]):
    """Duplicate the lining's nodes on each joint plane: the elements on its +y side take the copies.
    Returns the coordinates, the connectivity, the pairs [P, 2] (node on the -y side, its copy), each
    pair's joint index and its tributary area on the plane (a quarter of each adjacent joint face of
    the -y side)."""
    tol = _tolerance(plan)
    conn = conn.copy()
    pairs, index, area = [], [], []
    for j, y in enumerate(joints):
        el = conn[lining]
        on = np.abs(coords[el][:, :, 1] - y) < tol
        cy = coords[el][:, :, 1].mean(axis=1)
        plus, minus = lining[(cy > y) & on.any(axis=1)], lining[(cy < y) & on.any(axis=1)]
        nodes = np.unique(conn[plus][np.abs(coords[conn[plus]][:, :, 1] - y) < tol])
        copy = len(coords) + np.arange(len(nodes))
        remap = np.arange(len(coords) + len(nodes))
        remap[nodes] = copy
        conn[plus] = remap[conn[plus]]
        # the -y side's faces on the plane give the tributary areas
        faces, _ = hexmesh.boundary_faces(conn[minus])
        faces = faces[(np.abs(coords[faces][:, :, 1] - y) < tol).all(axis=1)]
        a = np.zeros(len(coords))
        np.add.at(a, faces.ravel(), np.repeat(_quad_areas(coords, faces) / 4, 4))
        coords = np.concatenate([coords, coords[nodes]])
        pairs.append(np.stack([nodes, copy], axis=1))
        index.append(np.full(len(nodes), j))
        area.append(a[nodes])
    if not joints:
        return coords, conn, np.zeros((0, 2), np.int64), np.zeros(0, np.int64), np.zeros(0)
    return coords, conn, np.concatenate(pairs).astype(np.int64), np.concatenate(index).astype(np.int64), \
        np.concatenate(area)


def _solid_mesh(plan: MeshPlan, gcoords: np.ndarray, hexes: dict, joints: list[float] = ()) -> dict:
    """Rock + lining with the interface nodes duplicated: the lining gets its own copies (except
    where the lining meets a plug of rock at a tunnel end: bonded there). With joints, the lining's
    nodes on each joint plane once more: the ring on the +y side takes the copies, and the rock's
    interface node stays paired with the -y side's node."""
    plug = hexes.get("plug", np.zeros((0, 8), np.int64))
    rock, lining = np.concatenate([hexes[ROCK], plug]), hexes[LINING]
    shared = np.setdiff1d(np.intersect1d(hexes[ROCK], lining), plug)  # gmsh tags on the rock-lining interface
    used = np.union1d(rock, lining)
    index = np.full(len(gcoords), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    dup = np.full(len(gcoords), -1, dtype=np.int64)
    dup[shared] = len(used) + np.arange(len(shared))
    coords = np.concatenate([gcoords[used], gcoords[shared]])

    rock_c = index[rock]
    lining_c = np.where(dup[lining] >= 0, dup[lining], index[lining])
    conn = np.concatenate([rock_c, lining_c])
    conn = hexmesh.orient_positive(conn, coords)
    coords, conn, joint_pairs, joint_index, joint_area = _split_joints(
        plan, coords, conn, np.arange(len(rock), len(rock) + len(lining)), list(joints))
    # The ground's elements take the region of the layer their centre lies in (each lies wholly
    # between two layer bottoms: those are grid lines of the outer rock).
    ground = layer_of(plan, gcoords[rock][:, :, 2].mean(axis=1)) if plan.layers else np.zeros(len(rock), np.int32)
    if plan.geology is not None:  # regions bounded by planes: by the centroid
        ground = assign(plan.geology, gcoords[rock].mean(axis=1), ground, 2 + len(plan.layers))
    region = np.concatenate([ground.astype(np.int32), np.ones(len(lining), np.int32)])
    pairs = np.stack([index[shared], dup[shared]], axis=1)

    nr = len(rock)
    q_rock = _quality(conn[:nr], coords, "rock")
    q_lining = _quality(conn[nr:], coords, "lining")

    faces, owner = hexmesh.boundary_faces(conn)
    groups = _classify_solid_faces(plan, coords, faces, region[owner], plug_levels(plan), list(joints))
    if plan.geology is not None and not plan.slice:
        groups.update(side_strips(plan, coords, groups))
    return {
        "coords": coords,
        "conn": conn,
        "region": region,
        "pairs": pairs,
        "joint_pairs": joint_pairs,
        "joint_index": joint_index,
        "joint_area": joint_area,
        "joint_y": np.asarray(list(joints), float),
        "faces": groups,
        "min_detj": min(q_rock[0], q_lining[0]),
        "min_scaled": (q_rock[1], q_lining[1]),
        "max_edge": max(q_rock[2], q_lining[2]),
    }


#: The side faces split into axial strips (STRIP_FORMAT.format(face, k)) for a ground that
#: changes along y: one element wide, each strip is horizontally layered whatever the regions.
STRIP_FORMAT = "{}_strip{:04d}"


def side_strips(plan: MeshPlan, coords: np.ndarray, groups: dict) -> dict:
    """The xmin and xmax faces cut into strips one axial layer wide, {name: quads}: the seismic
    stage drives each with a 1D free-field column of its own (tq-solid needs one material per
    horizontal row of a free-field face, which a band or a layer dipping along y breaks)."""
    levels = np.asarray(plan.y_levels)
    out = {}
    for face in ("xmin", "xmax"):
        quads = groups[face]
        k = np.searchsorted(levels, coords[quads][:, :, 1].mean(axis=1)) - 1
        for j in range(len(levels) - 1):
            out[STRIP_FORMAT.format(face, j)] = quads[k == j]
    return out


def _plane_faces(plan: MeshPlan, fx: np.ndarray) -> dict:
    """Masks of faces whose 4 nodes all lie on one of the block's six planes."""
    tol = _tolerance(plan)
    planes = {
        "bottom": (2, plan.zmin),
        "top": (2, plan.zmax),
        "xmin": (0, plan.xmin),
        "xmax": (0, plan.xmax),
        "ymin": (1, plan.ymin),
        "ymax": (1, plan.ymax),
    }
    out = {n: (np.abs(fx[:, :, ax] - v) < tol).all(axis=1) for n, (ax, v) in planes.items()}
    if plan.geology is not None and plan.geology.slope is not None:  # the ground surface follows the slope
        top = np.concatenate([fx[..., :2], np.full(fx.shape[:-1] + (1,), plan.zmax)], axis=-1)
        out["top"] = (np.abs(fx[:, :, 2] - surface_nodes(plan, top)[:, :, 2]) < tol).all(axis=1)
    return out


def _classify_solid_faces(plan, coords, faces, owner_region, ends=None, joints=()) -> dict:
    fx = coords[faces]
    tol = _tolerance(plan)
    r = _radius(plan, fx)
    masks = _plane_faces(plan, fx)
    names = list(SOLID_FACE_NAMES)
    if ends is not None:  # the plugs' faces towards the tunnel's hole
        masks[PLUG_FACES] = np.any([(np.abs(fx[:, :, 1] - y) < tol).all(axis=1) for y in ends], axis=0) & ~(
            masks["ymin"] | masks["ymax"])
        names.append(PLUG_FACES)
    if getattr(plan.geology, "fault", None) is not None and not plan.slice:
        lining_ends = (masks["ymin"] | masks["ymax"]) & (owner_region == 1)
        if lining_ends.any():
            masks["ymin"] &= ~lining_ends
            masks["ymax"] &= ~lining_ends
            masks[LINING_END_FACES] = lining_ends
            names.append(LINING_END_FACES)
    po = plan.geology.portal if plan.geology is not None else None
    if po is not None:  # the bench in front of the face and the face (the headwall and the lining's end)
        at_face = (np.abs(fx[:, :, 1] - po.station) < tol).all(axis=1)
        bench = (np.abs(fx[:, :, 2] - portal_bench(plan)) < tol).all(axis=1) & (fx[:, :, 1] < po.station + tol).all(
            axis=1)
        masks[PORTAL_FACES] = (at_face | bench) & ~masks["top"]
        names.append(PORTAL_FACES)
    on_a = (np.abs(r - plan.radius_inner) < tol).all(axis=1)
    on_b = (np.abs(r - plan.radius_outer) < tol).all(axis=1)
    masks["lining_inner"] = on_a & (owner_region == 1)
    masks["lining_outer"] = on_b & (owner_region == 1)
    masks["rock_hole"] = on_b & (owner_region != 1)
    if joints:  # both sides of every joint
        masks[JOINT_FACES] = np.any([(np.abs(fx[:, :, 1] - y) < tol).all(axis=1) for y in joints], axis=0) & (
            owner_region == 1)
        names.append(JOINT_FACES)
    hits = np.sum([m for m in masks.values()], axis=0)
    if (hits != 1).any():
        raise RuntimeError(
            f"{int((hits == 0).sum())} solid boundary faces are on no named boundary and "
            f"{int((hits > 1).sum())} on several"
        )
    return {name: faces[masks[name]].astype(np.int32) for name in names}


def _water_mesh(plan: MeshPlan, gcoords: np.ndarray, water: np.ndarray) -> dict:
    used = np.unique(water)
    index = np.full(len(gcoords), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    coords = gcoords[used]
    conn = hexmesh.orient_positive(index[water], coords)
    min_detj, min_scaled, max_edge = _quality(conn, coords, "water")
    faces, _ = hexmesh.boundary_faces(conn)
    fx = coords[faces]
    tol = _tolerance(plan)
    y0, y1 = lining_extent(plan)
    masks = {
        "interface": (np.abs(_radius(plan, fx) - plan.radius_inner) < tol).all(axis=1),
        "end_ymin": (np.abs(fx[:, :, 1] - y0) < tol).all(axis=1),
        "end_ymax": (np.abs(fx[:, :, 1] - y1) < tol).all(axis=1),
    }
    hits = np.sum(list(masks.values()), axis=0)
    if (hits != 1).any():
        raise RuntimeError("water boundary faces not all on the interface or the axial ends")
    return {
        "coords": coords,
        "hexes": conn,
        "faces": {k: faces[m] for k, m in masks.items()},
        "min_detj": min_detj,
        "min_scaled": min_scaled,
        "max_edge": max_edge,
    }


def _write_solid(path: pathlib.Path, s: dict, slice_mode: bool, regions: list[str]) -> None:
    """mesh.h5 exactly as docs/formats.md describes, built in memory (files.h5_in_memory: HDF5
    never meets a full disk), then written to `path`."""
    with h5_in_memory(path) as f:
        f.attrs["format"] = "tunnelquake-solid-mesh"
        f.attrs["version"] = np.int64(1)
        f.attrs["slice"] = np.int64(1 if slice_mode else 0)
        f.create_dataset("nodes/coordinates", data=s["coords"].astype(np.float64))
        el = f.create_group("elements")
        el.create_dataset("connectivity", data=s["conn"].astype(np.int32))
        el.create_dataset("region", data=s["region"].astype(np.int32))
        el.attrs["regions"] = np.array(regions, dtype=h5py.string_dtype())
        for name in list(SOLID_FACE_NAMES) + sorted(set(s["faces"]) - set(SOLID_FACE_NAMES)):
            f.create_dataset(f"faces/{name}", data=s["faces"][name].astype(np.int32).reshape(-1, 4))
        f.create_dataset("interfaces/rock_lining", data=s["pairs"].astype(np.int32))
        if len(s["joint_y"]):
            f.create_dataset("interfaces/lining_joints", data=s["joint_pairs"].astype(np.int32))
            f.create_dataset("interfaces/lining_joint_index", data=s["joint_index"].astype(np.int32))
            f.create_dataset("interfaces/lining_joint_area", data=s["joint_area"].astype(np.float64))
            f.create_dataset("interfaces/lining_joint_y", data=s["joint_y"].astype(np.float64))


def _write_gmsh22(path: pathlib.Path, w: dict) -> None:
    """The water mesh as gmsh 2.2 ASCII (gmshToFoam): physical groups water, interface,
    end_ymin, end_ymax; quads ordered counter-clockwise seen from outside the water.
    Coordinates are written with repr(), which round-trips doubles exactly, so interface points
    coincide bit for bit with the solid's lining_inner nodes.
    """
    tags = {"water": 1, "interface": 2, "end_ymin": 3, "end_ymax": 4}
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", str(len(tags))]
    out += [f'{3 if n == "water" else 2} {t} "{n}"' for n, t in tags.items()]
    out += ["$EndPhysicalNames", "$Nodes", str(len(w["coords"]))]
    out += [f"{i + 1} {x!r} {y!r} {z!r}" for i, (x, y, z) in enumerate(w["coords"].tolist())]
    out.append("$EndNodes")
    rows = []
    for name in ("interface", "end_ymin", "end_ymax"):
        t = tags[name]
        rows += [f"3 2 {t} {t} " + " ".join(map(str, q)) for q in (w["faces"][name] + 1).tolist()]
    rows += ["5 2 1 1 " + " ".join(map(str, h)) for h in (w["hexes"] + 1).tolist()]
    out += ["$Elements", str(len(rows))]
    out += [f"{i + 1} {r}" for i, r in enumerate(rows)]
    out.append("$EndElements")
    path.write_text("\n".join(out) + "\n")


__all__ = ["build_tunnel_mesh", "format_summary", "MeshInputError"]
