"""The lining's section forces and diameter changes that tq-solid writes to results.h5.

Layout, conventions and method: docs/formats.md ("Lining section forces") and docs/theory.md
("Lining section forces"). Per ring (an axial element layer of the lining): thrust N, moment M
and shear V per unit length of tunnel at every section (the mid-plane of each element column)
and every monitor sample, the change of each inner diameter, and per section the envelope
(max, time of max, min, time of min) of each. Beside these design forces (stress resultants), the
discrete ring's free-body section forces, which balance the lining's nodal loads to round-off
(docs/theory.md §7 "Equilibrium"), where the file has them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

#: The quantities of a ring: histories [T, S] (N, M, V) or [T, D] (diameter_change).
QUANTITIES = ("N", "M", "V", "diameter_change")
UNITS = {"N": "N/m", "M": "N m/m", "V": "N/m", "diameter_change": "m"}


@dataclass
class Envelope:
    """Per section (or diameter): the largest and smallest value over the run and their times (s)."""

    max: np.ndarray
    time_of_max: np.ndarray
    min: np.ndarray
    time_of_min: np.ndarray


@dataclass
class FreeBody:
    """The discrete ring's section forces [T, S] (same units and signs as the design forces): from
    the elements' nodal forces, in equilibrium with the lining's nodal loads to round-off."""

    N: np.ndarray
    M: np.ndarray
    V: np.ndarray


@dataclass
class Ring:
    """One ring's histories and envelopes; angles in rad from +x towards +z about the centre."""

    index: int
    y_min: float
    y_max: float
    centre: tuple[float, float]  # x, z (m)
    r_inner: float
    r_outer: float
    r_mid: float
    closed: bool
    angle: np.ndarray  # [S] section angles
    time: np.ndarray  # [T] s
    N: np.ndarray  # [T, S] N/m, tension positive
    M: np.ndarray  # [T, S] N m/m, positive with tension at the inner face
    V: np.ndarray  # [T, S] N/m
    diameter_angle: np.ndarray  # [D] direction of each diameter, [0, pi)
    diameter_change: np.ndarray  # [T, D] m, elongation positive, relative to the seismic start
    envelopes: dict[str, Envelope] = field(default_factory=dict)
    ovaling: dict[str, float] = field(default_factory=dict)  # the largest elongation and shortening
    free_body: FreeBody | None = None  # None in files without /ring_forces/<k>/free_body


def read_ring_forces(results: str | Path) -> list[Ring]:
    """The rings of a results.h5 (empty when tq-solid wrote none: see `ring_forces_note`).

    A file cut off during the run is read up to the last complete row of every history."""
    rings = []
    with h5py.File(results, "r") as f:
        if "ring_forces" not in f:
            return []
        g = f["ring_forces"]
        for key in sorted((k for k in g if k.isdigit()), key=int):
            r = g[key]
            a = r.attrs
            time = r["time"][:, 0] if "time" in r else np.zeros(0)
            hist = {q: r[q][...].astype(np.float64) if q in r else np.zeros((0, 0)) for q in QUANTITIES}
            fb = {q: r[f"free_body/{q}"][...] for q in ("N", "M", "V")} if "free_body/N" in r else None
            rows = min([len(time)] + [len(h) for q, h in hist.items() if q in r] + [len(h) for h in (fb or {}).values()])
            time = time[:rows]
            hist = {q: h[:rows] for q, h in hist.items()}
            env = {}
            for q in QUANTITIES:
                p = f"envelope/{q}"
                if p in r:
                    e = r[p][...]
                    env[q] = Envelope(e[:, 0], e[:, 1], e[:, 2], e[:, 3])
            ovaling = {k[len("ovaling_"):]: float(v) for k, v in a.items() if k.startswith("ovaling_")}
            rings.append(Ring(
                index=int(key), y_min=float(a["y_min"]), y_max=float(a["y_max"]),
                centre=(float(a["centre_x"]), float(a["centre_z"])), r_inner=float(a["r_inner"]),
                r_outer=float(a["r_outer"]), r_mid=float(a["r_mid"]), closed=bool(a["closed"]),
                angle=r["angle"][...], time=time, N=hist["N"], M=hist["M"], V=hist["V"],
                diameter_angle=r["diameter_angle"][...] if "diameter_angle" in r else np.zeros(0),
                diameter_change=hist["diameter_change"], envelopes=env, ovaling=ovaling,
                free_body=FreeBody(**{q: h[:rows] for q, h in fb.items()}) if fb is not None else None))
    return rings


def ring_forces_note(results: str | Path) -> str:
    """Why a results file has no (or incomplete) ring forces: tq-solid's note, or '' if none."""
    with h5py.File(results, "r") as f:
        if "ring_forces" not in f:
            return "no /ring_forces (output.ring_forces off, no lining region, or an older tq-solid)"
        return str(f["ring_forces"].attrs.get("note", ""))
