"""The subcycling levels tq-solid gives a mesh (time.subcycling), computed here from the mesh alone so
that `check` can count what a subcycled condition costs (scene.runtime_estimate) without running it.

The rule is tq-solid's own (Solver::enableSubcycling, ElementBlock::setChunkLevels, scatterOrder):

1. each element's stable step is safety x 2 / w, w = 2 c_p / L, L the element's volume over its
   largest face (hex8::computeGeometry: the face's area half its diagonals' cross product, the
   volume the 8-point Gauss sum, exact for a trilinear hexahedron); its level the largest l up to
   the case's levels with that step at least 2^(l+1) times the solid's step dt (dt the given step,
   else safety x 2 / w_max);
2. each node takes the lowest level of its elements; then, until nothing changes, the contributors'
   constraints (the contact's pairs, the lining's joints and the coupled wet wall at the finest
   level, a bonded interface's pairs at their common finest) and the grading (no node of an element
   more than one level above the element's finest node);
3. the elements are evaluated by chunks of 64 in each region's block (the region's elements in mesh
   order, renumbered breadth first from its smallest elements and those on the tunnel's faces when
   that at least halves the scatter's span, then in order of their estimated level: setOrderLevels,
   rule 1 at the automatic step with the tunnel's faces at the finest level and the grading), each
   chunk at the finest level of its elements' nodes.

A reinforced_concrete lining is taken at its concrete's modulus (tq-solid stiffens it by its bars'
steel ratio, which shortens the step a little: the counts may then differ from tq-solid's).

What this yields, per level L: the elements evaluated every 2^L fine steps and the nodes stepping
2^L dt, and the evaluations of a fine step against one-rate stepping (cost_fraction): tq-solid's
"subcycling: steps of 1, 2, 4, 8 x dt for ... elements (... nodes)" and its results file's
/subcycling attributes. tests/python/test_subcycle_levels.py holds the two equal on meshes unlike
each other.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: elements per chunk of an element block (ElementBlock::kChunk)
CHUNK = 64
#: blocks of at least this many elements may be renumbered (scatterOrder: any block of two or more)
RENUMBER_MIN = 2

#: the tunnel's face groups (tq/core/mesh.hpp face_group): the blocks' renumbering starts at their elements
TUNNEL_FACES = ("lining_inner", "lining_outer", "rock_hole")

# hex8 faces (as local node quadruples) and edges, tq-solid's numbering (tq/elements/hex8.hpp)
_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
_EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]])
_CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                     [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)


@dataclass(frozen=True)
class Levels:
    """The subcycling tq-solid would set up: counts by level (index L: steps of 2^L dt)."""

    elements: tuple[int, ...]  # active elements evaluated every 2^L fine steps (by chunk)
    nodes: tuple[int, ...]  # nodes stepping 2^L dt
    cost_fraction: float  # element evaluations a fine step against one-rate stepping
    dt: float  # the solid's (finest) step, s
    own: tuple[int, ...] = ()  # active elements whose finest node steps 2^L dt (a chunk's can be finer)

    @property
    def element_count(self) -> int:
        return sum(self.elements)

    @property
    def node_count(self) -> int:
        return sum(self.nodes)


def p_wave_speed(E: float, nu: float, rho: float) -> float:
    """sqrt((λ + 2μ) / ρ) in tq-solid's own arithmetic (ElasticModuli::pModulus), not the
    E(1 − ν)/((1 + ν)(1 − 2ν)) form of scene's estimates: an element whose step lies on a level's
    boundary then falls on tq-solid's side of it."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    return float(np.sqrt((lam + 2.0 * mu) / rho))


def characteristic_lengths(coords: np.ndarray, conn: np.ndarray) -> np.ndarray:
    """Each hexahedron's volume over its largest face area, m."""
    x = coords[conn]  # (E, 8, 3)
    g = 1.0 / np.sqrt(3.0)
    volume = np.zeros(len(conn))
    for p in _CORNERS * g:  # the 8 Gauss points, weight 1
        # dN_I/dxi_k = c_Ik (1 + c_Il p_l)(1 + c_Im p_m) / 8 over the other two directions l, m
        one = 1.0 + _CORNERS * p  # (8, 3)
        dn = np.empty((8, 3))
        dn[:, 0] = _CORNERS[:, 0] * one[:, 1] * one[:, 2] / 8
        dn[:, 1] = _CORNERS[:, 1] * one[:, 0] * one[:, 2] / 8
        dn[:, 2] = _CORNERS[:, 2] * one[:, 0] * one[:, 1] / 8
        jac = np.einsum("eIi,Ik->eik", x, dn)
        volume += np.linalg.det(jac)
    d1 = x[:, _FACES[:, 2]] - x[:, _FACES[:, 0]]
    d2 = x[:, _FACES[:, 3]] - x[:, _FACES[:, 1]]
    area = 0.5 * np.linalg.norm(np.cross(d1, d2), axis=2).max(axis=1)
    return volume / area


def _shortest_edges(coords: np.ndarray, conn: np.ndarray) -> np.ndarray:
    x = coords[conn]
    d = x[:, _EDGES[:, 0]] - x[:, _EDGES[:, 1]]
    return np.sqrt((d * d).sum(axis=2).min(axis=1))


def _scatter_span(conn: np.ndarray, elems: np.ndarray, num_nodes: int) -> int:
    """The largest distance in the list `elems` between two elements sharing a node."""
    nodes = conn[elems]  # (n, 8), row i at list position i
    pos = np.repeat(np.arange(len(elems)), 8)
    flat = nodes.ravel()
    first = np.full(num_nodes, len(elems), dtype=np.int64)
    np.minimum.at(first, flat, pos)
    return int((pos - first[flat]).max()) if len(elems) else 0


def _breadth_first(conn: np.ndarray, elems: np.ndarray, sources: list[int], num_nodes: int) -> list[int]:
    """List positions of `elems` in breadth-first order through shared nodes from `sources`; each
    element's neighbours by its nodes in turn, each node's elements in list order; then any part not
    reached, from its first element in the list."""
    nodes = conn[elems]
    n = len(elems)
    flat = nodes.ravel()
    order_by_node = np.argsort(flat, kind="stable")
    owners = (order_by_node // 8).tolist()
    head = np.zeros(num_nodes + 1, dtype=np.int64)
    np.add.at(head, flat + 1, 1)
    head = np.cumsum(head).tolist()
    rows = nodes.tolist()
    seen = bytearray(n)
    order: list[int] = []
    for r in sources:
        if not seen[r]:
            seen[r] = 1
            order.append(r)
    q = 0
    root = 0
    while len(order) < n or q < len(order):
        if q == len(order):
            while seen[root]:
                root += 1
            seen[root] = 1
            order.append(root)
        while q < len(order):
            for node in rows[order[q]]:
                for j in range(head[node], head[node + 1]):
                    e = owners[j]
                    if not seen[e]:
                        seen[e] = 1
                        order.append(e)
            q += 1
    return order


def _by_order_level(conn: np.ndarray, elems: np.ndarray, order_level) -> np.ndarray:
    """`elems` stably sorted by their estimated level (the smallest of their nodes' order_level);
    unchanged without one (ElementBlock's byOrderLevel)."""
    if order_level is None:
        return elems
    return elems[np.argsort(order_level[conn[elems]].min(axis=1), kind="stable")]


def block_order(coords: np.ndarray, conn: np.ndarray, elems: np.ndarray, wall_nodes=None,
                order_level=None) -> np.ndarray:
    """The order of a region's elements in tq-solid's block (scatterOrder): renumbered breadth first
    when that at least halves the scatter's span, from its smallest elements (shortest edge within
    1.5 x the block's shortest; none when they are more than an eighth of the block) and its
    elements with a node among `wall_nodes` (the tunnel's faces; none when more than an eighth),
    else from the element reached last from the first smallest one; then, given the nodes'
    `order_level` (order_levels), in order of the elements' estimated level."""
    n = len(elems)
    if n < RENUMBER_MIN:
        return elems
    num_nodes = len(coords)
    span = _scatter_span(conn, elems, num_nodes)
    if span < n // 16:
        return _by_order_level(conn, elems, order_level)
    edge = _shortest_edges(coords, conn[elems])
    small = np.flatnonzero(edge <= 1.5 * edge.min())
    smallest = int(small[0])
    on_wall = np.zeros(num_nodes, dtype=bool)
    if wall_nodes is not None and len(wall_nodes):
        on_wall[np.asarray(wall_nodes, dtype=np.int64)] = True
    wall = np.flatnonzero(on_wall[conn[elems]].any(axis=1))
    if len(wall) > n // 8:  # most of the block (the lining)
        wall = wall[:0]
    if len(small) > n // 8:  # about uniform size (a slice's thickness)
        small = small[:0]
    sources = np.union1d(small, wall).tolist()
    if not sources:  # about uniform: from a far end instead
        sources = [_breadth_first(conn, elems, [smallest], num_nodes)[-1]]
    renumbered = elems[np.array(_breadth_first(conn, elems, sources, num_nodes))]
    chosen = renumbered if _scatter_span(conn, renumbered, num_nodes) * 2 <= span else elems
    return _by_order_level(conn, chosen, order_level)


def _graded(node_level: np.ndarray, conn: np.ndarray, finest: np.ndarray, tied: np.ndarray) -> np.ndarray:
    """Node levels lowered until no constraint or grading lowers one: the nodes `finest` at 0, each
    row of `tied` at its members' finest, no node of an element more than one level above the
    element's finest node."""
    while True:
        lowered = node_level.copy()
        lowered[finest] = 0
        if len(tied):
            common = lowered[tied].min(axis=1)
            np.minimum.at(lowered, tied.ravel(), np.repeat(common, tied.shape[1]))
        cap = lowered[conn].min(axis=1) + 1
        np.minimum.at(lowered, conn.ravel(), np.repeat(cap, 8))
        if np.array_equal(lowered, node_level):
            return node_level
        node_level = lowered


def order_levels(w: np.ndarray, conn: np.ndarray, num_nodes: int, max_level: int, wall_nodes=None) -> np.ndarray:
    """tq-solid's estimate of the nodes' levels that its blocks' order follows (setOrderLevels): each
    element's level the largest l up to max_level with w_max >= w 2^(l+1) (w its 2 c_p / L), each
    node its elements' lowest, the tunnel's faces (`wall_nodes`) at 0, graded."""
    level_e = np.zeros(len(conn), dtype=np.int64)
    w_max = float(w.max())
    for lv in range(max_level):
        level_e += (level_e == lv) & (w_max >= w * float(2 << lv))
    node_level = np.full(num_nodes, max_level, dtype=np.int64)
    np.minimum.at(node_level, conn.ravel(), np.repeat(level_e, 8))
    wall = np.asarray(wall_nodes if wall_nodes is not None else [], dtype=np.int64)
    return _graded(node_level, conn, wall, np.zeros((0, 2), dtype=np.int64))


@dataclass(frozen=True)
class LevelArrays:
    """What levels() counts, node by node and element by element."""

    conn: np.ndarray  # (E, 8) the elements' nodes
    node_level: np.ndarray  # (N,) each node's level (steps of 2^L dt)
    chunk_level: np.ndarray  # (E,) each element's chunk's level: it is evaluated every 2^L fine steps
    blocks: tuple  # each region's elements in tq-solid's block order (chunks of CHUNK in turn)
    top: int  # the case's levels
    dt: float  # the solid's (finest) step, s


def level_arrays(coords: np.ndarray, conn: np.ndarray, region: np.ndarray, speeds: list[float], max_level: int,
                 safety: float, dt: float = 0.0, finest=None, tied=None, wall_nodes=None) -> LevelArrays:
    """The levels tq-solid gives the mesh (coords (N, 3), conn (E, 8), region (E,) indices into
    `speeds`, each region's P-wave speed) at `max_level` levels with the time step's safety factor
    `safety` and step `dt` (0: automatic, safety x 2 / w_max). The contributors' constraints: the
    nodes `finest` (contact pairs, lining joints, the wet wall) step at the finest level, each row
    of `tied` (the bonded interface's pairs) at its members' finest. `wall_nodes`: the nodes of the
    tunnel's faces, where the blocks' renumbering starts (block_order)."""
    conn = np.asarray(conn, dtype=np.int64)
    region = np.asarray(region)
    w = 2.0 * np.asarray(speeds, dtype=float)[region] / characteristic_lengths(coords, conn)
    if not dt > 0:
        dt = safety * ((2.0 / w.max()) * 1.0)
    dte = safety * 2.0 / w
    level_e = np.zeros(len(conn), dtype=np.int64)
    for lv in range(max_level):  # the largest l with dte >= dt 2^(l+1)
        level_e += (level_e == lv) & (dte >= dt * float(2 << lv))
    num_nodes = len(coords)
    node_level = np.full(num_nodes, max_level, dtype=np.int64)
    np.minimum.at(node_level, conn.ravel(), np.repeat(level_e, 8))
    finest = np.asarray(finest if finest is not None else [], dtype=np.int64)
    tied = np.asarray(tied if tied is not None else np.zeros((0, 2)), dtype=np.int64)
    node_level = _graded(node_level, conn, finest, tied)  # the constraints and the grading
    estimate = order_levels(w, conn, num_nodes, max_level, wall_nodes) if max_level > 0 else None
    chunk_level = np.full(len(conn), max_level, dtype=np.int64)
    blocks = []
    for r in np.unique(region):
        order = block_order(coords, conn, np.flatnonzero(region == r), wall_nodes, estimate)
        finest_e = node_level[conn[order]].min(axis=1)
        pad = -len(finest_e) % CHUNK
        chunk = np.concatenate([finest_e, np.full(pad, max_level)]).reshape(-1, CHUNK).min(axis=1)
        chunk_level[order] = np.repeat(chunk, CHUNK)[:len(finest_e)]
        blocks.append(order)
    return LevelArrays(conn=conn, node_level=node_level, chunk_level=chunk_level, blocks=tuple(blocks),
                       top=max_level, dt=float(dt))


def level_counts(a: LevelArrays) -> Levels:
    """The counts by level of level_arrays()."""
    conn, top = a.conn, a.top
    used = np.zeros(len(a.node_level), dtype=bool)
    used[conn.ravel()] = True
    nodes = np.bincount(a.node_level[used], minlength=top + 1)
    elements = np.zeros(top + 1, dtype=np.int64)
    own = np.bincount(a.node_level[conn].min(axis=1), minlength=top + 1)
    evals = 0.0
    for order in a.blocks:
        per_element = a.chunk_level[order]
        elements += np.bincount(per_element, minlength=top + 1)
        evals += float((1.0 / 2.0 ** per_element).sum())
    last = max((lv for lv in range(top + 1) if nodes[lv] > 0), default=0)
    return Levels(elements=tuple(int(x) for x in elements[:last + 1]), nodes=tuple(int(x) for x in nodes[:last + 1]),
                  cost_fraction=evals / len(conn) if len(conn) else 1.0, dt=a.dt,
                  own=tuple(int(x) for x in own[:last + 1]))


def levels(coords: np.ndarray, conn: np.ndarray, region: np.ndarray, speeds: list[float], max_level: int,
           safety: float, dt: float = 0.0, finest=None, tied=None, wall_nodes=None) -> Levels:
    """The counts by level of level_arrays() (the same arguments)."""
    return level_counts(level_arrays(coords, conn, region, speeds, max_level, safety, dt, finest, tied, wall_nodes))


def mesh_levels(mesh_h5: Path, materials: dict, max_level: int, safety: float, dt: float = 0.0,
                interface: str = "dynamic_contact", wet: bool = False) -> Levels:
    """The counts by level of mesh_level_arrays() (the same arguments)."""
    return level_counts(mesh_level_arrays(mesh_h5, materials, max_level, safety, dt, interface, wet))


def mesh_level_arrays(mesh_h5: Path, materials: dict, max_level: int, safety: float, dt: float = 0.0,
                      interface: str = "dynamic_contact", wet: bool = False) -> LevelArrays:
    """level_arrays() of a mesh.h5 (meshing.build's solid mesh), each region's P-wave speed from the
    case's materials (`materials[region]`: youngs_modulus, poisson_ratio, density). The constraints of
    tq-solid's contributors: the rock-lining pairs (/interfaces/rock_lining) at the finest level
    with `interface` dynamic_contact, tied with bonded; the lining joints' pairs at the finest; with
    `wet` (the water coupled, or its volume law carried in the solid) the lining's inner face too."""
    import h5py

    with h5py.File(mesh_h5, "r") as f:
        coords = f["nodes/coordinates"][()]
        conn = f["elements/connectivity"][()]
        region = f["elements/region"][()]
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in f["elements"].attrs["regions"]]
        pairs = f["interfaces/rock_lining"][()] if "interfaces/rock_lining" in f else np.zeros((0, 2), np.int64)
        finest = [f["interfaces/lining_joints"][()].ravel()] if "interfaces/lining_joints" in f else []
        wall = [f[f"faces/{g}"][()].ravel() for g in TUNNEL_FACES if f"faces/{g}" in f]
        if wet and "faces/lining_inner" in f:
            finest.append(f["faces/lining_inner"][()].ravel())
    speeds = [p_wave_speed(float(materials[n]["youngs_modulus"]), float(materials[n]["poisson_ratio"]),
                           float(materials[n]["density"])) for n in names]
    if interface == "dynamic_contact":
        finest.append(np.asarray(pairs).ravel())
        pairs = None
    finest = np.unique(np.concatenate(finest)) if finest else None
    wall_nodes = np.unique(np.concatenate(wall)) if wall else None
    return level_arrays(coords, conn, region, speeds, max_level, safety, dt, finest, pairs, wall_nodes)


def mesh_frequencies(mesh_h5: Path, materials: dict, stiffening: dict | None = None) -> dict[str, float]:
    """Each region of a mesh.h5 -> the largest 2 c_p / L of its hexahedra (rad/s), L their volume over
    largest face and c_p their material's P-wave speed (`materials[region]`, its moduli times
    `stiffening[region]` where given: a reinforced lining's bars): tq-solid's hex8 frequency bound
    (ElementBlock::frequency), whose largest over the model sets its stable step 2 / w_max."""
    import h5py

    with h5py.File(mesh_h5, "r") as f:
        coords = f["nodes/coordinates"][()]
        conn = np.asarray(f["elements/connectivity"][()], dtype=np.int64)
        region = f["elements/region"][()]
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in f["elements"].attrs["regions"]]
    length = characteristic_lengths(coords, conn)
    out = {}
    for r, name in enumerate(names):
        mine = region == r
        if mine.any():
            m = materials[name]
            c_p = p_wave_speed(float(m["youngs_modulus"]), float(m["poisson_ratio"]), float(m["density"]))
            out[name] = float(2.0 * c_p * np.sqrt((stiffening or {}).get(name, 1.0)) / length[mine].min())
    return out


def window_reach(conn: np.ndarray, node_level: np.ndarray, chunk_level: np.ndarray, chunk_of: np.ndarray,
                 wet: np.ndarray, pairs: np.ndarray, steps: int) -> dict:
    """What a coupling window's re-pass steps again (tq-solid's Solver::planRepasses, by its rule):
    between two passes only the water's force on the nodes `wet` differs. Over the window's `steps`
    fine steps (counted from a step at which every level is due) a node *changes* at an update whose
    force may differ: the wet nodes' from the first step, a node's with an element changed before, or
    with a partner (`pairs` (P, 2): the contact's, the ties', the joints') changed before or loaded
    differently at that step; an element changes from its first evaluation that reads a changed node.
    A re-pass evaluates every element with a changed node, by whole chunks. conn (E, 8), node_level (N,), chunk_level (E,) the
    level each element is evaluated at, chunk_of (E,) a chunk id per element (unique across blocks).
    Returns counts by level ("elements", "changed", "needed", "needed_by_chunk"), the element
    evaluations of a window of a whole pass and of a re-pass ("evals_whole", "evals_needed" by
    element, "evals_by_chunk"), and the nodes ("nodes", "nodes_changed", "updates_whole",
    "updates_changed")."""
    num_nodes, num_elems = len(node_level), len(conn)
    changed = np.zeros(num_nodes, dtype=bool)
    elem_changed = np.zeros(num_elems, dtype=bool)
    top = int(max(node_level.max(initial=0), chunk_level.max(initial=0)))
    evals_whole = 0
    for s in range(steps):  # fine steps from the window's start
        active = max(lv for lv in range(top + 1) if s % (1 << lv) == 0)
        due = chunk_level <= active
        evals_whole += int(due.sum())
        elem_changed |= due & changed[conn].any(axis=1)
        force = np.zeros(num_nodes, dtype=bool)  # whose force at this step may differ
        force[conn[elem_changed & due].ravel()] = True
        force[wet] = True
        if len(pairs):  # a pair's force from both nodes' motion, or their forces of this step
            force[pairs[(changed | force)[pairs].any(axis=1)].ravel()] = True
        changed |= force & (node_level <= active)
    needed = changed[conn].any(axis=1)
    chunk_needed = np.zeros(int(chunk_of.max(initial=0)) + 1, dtype=bool)
    chunk_needed[chunk_of[needed]] = True
    by_chunk = chunk_needed[chunk_of]
    per_window = np.array([steps >> int(lv) for lv in range(top + 1)])  # evaluations a window by level
    count = lambda mask: np.bincount(chunk_level[mask], minlength=top + 1)  # noqa: E731
    node_updates = per_window[node_level]
    return {
        "levels": np.arange(top + 1), "elements": count(np.ones(num_elems, dtype=bool)),
        "changed": count(elem_changed), "needed": count(needed), "needed_by_chunk": count(by_chunk),
        "evals_whole": evals_whole, "evals_needed": int((per_window[chunk_level] * needed).sum()),
        "evals_by_chunk": int((per_window[chunk_level] * by_chunk).sum()),
        "nodes": num_nodes, "nodes_changed": int(changed.sum()),
        "updates_whole": int(node_updates.sum()), "updates_changed": int(node_updates[changed].sum()),
    }


def mesh_window_reach(mesh_h5: Path, a: LevelArrays, steps: int) -> dict:
    """window_reach() of windows of `steps` fine steps on a mesh.h5 whose water is coupled on its
    lining's inner face, at the levels and chunks `a` (mesh_level_arrays of it with the wet wall at the
    finest level; max_level 0: one rate)."""
    import h5py

    with h5py.File(mesh_h5, "r") as f:
        wet = np.unique(f["faces/lining_inner"][()].ravel()) if "faces/lining_inner" in f else np.zeros(0, np.int64)
        # the contact's pairs, a bonded interface's ties and the lining's joints: each pair's forces
        # come from both nodes
        pairs = np.concatenate([f[g][()].astype(np.int64).reshape(-1, 2) for g in ("interfaces/rock_lining",
                                "interfaces/lining_joints") if g in f] or [np.zeros((0, 2), np.int64)])
    chunk_of = np.zeros(len(a.conn), dtype=np.int64)
    first = 0
    for order in a.blocks:
        chunk_of[order] = first + np.arange(len(order)) // CHUNK
        first += (len(order) + CHUNK - 1) // CHUNK
    return window_reach(a.conn, a.node_level, a.chunk_level, chunk_of, wet, pairs, steps)


# ------------------------------------------------------------------------------------------------
# The element-evaluation probe's box (rates.measure_eval_share)
# ------------------------------------------------------------------------------------------------
#: the probe's box: N x N elements in plan, THIN layers of 1/8 m at the base (they set the step and
#: step at the finest level) under THICK layers of 1 m (they step at 8 times it, the grading between)
PROBE_N, PROBE_THIN, PROBE_THICK = 16, 4, 12
#: its elastic rock
PROBE_ROCK = (8e9, 0.27, 2700.0)


def write_probe_box(folder: Path, steps: int, levels_: int) -> Path:
    """mesh.h5 and a solid input of the probe's box (base fixed, a ramped load on the top, gravity)
    stepping `steps` steps of half the thin layers' critical step at `levels_` subcycling levels."""
    from .box_mesh import write_box_mesh, write_loaded_box_input

    folder.mkdir(parents=True, exist_ok=True)
    n = PROBE_N
    zs = np.concatenate([np.arange(PROBE_THIN + 1) / 8.0, PROBE_THIN / 8.0 + np.arange(1, PROBE_THICK + 1)])
    g = np.arange(n + 1, dtype=float)
    write_box_mesh(folder / "mesh.h5", g, g, zs)
    E, nu, rho = PROBE_ROCK
    dt = 0.5 * (1.0 / 8.0) / p_wave_speed(E, nu, rho)
    return write_loaded_box_input(folder / f"input_{levels_}.h5", E=E, nu=nu, rho=rho, dt=dt, steps=steps,
                                  top_force=-1e6 * n * n, monitor_dt=steps * dt, subcycling_levels=levels_)
