"""Rock regions bounded by planes of any strike and dip: a fault zone (a band) and dipping layers.

Axes: x across the tunnel, y along its axis, z up (right-handed). Directions in plan are azimuths
in degrees measured from +y (the tunnel axis) clockwise seen from above, i.e. towards +x: with y
as north and x as east they are compass bearings (0 = +y, 90 = +x, 180 = -y, 270 = -x).

A plane of dip delta (degrees below horizontal, 0 < delta <= 90) and dip direction beta (the
azimuth of its steepest descent) has the unit normal

    n = (sin delta sin beta, sin delta cos beta, cos delta)

which points up (and, for a vertical plane, towards beta). A fault given by its strike sigma
takes the right-hand rule: it dips towards beta = sigma + 90. The strike is the angle, in plan,
between the tunnel axis and the fault's trace on a horizontal plane, so a fault of strike 60 (or
240) crosses the tunnel at 60 degrees.

* fault zone: the band |n . (x - p)| <= w / 2 (w the true thickness, p a point on its centre
  plane); it crosses the tunnel axis over the length w / |n_y| along y.
* dipping layer: the ground above its bottom plane, n . (x - p) > 0, not already in a layer
  listed before it (from the surface down, the first match wins).

Each ground element takes the region its centroid lies in: the fault zone first, then the
horizontal layers (grid lines of the mesh), then the dipping layers, then rock.

* sloping ground surface: flat at the block's top z_top behind a horizontal crest line through
  (x_c, y_c), descending at angle alpha towards azimuth beta past it, down to z_top - H (the toe;
  no toe when H is not given): with d = (x - x_c) sin beta + (y - y_c) cos beta the horizontal
  distance past the crest, z_s = z_top - min(max(d, 0) tan alpha, H). The mesh follows it by
  moving every node above a base level z_b (the top of the near-field box or the bottom of the
  top horizontal layer, whichever is higher) along its vertical, z' = z_b + (z - z_b) r(x, y),
  r = (z_s - z_b) / (z_top - z_b): the nodes at z_top land on the surface, those at or below z_b
  stay, so the ground under z_b (the tunnel, the horizontal layers) is untouched.

* portal: the tunnel leaves the hillside through a face across its axis at station y_p, facing -y
  (towards the block's ymin face). In front of the face (y < y_p) the ground is cut down to the bench
  z_f, the bottom of the tunnel's near-field box: every element whose centroid lies in front of y_p
  above z_f is removed, the tunnel's lining and bore with it, so the lining ends at the face. Behind
  it the face rises vertically from the bench to the portal's head z_h = crown + cover (the headwall,
  through which the tunnel's bore opens), and from the head the slope rises at its angle to the
  block's top: a Slope of that angle descending towards azimuth 180 + skew whose toe line, at z_h,
  passes through (x_c, y_p) (portal_slope), applied by the node map above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Plane:
    normal: tuple[float, float, float]
    point: tuple[float, float, float]

    def distance(self, x: np.ndarray) -> np.ndarray:
        """Signed distance of points x [..., 3] from the plane (positive on the normal's side)."""
        n = np.asarray(self.normal)
        return (np.asarray(x, float) - np.asarray(self.point)) @ n


def plane_normal(dip: float, dip_direction: float) -> tuple[float, float, float]:
    """Unit normal (x, y, z) of a plane of dip `dip` towards azimuth `dip_direction` (degrees;
    azimuth from +y clockwise seen from above, towards +x)."""
    d, b = math.radians(dip), math.radians(dip_direction)
    n = (math.sin(d) * math.sin(b), math.sin(d) * math.cos(b), math.cos(d))
    return tuple(0.0 if abs(c) < 1e-15 else c for c in n)


@dataclass(frozen=True)
class FaultZone:
    material: str
    plane: Plane  # the centre plane
    width: float  # true thickness, m
    elements_across: int  # elements along the axis across the band where it meets the near-field box

    def contains(self, x: np.ndarray) -> np.ndarray:
        return np.abs(self.plane.distance(x)) <= 0.5 * self.width

    @property
    def axial_length(self) -> float:
        """The band's length along y (any line parallel to the tunnel axis): w / |n_y|."""
        ny = abs(self.plane.normal[1])
        return math.inf if ny < 1e-12 else self.width / ny


def slip_vector(strike: float, dip: float, magnitude: float, rake: float) -> np.ndarray:
    """The hanging wall's displacement relative to the footwall (x, y, z; m) for a slip of
    `magnitude` at `rake` (degrees in the fault plane from the strike direction, Aki & Richards:
    90 reverse, the hanging wall up dip; -90 normal; 0 left-lateral; 180 right-lateral):
    magnitude (cos(rake) s + sin(rake) u), s the unit strike vector (horizontal, azimuth `strike`)
    and u the unit up-dip vector in the plane."""
    sg, d, b = math.radians(strike), math.radians(dip), math.radians(strike + 90.0)
    s = np.array([math.sin(sg), math.cos(sg), 0.0])
    up = np.array([-math.cos(d) * math.sin(b), -math.cos(d) * math.cos(b), math.sin(d)])
    r = math.radians(rake)
    v = magnitude * (math.cos(r) * s + math.sin(r) * up)
    v[np.abs(v) < 1e-15 * max(magnitude, 1e-300)] = 0.0
    return v


def hanging_wall_share(fault: FaultZone, x: np.ndarray) -> np.ndarray:
    """The share of the slip each point [..., 3] takes: 1 on the hanging wall (above the band,
    on its upward normal's side, n . (x - p) >= w/2), 0 on the footwall (n . (x - p) <= -w/2),
    linear in n . (x - p) across the band (the band sheared uniformly)."""
    s = fault.plane.distance(x) / fault.width + 0.5
    return np.clip(s, 0.0, 1.0)


@dataclass(frozen=True)
class DippingLayer:
    material: str
    bottom: Plane


@dataclass(frozen=True)
class Slope:
    angle: float  # degrees below horizontal, in (0, 90)
    dip_direction: float  # azimuth of the descent
    crest: tuple[float, float]  # (x, y) of a point of the crest line, m
    height: float | None = None  # the drop from the crest to the toe, m; None: no toe inside the block

    def drop(self, x, y) -> np.ndarray:
        """How far the surface lies below the block's top at plan points (x, y), m."""
        b = math.radians(self.dip_direction)
        d = (np.asarray(x, float) - self.crest[0]) * math.sin(b) + (np.asarray(y, float) - self.crest[1]) * math.cos(b)
        out = np.maximum(d, 0.0) * math.tan(math.radians(self.angle))
        return out if self.height is None else np.minimum(out, self.height)


def surface_ratio(slope: Slope, x, y, z_top: float, z_base: float) -> np.ndarray:
    """r(x, y) = (z_s - z_b) / (z_top - z_b): the factor the ground above z_b is squeezed by."""
    return 1.0 - slope.drop(x, y) / (z_top - z_base)


def map_to_surface(slope: Slope, xyz: np.ndarray, z_top: float, z_base: float) -> np.ndarray:
    """Points [..., 3] of the flat-topped block moved onto the sloping ground: z' = z_b + (z - z_b) r(x, y)
    above z_b, unchanged at and below it."""
    out = np.array(xyz, float, copy=True)
    above = out[..., 2] > z_base
    r = surface_ratio(slope, out[..., 0], out[..., 1], z_top, z_base)
    out[..., 2] = np.where(above, z_base + (out[..., 2] - z_base) * r, out[..., 2])
    return out


@dataclass(frozen=True)
class Portal:
    station: float  # y of the face where the tunnel leaves it, m
    angle: float  # the slope above the face, degrees below horizontal, in (0, 90)
    skew: float = 0.0  # degrees: the slope's strike against the normal to the axis (its descent azimuth 180 + skew)
    cover: float | None = None  # m of ground over the crown at the face; None: the least the mesh allows

    @property
    def dip_direction(self) -> float:
        return (180.0 + self.skew) % 360.0


def portal_slope(portal: Portal, head: float, xc: float, z_top: float) -> Slope:
    """The slope over a portal whose head (the top of the face over the tunnel) is at z = head: it
    falls at portal.angle towards azimuth 180 + skew from the block's top z_top to its toe at `head`,
    the toe line through (xc, station)."""
    h = z_top - head
    run = h / math.tan(math.radians(portal.angle))
    b = math.radians(portal.dip_direction)
    crest = (xc - run * math.sin(b), portal.station - run * math.cos(b))
    return Slope(portal.angle, portal.dip_direction, crest, h)


@dataclass(frozen=True)
class Geology:
    fault: FaultZone | None = None
    dipping: tuple[DippingLayer, ...] = ()
    slope: Slope | None = None
    portal: Portal | None = None

    @property
    def materials(self) -> list[str]:
        """Region names in mesh.h5 order after rock, lining and the horizontal layers."""
        return [layer.material for layer in self.dipping] + ([self.fault.material] if self.fault else [])


def corners(lo, hi) -> np.ndarray:
    """The 8 corners of the box [lo, hi] (3-vectors)."""
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], float)


def assign(geology: Geology, centroids: np.ndarray, base: np.ndarray, first: int) -> np.ndarray:
    """Ground region of each centroid [..., 3]. `base` holds the regions the horizontal layers
    give (0 rock, 2 + i layer i); the dipping layers take index first + j where the base is rock,
    the fault zone first + len(dipping) everywhere it reaches."""
    out = np.array(base, dtype=np.int32, copy=True)
    free = out == 0
    for j, layer in enumerate(geology.dipping):
        hit = free & (layer.bottom.distance(centroids) > 0)
        out[hit] = first + j
        free &= ~hit
    if geology.fault is not None:
        out[geology.fault.contains(centroids)] = first + len(geology.dipping)
    return out


def band_y_range(fault: FaultZone, xs, zs) -> tuple[float, float] | None:
    """The y-interval the band occupies over the rectangle xs x zs of the cross-section (the
    near-field box around the tunnel); None when the band runs parallel to the axis."""
    n, p = fault.plane.normal, fault.plane.point
    if abs(n[1]) < 1e-12:
        return None
    yc = [p[1] - (n[0] * (x - p[0]) + n[2] * (z - p[2])) / n[1] for x in xs for z in zs]
    half = 0.5 * fault.axial_length
    return min(yc) - half, max(yc) + half


def from_case(section: dict | None) -> Geology | None:
    """The Geology of a validated case's `geology:` section (SI values), None when it has none."""
    if not section:
        return None
    fz = section.get("fault_zone") or {}
    fault = None
    if fz.get("material") is not None:
        n = plane_normal(fz["dip"], (fz["strike"] + 90.0) % 360.0)
        fault = FaultZone(fz["material"], Plane(n, tuple(map(float, fz["point"]))), float(fz["width"]),
                          int(fz["elements_across"]))
    dipping = tuple(DippingLayer(e["material"], Plane(plane_normal(e["dip"], e["dip_direction"]),
                                                      tuple(map(float, e["point"]))))
                    for e in section.get("dipping_layers") or [])
    sl = section.get("slope") or {}
    slope = None
    if sl.get("angle") is not None:
        h = sl.get("height")
        slope = Slope(float(sl["angle"]), float(sl["dip_direction"]), tuple(map(float, sl["crest"])),
                      None if h is None else float(h))
    po = section.get("portal") or {}
    portal = None
    if po.get("station") is not None and po.get("slope_deg") is not None:
        portal = Portal(float(po["station"]), float(po["slope_deg"]), float(po.get("skew_deg") or 0.0),
                        None if po.get("cover") is None else float(po["cover"]))
    if fault is None and not dipping and slope is None and portal is None:
        return None
    return Geology(fault, dipping, slope, portal)
