"""The static in-situ stress under a portal (geology.portal) against CalculiX on the same section.

A block uniform across the tunnel (x) but for a bore 1 m wide: 12 m wide, its x faces on rollers, so
away from the bore tq-solid's 3D model is plane strain in the section along the axis (y, z). The
portal's face at y = 35 m: in front of it the ground cut down to the bench (z = -3 m), behind it the
headwall up to the face's head (z = 9.75 m) and the slope rising at 35 deg to the block's top
(z = 30 m). tq-solid's in_situ stage starts from the overburden of the flat top (sigma_v = -rho g
(30 - z), sigma_yy = ky sigma_v) and relaxes it with gravity to equilibrium, so the cut is made in a
stressed ground. CalculiX (Debian's calculix-ccx, an independent solver) solves the same section in
plane strain with quadratic elements (CPE8R, half tq-solid's axial element): the start's traction on
the bench, the headwall and the slope released (consistent nodal forces), the base fixed and the y
faces on rollers, as tq-solid's static supports, elastic; the start added back. The section's surface
is the mesh's: piecewise linear through the heights of tq-solid's top nodes at its axial grid lines.

Compared at monitors 10 m and more from the bore and from the re-entrant corner where the bench meets
the face: under the face, under the bench in front of it, under the slope, behind the crest and deep
under the portal: sigma_yy, sigma_zz and tau_yz within 1 % of the vertical stress there.
"""
from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
from case_texts import synthetic_motion, tunnel
from static_section import ccx_section_stress, monitors_against_section
from test_solid_input import _solid_with_stages

from conftest import checked_input, run_solid
from tunnelquake.case import case_geology, ground_layers
from tunnelquake.meshing.params import resolve, surface_nodes

G = 9.81
RHO, E, NU = 2400.0, 6e9, 0.3
KX, KY = 0.6, 0.5
Y0, Y1, Z0, Z_TOP = 0.0, 100.0, -45.0, 30.0
STATION, ANGLE = 35.0, 35.0
Z_BENCH = -3.0  # the near-field box's bottom: centre 0, half width 3 m

STATIC = tunnel("portal_static", [-6.0, 6.0], [Y0, Y1], [Z0, Z_TOP], centre_x=0.0, centre_z=0.0, radius="0.5 m",
                lining="0.1 m", max_element_size="3 m", lining_elements_around=8, lining_elements_through=1,
                water_ring_divisions=1, near_field_half_width=3.0, near_field_radial_divisions=2,
                elements_along_axis=42) + f"""materials:
  rock: {{model: elastic, youngs_modulus: {E / 1e9:g} GPa, poisson_ratio: {NU:g}, density: {RHO:g}}}
  lining: {{model: elastic, youngs_modulus: {E / 1e9:g} GPa, poisson_ratio: {NU:g}, density: {RHO:g}}}
geology:
  portal: {{station: {STATION:g}, slope_deg: {ANGLE:g}}}
interface: {{model: bonded}}
""" + synthetic_motion("1.0 m/s^2", 0.5, 1.0) + f"""in_situ: {{kx: {KX:g}, ky: {KY:g}, kz: 1.0}}
stages:
  sequence: [in_situ, seismic]
  relaxation_tolerance: 1.0e-8
  relaxation_max_steps: 400000
conditions: [no_water]
time: {{end_time: 0.0005}}
output:
  monitors:
    under_face: [-4.5, 40.0, -12.0]
    under_bench: [-4.5, 22.0, -12.0]
    under_slope: [-4.5, 52.0, 13.0]
    behind_crest: [-4.5, 88.0, 16.0]
    deep_under_portal: [-4.5, 35.0, -35.0]
"""


def _sigma0(z):
    """The in_situ stage's start, the overburden of the flat top: (sigma_yy, sigma_zz), Pa."""
    sv = -RHO * G * (Z_TOP - np.asarray(z, float))
    return KY * sv, sv


def _profile(plan):
    """(axial grid lines y, the surface's height there) behind the face: the heights of the mesh's top nodes."""
    ys = np.asarray(plan.y_levels, float)
    ys = ys[ys >= STATION - 1e-9]
    top = np.stack([np.zeros_like(ys), ys, np.full_like(ys, Z_TOP)], axis=1)
    return ys, surface_nodes(plan, top)[:, 2]


def _ccx_section(work, plan, per_element=2, h_low=1.5):
    """CalculiX's plane-strain solution of the section (CPE8R; CalculiX's x, y are the model's y, z):
    the bench's and the lower block's columns every tq-solid axial element split in `per_element`,
    rows about h_low; the block behind the face above the bench the same columns. Returns the
    elements' centroids [E, 2] (y, z) and their mean stress (sigma_yy, sigma_zz, tau_yz) [E, 3], the
    start's added."""
    ys_all = np.asarray(plan.y_levels, float)
    ys = np.concatenate([np.linspace(a, b, per_element + 1)[:-1] for a, b in zip(ys_all[:-1], ys_all[1:],
                                                                                   strict=True)] + [ys_all[-1:]])
    yp, zp = _profile(plan)
    n_lo = max(1, round((Z_BENCH - Z0) / h_low))
    n_up = max(1, round((zp.max() - Z_BENCH) / h_low))
    yq = np.linspace(ys[:-1], ys[1:], 3).T[:, :2].ravel()  # the quadratic lattice along y
    yq = np.append(yq, ys[-1])
    i_face = int(np.argmin(np.abs(yq - STATION)))
    nid, xyz = {}, []

    def node(i, j):
        if (i, j) not in nid:
            y = yq[i]
            if j <= 2 * n_lo:
                z = Z0 + (Z_BENCH - Z0) * j / (2 * n_lo)
            else:
                top = float(np.interp(y, yp, zp))
                z = Z_BENCH + (top - Z_BENCH) * (j - 2 * n_lo) / (2 * n_up)
            nid[(i, j)] = len(xyz) + 1
            xyz.append((y, z))
        return nid[(i, j)]

    elems, cents = [], []
    for a in range(0, len(yq) - 1, 2):
        rows = n_lo + (n_up if a >= i_face else 0)
        for b in range(0, 2 * rows, 2):
            e = [node(a, b), node(a + 2, b), node(a + 2, b + 2), node(a, b + 2), node(a + 1, b), node(a + 2, b + 1),
                 node(a + 1, b + 2), node(a, b + 1)]
            elems.append(e)
            c = np.array([xyz[k - 1] for k in e[:4]]).mean(axis=0)
            cents.append(c)
    xyz, cents = np.array(xyz), np.array(cents)
    # the free boundary: the bench (j = 2 n_lo, in front), the face (i = i_face, above the bench), the
    # slope (the top row behind the face); each quadratic edge's released traction -sigma0 . n
    edges = [[nid[(a + k, 2 * n_lo)] for k in range(3)] for a in range(0, i_face, 2)]
    edges += [[nid[(i_face, j + k)] for k in range(3)] for j in range(2 * n_lo, 2 * (n_lo + n_up), 2)]
    jt = 2 * (n_lo + n_up)
    edges += [[nid[(a + k, jt)] for k in range(3)] for a in range(i_face, len(yq) - 1, 2)]
    force = np.zeros((len(xyz) + 1, 2))
    gp, gw = np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)]), np.array([5.0, 8.0, 5.0]) / 9.0
    for ids in edges:
        p = xyz[np.array(ids) - 1]
        for s, w in zip(gp, gw, strict=True):
            n_ = np.array([0.5 * s * (s - 1), 1 - s * s, 0.5 * s * (s + 1)])
            dn = np.array([s - 0.5, -2 * s, s + 0.5])
            ty, tz = dn @ p[:, 0], dn @ p[:, 1]
            normal = np.array([-tz, ty])  # outward: the boundary runs bench (+y), face (up), slope (+y)
            syy, szz = _sigma0(n_ @ p[:, 1])
            traction = -np.array([syy * normal[0], szz * normal[1]])
            for k in range(3):
                force[ids[k]] += w * n_[k] * traction
    lines = ["*HEADING", "portal section, plane strain", "*NODE"]
    lines += [f"{k + 1}, {y:.12e}, {z:.12e}" for k, (y, z) in enumerate(xyz)]
    lines.append("*ELEMENT, TYPE=CPE8R, ELSET=EROCK")
    lines += [f"{k + 1}, " + ", ".join(map(str, e)) for k, e in enumerate(elems)]
    lines += ["*MATERIAL, NAME=ROCK", "*ELASTIC", f"{E!r}, {NU!r}", "*SOLID SECTION, ELSET=EROCK, MATERIAL=ROCK", "1."]
    base = [k + 1 for k, (_, z) in enumerate(xyz) if abs(z - Z0) < 1e-9]
    sides = [k + 1 for k, (y, _) in enumerate(xyz) if abs(y - Y0) < 1e-9 or abs(y - Y1) < 1e-9]
    lines += ["*BOUNDARY"] + [f"{n}, 1, 2" for n in base] + [f"{n}, 1, 1" for n in sides]
    lines += ["*STEP", "*STATIC", "*CLOAD"]
    lines += [f"{n}, {d + 1}, {force[n, d]:.12e}" for n in np.flatnonzero(np.abs(force).sum(axis=1)) for d in (0, 1)]
    lines += ["*EL PRINT, ELSET=EROCK", "S", "*END STEP"]
    return cents, ccx_section_stress(work, "portal", lines, len(elems), _sigma0(cents[:, 1]))


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed")
def test_static_stress_under_the_portal_matches_calculix(tmp_path, capsys):
    from scipy.interpolate import LinearNDInterpolator

    exe = _solid_with_stages()
    case, inp = checked_input(tmp_path, STATIC, capsys)
    d = case.data
    plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    ys, zs = _profile(plan)
    assert zs[0] == pytest.approx(9.75) and zs[-1] == pytest.approx(Z_TOP)  # the head, the top
    res = tmp_path / "results.h5"
    run_solid(exe, inp, res, timeout=600)
    cents, ccx = _ccx_section(tmp_path, plan)
    at = LinearNDInterpolator(cents, ccx)
    worst = monitors_against_section(res, ("under_face", "under_bench", "under_slope", "behind_crest",
                                           "deep_under_portal"), at, 1, (1, 2, 4), ("syy", "szz", "tyz"), _sigma0)
    assert worst < 0.01
