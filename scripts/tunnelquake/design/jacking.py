"""Hydraulic jacking: the rock's smallest compressive principal stress around the tunnel against the
internal water pressure.

Water that leaks through the lining (or an unlined wall) reaches the joints of the rock at the
tunnel's internal pressure; a joint opens where that pressure exceeds the stress that closes it,
at most the smallest compressive principal stress σ_min. The check takes every rock element whose
centroid lies within `reach` of the excavated wall (in 3D the element layer of the monitors'
section) and forms

    ratio = σ_min / p_w,    p_w = ρ_w g (head − (z − z_axis))   at the element's elevation,

σ_min = −σ3 with σ3 the most tensile principal stress (tension positive, as tq-solid writes them).
Jacking is excluded where ratio ≥ 1; the smallest ratio and where it occurs govern.
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


def principal_min_compression(stress: np.ndarray) -> np.ndarray:
    """σ_min (compression positive) of [E, 6] stresses (xx, yy, zz, xy, yz, zx; tension positive):
    minus the most tensile principal stress."""
    s = np.asarray(stress, float)
    m = np.empty((s.shape[0], 3, 3))
    m[:, 0, 0], m[:, 1, 1], m[:, 2, 2] = s[:, 0], s[:, 1], s[:, 2]
    m[:, 0, 1] = m[:, 1, 0] = s[:, 3]
    m[:, 1, 2] = m[:, 2, 1] = s[:, 4]
    m[:, 0, 2] = m[:, 2, 0] = s[:, 5]
    return -np.linalg.eigvalsh(m)[:, -1]


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
    smin = principal_min_compression(np.asarray(stress, float)[sel])
    ratio = smin / pw[sel]
    k = int(np.argmin(ratio))
    idx = np.flatnonzero(sel)[k]
    return JackingResult(float(ratio[k]), float(smin[k]), float(pw[idx]),
                         float(crown_angle(np.arctan2(dz[idx], dx[idx]))), float(dist[idx]), float(time),
                         int(sel.sum()))
