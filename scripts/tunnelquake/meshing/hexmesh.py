"""Hexahedron geometry on plain arrays: corner Jacobians, volumes, edges, boundary faces.

Node order is gmsh/VTK's hex8: 0-3 the bottom face (reference zeta = -1) counter-clockwise seen
from +zeta, 4-7 the top face, node i+4 above node i. Reference corners (xi, eta, zeta):
0 (-,-,-) 1 (+,-,-) 2 (+,+,-) 3 (-,+,-), 4-7 the same with zeta = +1.
"""

from __future__ import annotations

import numpy as np

#: Faces of a hex8 with nodes ordered counter-clockwise seen from outside (outward normal by the
#: right-hand rule when the element has positive volume).
HEX_FACES = np.array(
    [
        [0, 3, 2, 1],  # zeta = -1
        [4, 5, 6, 7],  # zeta = +1
        [0, 1, 5, 4],  # eta = -1
        [1, 2, 6, 5],  # xi = +1
        [2, 3, 7, 6],  # eta = +1
        [3, 0, 4, 7],  # xi = -1
    ],
    dtype=np.int64,
)

#: The 12 edges.
HEX_EDGES = np.array(
    [[0, 1], [1, 2], [3, 2], [0, 3], [4, 5], [5, 6], [7, 6], [4, 7], [0, 4], [1, 5], [2, 6], [3, 7]],
    dtype=np.int64,
)

# At corner c the trilinear map's derivatives are half the edges leaving c in the +xi, +eta and
# +zeta directions: (from, to) node pairs of those three edges per corner.
_CORNER_EDGES = np.array(
    [
        [[0, 1], [0, 3], [0, 4]],
        [[0, 1], [1, 2], [1, 5]],
        [[3, 2], [1, 2], [2, 6]],
        [[3, 2], [0, 3], [3, 7]],
        [[4, 5], [4, 7], [0, 4]],
        [[4, 5], [5, 6], [1, 5]],
        [[7, 6], [5, 6], [2, 6]],
        [[7, 6], [4, 7], [3, 7]],
    ],
    dtype=np.int64,
)

#: Reorder that turns a negative-volume hex into a positive one: swap bottom and top faces.
FLIP = np.array([4, 5, 6, 7, 0, 1, 2, 3], dtype=np.int64)


def corner_jacobians(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """det J of the trilinear map at the 8 corners, and the scaled Jacobian there.

    x: [E, 8, 3] node coordinates. Returns (detj [E, 8] in m^3 per unit reference volume,
    i.e. det of the three half-edges, and scaled [E, 8] = det(e1, e2, e3) / (|e1||e2||e3|) in
    [-1, 1], 1 for a right-angled corner).
    """
    e = x[:, _CORNER_EDGES[:, :, 1], :] - x[:, _CORNER_EDGES[:, :, 0], :]  # [E, 8, 3, 3]
    det = np.einsum("eci,eci->ec", np.cross(e[:, :, 0], e[:, :, 1]), e[:, :, 2])
    norms = np.linalg.norm(e, axis=3).prod(axis=2)
    return det / 8.0, det / norms


def volumes(x: np.ndarray) -> np.ndarray:
    """Exact volume of each trilinear hex: 2 x 2 x 2 Gauss quadrature of det J.

    det J is a polynomial of degree <= 2 in each reference coordinate, so the 2-point rule per
    direction integrates it exactly.
    """
    g = 1.0 / np.sqrt(3.0)
    sign = np.array(
        [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
        dtype=float,
    )
    vol = np.zeros(x.shape[0])
    for q in sign * g:
        # dN_a/dxi_k at q for N_a = prod_k (1 + s_ak q_k) / 8
        dn = np.empty((8, 3))
        for k in range(3):
            others = [j for j in range(3) if j != k]
            dn[:, k] = sign[:, k] * np.prod(1.0 + sign[:, others] * q[others], axis=1) / 8.0
        jac = np.einsum("eai,ak->eik", x, dn)
        vol += np.linalg.det(jac)
    return vol


def max_edge_length(x: np.ndarray) -> float:
    """Longest element edge (m): the element size the wavelength rule is checked against."""
    d = x[:, HEX_EDGES[:, 1], :] - x[:, HEX_EDGES[:, 0], :]
    return float(np.sqrt((d**2).sum(axis=2)).max()) if len(x) else 0.0


def orient_positive(conn: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """Return conn with every negative-volume hex flipped (bottom and top faces swapped)."""
    detj, _ = corner_jacobians(coords[conn])
    neg = detj.sum(axis=1) < 0
    out = conn.copy()
    out[neg] = conn[neg][:, FLIP]
    return out


def boundary_faces(conn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces used by exactly one element: ([F, 4] outward-ordered nodes, [F] owning element)."""
    faces = conn[:, HEX_FACES].reshape(-1, 4)
    key = np.sort(faces, axis=1)
    n = int(conn.max()) + 1 if conn.size else 1
    if n <= 2_000_000:
        # Two distinct faces of a conforming hex mesh never share 3 nodes, so the 3 smallest
        # node ids identify a face; packed into one int64 they make a fast 1-D unique.
        key = (key[:, 0] * n + key[:, 1]) * n + key[:, 2]
        _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    else:
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = counts[inverse.ravel()] == 1
    return faces[once], np.nonzero(once)[0] // 6


def face_normals(coords: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit normals of quads by the right-hand rule on their node order (diagonal cross product)."""
    p = coords[faces]
    n = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    return n / np.linalg.norm(n, axis=1, keepdims=True)
