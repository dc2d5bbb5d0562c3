"""The case's `incident_wave` section: a plane P, SV or SH wave from any direction, brought into a 3D
model through a domain-reduction (DRM) layer.

The ground motion's horizontal record (`ground_motion`, processed as for any run: window, filter,
baseline, PGA) is the wave's defining component (`freefield.record_component`: z for P, the
horizontal propagation direction for SV, across it for SH) under the record's convention. The free
field is that of the case's own ground: its horizontal layers (`layers`) over materials.rock as the
half-space, each medium's Vp, Vs and density from its elastic constants (`ground_profile`),
computed by `tunnelquake.freefield` at the DRM layer's nodes (`drm_layer`) and written into
solid_input.h5's `/drm` (`tunnelquake.drm_input`). The incident wave then does not enter through the
base and the sides: they absorb what the tunnel scatters (docs/theory.md §6.2).

The layer: the elements `drm_offset` element rings in from the block's four sides and its base
(rings counted through shared nodes, so a structured mesh's ring is one element thick), open at the
ground surface. Everything from the layer outwards must be linear elastic (tq-solid refuses an
element of another material in the layer), and the tunnel must lie inside it: its ends are filled
with rock (mesh.tunnel_end_plugs) so that the layer crosses no lining, water or hole.
"""
from __future__ import annotations

import math

import numpy as np

from . import units as U
from .schema import Bool, Choice, Issue, Number, Section, Text, Tuple

KINDS = ("none", "P", "SV", "SH", "h5drm")
#: the keys that shape a plane wave (not a free field read from a file)
PLANE_WAVE_KEYS = ("angle", "azimuth", "convention", "damping")
#: the ground materials the DRM layer may cross: tq-solid forms the layer's stiffness once
LINEAR_MODELS = ("elastic",)


def section() -> Section:
    """The `incident_wave:` keys."""
    return Section(doc="a plane wave from any direction through a domain-reduction layer (3D only; "
                       "docs/user_guide.md \"Waves from any direction\")", fields={
        "type": Choice(choices=KINDS, default="none",
                       doc="none: the vertically incident motion through the base and free-field sides; P, SV or "
                           "SH: the ground motion's horizontal record is this plane wave's defining component (z "
                           "for P, the horizontal propagation direction for SV, across it for SH); h5drm: the free "
                           "field at the layer's nodes read from an H5DRM file (incident_wave.h5drm)"),
        "angle": Number(min=0.0, max=90.0, max_open=True, default=0.0,
                        doc="incidence angle from the vertical in the half-space (materials.rock), deg; SV below "
                            "the critical angle asin(Vs/Vp)"),
        "azimuth": Number(min=-360.0, max=360.0, default=0.0,
                          doc="horizontal propagation direction, deg from the tunnel's axis +y towards +x: 0 travels "
                              "along the tunnel, 90 across it"),
        "convention": Choice(choices=("outcrop", "incident", "within"), default=None,
                             doc="what the record is: outcrop (the half-space's own free-surface motion, no layers), "
                                 "incident (the up-going wave at the top of the half-space) or within (the total "
                                 "motion there, inside the layers); default: ground_motion.convention"),
        "damping": Number(min=0.0, max=0.5, max_open=True, default=0.0,
                          doc="damping ratio of every ground medium in the free field (a complex velocity "
                              "c (1 + i ratio), docs/theory.md §6.1)"),
        "write_h5drm": Bool(default=False,
                            doc="also write the free field at the layer's nodes as an H5DRM file (OpenSees' layout, "
                                "docs/formats.md \"H5DRM\"), <condition>/free_field.h5drm in the results folder"),
        "h5drm": Section(doc="the free field from an H5DRM file (type: h5drm; OpenSees' H5DRM pattern's arguments; "
                             "docs/formats.md \"H5DRM\")", fields={
            "file": Text(doc="the H5DRM file, relative to the case file: the free field at the DRM layer's nodes, "
                             "its first sample at the seismic stage's start"),
            "factor": Number(min=0.0, min_open=True, default=1.0,
                             doc="multiplies the file's displacement, velocity and acceleration (to m, m/s, m/s^2)"),
            "crd_scale": Number(min=0.0, min_open=True, default=1.0,
                                doc="multiplies the file's coordinates less drmbox_x0 (to m: 1000 for km)"),
            "distance_tolerance": Number(dim=U.LENGTH, min=0.0, min_open=True, default=0.01,
                                         doc="largest distance from a DRM layer node to its file point, m"),
            "transformation": Tuple(item=Number(), length=9, default=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                                    doc="T row by row (T00 ... T22): x = T (crd_scale (x_file - drmbox_x0)) + x0 "
                                        "for the file's points; the motion rows are read as OpenSees reads them, "
                                        "u = factor (row 0, row 1, -row 2) in the model's axes"),
            "x0": Tuple(item=Number(dim=U.LENGTH), length=3, default=[0.0, 0.0, 0.0],
                        doc="the model's point of the file's drmbox_x0, m (added after the transformation)"),
        }),
        "drm_offset": Number(integer=True, min=0, default=1,
                             doc="element rings between the block's sides and base and the DRM layer (0: the "
                                 "layer's outer nodes on them); the absorbing boundaries sit there"),
    })


def active(d: dict) -> bool:
    """Whether the case asks for a plane wave through a DRM layer."""
    return (d.get("incident_wave") or {}).get("type", "none") != "none"


def _speeds(m: dict) -> tuple[float, float, float]:
    """(Vp, Vs, rho) of a case material from its E, nu and density."""
    E, nu, rho = float(m["youngs_modulus"]), float(m["poisson_ratio"]), float(m["density"])
    vs = math.sqrt(E / (2 * (1 + nu)) / rho)
    return math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu) * rho)), vs, rho


def ground_profile(d: dict, layers: list[tuple[str, float]]):
    """The free field's profile from the case: `layers` [(material, z of its bottom)] from the
    surface geometry.z_range[1] down, over materials.rock as the half-space."""
    from .freefield import HalfSpace, Layer, Profile

    xi = float(d["incident_wave"]["damping"])
    top = float(d["geometry"]["z_range"][1])
    out, z = [], top
    for name, zb in layers:
        vp, vs, rho = _speeds(d["materials"][name])
        out.append(Layer(z - zb, vp, vs, rho, xi))
        z = zb
    vp, vs, rho = _speeds(d["materials"]["rock"])
    return Profile(tuple(out), HalfSpace(vp, vs, rho, xi), surface=top)


def plane_wave(d: dict):
    from .freefield import PlaneWave

    w = d["incident_wave"]
    return PlaneWave(w["type"], float(w["angle"]), float(w["azimuth"]))


def convention(d: dict) -> str:
    return d["incident_wave"]["convention"] or d["ground_motion"]["convention"]


def checks(d: dict, layers: list[tuple[str, float]], lines: dict, section_lines) -> list[Issue]:
    """Everything a run could not honour, each naming its key: `lines` the top-level key -> line
    map, `section_lines(name)` a section's."""
    w = d["incident_wave"]
    wl = section_lines("incident_wave")
    if not active(d):
        given = [k for k in (*PLANE_WAVE_KEYS, "drm_offset", "write_h5drm", "h5drm") if k in wl]
        return [Issue(f"incident_wave.{given[0]}", w[given[0]], "is given but incident_wave.type is none (no plane "
                      "wave)", "add 'type: P', 'SV', 'SH' or 'h5drm', or remove it", wl.get(given[0]))] if given else []
    issues: list[Issue] = []
    line = wl.get("type") or lines.get("incident_wave")
    kind = w["type"]
    from_file = kind == "h5drm"
    if from_file:
        for k in (x for x in (*PLANE_WAVE_KEYS, "write_h5drm") if x in wl):
            issues.append(Issue(f"incident_wave.{k}", w[k], "is given but incident_wave.type is h5drm: the free field "
                                "comes from the file, not from a plane wave the tool computes", "remove it, or give "
                                "type: P, SV or SH", wl.get(k)))
        if not w["h5drm"]["file"]:
            issues.append(Issue("incident_wave.h5drm.file", None, "is missing: type h5drm reads the free field at the "
                                "DRM layer's nodes from that file", "add 'h5drm: {file: <path of the H5DRM file>}'",
                                wl.get("h5drm") or line))
    elif "h5drm" in wl:
        issues.append(Issue("incident_wave.h5drm", "...", f"is given but incident_wave.type is {kind}: the tool "
                            "computes that plane wave's free field itself", "remove it, or give type: h5drm",
                            wl.get("h5drm")))
    if d["mesh"]["mode"] != "3d":
        issues.append(Issue("incident_wave.type", kind, "needs a 3D model (a domain-reduction layer round the "
                            "tunnel); mesh.mode is slice", "use mesh.mode: 3d, or incident_wave.type: none (the "
                            "slice takes vertically incident waves)", line))
        return issues
    plugs, offset = int(d["mesh"].get("tunnel_end_plugs") or 0), int(w["drm_offset"])
    if plugs < offset + 2:
        issues.append(Issue("mesh.tunnel_end_plugs", plugs, f"leaves the tunnel crossing the DRM layer (drm_offset "
                            f"{offset}: the layer is axial element layer {offset + 1} from each end; the tunnel must "
                            "end inside it, with at least one layer of rock between)",
                            f"set mesh.tunnel_end_plugs: {offset + 2} or more", section_lines("mesh").get(
                                "tunnel_end_plugs") or lines.get("mesh") or line))
    if not from_file and d.get("geology") and (d["geology"].get("slope") or {}).get("angle") is not None:
        issues.append(Issue("geology.slope", "a sloping surface", "the free field of a plane wave is computed for a "
                            "flat ground surface only", "remove geology.slope, or incident_wave.type: none (the "
                            "side faces' free-field columns and the base drive a sloping block)", lines.get("geology")))
    if not from_file and d.get("geology") and ((d["geology"].get("fault_zone") or {}).get("material")
                                               or d["geology"].get("dipping_layers")):
        issues.append(Issue("geology", "fault zone / dipping layers", "the free field of a plane wave is computed "
                            "for horizontal layers only", "remove the geology section, or incident_wave.type: none",
                            lines.get("geology")))
    for name in ["rock"] + [m for m, _ in layers]:
        m = d["materials"].get(name)
        if m is not None and m["model"] not in LINEAR_MODELS:
            issues.append(Issue(f"materials.{name}.model", m["model"], "is not linear elastic, and the DRM layer and "
                                "everything outside it lie in this ground material (the free field and the layer's "
                                "forces are those of an elastic ground)", "use model: elastic for the ground, or "
                                "incident_wave.type: none", section_lines("materials").get(name)))
    if "dynamic_water" in d["conditions"]:
        issues.append(Issue("conditions", "dynamic_water", "with an incident wave is not built: the coupled water "
                            "with plugged tunnel ends is not verified", "run no_water and static_water, or "
                            "incident_wave.type: none", lines.get("conditions") or line))
    if from_file:
        return issues  # (the file's own checks: h5drm_issues, once the mesh plan is known)
    gm, gml = d["ground_motion"], section_lines("ground_motion")
    if gm["source"] == "none":
        issues.append(Issue("ground_motion.source", "none", f"leaves the {kind} wave without its record",
                            "give the wave's record as the horizontal record (source: file or synthetic)",
                            gml.get("source")))
    for key in ("second_horizontal", "vertical"):
        if gm[key]["file"] is not None:
            issues.append(Issue(f"ground_motion.{key}.file", gm[key]["file"], f"is a further component; the {kind} "
                                "wave is defined by one record, its direction by incident_wave", f"remove {key}",
                                gml.get(key)))
    if gm["vertical_ratio"]:
        issues.append(Issue("ground_motion.vertical_ratio", gm["vertical_ratio"], f"adds a vertical motion, which the "
                            f"{kind} wave's own field gives", "set vertical_ratio: 0", gml.get("vertical_ratio")))
    if gm["azimuth"]:
        issues.append(Issue("ground_motion.azimuth", gm["azimuth"], "turns the horizontal record; the wave's "
                            "direction is incident_wave.azimuth", "remove ground_motion.azimuth (or 0)",
                            gml.get("azimuth")))
    if issues or any(m not in d["materials"] for m, _ in layers):
        return issues  # (a layer without its material: said by the layers' own check)
    from .freefield import FreeFieldError, incident_motion

    try:
        profile = ground_profile(d, layers)
        # (a within record's deconvolution depends on the record's content: case._within_record_checks)
        conv = "outcrop" if convention(d) == "within" else convention(d)
        incident_motion(np.zeros(4), 0.01, plane_wave(d), profile, conv)
    except FreeFieldError as e:
        key = "angle" if "angle" in e.problem else "convention"
        issues.append(Issue(f"incident_wave.{key}", w[key] if key == "angle" else convention(d), e.problem,
                            e.fix or "see docs/theory.md §6.1", wl.get(key) or line))
    return issues


def band_issue(d: dict, plan, section_lines) -> Issue | None:
    """The DRM layer must stay in the outer ground, outside the near-field box round the tunnel:
    the bands beside and below it need drm_offset + 2 elements or more."""
    offset = int(d["incident_wave"]["drm_offset"])
    bands = {b: sum(div.count for _, div in getattr(plan, b)) for b in ("left", "right", "bottom")}
    short = {b: n for b, n in bands.items() if n < offset + 2}
    if not short:
        return None
    b, n = min(short.items(), key=lambda kv: kv[1])
    return Issue("incident_wave.drm_offset", offset, f"puts the DRM layer into the near-field box round the tunnel: "
                 f"the {b} band has {n} element(s) between the box and the block's face, and the layer needs "
                 f"drm_offset + 2 = {offset + 2}", "lower drm_offset, enlarge the block, or lower "
                 "mesh.max_element_size", section_lines("incident_wave").get("drm_offset"))


def inner_box(plan, offset: int) -> tuple[tuple[float, float], tuple[float, float], float]:
    """((x0, x1), (y0, y1), z0): the region inside the DRM layer (its inner nodes' planes), from
    the mesh plan's grid lines: offset + 1 elements in from the sides and the base."""
    from .meshing.params import grid_lines

    xs, ys, zs = grid_lines(plan)
    k = offset + 1
    return (float(xs[k]), float(xs[-1 - k])), (float(ys[k]), float(ys[-1 - k])), float(zs[k])


def layer_points(plan, offset: int) -> tuple[np.ndarray, np.ndarray]:
    """(xyz, internal) of the DRM layer's nodes that lie on the mesh plan's outer grid, without
    meshing: the grid's points of the shell between the planes `offset` and `offset` + 1 in from the
    sides and the base (drm_layer finds them in the mesh); internal: on the inner planes or inside
    them. Left out: the end caps' nodes inside the near-field box round the tunnel (its O-grid, the
    plugged tunnel), which only the mesh gives."""
    from .meshing.params import grid_lines

    xs, ys, zs = grid_lines(plan)
    o = offset
    i, j, k = np.meshgrid(np.arange(o, xs.size - o), np.arange(o, ys.size - o), np.arange(o, zs.size), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    nx, ny = xs.size - 1, ys.size - 1
    inside = (i > o + 1) & (i < nx - o - 1) & (j > o + 1) & (j < ny - o - 1) & (k > o + 1)
    inner = (i >= o + 1) & (i <= nx - o - 1) & (j >= o + 1) & (j <= ny - o - 1) & (k >= o + 1)
    L, tol = plan.box_half_width, 1e-9 * max(1.0, plan.box_half_width)
    in_box = (np.abs(xs[i] - plan.xc) < L - tol) & (np.abs(zs[k] - plan.zc) < L - tol)
    keep = ~inside & ~in_box
    xyz = np.stack([xs[i[keep]], ys[j[keep]], zs[k[keep]]], axis=1).astype(float)
    return xyz, inner[keep]


def h5drm_options(d: dict) -> dict:
    """read_h5drm's keyword arguments from incident_wave.h5drm (OpenSees' H5DRM mapping: x = T
    (crd_scale (x_file - drmbox_x0)) + x0 for the points, u = factor diag(1, 1, -1) row for the
    motion, which T does not turn)."""
    from .freefield import OPENSEES_ROWS

    h = d["incident_wave"]["h5drm"]
    T = np.asarray(h["transformation"], dtype=float).reshape(3, 3)
    return {"scale": float(h["crd_scale"]), "transform": T, "origin": np.asarray(h["x0"], dtype=float),
            "rows": OPENSEES_ROWS, "motion_scale": float(h["factor"]), "tolerance": float(h["distance_tolerance"])}


def h5drm_issues(d: dict, plan, case_dir, section_lines, t_end: float | None) -> list[Issue]:
    """An H5DRM file the run could not use, named under incident_wave.h5drm: missing, not in the
    layout or of inconsistent shapes, a clock that is not increasing or does not reach t_end (the
    seismic stage's length, when known), points that do not match the DRM layer's nodes (the count
    and the largest distance: a wrong crd_scale), inner and outer flags that disagree."""
    from pathlib import Path

    from .freefield import FreeFieldError, h5drm_layout, match_points

    h = d["incident_wave"]["h5drm"]
    hl = section_lines("incident_wave")
    line = hl.get("h5drm")
    key = "incident_wave.h5drm.file"
    path = Path(h["file"]) if Path(h["file"]).is_absolute() else Path(case_dir) / h["file"]
    if not path.is_file():
        return [Issue(key, h["file"], f"{path}: file not found", "give the H5DRM file's path, relative to the case "
                      "file", line)]
    try:
        lay = h5drm_layout(path)
    except FreeFieldError as e:
        return [Issue(key, h["file"], e.problem, e.fix or "give a file in the H5DRM layout (docs/formats.md "
                      "\"H5DRM\")", line)]
    issues = []
    span = lay["dt"] * (lay["samples"] - 1)
    if t_end is not None and span < t_end - 1e-9 * max(t_end, 1.0):
        issues.append(Issue(key, h["file"], f"holds {lay['samples']} samples every {lay['dt']:g} s ({span:g} s from "
                            f"its first sample), shorter than the seismic stage's {t_end:g} s: the free field would "
                            "stand still after the file's end", "give a file that lasts the run, or a shorter "
                            "time.end_time", line))
    opts = h5drm_options(d)
    xyz, internal = layer_points(plan, int(d["incident_wave"]["drm_offset"]))
    pts = ((lay["xyz"] - lay["x0"][None]) * opts["scale"]) @ opts["transform"].T + opts["origin"][None]
    try:
        idx = match_points(xyz, pts, opts["tolerance"])
    except FreeFieldError as e:
        return issues + [Issue(key, h["file"], f"{path}: {e.problem}", "set incident_wave.h5drm.crd_scale, "
                               "transformation and x0 so that the file's points land on the model's (OpenSees' "
                               "mapping), or give the file of this model's DRM layer", line)]
    if lay["internal"] is not None:
        bad = np.flatnonzero(internal != lay["internal"][idx])
        if bad.size:
            issues.append(Issue(key, h["file"], f"{path}: {bad.size} of {len(idx)} DRM layer nodes are inner (b) "
                                "nodes in the model and outer (e) ones in the file or the reverse (first at "
                                f"{tuple(round(float(v), 3) for v in xyz[bad[0]])} m)", "give the file of this "
                                "model's DRM layer (incident_wave.drm_offset)", line))
    return issues


def monitor_issues(d: dict, plan, section_lines) -> list[Issue]:
    """Outside the DRM layer tq-solid computes the scattered field only (u minus the free field):
    a monitor there, or the base and side reference points of output.displacement_reference, would
    record that, not the motion."""
    (x0, x1), (y0, y1), z0 = inner_box(plan, int(d["incident_wave"]["drm_offset"]))
    out = []
    ref = d["output"]["displacement_reference"]
    if ref != "absolute":
        out.append(Issue("output.displacement_reference", ref, "is measured at the model's base or side, outside the "
                         "DRM layer, where tq-solid computes the scattered field only", "use displacement_reference: "
                         "absolute with an incident wave", section_lines("output").get("displacement_reference")))
    tol = 1e-6 * max(x1 - x0, y1 - y0)
    for name, p in (d["output"]["monitors"] or {}).items():
        if p is not None and not (x0 - tol <= p[0] <= x1 + tol and y0 - tol <= p[1] <= y1 + tol and p[2] >= z0 - tol):
            out.append(Issue(f"output.monitors.{name}", p, f"lies outside the DRM layer (the region inside it is x "
                             f"{x0:g}..{x1:g}, y {y0:g}..{y1:g}, z >= {z0:g} m), where tq-solid computes the "
                             "scattered field only, not the motion", "move it inside that region",
                             section_lines("output").get("monitors")))
    return out


# ------------------------------------------------------------------------------------------------
# The layer in a mesh, and /drm
# ------------------------------------------------------------------------------------------------
class DrmLayerError(ValueError):
    """The mesh has no DRM layer where the case asks for one; the text says why and what to do."""


def drm_layer(xyz: np.ndarray, conn: np.ndarray, offset: int, faces: dict) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, internal) of the DRM layer `offset` element rings in from the faces named in `faces`
    ({name: quads}: the four sides and the base). Ring 1: the elements with a node on those faces;
    ring k + 1: those sharing a node with ring k and in no earlier ring. The layer's inner nodes (b)
    are those it shares with the region inside it, its outer ones (e) the rest."""
    n_el = conn.shape[0]
    ring = np.zeros(n_el, np.int32)
    front = np.zeros(xyz.shape[0], bool)
    for q in faces.values():
        front[np.asarray(q).ravel()] = True
    for k in range(1, offset + 2):
        hit = (ring == 0) & front[conn].any(axis=1)
        ring[hit] = k
        front = np.zeros(xyz.shape[0], bool)
        front[conn[hit].ravel()] = True
    layer, inner = ring == offset + 1, ring == 0
    if not layer.any() or not inner.any():
        raise DrmLayerError(f"the mesh has no element {offset + 1} rings in from its sides and base, or none inside "
                            "that ring: lower incident_wave.drm_offset or refine the mesh")
    in_layer = np.zeros(xyz.shape[0], bool)
    in_layer[conn[layer].ravel()] = True
    in_inner = np.zeros(xyz.shape[0], bool)
    in_inner[conn[inner].ravel()] = True
    nodes = np.flatnonzero(in_layer)
    return nodes, in_inner[nodes]
