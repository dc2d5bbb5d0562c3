"""The gmsh model: a structured all-hex tunnel cross-section extruded along the tunnel axis.

Cross-section (x-z plane, tunnel centre C), from the axis outwards, every ring split into four
blocks by the diagonals through C (45 deg + k 90 deg):

    water core   square of half-side c, (n/4) x (n/4) quads            (butterfly / O-grid core)
    water ring   square -> circle r = a, n around x water_ring_divisions
    lining       circle a -> circle b, n around x lining_elements_through
    rock ring    circle b -> near-field box of half-side L, n around x near_field_radial_divisions
    outer rock   3 x 3 block grid around the box (the box is the centre block): columns
                 [xmin, xc-L], [xc-L, xc+L], [xc+L, xmax], rows likewise in z

All surfaces are transfinite and recombined, then extruded along +y in uniform layers, which
makes every volume element an 8-node hexahedron and every interface conforming. Curves that grade
are created pointing away from the tunnel so a progression ratio > 1 grows outwards.
"""

from __future__ import annotations

import math

import gmsh

from .params import Divisions, MeshPlan

# Region names (gmsh physical volume names).
ROCK, LINING, WATER = "rock", "lining", "water"


class _Builder:
    """Adds points, lines and arcs to gmsh.model.geo once each, remembering their direction."""

    def __init__(self, plan: MeshPlan):
        self.p = plan
        self.points: dict[tuple, int] = {}
        self.curves: dict[frozenset, tuple[int, int, int]] = {}  # {p, q} -> (tag, start, end)
        self.transfinite: dict[int, Divisions] = {}

    def point(self, x: float, z: float) -> int:
        key = (round(x, 9), round(z, 9))
        if key not in self.points:
            self.points[key] = gmsh.model.geo.addPoint(x, self.p.ymin, z)
        return self.points[key]

    def corner(self, h: float, k: int) -> int:
        """Point (xc +- h, zc +- h) on the k-th diagonal (angle 45 + 90 k deg, k = 0 is +x +z),
        i.e. at radius h sqrt(2); computed without trigonometry so that square corners are exact.
        """
        sx, sz = ((1, 1), (-1, 1), (-1, -1), (1, -1))[k]
        return self.point(self.p.xc + sx * h, self.p.zc + sz * h)

    def _curve(self, p: int, q: int, div: Divisions, make) -> int:
        key = frozenset((p, q))
        if key not in self.curves:
            tag = make()
            self.curves[key] = (tag, p, q)
            self.transfinite[tag] = div
        tag, start, _ = self.curves[key]
        return tag if start == p else -tag

    def line(self, p: int, q: int, div: Divisions) -> int:
        """Signed tag of the straight line p -> q (created p -> q the first time)."""
        return self._curve(p, q, div, lambda: gmsh.model.geo.addLine(p, q))

    def arc(self, p: int, q: int, div: Divisions) -> int:
        """Signed tag of the arc p -> q about the tunnel centre."""
        c = self.point(self.p.xc, self.p.zc)
        return self._curve(p, q, div, lambda: gmsh.model.geo.addCircleArc(p, c, q))

    def surface(self, loop: list[int]) -> int:
        tag = gmsh.model.geo.addPlaneSurface([gmsh.model.geo.addCurveLoop(loop)])
        gmsh.model.geo.mesh.setTransfiniteSurface(tag)
        gmsh.model.geo.mesh.setRecombine(2, tag)
        return tag

    def apply_transfinite(self) -> None:
        for tag, div in self.transfinite.items():
            gmsh.model.geo.mesh.setTransfiniteCurve(tag, div.count + 1, "Progression", div.growth)


def build_cross_section(plan: MeshPlan) -> dict[str, list[int]]:
    """Create the cross-section surfaces at y = ymin; returns the surface tags per region."""
    b = _Builder(plan)
    q = plan.quarter
    regions: dict[str, list[int]] = {WATER: [], LINING: [], ROCK: []}

    # The O-grid rings outside the core, innermost first: (half-diagonal h of the ring's outer
    # boundary, i.e. its corners are (xc +- h, zc +- h), its shape, radial divisions, region).
    s2 = math.sqrt(0.5)
    rings = [
        (plan.radius_inner * s2, "arc", plan.water_ring, WATER),
        (plan.radius_outer * s2, "arc", plan.lining, LINING),
        (plan.box_half_width, "line", plan.near_field, ROCK),
    ]
    # water core: the inner square
    sq = [b.corner(plan.core_half_width, k) for k in range(4)]
    regions[WATER].append(b.surface([b.line(sq[k], sq[(k + 1) % 4], q) for k in range(4)]))
    prev_pts, prev_kind = sq, "line"
    for h, kind, radial, region in rings:
        pts = [b.corner(h, k) for k in range(4)]
        for k in range(4):  # radial lines first, all pointing outwards (growth > 1 grows out)
            b.line(prev_pts[k], pts[k], radial)
        for k in range(4):
            k1 = (k + 1) % 4
            inner = (b.line if prev_kind == "line" else b.arc)(prev_pts[k], prev_pts[k1], q)
            side1 = b.line(prev_pts[k1], pts[k1], radial)
            outer = (b.line if kind == "line" else b.arc)(pts[k1], pts[k], q)
            side0 = b.line(pts[k], prev_pts[k], radial)
            regions[region].append(b.surface([inner, side1, outer, side0]))
        prev_pts, prev_kind = pts, kind

    # outer rock: a tensor grid of blocks around the near-field box (the box is the centre block,
    # already meshed): columns left of / across / right of the box, rows likewise in z. Each outer
    # band may have several segments (graded transition + uniform); lines in them are created
    # pointing away from the box so their growth ratio counts outwards.
    L = plan.box_half_width

    def axis(c, low_band, high_band, lo, hi):
        """Grid coordinates and per-interval (divisions, direction) along one axis."""
        coords, divs = [c - L], [(q, 1)]
        for d, div in low_band:
            coords.insert(0, coords[0] - d)
            divs.insert(0, (div, -1))
        coords.append(c + L)
        for d, div in high_band:
            coords.append(coords[-1] + d)
            divs.append((div, 1))
        coords[0], coords[-1] = lo, hi  # exact block bounds, free of summation round-off
        return coords, divs

    xs, xdiv = axis(plan.xc, plan.left, plan.right, plan.xmin, plan.xmax)
    zs, zdiv = axis(plan.zc, plan.bottom, plan.top, plan.zmin, plan.zmax)
    ibox, jbox = len(plan.left), len(plan.bottom)  # the box's block indices
    grid = [[b.point(x, z) for z in zs] for x in xs]

    def edge(p: int, r: int, div_dir) -> int:
        """Signed tag of the line p -> r (p before r on its axis), created away from the box."""
        div, direction = div_dir
        return -b.line(r, p, div) if direction < 0 else b.line(p, r, div)

    for i in range(len(xs) - 1):
        for j in range(len(zs) - 1):
            if (i, j) == (ibox, jbox):
                continue
            loop = [
                edge(grid[i][j], grid[i + 1][j], xdiv[i]),
                edge(grid[i + 1][j], grid[i + 1][j + 1], zdiv[j]),
                -edge(grid[i][j + 1], grid[i + 1][j + 1], xdiv[i]),
                -edge(grid[i][j], grid[i][j + 1], zdiv[j]),
            ]
            regions[ROCK].append(b.surface(loop))

    b.apply_transfinite()
    return regions


def build_model(plan: MeshPlan, name: str = "tunnel") -> dict:
    """Build and mesh the model in the current gmsh session.

    Returns {"volumes": {region: [volume tags]}, "groups": {physical name: (dim, tag)}}.
    Physical groups: volumes rock, lining, water; surfaces bottom, top, xmin, xmax, ymin, ymax
    (solid outer boundary), rock_lining (rock-lining interface = rock_hole = lining_outer),
    lining_inner (lining-water interface), end_ymin, end_ymax (water axial ends).
    """
    gmsh.model.add(name)
    surfaces = build_cross_section(plan)
    order = [(region, s) for region in (ROCK, LINING, WATER) for s in surfaces[region]]
    out = gmsh.model.geo.extrude(
        [(2, s) for _, s in order],
        0.0,
        plan.ymax - plan.ymin,
        0.0,
        numElements=[1] * plan.axial.count if _graded(plan) else [plan.axial.count],
        heights=_heights(plan) if _graded(plan) else [],
        recombine=True,
    )
    # gmsh returns, per input surface: its top copy, the volume, then the lateral surfaces.
    vols = [tag for dim, tag in out if dim == 3]
    assert len(vols) == len(order)
    volumes: dict[str, list[int]] = {ROCK: [], LINING: [], WATER: []}
    region_of: dict[int, str] = {}
    for (region, _), v in zip(order, vols, strict=True):
        volumes[region].append(v)
        region_of[v] = region
    gmsh.model.geo.synchronize()
    gmsh.model.mesh.generate(3)

    groups = _physical_groups(plan, volumes, region_of)
    return {"volumes": volumes, "groups": groups}


def _graded(plan: MeshPlan) -> bool:
    """Whether the axial grid is not uniform (a fault zone's refined stretch)."""
    y = plan.y_levels
    if len(y) < 3:
        return False
    d = [b - a for a, b in zip(y[:-1], y[1:], strict=True)]
    return max(d) - min(d) > 1e-9 * (plan.ymax - plan.ymin)


def _heights(plan: MeshPlan) -> list[float]:
    """The extrusion's layer tops as fractions of the axial length."""
    span = plan.ymax - plan.ymin
    return [(y - plan.ymin) / span for y in plan.y_levels[1:]]


def _physical_groups(plan: MeshPlan, volumes, region_of) -> dict:
    """Name every boundary and interface surface from its adjacent volumes and its nodes."""
    tol = 1e-6 * max(plan.xmax - plan.xmin, plan.zmax - plan.zmin)
    named: dict[str, list[int]] = {}
    for _, s in gmsh.model.getEntities(2):
        up, _ = gmsh.model.getAdjacencies(2, s)
        regs = sorted({region_of[v] for v in up})
        _, xyz, _ = gmsh.model.mesh.getNodes(2, s, includeBoundary=True)
        x, y, z = xyz[0::3], xyz[1::3], xyz[2::3]
        r = [math.hypot(xi - plan.xc, zi - plan.zc) for xi, zi in zip(x, z, strict=True)]

        def on(values, target):
            return all(abs(v - target) < tol for v in values)

        name = None
        if regs == [WATER]:
            name = "end_ymin" if on(y, plan.ymin) else "end_ymax" if on(y, plan.ymax) else None
        elif regs == [LINING, ROCK]:
            name = "rock_lining"
        elif regs == [LINING, WATER]:
            name = "lining_inner"
        elif len(up) == 1:
            for cand, vals, target in (
                ("ymin", y, plan.ymin),
                ("ymax", y, plan.ymax),
                ("bottom", z, plan.zmin),
                ("top", z, plan.zmax),
                ("xmin", x, plan.xmin),
                ("xmax", x, plan.xmax),
            ):
                if on(vals, target):
                    name = cand
                    break
            if name is None:
                raise RuntimeError(f"gmsh surface {s} is a boundary of {regs} but on no known face")
        if name == "rock_lining":
            assert on(r, plan.radius_outer), "rock-lining interface off the excavation circle"
        if name == "lining_inner":
            assert on(r, plan.radius_inner), "lining-water interface off the inner circle"
        if name is not None:
            named.setdefault(name, []).append(s)

    groups = {}
    for region, tags in volumes.items():
        groups[region] = (3, gmsh.model.addPhysicalGroup(3, tags, name=region))
    for name in (
        "bottom",
        "top",
        "xmin",
        "xmax",
        "ymin",
        "ymax",
        "rock_lining",
        "lining_inner",
        "end_ymin",
        "end_ymax",
    ):
        if name not in named:
            raise RuntimeError(f"no gmsh surface found for physical group '{name}'")
        groups[name] = (2, gmsh.model.addPhysicalGroup(2, named[name], name=name))
    return groups
