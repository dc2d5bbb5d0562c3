"""Hydraulic jacking: the rock's compressive stress around the tunnel against the internal water
pressure.

Water at the tunnel's pressure that reaches the rock (through a cracked or pervious lining, or at an
unlined wall) opens the joints that run radially from the tunnel where it exceeds the stress that
closes them: a pressurised cavity fractures radially (Hubbert & Willis 1957), against the normal
stress on planes that contain the radial direction. The check takes every rock element whose
centroid lies within `reach` of the excavated wall (in 3D the element layer of the monitors'
section) and forms

    ratio = σ_min / p_w,    p_w = ρ_w g (head − (z − z_axis))   at the element's elevation,

σ_min the smallest compressive normal stress on a radial plane: the smaller eigenvalue of the
stress in the plane of the hoop and axial directions (compression positive). The radial stress
itself is left out: at the wall it is the pressure that acts there. Jacking is excluded where
ratio ≥ 1; the smallest ratio and where it occurs govern.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .angles import crown_angle


@dataclass
class JackingResult:
    ratio: float  # the smallest σ_min / p_w
    sigma_min: float  # Pa (compression positive) where it occurs
    p_w: float  # Pa there
    angle: float  # deg from the crown towards +x
    distance: float  # m from the excavated wall
    time: float  # s (NaN for a state without time)
    elements: int  # rock elements checked


def radial_plane_min_compression(stress: np.ndarray, dx: np.ndarray, dz: np.ndarray) -> np.ndarray:
    """σ_min (compression positive) on the planes through the radial direction: the smaller
    eigenvalue of −σ restricted to the hoop and axial directions, of [E, 6] stresses (xx, yy, zz, xy,
    yz, zx; tension positive) at points (dx, dz) from the tunnel axis in the x-z plane."""
    s = np.asarray(stress, float)
    r = np.hypot(dx, dz)
    tx, tz = -dz / r, dx / r  # the hoop direction (0, y, 0 is the axis)
    s_tt = s[:, 0] * tx * tx + s[:, 2] * tz * tz + 2 * s[:, 5] * tx * tz
    s_yy = s[:, 1]
    s_ty = s[:, 3] * tx + s[:, 4] * tz  # σ_xy t_x + σ_yz t_z
    mean, half = (s_tt + s_yy) / 2, np.hypot((s_tt - s_yy) / 2, s_ty)
    return -(mean + half)  # minus the more tensile eigenvalue


def jacking(centroids: np.ndarray, stress: np.ndarray, centre: tuple[float, float], radius: float, reach: float,
            head: float, rho_w: float, g: float, time: float = float("nan")) -> JackingResult | None:
    """The smallest σ_min / p_w over the elements (centroids [E, 3] in x, y, z; stress [E, 6]) whose
    distance from the wall r − radius lies in [0, reach] and where p_w > 0; None when none does."""
    c = np.asarray(centroids, float)
    dx, dz = c[:, 0] - centre[0], c[:, 2] - centre[1]
    dist = np.hypot(dx, dz) - radius
    pw = rho_w * g * (head - dz)
    sel = (dist >= -1e-9 * radius) & (dist <= reach) & (pw > 0)
    if not np.any(sel):
        return None
    smin = radial_plane_min_compression(np.asarray(stress, float)[sel], dx[sel], dz[sel])
    ratio = smin / pw[sel]
    k = int(np.argmin(ratio))
    idx = np.flatnonzero(sel)[k]
    return JackingResult(float(ratio[k]), float(smin[k]), float(pw[idx]),
                         float(crown_angle(np.arctan2(dz[idx], dx[idx]))), float(dist[idx]), float(time),
                         int(sel.sum()))
