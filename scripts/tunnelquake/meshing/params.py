"""Mesh parameters: defaults, documentation, validation and the derived division counts.

The case file's ``mesh:`` section accepts exactly the keys of :data:`MESH_DEFAULTS`; each key's
meaning and unit is in :data:`MESH_DOC`. :func:`resolve` checks a geometry and a mesh dict and
turns them into a :class:`MeshPlan`, the numbers the gmsh builder needs (division counts per
block, progression ratios, the axial extent), so the builder itself makes no decisions.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .geology import Geology, band_y_range, corners, map_to_surface, portal_slope, surface_ratio

#: Every mesh parameter with its default. The defaults reproduce the paper's mesh (Liu, Zhang &
#: Xiao 2021, §3.1): 58,080 rock and 6,336 lining hexahedra exactly, 14,784 water hexahedra
#: (paper 14,256: a conforming water mesh with 48 cells around cannot reach 324 cells a layer).
MESH_DEFAULTS: dict = {
    "mode": "3d",
    "max_element_size": 6.75,
    "lining_elements_around": 48,
    "lining_elements_through": 3,
    "elements_along_axis": 44,
    "slice_thickness": None,
    "water_core_half_width_ratio": 0.5,
    "water_ring_divisions": 4,
    "water_ring_growth": 1.0,
    "near_field_half_width": 14.0,
    "near_field_radial_divisions": 11,
    "near_field_growth": 1.1,
    "outer_growth": 1.0,
    "refinement_factor": 1,
    "axial_growth": 1.2,
    "tunnel_end_plugs": 0,
    "symmetry": "none",
}

#: One line per key of MESH_DEFAULTS: meaning and unit.
MESH_DOC: dict = {
    "mode": "'3d': the full model extruded along y; 'slice': the same cross-section one element "
    "thick in y (plane strain, one-cell-thick 2D water)",
    "max_element_size": "m; upper bound on every element edge (rock, lining, water); the build "
    "fails if any edge is longer. Paper: 6.75 m = cs/(8 f) with cs = 1080 m/s, f = 20 Hz",
    "lining_elements_around": "elements around the circumference (lining, rock ring and water); "
    "a multiple of 4 (one O-grid block per quarter)",
    "lining_elements_through": "elements through the lining thickness",
    "elements_along_axis": "elements along the tunnel axis y (3d mode), uniform",
    "slice_thickness": "m; y-thickness of the slice (slice mode); null = the 3d axial element "
    "length (y extent / elements_along_axis). The slice is centred on the middle of y_range",
    "water_core_half_width_ratio": "half-side of the square water core / lining inner radius "
    "(dimensionless, 0.2-0.65); the core is meshed (around/4) x (around/4)",
    "water_ring_divisions": "radial cells between the water core square and the lining",
    "water_ring_growth": "ratio of consecutive radial cell sizes in the water ring, from the core "
    "to the wall (1 = uniform, < 1 refines towards the wall)",
    "near_field_half_width": "m; half-side of the square box around the tunnel centre that "
    "bounds the rock O-grid ring; outside it the rock is a 3 x 3 block grid",
    "near_field_radial_divisions": "radial elements in the rock ring between the lining and the near-field box",
    "near_field_growth": "ratio of consecutive radial element sizes in the rock ring, away from "
    "the tunnel (1 = uniform)",
    "outer_growth": "ratio of consecutive element sizes in the outer rock blocks, away from the "
    "near-field box (1 = uniform); their division counts are the smallest that keep every edge "
    "<= max_element_size",
    "refinement_factor": "integer >= 1 multiplying every division count (convergence studies); "
    "growth ratios are adjusted so the grading stays the same",
    "axial_growth": "ratio of consecutive axial element lengths away from a fault zone's refined "
    "stretch (geology.fault_zone), up to the length elements_along_axis gives (1 = a sudden jump)",
    "tunnel_end_plugs": "3d mode: axial element layers at each end of the block where the tunnel is filled "
    "with rock (no lining, no water), so the tunnel ends inside the block; 0: it runs through both y faces. "
    "A domain-reduction layer (incident_wave) needs the tunnel inside it",
    "symmetry": "3d mode: 'mid_length' meshes only the half of the block y <= the middle of y_range, its ymax "
    "face the plane of symmetry (rollers, u_y = 0; the water's end there a symmetry plane), for a scene symmetric "
    "about that plane: half the elements and cells, the same answer; 'none': the whole block",
}

GEOMETRY_KEYS = (
    "x_range",
    "y_range",
    "z_range",
    "tunnel_centre_x",
    "tunnel_centre_z",
    "excavated_radius",
    "lining_thickness",
)

#: The paper's geometry (§3.1), for tests and examples.
PAPER_GEOMETRY: dict = {
    "x_range": [-60.0, 60.0],
    "y_range": [0.0, 80.0],
    "z_range": [-28.0, 154.7],
    "tunnel_centre_x": 0.0,
    "tunnel_centre_z": 32.0,
    "excavated_radius": 5.25,
    "lining_thickness": 0.75,
}


class MeshInputError(ValueError):
    """A geometry or mesh parameter is invalid; the message names the key, value and fix.

    `key` (dotted, e.g. 'mesh.lining_elements_around'), `value`, `problem` and `fix` hold the
    parts of the message, so that `tunnelquake check` can say it against the case file's line."""

    def __init__(self, message: str, key: str | None = None, value=None, problem: str | None = None,
                 fix: str | None = None):
        super().__init__(message)
        self.key, self.value, self.problem, self.fix = key, value, problem, fix


@dataclass(frozen=True)
class Divisions:
    """Element count and progression ratio along one family of block edges."""

    count: int
    growth: float = 1.0  # ratio of consecutive sizes along the edge's stored direction


@dataclass(frozen=True)
class MeshPlan:
    """Everything the builder needs, derived and checked."""

    # geometry (m)
    xmin: float
    xmax: float
    ymin: float
    ymax: float
    zmin: float
    zmax: float
    xc: float
    zc: float
    radius_inner: float  # lining inner radius a = excavated radius - lining thickness
    radius_outer: float  # excavated radius b
    core_half_width: float  # half-side of the water core square
    box_half_width: float  # half-side of the near-field box
    slice: bool
    max_element_size: float
    # divisions
    quarter: Divisions  # per quarter of the circumference (= per side of every square)
    lining: Divisions
    water_ring: Divisions
    near_field: Divisions
    # Outer bands beside the near-field box: segments (length in m, divisions), ordered from the
    # box outwards, growth counted outwards. One uniform segment when outer_growth = 1; else a
    # graded transition segment and, if the band is long enough, a uniform one at the size cap.
    left: tuple[tuple[float, Divisions], ...]
    right: tuple[tuple[float, Divisions], ...]
    bottom: tuple[tuple[float, Divisions], ...]
    top: tuple[tuple[float, Divisions], ...]
    axial: Divisions
    # Ground layers above the near-field box, from the surface down: (region name, z of the
    # layer's bottom in m). The top band has a grid line at every bottom; below the last one the
    # ground is the region 'rock'.
    layers: tuple[tuple[str, float], ...] = ()
    # Regions bounded by planes (geology.py): dipping layers and a fault zone, assigned by centroid.
    geology: Geology | None = None
    # The axial grid: y of every extrusion layer boundary, ymin .. ymax (len = axial.count + 1).
    # Uniform unless a fault zone refines the stretch where it crosses the near-field box.
    y_levels: tuple[float, ...] = ()
    # Axial element layers at each end where the tunnel is filled with rock (3d mode; 0: none).
    plugs: int = 0
    # The half y <= the middle of y_range only (mesh.symmetry: mid_length): ymax is the plane of
    # symmetry, with no plug there.
    symmetric: bool = False


def _fail(where: str, key: str, value, why: str, fix: str):
    raise MeshInputError(f"{where} '{key}' = {value!r}: {why}. {fix}", f"{where}.{key}", value, why, fix)


def _number(where, d, key, positive=True):
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        _fail(where, key, v, "must be a finite number", "Give a value in SI units (m).")
    if positive and v <= 0:
        _fail(where, key, v, "must be > 0", "Give a positive value.")
    return float(v)


def _integer(where, d, key, minimum=1):
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, int) or v < minimum:
        _fail(where, key, v, f"must be an integer >= {minimum}", "Give a whole number.")
    return v


def _range(where, d, key):
    v = d[key]
    ok = isinstance(v, (list, tuple)) and len(v) == 2
    ok = ok and all(isinstance(t, (int, float)) and not isinstance(t, bool) for t in v)
    if not ok or not all(math.isfinite(t) for t in v) or not v[0] < v[1]:
        _fail(where, key, v, "must be [min, max] with min < max", "Give two numbers in m.")
    return float(v[0]), float(v[1])


def _check_keys(where: str, given: dict, allowed) -> None:
    unknown = sorted(set(given) - set(allowed))
    if unknown:
        raise MeshInputError(f"{where}: unknown key(s) {unknown}. Allowed keys: {sorted(allowed)}.")


def graded_count(length: float, max_size: float, growth: float, key: str = "outer_growth") -> int:
    """Smallest n whose geometric division of ``length`` (ratio ``growth``) has all sizes <= max.

    Sizes h_i = h_1 g^i, i = 0..n-1, sum = length, so with g > 1 the largest is
    length (g - 1) / (g - g^(1-n)) (length / n for g = 1; g < 1 is the same set reversed). As n
    grows it tends to length (g - 1) / g: a larger growth can never meet max_size.
    """
    g = max(growth, 1.0 / growth)
    if abs(g - 1.0) < 1e-12:
        return max(1, math.ceil(length / max_size - 1e-9))
    limit = length * (g - 1.0) / g
    if limit >= max_size:
        g_max = 1.0 / (1.0 - max_size / length)
        why = (f"a geometric grading over {length:.4g} m keeps its largest element above {limit:.4g} m > "
               f"max_element_size {max_size} m whatever the count")
        fix = f"Use a ratio below {g_max:.4f} (or 1 for uniform)."
        raise MeshInputError(f"mesh '{key}' = {growth!r}: {why}. {fix}", f"mesh.{key}", growth, why, fix)
    n = 1
    while length * (g - 1.0) / (g - g ** (1 - n)) > max_size * (1.0 + 1e-9):
        n += 1
    return n


def outer_band(length: float, h0: float, max_size: float, growth: float):
    """Segments [(length, Divisions)] of an outer band, from the near-field box outwards.

    growth = 1: one uniform segment of ceil(length / max_size) elements. growth > 1: a graded
    transition of m elements h0 g, h0 g^2, ..., h0 g^m (length h0 g (g^m - 1)/(g - 1)), then a
    uniform segment of size u <= max_size. m is the largest count with h0 g^m <= u, so sizes never
    decrease outwards. When the band is shorter than the transition, one geometric segment.
    """
    if abs(growth - 1.0) < 1e-12 or h0 * growth > max_size:
        return [(length, Divisions(graded_count(length, max_size, 1.0)))]
    if growth < 1.0:
        why = "must be >= 1 (elements grow away from the tunnel)"
        raise MeshInputError(f"mesh 'outer_growth' = {growth!r}: {why}", "mesh.outer_growth", growth, why,
                             "Use a ratio of 1 (uniform) or more.")
    m = int(math.floor(math.log(max_size / h0) / math.log(growth) + 1e-9))
    while m > 0:
        t = h0 * growth * (growth**m - 1.0) / (growth - 1.0)
        if t >= length:
            return [(length, Divisions(graded_count(length, max_size, growth), growth))]
        rest = length - t
        n_u = graded_count(rest, max_size, 1.0)
        if rest / n_u >= h0 * growth**m * (1.0 - 1e-9):
            return [(t, Divisions(m, growth)), (rest, Divisions(n_u))]
        m -= 1
    return [(length, Divisions(graded_count(length, max_size, 1.0)))]


def graded_sizes(length: float, div: Divisions) -> list[float]:
    """Element sizes of an edge of ``length`` divided as ``div``, in the stored direction."""
    g, n = div.growth, div.count
    if abs(g - 1.0) < 1e-12:
        return [length / n] * n
    h1 = length * (g - 1.0) / (g**n - 1.0)
    return [h1 * g**i for i in range(n)]


def merged_mesh_params(mesh: dict | None) -> dict:
    """MESH_DEFAULTS updated by ``mesh``, rejecting unknown keys."""
    mesh = dict(mesh or {})
    _check_keys("mesh", mesh, MESH_DEFAULTS)
    out = dict(MESH_DEFAULTS)
    out.update(mesh)
    return out


def resolve(geometry: dict, mesh: dict | None, layers=None, geology: Geology | None = None) -> MeshPlan:
    """Validate ``geometry`` and ``mesh`` (MESH_DEFAULTS keys) and derive the block divisions.

    ``layers``: the ground's horizontal layers from the surface down, [(region name, z of its
    bottom in m)], the ground below the last being 'rock'. Each bottom becomes a grid line of the
    outer rock's top band; the near-field box must lie below them all (in 'rock'), and a layer
    must be at least one near-field element (2 near_field_half_width / (around / 4)) thick.

    ``geology``: regions bounded by planes (geology.Geology): checked against the block here, and
    a fault zone refines the axial divisions where it crosses the near-field box (axial_levels)."""
    _check_keys("geometry", geometry, GEOMETRY_KEYS)
    missing = [k for k in GEOMETRY_KEYS if k not in geometry]
    if missing:
        raise MeshInputError(f"geometry: missing key(s) {missing}.")
    m = merged_mesh_params(mesh)
    g = "geometry"
    xmin, xmax = _range(g, geometry, "x_range")
    ymin, ymax = _range(g, geometry, "y_range")
    zmin, zmax = _range(g, geometry, "z_range")
    xc = _number(g, geometry, "tunnel_centre_x", positive=False)
    zc = _number(g, geometry, "tunnel_centre_z", positive=False)
    b = _number(g, geometry, "excavated_radius")
    t = _number(g, geometry, "lining_thickness")
    if t >= b:
        _fail(g, "lining_thickness", t, f"must be smaller than the excavated radius {b} m", "Check the units (m).")
    a = b - t

    w = "mesh"
    if m["mode"] not in ("3d", "slice"):
        _fail(w, "mode", m["mode"], "must be '3d' or 'slice'", "Pick one of the two.")
    hmax = _number(w, m, "max_element_size")
    k = _integer(w, m, "refinement_factor")
    around = _integer(w, m, "lining_elements_around", 4)
    if around % 4:
        _fail(
            w,
            "lining_elements_around",
            around,
            "must be a multiple of 4 (one O-grid block per quarter)",
            f"Use {4 * round(around / 4) or 4}.",
        )
    through = _integer(w, m, "lining_elements_through")
    along = _integer(w, m, "elements_along_axis")
    n_water = _integer(w, m, "water_ring_divisions")
    n_near = _integer(w, m, "near_field_radial_divisions")
    ratio = _number(w, m, "water_core_half_width_ratio")
    if not 0.2 <= ratio <= 0.65:
        _fail(
            w,
            "water_core_half_width_ratio",
            ratio,
            "must lie in [0.2, 0.65] (the core square must stay well inside the lining)",
            "0.5 is a good value.",
        )
    growths = {}
    for key in ("water_ring_growth", "near_field_growth", "outer_growth", "axial_growth"):
        v = _number(w, m, key)
        if not 0.5 <= v <= 2.0:
            _fail(w, key, v, "must lie in [0.5, 2]", "Use 1 for uniform sizes.")
        growths[key] = v ** (1.0 / k)  # same grading with k times more elements
    L = _number(w, m, "near_field_half_width")
    if L <= b * 1.2:
        _fail(
            w,
            "near_field_half_width",
            L,
            f"must exceed 1.2 x the excavated radius ({1.2 * b:.3f} m) to leave room for the rock ring",
            "Increase it.",
        )
    for name, inside in (
        ("x_range[0]", xmin < xc - L),
        ("x_range[1]", xc + L < xmax),
        ("z_range[0]", zmin < zc - L),
        ("z_range[1]", zc + L < zmax),
    ):
        if not inside:
            _fail(
                w,
                "near_field_half_width",
                L,
                f"the near-field box around the tunnel (centre x={xc}, z={zc}) reaches beyond geometry {name}",
                "Reduce near_field_half_width or enlarge the block.",
            )

    slice_mode = m["mode"] == "slice"
    symmetric = _symmetry(m, slice_mode, along * k)
    if symmetric:  # the half below the middle plane: the tunnel's y faces at ymin and at that plane
        ymax = 0.5 * (ymin + ymax)
    if slice_mode:
        if m["slice_thickness"] is None:
            thick = (ymax - ymin) / (along * k)
        else:
            thick = _number(w, m, "slice_thickness")
        ymid = 0.5 * (ymin + ymax)
        ymin, ymax = ymid - 0.5 * thick, ymid + 0.5 * thick
        axial = Divisions(1)
    else:
        axial = Divisions(along * k // (2 if symmetric else 1))

    h_box = 2.0 * L / (around // 4)  # box side spacing: the size the outer bands start from

    def outer(length):
        segs = outer_band(length, h_box, hmax, float(m["outer_growth"]))
        return tuple((d, Divisions(div.count * k, div.growth ** (1.0 / k))) for d, div in segs)

    layers = tuple((str(n), float(z)) for n, z in (layers or ()))
    top = _layered_band(layers, zc + L, zmax, h_box, hmax, float(m["outer_growth"]), k) if layers else outer(zmax - zc - L)

    if geology is not None and geology.portal is not None:
        geology = _portal_geology(geology, m, (xmin, ymin, zmin), (xmax, ymax, zmax), xc, zc, b, L, layers,
                                  slice_mode, axial.count)
    if geology is not None:
        z_base = max([zc + L] + [z for _, z in layers])
        _check_geology(geology, (xmin, ymin, zmin), (xmax, ymax, zmax), slice_mode, z_base)
        if geology.slope is not None:  # the x bands' edges lean with the surface: keep them <= hmax
            top_x = math.tan(math.radians(geology.slope.angle)) * abs(math.sin(math.radians(geology.slope.dip_direction)))
            hx = hmax / math.sqrt(1.0 + top_x**2)

            def outer_x(length):
                segs = outer_band(length, h_box, hx, float(m["outer_growth"]))
                return tuple((d, Divisions(div.count * k, div.growth ** (1.0 / k))) for d, div in segs)
        else:
            outer_x = outer
        if geology.portal is not None:
            y_levels = portal_levels(geology.portal.station, ymin, ymax, axial.count)
        else:
            y_levels = axial_levels(geology, ymin, ymax, axial.count, (xc - L, xc + L), (zc - L, zc + L),
                                    growths["axial_growth"], k)
    else:
        y_levels = tuple(np.linspace(ymin, ymax, axial.count + 1))
    axial = Divisions(len(y_levels) - 1)

    plan = MeshPlan(
        xmin=xmin,
        xmax=xmax,
        ymin=ymin,
        ymax=ymax,
        zmin=zmin,
        zmax=zmax,
        xc=xc,
        zc=zc,
        radius_inner=a,
        radius_outer=b,
        core_half_width=ratio * a,
        box_half_width=L,
        slice=slice_mode,
        max_element_size=hmax,
        quarter=Divisions(around // 4 * k),
        lining=Divisions(through * k),
        water_ring=Divisions(n_water * k, growths["water_ring_growth"]),
        near_field=Divisions(n_near * k, growths["near_field_growth"]),
        left=(outer_x if geology is not None else outer)(xc - L - xmin),
        right=(outer_x if geology is not None else outer)(xmax - xc - L),
        bottom=outer(zc - L - zmin),
        top=top,
        axial=axial,
        layers=layers,
        geology=geology,
        y_levels=y_levels,
        plugs=_plugs(m, slice_mode, axial.count, k, symmetric),
        symmetric=symmetric,
    )
    _check_sizes(plan)
    if geology is not None and geology.slope is not None:
        _check_slope_edges(plan)
    return plan


def portal_levels(station: float, ymin: float, ymax: float, count: int) -> tuple[float, ...]:
    """The axial grid with a portal: a grid line at the face's station, the stretches in front of it
    and behind it each uniform, their elements no longer than the uniform (ymax - ymin) / count."""
    h0 = (ymax - ymin) / count
    n1 = max(1, math.ceil((station - ymin) / h0 - 1e-9))
    n2 = max(1, math.ceil((ymax - station) / h0 - 1e-9))
    levels = list(np.linspace(ymin, station, n1 + 1)) + list(np.linspace(station, ymax, n2 + 1))[1:]
    return tuple(float(v) for v in levels)


def portal_bench(p: MeshPlan) -> float:
    """z of the bench in front of a portal's face: the bottom of the tunnel's near-field box."""
    return p.zc - p.box_half_width


def portal_cut(p: MeshPlan, centroids: np.ndarray) -> np.ndarray:
    """Which elements (by their centroids [..., 3]) a portal removes: in front of its face (y below the
    station) and above the bench; all False without a portal."""
    po = p.geology.portal if p.geology is not None else None
    c = np.asarray(centroids, float)
    if po is None:
        return np.zeros(c.shape[:-1], bool)
    return (c[..., 1] < po.station) & (c[..., 2] > portal_bench(p))


def lining_extent(p: MeshPlan) -> tuple[float, float]:
    """(y where the lining starts, y where it ends): the plugs' ends, a portal's face, else the block's y faces."""
    ends = plug_levels(p)
    if ends is not None:
        return ends
    po = p.geology.portal if p.geology is not None else None
    return (po.station if po is not None else p.ymin), p.ymax


def portal_least_cover(zc: float, b: float, L: float, layers, z_top: float) -> tuple[float, float]:
    """(the least cover over the crown at a portal's face, the base z_b it is measured from): the
    slope's node map must keep SLOPE_MIN_SHARE of the ground above z_b (_check_slope)."""
    zb = max([zc + L] + [z for _, z in layers])
    return zb + SLOPE_MIN_SHARE * (z_top - zb) - (zc + b), zb


def _portal_geology(geo: Geology, m: dict, lo, hi, xc, zc, b, L, layers, slice_mode: bool, count: int) -> Geology:
    """Check a portal (geology.portal) against the block and the mesh, and return the geology with the
    slope above its face (geology.portal_slope) as its ground surface."""
    po = geo.portal
    key = "geology.portal"
    if slice_mode:
        why = "a slice holds one section across the tunnel, and a portal ends the tunnel along its axis"
        raise MeshInputError(f"{key}.station: {why}", f"{key}.station", po.station, why,
                             "Use mesh.mode: 3d with a portal.")
    if geo.slope is not None:
        why = "a portal makes its own ground surface (the slope above its face), so a second slope cannot be laid on it"
        raise MeshInputError(f"geology.slope: {why}", "geology.slope.angle", geo.slope.angle, why,
                             "Remove geology.slope; geology.portal.slope_deg and skew_deg set the slope over the portal.")
    if geo.fault is not None:
        why = "a fault zone and a portal in one block are not meshed together"
        raise MeshInputError(f"{key}: {why}", "geology.fault_zone.material", geo.fault.material, why,
                             "Model the fault crossing and the portal as two cases.")
    if int(m.get("tunnel_end_plugs") or 0):
        why = "the tunnel ends at the portal's face, not in a plug of rock"
        raise MeshInputError(f"mesh.tunnel_end_plugs: {why}", "mesh.tunnel_end_plugs", m["tunnel_end_plugs"], why,
                             "Use tunnel_end_plugs: 0 with a portal.")
    ymin, ymax = lo[1], hi[1]
    h0 = (ymax - ymin) / count
    if not ymin + h0 - 1e-9 <= po.station <= ymax - h0 + 1e-9:
        why = (f"lies outside the tunnel, which runs along y {ymin:g}..{ymax:g} m here: the face must cross it with at "
               f"least one axial element ({h0:.4g} m) of cut in front and of tunnel behind")
        raise MeshInputError(f"{key}.station: {why}", f"{key}.station", po.station, why,
                             f"Give a station between {ymin + h0:.4g} and {ymax - h0:.4g} m (the face faces -y, "
                             "towards the block's ymin face), or lengthen geometry.y_range.")
    z_top = hi[2]
    least, zb = portal_least_cover(zc, b, L, layers, z_top)
    crown = zc + b
    cover = least if po.cover is None else po.cover
    if cover < least * (1 - 1e-9) - 1e-9:
        why = (f"is less than the block allows: the slope above the face squeezes the ground above z = {zb:g} m (the top "
               f"of the near-field box, or the bottom of the top horizontal layer), which must keep {SLOPE_MIN_SHARE:g} "
               f"of its {z_top - zb:g} m, so the face's head lies at z >= {crown + least:.4g} m")
        raise MeshInputError(f"{key}.cover: {why}", f"{key}.cover", po.cover, why,
                             f"Give cover >= {least:.4g} m (or leave it out), or lower mesh.near_field_half_width.")
    head = crown + cover
    if head >= z_top - 1e-9:
        why = f"puts the face's head at z = {head:.4g} m, at or above the block's top {z_top:g} m: no slope is left"
        raise MeshInputError(f"{key}.cover: {why}", f"{key}.cover", po.cover, why,
                             f"Give cover < {z_top - crown:.4g} m, or raise geometry.z_range[1].")
    slope = portal_slope(po, head, xc, z_top)
    levels = portal_levels(po.station, ymin, ymax, count)
    hy = float(np.diff(levels).max())
    hmax = float(m["max_element_size"])
    t = math.tan(math.radians(po.angle))
    ca = abs(math.cos(math.radians(po.dip_direction)))
    rise = z_top - head
    # the axial edges lean with the slope: hy sqrt(1 + (tan a cos skew)^2) <= max_element_size; and the face
    # must span two axial elements at least, else the mesh's surface cannot show its angle
    steep_lean = math.degrees(math.atan(math.sqrt(max(hmax * hmax / (hy * hy) - 1.0, 0.0)) / max(ca, 1e-12)))
    steep_face = math.degrees(math.atan(rise / (2.0 * hy * max(ca, 1e-12))))
    if po.angle > min(steep_lean, steep_face) + 1e-9:
        lean = hy * math.sqrt(1 + (t * ca) ** 2)
        if steep_face <= steep_lean:
            why = (f"is steeper than the block allows: the slope rises {rise:.4g} m from the face's head (z = {head:.4g} m) "
                   f"to the block's top over {rise / (t * max(ca, 1e-12)):.4g} m along the axis, less than two of its "
                   f"{hy:.4g} m axial elements, so the mesh cannot follow the face")
        else:
            why = (f"is steeper than the block allows: the axial elements ({hy:.4g} m) lean with the slope to "
                   f"{lean:.4g} m > max_element_size {hmax:g} m")
        need = math.ceil((ymax - ymin) / min(hmax / math.sqrt(1 + (t * ca) ** 2), rise / (2 * t * max(ca, 1e-12))))
        raise MeshInputError(f"{key}.slope_deg: {why}", f"{key}.slope_deg", po.angle, why,
                             f"Use slope_deg <= {math.floor(10 * min(steep_lean, steep_face)) / 10:.1f} deg with this "
                             f"mesh, or mesh.elements_along_axis >= {need}.")
    return dataclasses.replace(geo, slope=slope)


def slope_base(p: MeshPlan) -> float:
    """z_b: the level above which a sloping surface moves the mesh's nodes (geology.map_to_surface):
    the near-field box's top or the top horizontal layer's bottom, whichever is higher."""
    return max([p.zc + p.box_half_width] + [z for _, z in p.layers])


def surface_nodes(p: MeshPlan, xyz: np.ndarray) -> np.ndarray:
    """Points [..., 3] of the flat-topped block on the plan's ground: moved onto the sloping surface
    when the geology has one, else unchanged."""
    slope = p.geology.slope if p.geology is not None else None
    if slope is None:
        return np.asarray(xyz, float)
    return map_to_surface(slope, xyz, p.zmax, slope_base(p))


def _check_slope_edges(p: MeshPlan) -> None:
    """A sloping surface leans the horizontal edges of the elements above z_b: an edge of plan
    length h becomes up to h sqrt(1 + (tan(angle) c)^2) long, c the direction cosine of the descent
    along it. The x bands are divided for it (resolve); the near-field box's sides and the axial
    elements are checked here."""
    s = p.geology.slope
    t = math.tan(math.radians(s.angle))
    b = math.radians(s.dip_direction)
    h_box = 2.0 * p.box_half_width / p.quarter.count
    hy = float(np.diff(p.y_levels).max()) if not p.slice else 0.0
    lx, ly = h_box * math.sqrt(1 + (t * math.sin(b)) ** 2), hy * math.sqrt(1 + (t * math.cos(b)) ** 2)
    if ly > p.max_element_size * (1 + 1e-9):
        need = math.ceil((p.ymax - p.ymin) * math.sqrt(1 + (t * math.cos(b)) ** 2) / p.max_element_size)
        why = (f"axial elements {hy:.4g} m long lean with the slope (angle {s.angle:g} deg) to {ly:.4g} m > "
               f"max_element_size {p.max_element_size:g} m")
        raise MeshInputError(f"mesh.elements_along_axis: {why}", "mesh.elements_along_axis", p.axial.count, why,
                             f"Use elements_along_axis >= {need}, or a larger max_element_size.")
    if lx > p.max_element_size * (1 + 1e-9):
        why = (f"the near-field box's {h_box:.4g} m divisions lean with the slope (angle {s.angle:g} deg) to "
               f"{lx:.4g} m > max_element_size {p.max_element_size:g} m")
        raise MeshInputError(f"mesh.lining_elements_around: {why}", "mesh.lining_elements_around",
                             4 * p.quarter.count, why, "Use more elements around, or a larger max_element_size.")


def _symmetry(m: dict, slice_mode: bool, along: int) -> bool:
    """Whether the mesh is the half y <= the middle of y_range (mesh.symmetry: mid_length): a 3D block
    whose axial layers (elements_along_axis times the refinement factor) are even, so that the
    middle plane is one of the whole block's grid planes."""
    sym = m.get("symmetry") or "none"
    if sym not in ("none", "mid_length"):
        _fail("mesh", "symmetry", sym, "must be 'none' or 'mid_length'", "Pick one of the two.")
    if sym == "none":
        return False
    if slice_mode:
        _fail("mesh", "symmetry", sym, "a slice is one element thick: it has no half along the axis",
              "Use symmetry: none with mode: slice.")
    if along % 2:
        _fail("mesh", "symmetry", sym, f"halves the {along} axial element layers (elements_along_axis times the "
              "refinement factor), an odd number: the middle plane would cut a layer", "Give an even elements_along_axis.")
    return True


def _plugs(m: dict, slice_mode: bool, axial: int, k: int, symmetric: bool = False) -> int:
    """The axial element layers filled with rock at each end (mesh.tunnel_end_plugs, times the
    refinement factor; at the ymin end only in a half block, mesh.symmetry); the tunnel must keep
    at least one layer between them."""
    n = _integer("mesh", m, "tunnel_end_plugs", 0)
    if n and slice_mode:
        _fail("mesh", "tunnel_end_plugs", n, "a slice is one element thick: it has no tunnel ends to fill",
              "Use tunnel_end_plugs: 0 with mode: slice.")
    ends = 1 if symmetric else 2
    if n and ends * n * k >= axial:
        _fail("mesh", "tunnel_end_plugs", n, f"fills {ends * n * k} of the {axial} axial element layers"
              + (" of the half block (mesh.symmetry)" if symmetric else "") + ": the tunnel needs at least one "
              "between the " + ("plug and the plane of symmetry" if symmetric else "two plugs"),
              "Lower it or raise elements_along_axis.")
    return n * k


def plug_levels(plan: MeshPlan) -> tuple[float, float] | None:
    """(y where the tunnel starts, y where it ends) with plugged ends, None without plugs; in a half
    block (mesh.symmetry) the tunnel ends at the plane of symmetry."""
    if not plan.plugs:
        return None
    return float(plan.y_levels[plan.plugs]), float(plan.y_levels[-1 - (0 if plan.symmetric else plan.plugs)])


def _layered_band(layers, z_box, zmax, h_box, hmax, growth, k):
    """The top band's segments (from the box up) with a grid line at every layer bottom: each
    stretch between two bottoms is an outer band of its own, starting from the size the stretch
    below it ended with (so the grading carries on across the interfaces)."""
    def _fail_layer(i, z, why, fix):
        key = f"layers[{i}].bottom"
        raise MeshInputError(f"{key} = {z!r}: {why}. {fix}", key, z, why, fix)

    z_prev = zmax
    for i, (name, z) in enumerate(layers):
        if not z < z_prev:
            what = "the ground surface (geometry.z_range[1])" if i == 0 else f"the bottom of layer {i - 1}"
            _fail_layer(i, z, f"must lie below {what} at z = {z_prev:g} m (layers go from the surface down)",
                  "Order the layers from the surface down, each bottom lower than the one above.")
        if z < z_box - 1e-9:
            _fail_layer(i, z, f"reaches below the top of the near-field box around the tunnel at z = {z_box:g} m "
                  "(the tunnel, its lining and the rock ring lie in materials.rock, below every layer)",
                  "Raise the layer's bottom to that height or above, or reduce mesh.near_field_half_width.")
        if z_prev - z < h_box * (1 - 1e-9):
            _fail_layer(i, z, f"makes layer {i} ({name}) {z_prev - z:.4g} m thick, thinner than one element of "
                  f"the near-field box ({h_box:.4g} m)",
                  "Merge it with its neighbour, or make it thicker.")
        z_prev = z
    if 1e-9 < z_prev - z_box < h_box * (1 - 1e-9):
        i = len(layers) - 1
        _fail_layer(i, z_prev, f"leaves {z_prev - z_box:.4g} m of materials.rock above the near-field "
              f"box (top at z = {z_box:g} m), thinner than one of its elements ({h_box:.4g} m)",
              "Put the bottom at the box's top or at least one element above it.")
    cuts = [z_box] + [z for _, z in reversed(layers) if z > z_box + 1e-9] + [zmax]
    segs, h0 = [], h_box
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        band = outer_band(hi - lo, h0, hmax, growth)
        segs += band
        h0 = graded_sizes(*band[-1])[-1]
    return tuple((d, Divisions(div.count * k, div.growth ** (1.0 / k))) for d, div in segs)


def layer_of(plan: MeshPlan, z: np.ndarray) -> np.ndarray:
    """Ground region index of heights z: 0 for 'rock', 2 + i for layer i (1 is the lining)."""
    out = np.zeros(np.shape(z), dtype=np.int32)
    for i, (_, bottom) in enumerate(reversed(plan.layers)):
        out[np.asarray(z) > bottom] = 2 + len(plan.layers) - 1 - i
    return out


def _check_sizes(p: MeshPlan) -> None:
    """Fail early, naming the key to change, when a structured edge family is too coarse."""
    h = p.max_element_size
    checks = [
        (
            "near_field_half_width / lining_elements_around",
            2 * p.box_half_width / p.quarter.count,
            "the near-field box side spacing",
        ),
        (
            "near_field_radial_divisions / near_field_growth",
            max(graded_sizes(math.sqrt(2) * p.box_half_width - p.radius_outer, p.near_field)),
            "the largest radial element of the rock ring (on its diagonal)",
        ),
        (
            "elements_along_axis" if not p.slice else "slice_thickness",
            (p.ymax - p.ymin) / p.axial.count,
            "the axial element length",
        ),
    ]
    # The mesher puts a face on a named boundary when its nodes lie within 1e-6 of the block's
    # largest extent of it (build._tolerance): an element thinner than that cannot be told from the
    # boundary it touches (the pressure tunnel with 90 radial divisions, 1.22e-4 m against 1.4e-4 m:
    # "16 solid boundary faces ... on several"; with 86, 1.79e-4 m, it meshes).
    finest = 1e-6 * max(p.xmax - p.xmin, p.zmax - p.zmin)
    h1 = min(graded_sizes(p.box_half_width - p.radius_outer, p.near_field))
    if h1 < finest:
        why = (f"the first radial element of the rock ring is {h1:.3g} m, thinner than {finest:.3g} m (1e-6 of the "
               "block), below which the mesher cannot tell its faces from the tunnel's surface")
        raise MeshInputError(f"mesh: {why}.", "mesh.near_field_radial_divisions", p.near_field.count, why,
                             "Lower near_field_radial_divisions or near_field_growth.")
    for keys, size, what in checks:
        if size > h * (1 + 1e-9):
            why = f"{what} is {size:.4g} m > max_element_size {h} m"
            raise MeshInputError(f"mesh: {why}. Change {keys}.", "mesh.max_element_size", h, why,
                                 f"Change {keys}, or raise max_element_size to {size:.4g} m or more.")


def check_element_size(max_size: float, shear_velocity: float, cutoff_hz: float) -> str | None:
    """Warning text when ``max_size`` exceeds lambda_min / 8 = cs / (8 f), else None.

    Kuhlemeyer & Lysmer (1973): an element should be at most 1/8 to 1/12 of the shortest
    wavelength carried, lambda_min = cs / f_max with the slowest (shear) velocity cs (m/s) and the
    input's cut-off frequency f_max (Hz). The paper: cs ~ 1080 m/s, 20 Hz -> 6.75 m.
    """
    if shear_velocity <= 0 or cutoff_hz <= 0:
        raise ValueError(
            f"check_element_size: shear_velocity ({shear_velocity} m/s) and cutoff_hz ({cutoff_hz} Hz) must be > 0"
        )
    limit = shear_velocity / (8.0 * cutoff_hz)
    if max_size > limit * (1.0 + 1e-9):
        return (
            f"element size {max_size:.3f} m exceeds lambda_min/8 = cs/(8 f) = "
            f"{shear_velocity:g}/(8 x {cutoff_hz:g}) = {limit:.3f} m: waves up to {cutoff_hz:g} Hz "
            f"are not resolved (8 elements per shortest wavelength). Reduce mesh.max_element_size "
            f"to {limit:.3f} m or lower the cut-off frequency."
        )
    return None


def element_counts(p: MeshPlan) -> dict:
    """Hexahedra and nodes the builder will make from plan `p`, counted from its divisions alone
    (nothing is meshed): the cross-section's blocks times the axial layers.

    Cross-section, with q elements per quarter: the water core q x q and its ring 4 q n_water; the
    lining 4 q n_lining; the rock ring 4 q n_near and the outer tensor grid (nx x nz blocks' worth
    of elements less the near-field box's q x q). Nodes: a structured quad mesh of the plane has
    as many nodes as quads plus one per ring around the tunnel (the O-grid's rings close on
    themselves) plus one per outer grid line; the solid duplicates the rock-lining ring.

    'rock' counts the whole ground (its layers included); 'regions' splits it into the mesh's
    ground regions ('rock' below the layers, then each layer)."""
    q = p.quarter.count
    nx = q + sum(d.count for _, d in p.left) + sum(d.count for _, d in p.right)
    nz = q + sum(d.count for _, d in p.bottom) + sum(d.count for _, d in p.top)
    water2 = q * q + 4 * q * p.water_ring.count
    lining2 = 4 * q * p.lining.count
    rock2 = 4 * q * p.near_field.count + nx * nz - q * q
    layers = p.axial.count
    # plane nodes: the outer grid's (nx + 1)(nz + 1) less those inside the near-field box
    # ((q - 1)^2), plus the O-grid rings inside its edge (4 q nodes each: one per radial division
    # of the rock ring and of the lining, and the lining's own copy of the rock-lining ring)
    solid_nodes2 = (nx + 1) * (nz + 1) - (q - 1) ** 2 + 4 * q * (p.near_field.count + p.lining.count + 1)
    water_nodes2 = (q + 1) ** 2 + 4 * q * p.water_ring.count
    # The ground's regions: every layer is nx x (its rows of the top band) of the outer grid.
    regions, rows = {}, 0
    if p.layers:
        zs = np.cumsum([p.zc + p.box_half_width] + [d for d, _ in p.top])
        top_rows = [div.count for _, div in p.top]
        zmid = zs[:-1] + 0.5 * np.diff(zs)
        region = layer_of(p, zmid)
        for i, (name, _) in enumerate(p.layers):
            n = sum(c for c, r in zip(top_rows, region, strict=True) if r == 2 + i)
            regions[name] = nx * n * layers
            rows += n
    regions = {"rock": (rock2 - nx * rows) * layers, **regions}
    if p.geology is not None:
        regions = _geology_regions(p)
    # a portal keeps, in front of its face, the outer grid's rows below the bench only
    front = sum(1 for y in p.y_levels[1:] if y <= p.geology.portal.station + 1e-9) if (
        p.geology is not None and p.geology.portal is not None) else 0
    behind = layers - front
    nb = sum(d.count for _, d in p.bottom)
    return {
        "rock": rock2 * behind + nx * nb * front,
        "regions": regions,
        "lining": lining2 * behind,
        "water": water2 * behind,
        "solid_nodes": solid_nodes2 * (behind + 1) + (nx + 1) * (nb + 1) * front,
        "water_nodes": water_nodes2 * (behind + 1) if behind < layers else water_nodes2 * (layers + 1),
    }


def _grid_lines(c, L, q, low_band, high_band, lo, hi) -> np.ndarray:
    """Grid coordinates along x or z (as gmsh_model.build_cross_section lays them): the outer
    bands' graded segments, the near-field box's q uniform divisions."""
    out = list(np.linspace(c - L, c + L, q + 1))
    y = c - L
    for length, div in low_band:
        for s in graded_sizes(length, div):
            y -= s
            out.insert(0, y)
    y = c + L
    for length, div in high_band:
        for s in graded_sizes(length, div):
            y += s
            out.append(y)
    out[0], out[-1] = lo, hi
    return np.asarray(out)


def grid_lines(p: MeshPlan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The outer grid's node coordinates along x, y and z (the near-field box's sides included)."""
    q, L = p.quarter.count, p.box_half_width
    return (_grid_lines(p.xc, L, q, p.left, p.right, p.xmin, p.xmax), np.asarray(p.y_levels, float),
            _grid_lines(p.zc, L, q, p.bottom, p.top, p.zmin, p.zmax))


def ground_centroids(p: MeshPlan) -> np.ndarray:
    """(x, z) of every ground element's centroid in the cross-section, [N, 2]: the rock ring
    (transfinite: node (i, j) = (1 - v_j) C_b(u_i) + v_j C_box(u_i), u uniform, v graded) and the
    outer tensor grid less the near-field box."""
    q, L = p.quarter.count, p.box_half_width
    v = np.concatenate([[0.0], np.cumsum(graded_sizes(1.0, p.near_field))])
    v[-1] = 1.0
    cents = []
    for k in range(4):
        a0, a1 = math.radians(45 + 90 * k), math.radians(135 + 90 * k)
        u = np.linspace(0.0, 1.0, q + 1)
        t = a0 + (a1 - a0) * u
        inner = np.stack([p.xc + p.radius_outer * np.cos(t), p.zc + p.radius_outer * np.sin(t)], axis=1)
        c0 = np.array([p.xc + L * np.sign(math.cos(a0)), p.zc + L * np.sign(math.sin(a0))])
        c1 = np.array([p.xc + L * np.sign(math.cos(a1)), p.zc + L * np.sign(math.sin(a1))])
        outer = c0 + u[:, None] * (c1 - c0)
        nodes = (1 - v)[None, :, None] * inner[:, None, :] + v[None, :, None] * outer[:, None, :]
        cents.append(0.25 * (nodes[:-1, :-1] + nodes[1:, :-1] + nodes[:-1, 1:] + nodes[1:, 1:]).reshape(-1, 2))
    xs = _grid_lines(p.xc, L, q, p.left, p.right, p.xmin, p.xmax)
    zs = _grid_lines(p.zc, L, q, p.bottom, p.top, p.zmin, p.zmax)
    xm, zm = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (zs[1:] + zs[:-1])
    X, Z = np.meshgrid(xm, zm, indexing="ij")
    box = (np.abs(X - p.xc) < L) & (np.abs(Z - p.zc) < L)
    cents.append(np.stack([X[~box], Z[~box]], axis=1))
    return np.concatenate(cents)


def _geology_regions(p: MeshPlan) -> dict:
    """Ground elements per region with regions bounded by planes: every ground element's
    centroid (cross-section centroid, axial layer mid-point) through geology.assign, as the
    builder assigns them."""
    names = [ROCK_REGION, LINING_REGION] + [n for n, _ in p.layers] + p.geology.materials
    counts = np.zeros(len(names), dtype=np.int64)
    if p.geology.portal is not None:
        xz, y = ground_centroids(p), np.asarray(p.y_levels)
    for j in range(0, p.axial.count, 64):  # a few axial layers at a time: memory stays small
        _, r = ground_regions(p, range(j, min(j + 64, p.axial.count)))
        if p.geology.portal is not None:  # what a portal's cut removes (by the unmoved centroid: the
            # cut's elements lie wholly in front of the face, their z is that of the flat block's)
            yy = 0.5 * (y[j:j + r.shape[1]] + y[j + 1:j + 1 + r.shape[1]])
            keep = ~((yy[None, :] < p.geology.portal.station) & (xz[:, None, 1] > portal_bench(p)))
            r = r[keep]
        counts += np.bincount(r.ravel(), minlength=len(names))
    return {n: int(c) for i, (n, c) in enumerate(zip(names, counts, strict=True)) if i != 1}


def ground_regions(p: MeshPlan, layers) -> tuple[np.ndarray, np.ndarray]:
    """(centroids [N, L, 3], regions [N, L]) of every ground element (ground_centroids' order) in the
    axial element layers `layers` (indices, ascending and consecutive), as the builder places and
    assigns them: on a sloping surface each centroid's z is moved by the mean surface ratio of its
    plan corners; the region index is that of build.region_names (0 rock, 2 + i horizontal layer i,
    then the regions bounded by planes)."""
    from .geology import assign

    xz = ground_centroids(p)
    y = np.asarray(p.y_levels)
    js = np.asarray(list(layers), dtype=int)
    y_lo, y_hi = y[js], y[js + 1]
    yy = 0.5 * (y_lo + y_hi)
    base = layer_of(p, xz[:, 1]) if p.layers else np.zeros(len(xz), np.int32)
    pts = np.empty((len(xz), len(yy), 3))
    pts[:, :, 0], pts[:, :, 1], pts[:, :, 2] = xz[:, None, 0], yy[None, :], xz[:, None, 1]
    slope = p.geology.slope if p.geology is not None else None
    if slope is not None:  # the element's centroid on the slope: its z times the mean r of its plan corners
        q, L = p.quarter.count, p.box_half_width
        xs = _grid_lines(p.xc, L, q, p.left, p.right, p.xmin, p.xmax)
        zs = _grid_lines(p.zc, L, q, p.bottom, p.top, p.zmin, p.zmax)
        X0, Z = np.meshgrid(xs[:-1], 0.5 * (zs[1:] + zs[:-1]), indexing="ij")
        X1, _ = np.meshgrid(xs[1:], zs[1:], indexing="ij")
        xm = 0.5 * (X0 + X1)
        box = (np.abs(xm - p.xc) < L) & (np.abs(Z - p.zc) < L)
        x_ends = np.full((len(xz), 2), np.nan)  # the outer grid's x extents (ground_centroids lists its elements last)
        x_ends[len(xz) - int((~box).sum()):] = np.stack([X0[~box], X1[~box]], axis=1)
        zb = slope_base(p)
        r = np.zeros((len(xz), len(yy)))
        for xe in (x_ends[:, 0], x_ends[:, 1]):
            for ye in (y_lo, y_hi):
                r += 0.25 * surface_ratio(slope, xe[:, None], ye[None, :], p.zmax, zb)
        above = np.isfinite(r) & (pts[:, :, 2] > zb)
        pts[:, :, 2] = np.where(above, zb + (pts[:, :, 2] - zb) * np.where(above, r, 1.0), pts[:, :, 2])
    base = np.repeat(base[:, None], len(yy), axis=1)
    if p.geology is None:
        return pts, base
    return pts, assign(p.geology, pts, base, 2 + len(p.layers))


ROCK_REGION, LINING_REGION = "rock", "lining"


#: Bytes of memory per hexahedron while meshing (gmsh's model and the Python arrays that build
#: mesh.h5 and water.msh), measured as the peak RSS of build_tunnel_mesh: 2.1 kB on the paper's 3D
#: mesh (79,200 hexahedra), 2.0 kB at refinement_factor 2 (633,600), 2.3 kB on the slice at 8.
MESHING_BYTES_PER_HEX = 2300
#: Bytes per element of tq-solid (docs/benchmarks.md: 1.4 kB per element with its node, peak RSS
#: from 10k to 512k elements), with room for the Mohr-Coulomb state.
SOLID_BYTES_PER_ELEMENT = 1500
#: Bytes per water cell of OpenFOAM (its usual figure of about 1 GB per million cells; not
#: measured here).
WATER_BYTES_PER_CELL = 1000
#: What the mesher holds before any mesh (Python with numpy, h5py and gmsh: 55 MB measured), bytes.
MESHING_BASE_BYTES = 60e6
#: What `tunnelquake run`'s own Python process holds while its solvers run (numpy, h5py, gmsh,
#: matplotlib, the motion and the solver inputs it wrote), bytes: peak RSS 176 MB on
#: cases/fault_crossing (its imports alone 80 MB; docs/benchmarks.md "check's estimates on the 3D cases").
DRIVER_BYTES = 180e6
#: What one tq-solid process holds before its mesh (the program and its libraries), bytes: 18.3 MB
#: peak RSS of a tq-solid that read its input and refused it.
SOLID_BASE_BYTES = 18e6
#: What OpenFOAM's libraries hold before any cell, bytes (not measured here).
WATER_BASE_BYTES = 100e6


def memory_estimate(counts: dict, conditions=("dynamic_water",)) -> dict:
    """Peak memory in bytes, from element_counts: 'meshing' (build_tunnel_mesh) and 'run' (`tunnelquake
    run`'s own process and the conditions' solvers: it runs the coupled condition beside one
    solid-only one, so up to two tq-solid processes and OpenFOAM at once; solid-only conditions one
    after another). A DRM field's samples (incident_wave) are not counted."""
    solid = counts["rock"] + counts["lining"]
    hexes = solid + counts["water"]
    conds = list(conditions)
    solids = 2 if "dynamic_water" in conds and len(conds) > 1 else 1
    water = WATER_BASE_BYTES + counts["water"] * WATER_BYTES_PER_CELL if "dynamic_water" in conds else 0.0
    return {
        "meshing": MESHING_BASE_BYTES + hexes * MESHING_BYTES_PER_HEX,
        "run": DRIVER_BYTES + solids * (SOLID_BASE_BYTES + solid * SOLID_BYTES_PER_ELEMENT) + water,
    }


#: Where machine_memory reads the machine's memory (tests point it at a file of their own).
MEMINFO = "/proc/meminfo"


def machine_memory() -> dict | None:
    """{'total', 'available'} bytes from /proc/meminfo (MemTotal, MemAvailable), or None where it
    cannot be read."""
    try:
        with open(MEMINFO) as f:
            text = f.read()
    except OSError:
        return None
    kb = {}
    for line in text.splitlines():
        key, _, rest = line.partition(":")
        parts = rest.split()
        if parts and parts[0].isdigit():
            kb[key.strip()] = int(parts[0])
    if "MemTotal" not in kb:
        return None
    return {"total": kb["MemTotal"] * 1024.0, "available": kb.get("MemAvailable", kb["MemTotal"]) * 1024.0}


#: The thinnest a sloping surface may leave the ground above z_b, as a share of z_top - z_b: the
#: elements there are squeezed vertically by this factor at most.
SLOPE_MIN_SHARE = 0.25


def _check_slope(s, lo, hi, slice_mode: bool, z_base: float) -> None:
    """The slope against the block: it must descend inside it, and its surface must stay above
    z_b + SLOPE_MIN_SHARE (z_top - z_b) everywhere (else the ground above the tunnel's near-field
    box, or the top horizontal layer, would be squeezed to nothing or cut through)."""
    key = "geology.slope"
    if slice_mode and abs(math.cos(math.radians(s.dip_direction))) > 1e-9:
        why = ("a slice holds one section across the tunnel, and a slope descending along the axis changes the "
               "section along it")
        raise MeshInputError(f"{key}.dip_direction: {why}", f"{key}.dip_direction", s.dip_direction, why,
                             "Use dip_direction 90 or 270 (descending across the tunnel) in a slice, or mesh.mode: 3d.")
    plan_corners = [(x, y) for x in (lo[0], hi[0]) for y in (lo[1], hi[1])]
    drops = [float(s.drop(x, y)) for x, y in plan_corners]
    if max(drops) <= 0.0:
        why = (f"the crest line through {list(s.crest)} leaves the whole block x {lo[0]:g}..{hi[0]:g}, "
               f"y {lo[1]:g}..{hi[1]:g} behind it: the slope never descends inside the block")
        raise MeshInputError(f"{key}.crest: {why}", f"{key}.crest", list(s.crest), why,
                             "Give a crest point inside the block (in plan), or check dip_direction (the azimuth "
                             "the ground descends towards).")
    allowed = (1.0 - SLOPE_MIN_SHARE) * (hi[2] - z_base)
    worst = max(drops)
    if worst > allowed * (1 + 1e-12):
        x, y = plan_corners[int(np.argmax(drops))]
        b = math.radians(s.dip_direction)
        reach = (x - s.crest[0]) * math.sin(b) + (y - s.crest[1]) * math.cos(b)  # the farthest distance past the crest
        limit = (f"the ground above z = {z_base:g} m (the top of the tunnel's near-field box, or the bottom of the top "
                 f"horizontal layer) must keep {SLOPE_MIN_SHARE:g} of its {hi[2] - z_base:g} m")
        if s.height is not None and s.height > allowed:
            why = f"drops the surface {s.height:g} m, to z = {hi[2] - s.height:g} m, but {limit}: at most {allowed:.4g} m"
            raise MeshInputError(f"{key}.height: {why}", f"{key}.height", s.height, why,
                                 f"Give height <= {allowed:.4g} m, or raise geometry.z_range[1] / lower the tunnel "
                                 "(geometry.tunnel_centre_z) to give the slope room.")
        steepest = math.degrees(math.atan(allowed / reach))
        why = (f"is steeper than the block allows: descending from the crest through {list(s.crest)}, the surface "
               f"falls {worst:.4g} m by ({x:g}, {y:g}), to z = {hi[2] - worst:.4g} m, but {limit}")
        raise MeshInputError(f"{key}.angle: {why}", f"{key}.angle", s.angle, why,
                             f"Use angle <= {steepest:.1f} deg with this crest, or give height <= {allowed:.4g} m "
                             "(a toe inside the block), move the crest (geology.slope.crest) towards the descent, or "
                             "raise geometry.z_range[1].")


def _check_geology(geo: Geology, lo, hi, slice_mode: bool, z_base: float | None = None) -> None:
    """The planes against the block: a fault zone must meet the block and not cover it, a dipping
    layer's bottom must cut the block (else the layer is empty or the whole ground); a slope must
    descend inside the block and leave ground above z_base (_check_slope)."""
    if geo.slope is not None:
        _check_slope(geo.slope, lo, hi, slice_mode, hi[2] if z_base is None else z_base)
    box = corners(lo, hi)
    f = geo.fault
    if f is not None:
        key = "geology.fault_zone"
        if slice_mode:
            why = "a slice is one element thick along the axis and cannot hold a band crossing it"
            raise MeshInputError(f"{key}: {why}", f"{key}.material", f.material, why,
                                 "Use mesh.mode: 3d (the band needs the tunnel's length), or remove the fault zone.")
        dist = f.plane.distance(box)
        half = 0.5 * f.width
        if dist.min() > half or dist.max() < -half:
            near = float(np.abs(dist).min()) - half
            why = (f"the band ({f.width:g} m wide about the plane through {list(f.plane.point)}) misses the block "
                   f"x {lo[0]:g}..{hi[0]:g}, y {lo[1]:g}..{hi[1]:g}, z {lo[2]:g}..{hi[2]:g} by {near:.4g} m")
            raise MeshInputError(f"{key}.point: {why}", f"{key}.point", list(f.plane.point), why,
                                 "Give a point on the fault's centre plane inside the block (e.g. on the tunnel "
                                 "axis), or check strike and dip.")
        if (np.abs(dist) <= half).all() or f.axial_length >= hi[1] - lo[1]:
            what = ("covers the whole block" if (np.abs(dist) <= half).all() else
                    f"is {f.axial_length:.4g} m long along the tunnel axis (width / |n_y|), not shorter than the "
                    f"block's {hi[1] - lo[1]:g} m")
            why = f"the band, {f.width:g} m wide, {what}, so the block has no rock beside it"
            raise MeshInputError(f"{key}.width: {why}", f"{key}.width", f.width, why,
                                 "Give the fault zone's true thickness (normal to its plane), smaller than the "
                                 "block, or lengthen geometry.y_range.")
    for i, layer in enumerate(geo.dipping):
        dist = layer.bottom.distance(box)
        if dist.min() > 0 or dist.max() < 0:
            key = f"geology.dipping_layers[{i}]"
            side = "below" if dist.min() > 0 else "above"
            what = "the whole block is the layer" if side == "below" else "the layer is empty"
            why = (f"its bottom plane (dip and dip_direction through {list(layer.bottom.point)}) passes {side} the "
                   f"block, leaving it without cutting it: {what}")
            raise MeshInputError(f"{key}.point: {why}", f"{key}.point", list(layer.bottom.point), why,
                                 "Give a point of the layer's bottom inside the block, or check dip and "
                                 "dip_direction.")


def axial_levels(geo: Geology, ymin: float, ymax: float, count: int, xs, zs, growth: float,
                 k: int = 1) -> tuple[float, ...]:
    """The y of every axial grid line. Uniform (``count`` elements) unless a fault zone crosses the
    near-field box xs x zs: then the stretch [ya, yb] the band occupies there has elements of at
    most min(h0, (w / |n_y|) / (N k)) (N = elements_across, h0 = the uniform length), so the band
    has at least N k elements across along the axis in the lining and the rock ring around it, and
    outside it the elements grow by ``growth`` back to h0 (outer_band)."""
    h0 = (ymax - ymin) / count
    f = geo.fault
    span = band_y_range(f, xs, zs) if f is not None else None
    if span is None or span[1] <= ymin or span[0] >= ymax:
        return tuple(np.linspace(ymin, ymax, count + 1))
    ya, yb = max(span[0], ymin), min(span[1], ymax)
    h = min(h0, f.axial_length / (f.elements_across * k))
    n_band = max(1, math.ceil((yb - ya) / h - 1e-9))
    h = (yb - ya) / n_band
    levels = list(np.linspace(ya, yb, n_band + 1))
    if ya > ymin + 1e-9 * (ymax - ymin):  # the stretch below, its sizes growing away from the band
        y = ya
        for length, div in outer_band(ya - ymin, h, h0, max(growth, 1.0)):
            sizes = graded_sizes(length, div)
            for s in sizes:
                y -= s
                levels.insert(0, y)
        levels[0] = ymin
    if yb < ymax - 1e-9 * (ymax - ymin):
        y = yb
        for length, div in outer_band(ymax - yb, h, h0, max(growth, 1.0)):
            for s in graded_sizes(length, div):
                y += s
                levels.append(y)
        levels[-1] = ymax
    return tuple(float(v) for v in levels)
