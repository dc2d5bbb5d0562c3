"""The lining as a beam along the tunnel axis (y): its axial strain and curvatures, its section
resultants (axial force, biaxial bending, shear, torsion) and the rock-lining interface's slip, station by
station along the axis, from a field snapshot (displacements [N, 3], element stresses [E, 6]).

Conventions (docs/solid_solver.md "Fault offset"; x across the tunnel, y along it, z up; the
section's centre (x_c, z_c) is the tunnel axis):

* kinematics, from the lining's nodal displacements: at each station (a plane of lining nodes at
  one y) the least-squares plane u_y = a + b (x - x_c) + c (z - z_c) over the station's nodes;
  a is the section's axial displacement, -b and -c its rotations (plane sections). Between two
  stations: axial strain eps = da/dy, curvatures kappa_h = -db/dy (bending in the horizontal
  plane, u_x'' for a beam) and kappa_v = -dc/dy (in the vertical plane, u_z''), at the mid-point y. The
  same numbers come from any code's nodal displacements on the same mesh, which is how the
  benchmark compares tq-solid with CalculiX (benchmarks/fault_offset.py).
* resultants, from the elements' stresses (the one-point element's, or any element's mean):
  per axial element layer of the lining, with each element's cross-section A_e = V_e / L_e (its
  volume over its axial length): N = sum sigma_yy A_e (tension positive), the moments in the
  horizontal and vertical planes M_h = -sum sigma_yy (x - x_c) A_e and M_v = -sum sigma_yy
  (z - z_c) A_e (N m; for a beam M = EI kappa with the curvatures above), the shears V_h = sum
  sigma_xy A_e and V_v = sum sigma_yz A_e (N), and the torsion T = sum ((z - z_c) sigma_xy -
  (x - x_c) sigma_yz) A_e (N m): the moment about +y of the traction on the section's +y face
  (right-handed; T = G J theta' for a twist theta about +y growing along y). It is -sum r
  sigma_y_theta A_e with theta measured from +x towards +z, the ring's angle (docs/formats.md).
* interface slip, per rock-lining node pair (rock node, lining node): the lining's displacement
  less the rock's; per station its axial component (y) and its component round the ring, the
  largest magnitude of each over the station's pairs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Stress components in results.h5 snapshots (docs/formats.md): xx, yy, zz, xy, yz, zx.
SXX, SYY, SZZ, SXY, SYZ, SZX = range(6)


@dataclass
class AxisProfile:
    """Kinematics along the axis: station y [S] and per interval [S - 1] the mid-point y, the axial
    strain and the two curvatures (1/m); the sections' axial displacement and rotations at the stations."""

    station_y: np.ndarray
    axial_u: np.ndarray
    rotation_h: np.ndarray  # -b: the section's rotation that goes with u_x'
    rotation_v: np.ndarray  # -c: with u_z'
    y: np.ndarray
    strain: np.ndarray
    kappa_h: np.ndarray
    kappa_v: np.ndarray


@dataclass
class AxisResultants:
    """Per axial element layer of the lining: its mid y and its resultants (N, N m): axial force,
    moments and shears in the horizontal and the vertical plane, torsion."""

    y: np.ndarray
    N: np.ndarray
    M_h: np.ndarray
    M_v: np.ndarray
    V_h: np.ndarray
    V_v: np.ndarray
    T: np.ndarray


@dataclass
class InterfaceSlip:
    """Per station of interface pairs: y, the largest |axial slip| and |slip round the ring| (m)."""

    y: np.ndarray
    axial: np.ndarray
    around: np.ndarray


def _stations(y: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Distinct y values (to tol) and each point's station index."""
    order = np.argsort(y)
    ys = y[order]
    new = np.concatenate([[True], np.diff(ys) > tol])
    idx_sorted = np.cumsum(new) - 1
    idx = np.empty_like(idx_sorted)
    idx[order] = idx_sorted
    centres = np.array([ys[idx_sorted == k].mean() for k in range(int(idx_sorted[-1]) + 1)])
    return centres, idx


def lining_nodes(connectivity: np.ndarray, region: np.ndarray, lining: int) -> np.ndarray:
    return np.unique(connectivity[region == lining].ravel())


def axis_profile(coords: np.ndarray, nodes: np.ndarray, u: np.ndarray, centre: tuple[float, float]) -> AxisProfile:
    """Plane-section kinematics of the lining nodes `nodes` (see the module docstring)."""
    x = coords[nodes]
    span = float(np.ptp(coords[:, 1])) or 1.0
    sy, idx = _stations(x[:, 1], 1e-7 * span)
    a, b, c = (np.empty(len(sy)) for _ in range(3))
    for k in range(len(sy)):
        m = idx == k
        A = np.column_stack([np.ones(m.sum()), x[m, 0] - centre[0], x[m, 2] - centre[1]])
        a[k], b[k], c[k] = np.linalg.lstsq(A, u[nodes[m], 1], rcond=None)[0]
    dy = np.diff(sy)
    return AxisProfile(station_y=sy, axial_u=a, rotation_h=-b, rotation_v=-c, y=0.5 * (sy[1:] + sy[:-1]),
                       strain=np.diff(a) / dy, kappa_h=-np.diff(b) / dy, kappa_v=-np.diff(c) / dy)


def _hex_volume(x: np.ndarray) -> np.ndarray:
    """Volumes of hexahedra [E, 8, 3] (VTK order) as the sum of six tetrahedra about the 0-6 diagonal."""
    tets = ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6))
    v = np.zeros(len(x))
    for p, q, r, s in tets:
        v += np.einsum("ei,ei->e", x[:, q] - x[:, p], np.cross(x[:, r] - x[:, p], x[:, s] - x[:, p])) / 6.0
    return np.abs(v)


def axis_resultants(coords: np.ndarray, connectivity: np.ndarray, elements: np.ndarray, stress: np.ndarray,
                    centre: tuple[float, float]) -> AxisResultants:
    """Section resultants of the lining elements `elements` per axial element layer (see the
    module docstring). stress [E, 6] of every element of the mesh."""
    x = coords[connectivity[elements]]
    cen = x.mean(axis=1)
    length = x[:, :, 1].max(axis=1) - x[:, :, 1].min(axis=1)
    area = _hex_volume(x) / length
    span = float(np.ptp(coords[:, 1])) or 1.0
    ly, idx = _stations(cen[:, 1], 1e-7 * span)
    s = stress[elements]
    dx, dz = cen[:, 0] - centre[0], cen[:, 2] - centre[1]
    out = {k: np.zeros(len(ly)) for k in ("N", "M_h", "M_v", "V_h", "V_v", "T")}
    for key, val in (("N", s[:, SYY] * area), ("M_h", -s[:, SYY] * dx * area), ("M_v", -s[:, SYY] * dz * area),
                     ("V_h", s[:, SXY] * area), ("V_v", s[:, SYZ] * area),
                     ("T", (dz * s[:, SXY] - dx * s[:, SYZ]) * area)):
        np.add.at(out[key], idx, val)
    return AxisResultants(y=ly, **out)


def interface_slip(coords: np.ndarray, pairs: np.ndarray, u: np.ndarray, centre: tuple[float, float]) -> InterfaceSlip:
    """The lining's displacement less the rock's at each (rock, lining) pair, by station."""
    rock, lin = pairs[:, 0], pairs[:, 1]
    d = u[lin] - u[rock]
    x = coords[rock]
    theta = np.arctan2(x[:, 2] - centre[1], x[:, 0] - centre[0])
    around = -np.sin(theta) * d[:, 0] + np.cos(theta) * d[:, 2]
    span = float(np.ptp(coords[:, 1])) or 1.0
    sy, idx = _stations(x[:, 1], 1e-7 * span)
    ax, ar = np.zeros(len(sy)), np.zeros(len(sy))
    np.maximum.at(ax, idx, np.abs(d[:, 1]))
    np.maximum.at(ar, idx, np.abs(around))
    return InterfaceSlip(y=sy, axial=ax, around=ar)
