"""The case file (`case.yaml`): its schema, its validation, and the validated `Case`.

Every key is documented here with its unit; docs/user_guide.md is written from the same table.
Values are SI numbers or '<number> <unit>' strings (see units.py). Unknown keys, missing keys,
wrong units and impossible values are errors naming the key, the value, the line and the fix.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from . import units as U
from .post import DISPLACEMENT_REFERENCES
from .schema import (
    Bool,
    CaseError,
    Choice,
    Issue,
    LineDict,
    ListOf,
    MapOf,
    Number,
    OneOrMap,
    Section,
    Text,
    Tuple,
    load_yaml,
    validate,
)
from .solver_input_table import MODELS

#: the fix of a bare PGA
PGA_EXAMPLE = "'0.3 g' or '2.94 m/s^2'"
STAGES = ("in_situ", "excavation", "lining", "hydrostatic", "seismic")
CONDITIONS = ("no_water", "static_water", "dynamic_water")
#: s of simulated time between the water's printed passes (water.log: brief)
WATER_LOG_INTERVAL = 0.01
#: Pa: the bulk modulus of fresh water near 10-20 degC (water.bulk_modulus's default); the one place the
#: number is written (fluid_case.py and the verification scripts read it here)
WATER_BULK_MODULUS = 2.2e9
#: s of simulated time between restart checkpoints (output.checkpoint_interval): the cost of one
#: is measured in docs/benchmarks.md "Restart checkpoints"
CHECKPOINT_INTERVAL = 1.0


def _num(dim=U.DIMENSIONLESS, doc="", **kw) -> Number:
    return Number(dim=dim, doc=doc, **kw)


def _length(doc="", **kw):
    return _num(U.LENGTH, doc, **kw)


def _positive(dim, doc, **kw):
    return Number(dim=dim, doc=doc, min=0.0, min_open=True, **kw)


# ----------------------------------------------------------------------------------------------
# Cross-field checks (run only when the section itself is valid)
# ----------------------------------------------------------------------------------------------
def _check_geometry(g, path, raw: LineDict, ctx):
    (x0, x1), (z0, z1) = g["x_range"], g["z_range"]
    b = g["excavated_radius"]
    if g["lining_thickness"] >= b:
        ctx.error(f"{path}.lining_thickness", g["lining_thickness"],
                  f"must be smaller than the excavated radius {b:g} m (the water needs room)",
                  "check the two values (paper: radius 5.25 m, lining 0.75 m)", raw.key_lines.get("lining_thickness"))
    cx, cz = g["tunnel_centre_x"], g["tunnel_centre_z"]
    if not (x0 < cx - b and cx + b < x1 and z0 < cz - b and cz + b < z1):
        ctx.error(f"{path}.tunnel_centre_z", cz,
                  f"the tunnel (centre x={cx:g}, z={cz:g}, radius {b:g} m) does not fit inside the block "
                  f"x {x0:g}..{x1:g}, z {z0:g}..{z1:g}", "move the tunnel or enlarge the block",
                  raw.key_lines.get("tunnel_centre_z"))


def _check_material(m, path, raw, ctx):
    from .solver_input_table import required_by

    for key in required_by(m["model"]):  # the solver's table says what the model needs
        if m[key] is None:
            ctx.error(f"{path}.{key}", None, f"is required by model {m['model']}",
                      f"add '{key}:' or set model: elastic", raw.line)
    if m["dilation_angle"] is not None and m["friction_angle"] is not None and m["dilation_angle"] > m["friction_angle"]:
        ctx.error(f"{path}.dilation_angle", m["dilation_angle"],
                  f"exceeds the friction angle {m['friction_angle']:g} deg (non-physical dilatancy)",
                  "use a dilation angle between 0 and the friction angle", raw.key_lines.get("dilation_angle"))


def _check_interface(i, path, raw, ctx):
    if i["dynamic_friction"] > i["static_friction"]:
        ctx.error(f"{path}.dynamic_friction", i["dynamic_friction"],
                  f"exceeds the static friction {i['static_friction']:g}",
                  "use dynamic <= static friction (paper: both 0.6)", raw.key_lines.get("dynamic_friction"))


def _check_layer(layer, path, raw, ctx):
    if (layer["bottom"] is None) == (layer["thickness"] is None):
        ctx.error(f"{path}.bottom", layer["bottom"], "give the layer's bottom elevation or its thickness, one of the two",
                  "write 'bottom: <z> m' or 'thickness: <t> m'", raw.line)


def ground_layers(d: dict) -> list[tuple[str, float]]:
    """The case's ground layers from the surface down as [(material, z of the layer's bottom)]
    (a thickness counted down from the bottom of the layer above, the first from the ground
    surface geometry.z_range[1]); what the mesher takes (meshing.params.resolve)."""
    out, z = [], d["geometry"]["z_range"][1]
    for layer in d.get("layers") or []:
        z = layer["bottom"] if layer["bottom"] is not None else z - layer["thickness"]
        out.append((layer["material"], float(z)))
    return out


# ----------------------------------------------------------------------------------------------
# Regions bounded by planes: a fault zone and dipping layers (meshing/geology.py)
# ----------------------------------------------------------------------------------------------
#: the convention of directions, said once for every key that takes one
AZIMUTH = "degrees in plan from the tunnel axis +y, clockwise seen from above (towards +x)"


def _geology_section() -> Section:
    def dip(what):
        return Number(min=0.0, min_open=True, max=90.0, why="degrees below horizontal: 90 is vertical, and a "
                      "horizontal interface is a layers[] entry", doc=f"{what}, degrees below horizontal, in (0, 90]")

    point = Tuple(item=_length(), length=3, doc="[x, y, z] m, a point on the plane")
    fault = Section(checks=[_check_fault_zone], fields={
        "material": Text(doc="the band's material: a name in materials, its own mesh region"),
        "width": _positive(U.LENGTH, "true thickness of the band, normal to its plane, m"),
        "strike": Number(min=0.0, max=360.0, doc=f"direction of the fault's horizontal trace, {AZIMUTH}: the angle "
                                                   "at which it crosses the tunnel; it dips to the right of it "
                                                   "(towards strike + 90)"),
        "dip": dip("the fault's dip"),
        "point": Tuple(item=_length(), length=3, doc="[x, y, z] m, a point on the band's centre plane (e.g. where "
                                                     "it crosses the tunnel axis)"),
        "elements_across": Number(integer=True, min=1, default=4,
                                  doc="elements along the tunnel axis across the band where it crosses the "
                                      "near-field box (the axial divisions are refined there)"),
    })
    layer = Section(fields={
        "material": Text(required=True, doc="the layer's material: a name in materials, its own mesh region"),
        "dip": dip("dip of the layer's bottom plane"),
        "dip_direction": Number(min=0.0, max=360.0, required=True,
                                doc=f"azimuth of the bottom plane's steepest descent, {AZIMUTH}"),
        "point": point,
    })
    for f in ("dip", "point"):
        layer.fields[f].required = True
    slope = Section(checks=[_check_slope], fields={
        "angle": Number(min=0.0, min_open=True, max=90.0, max_open=True,
                        why="degrees below horizontal: 0 is flat ground (leave the slope out) and a vertical face "
                            "is not meshed",
                        doc="the slope's angle, degrees below horizontal, in (0, 90)"),
        "dip_direction": Number(min=0.0, max=360.0, doc=f"azimuth the ground descends towards, {AZIMUTH}"),
        "crest": Tuple(item=_length(), length=2, doc="[x, y] m, a point in plan of the crest line (the slope's top "
                                                       "edge, at the block's top geometry.z_range[1])"),
        "height": _positive(U.LENGTH, "the drop from the crest to the toe, m (flat ground below the toe); default: "
                                      "no toe inside the block"),
    })
    portal = Section(checks=[_check_portal], fields={
        "station": _length("y of the face where the tunnel leaves the hillside, m; the face looks towards -y (the "
                           "block's ymin face): in front of it the ground is cut down to the bench (the bottom of the "
                           "tunnel's near-field box) and the tunnel ends"),
        "slope_deg": Number(min=0.0, min_open=True, max=90.0, max_open=True,
                            why="degrees below horizontal: 0 is flat ground and a vertical face is the headwall alone",
                            doc="the slope above the face, degrees below horizontal, in (0, 90): it rises from the "
                                "face's head to the block's top"),
        "skew_deg": Number(min=-60.0, max=60.0, default=0.0,
                           doc="degrees between the slope's strike and the normal to the tunnel axis (the slope "
                               "descends towards azimuth 180 + skew_deg); 0: its strike square to the axis"),
        "cover": _positive(U.LENGTH, "m of ground over the crown at the face (the headwall's top); default: the least "
                                     "the mesh allows (a quarter of the ground above the near-field box kept)"),
    })
    return Section(doc="rock regions bounded by planes and the ground surface (docs/meshing.md \"Regions bounded by "
                       "planes\", \"Sloping ground surface\"; docs/user_guide.md \"Portal\")", fields={
        "slope": slope,
        "portal": portal,
        "fault_zone": fault,
        "dipping_layers": ListOf(item=layer, default=[],
                                 doc="layers whose bottom is a plane of any dip, from the top down: an element "
                                     "above a bottom plane is that layer's unless a layer listed before (or a "
                                     "horizontal layers[] entry) has it; below them all, materials.rock"),
    })


def _check_slope(sl, path, raw, ctx):
    if sl["angle"] is None:
        given = [k for k in ("dip_direction", "crest", "height") if sl[k] is not None]
        if given:
            ctx.error(f"{path}.angle", None, f"is missing: {', '.join(given)} describe a slope of no angle",
                      "add 'angle: <deg below horizontal, in (0, 90)>'", raw.line)
        return
    for k, fix in (("dip_direction", "add 'dip_direction: <azimuth the ground descends towards, deg from the tunnel "
                                     "axis y, clockwise seen from above>'"),
                   ("crest", "add 'crest: [x, y]' (a point of the slope's top edge in plan, in m)")):
        if sl[k] is None:
            ctx.error(f"{path}.{k}", None, "is required with a slope", fix, raw.line)


def _check_portal(po, path, raw, ctx):
    given = [k for k in ("station", "slope_deg", "cover") if po[k] is not None]
    if given and po["station"] is None:
        ctx.error(f"{path}.station", None, f"is missing: {', '.join(given)} describe a portal with no face",
                  "add 'station: <y of the face, m>'", raw.line)
    elif given and po["slope_deg"] is None:
        ctx.error(f"{path}.slope_deg", None, "is required with a portal",
                  "add 'slope_deg: <the slope above the face, deg below horizontal, in (0, 90)>'", raw.line)


def _check_fault_zone(fz, path, raw, ctx):
    given = [k for k in ("width", "strike", "dip", "point") if fz[k] is not None]
    if fz["material"] is None and given:
        ctx.error(f"{path}.material", None, f"is missing: {', '.join(given)} describe a fault zone of no material",
                  "add 'material: <a name in materials>'", raw.line)
    elif fz["material"] is not None:
        for k in ("width", "strike", "dip", "point"):
            if fz[k] is None:
                ctx.error(f"{path}.{k}", None, "is required with a fault zone",
                          {"width": "add 'width: <true thickness> m'",
                           "strike": "add 'strike: <deg from the tunnel axis y, clockwise seen from above>'",
                           "dip": "add 'dip: <deg below horizontal, in (0, 90]>'",
                           "point": "add 'point: [x, y, z]' (a point on its centre plane, in m)"}[k], raw.line)


def _fault_offset_section() -> Section:
    return Section(checks=[_check_fault_offset],
                   doc="a prescribed slip across geology.fault_zone, imposed on the block's boundaries before the "
                       "shaking (docs/solid_solver.md \"Fault offset\")", fields={
        "slip": Tuple(item=_length(), length=3,
                      doc="[x, y, z] m: the hanging wall's displacement relative to the footwall, in the fault's "
                          "plane (or give magnitude and rake)"),
        "magnitude": _positive(U.LENGTH, "the slip's length in the fault's plane, m (with rake)"),
        "rake": Number(min=-180.0, max=180.0,
                       doc="degrees in the fault's plane from its strike direction (Aki & Richards): 90 reverse "
                           "(the hanging wall up dip), -90 normal, 0 left-lateral, 180 right-lateral"),
        "increments": Number(integer=True, min=1, default=10,
                             doc="equal steps the static slip is imposed in, each relaxed to static equilibrium "
                                 "(more follow a yielding ground's path more closely)"),
        "rise_time": _positive(U.TIME, "s: the slip during the run instead, from start_time over rise_time (a "
                                       "cosine ramp), the block's faces but the top held to it, so no record "
                                       "enters (the slip alone, dynamic); none: the static offset before the "
                                       "shaking"),
        "start_time": Number(dim=U.TIME, min=0.0, doc="s from the start of the run (the seismic stage) at which a "
                                                      "slip with rise_time starts (default 0)"),
    })


def _check_fault_offset(fo, path, raw, ctx):
    line = raw.line if isinstance(raw, LineDict) else None
    if fo["slip"] is not None and fo["magnitude"] is not None:
        ctx.error(f"{path}.magnitude", fo["magnitude"], "is given with slip: the slip is given twice",
                  "give either slip: [x, y, z] or magnitude and rake", line)
    elif fo["magnitude"] is not None and fo["rake"] is None:
        ctx.error(f"{path}.rake", None, "is required with magnitude",
                  "add 'rake: <deg in the fault plane from the strike: 90 reverse, -90 normal, 0 left-lateral>'",
                  line)
    elif fo["rake"] is not None and fo["magnitude"] is None:
        ctx.error(f"{path}.magnitude", None, "is required with rake", "add 'magnitude: <slip> m'", line)
    if fo["start_time"] is not None and fo["rise_time"] is None:
        ctx.error(f"{path}.start_time", fo["start_time"], "times a slip during the run, which needs rise_time",
                  "add 'rise_time: <s>' (the slip during the run), or remove start_time (the static offset before "
                  "the shaking)", line)


def fault_offset_slip(d: dict):
    """The hanging wall's displacement relative to the footwall (numpy [3], m) of a validated
    case's fault_offset section, None when it has none."""
    import numpy as np

    fo = d.get("fault_offset") or {}
    if fo.get("slip") is not None:
        return np.asarray(fo["slip"], float)
    if fo.get("magnitude") is None:
        return None
    from .meshing.geology import slip_vector

    fz = d["geology"]["fault_zone"]
    return slip_vector(fz["strike"], fz["dip"], float(fo["magnitude"]), float(fo["rake"]))


def _fault_offset_checks(d: dict, raw: LineDict) -> list[Issue]:
    """A slip needs a fault zone, and lies in its plane."""
    import numpy as np

    fo = d.get("fault_offset") or {}
    given = fo.get("slip") is not None or fo.get("magnitude") is not None
    if not given:
        return []
    line = _section_lines(raw, "fault_offset").get("slip" if fo.get("slip") is not None else "magnitude")
    fz = (d.get("geology") or {}).get("fault_zone") or {}
    if fz.get("material") is None:
        return [Issue("fault_offset", None, "prescribes a slip with no fault zone to slip across",
                      "add geology.fault_zone (material, width, strike, dip, point), or remove fault_offset", line)]
    if fz.get("width") is None or fz.get("strike") is None or fz.get("dip") is None or fz.get("point") is None:
        return []  # the fault zone's own check names what is missing
    slip = fault_offset_slip(d)
    size = float(np.linalg.norm(slip))
    if size == 0:
        return [Issue("fault_offset.slip", list(map(float, slip)), "is zero: the fault does not move",
                      "give the hanging wall's displacement, e.g. slip: [0, 0, 0.5] m, or remove fault_offset", line)]
    end = (d.get("time") or {}).get("end_time")
    if fo.get("rise_time") is not None and end is not None and (fo.get("start_time") or 0.0) + fo["rise_time"] > end:
        return [Issue("fault_offset.rise_time", fo["rise_time"],
                      f"with start_time {fo.get('start_time') or 0.0:g} s ends the slip at "
                      f"{(fo.get('start_time') or 0.0) + fo['rise_time']:g} s, after the run's end (time.end_time "
                      f"{end:g} s)", "shorten the rise time or start the slip earlier, or lengthen time.end_time",
                      _section_lines(raw, "fault_offset").get("rise_time"))]
    geo = case_geology(d)
    normal = float(np.dot(slip, geo.fault.plane.normal))
    if abs(normal) > 1e-3 * size:
        along = slip - normal * np.asarray(geo.fault.plane.normal)
        return [Issue("fault_offset.slip", list(map(float, slip)),
                      f"has {normal:+.4g} m normal to the fault's plane ({100 * abs(normal) / size:.3g} % of its "
                      "length): it would open or close the fault",
                      "give a slip in the plane, e.g. its in-plane part "
                      f"[{along[0]:.4g}, {along[1]:.4g}, {along[2]:.4g}] m, or magnitude and rake", line)]
    return []


def _lining_joints_section() -> Section:
    return Section(doc="the lining as rings of one length along the axis, joined at circumferential joints "
                       "(3D meshes; docs/theory.md \"Lining joints\")", fields={
        "spacing": _positive(U.LENGTH, "m: each ring's length along the axis; joints every spacing from the "
                                       "tunnel's start, each on a plane of the mesh's axial element layers"),
        "normal_stiffness": _positive(U.STIFFNESS_PER_AREA, "k_n, Pa/m: the joint's normal stiffness per unit area "
                                                            "(opening = axial stress / k_n)"),
        "shear_stiffness": _positive(U.STIFFNESS_PER_AREA, "k_s, Pa/m: its shear stiffness per unit area (gaskets, "
                                                           "dowels)"),
        "tensile_strength": Number(dim=U.PRESSURE, min=0.0, default=0.0,
                                   doc="f_t, Pa: the axial tension a joint carries before it opens; once open it "
                                       "carries none (0: joints open under any tension)"),
        "friction": Number(min=0.0, doc="mu: the joint's shear capped at mu x its compression (slip beyond); none: "
                                        "the shear spring without a cap"),
        "allowed_opening": _positive(U.LENGTH, "m: the watertightness limit; the report compares each joint's "
                                               "largest opening with it"),
        "held_at": Choice(choices=JOINT_HOLDS, default="along_ring",
                          doc="where each ring is tied to the rock: along_ring (at every plane of nodes along "
                              "it but its -y end: grouted along its length) or ring_middle (at its middle "
                              "plane only, elsewhere free of the rock, without contact: rings held at "
                              "mid-length; needs rings of an even number of axial elements)"),
    })


#: lining_joints.held_at: where each ring is tied to the rock (meshing.build)
JOINT_HOLDS = ("along_ring", "ring_middle")


def lining_joints_active(d: dict) -> bool:
    """Whether the case asks for lining joints (any key of lining_joints given)."""
    lj = d.get("lining_joints") or {}
    return any(v is not None for k, v in lj.items() if k not in ("tensile_strength", "held_at"))  # (with defaults)


def joint_spacing(d: dict) -> float | None:
    """The lining's ring length (m) when the case has lining joints, else None."""
    return float(d["lining_joints"]["spacing"]) if lining_joints_active(d) else None


def joint_hold(d: dict) -> str:
    """Where the lining's rings are tied to the rock (lining_joints.held_at; along_ring without joints)."""
    return (d["lining_joints"].get("held_at") or "along_ring") if lining_joints_active(d) else "along_ring"


def _lining_joint_checks(d: dict, raw: LineDict) -> list[Issue]:
    """Joints need a 3D mesh, a spacing that divides the lining's length into whole rings shorter
    than it, and each joint on a plane of the axial element layers."""
    if not lining_joints_active(d):
        return []
    lj = d["lining_joints"]
    lines = _section_lines(raw, "lining_joints")
    here = raw.key_lines.get("lining_joints")
    for key, fix in (("spacing", "add 'spacing: <ring length> m' (e.g. 1.5 m)"),
                     ("normal_stiffness", "add 'normal_stiffness: <k_n> MPa/m' (a gasket: of the order of "
                                          "1e3-1e5 MPa/m)"),
                     ("shear_stiffness", "add 'shear_stiffness: <k_s> MPa/m'")):
        if lj.get(key) is None:
            return [Issue(f"lining_joints.{key}", None, "is required with lining joints", fix, here)]
    if "dynamic_water" in d["conditions"]:
        return [Issue("lining_joints", None, "cannot run with the dynamic_water condition: the coupled water's wall "
                      "has one node where the lining has two at every joint, and the exchange maps them one to one "
                      "(coincident map)", "run the no_water and static_water conditions (conditions: [no_water, "
                      "static_water]), or remove lining_joints", here)]
    if d["mesh"]["mode"] != "3d":
        return [Issue("lining_joints", None, f"needs a 3D mesh: a {d['mesh']['mode']} mesh has no length along the "
                      "axis to cut into rings", "set mesh.mode: 3d, or remove lining_joints", here)]
    import numpy as np

    from .meshing.params import lining_extent

    plan = _mesh_plan(d)
    if plan is None:
        return []  # said by _mesh_checks
    y0, y1 = lining_extent(plan)  # the plugs' ends, a portal's face, or the block's y faces
    length, s = y1 - y0, float(lj["spacing"])
    line = lines.get("spacing") or here
    tol = 1e-6 * length
    levels = np.asarray([y for y in plan.y_levels if y0 - tol <= y <= y1 + tol])
    h = float(np.diff(levels).max())
    options = [k for k in range(1, len(levels) - 1) if (len(levels) - 1) % k == 0]
    suggest = min(options, key=lambda k: abs(k * h - s)) * h if options else None
    count = round(suggest / h) if suggest is not None else 0
    hint = (f"e.g. {suggest:g} m ({count} axial element{'s' if count > 1 else ''} of {h:g} m)" if count else
            "refine mesh.elements_along_axis")
    if s >= length - tol:
        longest = f"e.g. {max(options) * h:g} m" if options else "refine mesh.elements_along_axis"
        return [Issue("lining_joints.spacing", s, f"is not shorter than the lining ({length:g} m from y = {y0:g} to "
                      f"{y1:g} m): no joint fits in it", f"give a ring length of whole axial elements that divides "
                      f"{length:g} m into two or more rings, {longest}", line)]
    n = length / s
    if abs(n - round(n)) > 1e-6 * n:
        return [Issue("lining_joints.spacing", s, f"divides the lining's {length:g} m into {n:.4g} rings: the rings "
                      "must be whole", f"give a spacing that divides {length:g} m and is a whole number of axial "
                      f"elements, {hint}", line)]
    for k in range(1, round(n)):
        y = y0 + k * s
        if np.abs(levels - y).min() > tol:
            return [Issue("lining_joints.spacing", s, f"puts joint {k} at y = {y:g} m, between the mesh's axial "
                          f"element layers ({h:g} m long): a joint must be a plane of element faces",
                          f"give a spacing that is a whole number of axial elements, {hint}, or set "
                          "mesh.elements_along_axis so that the layers fall on the joints", line)]
    if lj.get("held_at") == "ring_middle":
        for k in range(round(n)):
            y = y0 + (k + 0.5) * s
            if np.abs(levels - y).min() > tol:
                even = [m for m in options if m % 2 == 0]
                fix = (f"give rings of an even number of axial elements, e.g. spacing: "
                       f"{min(even, key=lambda m: abs(m * h - s)) * h:g} m, or " if even else
                       "refine mesh.elements_along_axis to give rings of an even number of axial elements, or ")
                return [Issue("lining_joints.held_at", "ring_middle", f"needs a plane of nodes at each ring's middle: "
                              f"the ring from y = {y0 + k * s:g} to {y0 + (k + 1) * s:g} m ({s:g} m, axial elements "
                              f"of {h:g} m) has none at y = {y:g} m",
                              fix + "hold the rings along their length (held_at: along_ring)",
                              lines.get("held_at") or here)]
    return []


def case_geology(d: dict):
    """The case's regions bounded by planes (meshing.geology.Geology), None when it has none."""
    from .meshing.geology import from_case

    return from_case(d.get("geology"))


def _geology_checks(d: dict, raw: LineDict) -> list[Issue]:
    """Every region the geology section names is a material of the case, and a region of its own
    (not rock, lining, a horizontal layer's or another plane region's). Where the planes lie
    against the block is the mesher's rule (meshing.params), said by _mesh_checks."""
    g = d.get("geology") or {}
    entries = [(f"geology.dipping_layers[{i}].material", e["material"]) for i, e in enumerate(g["dipping_layers"])]
    if g["fault_zone"]["material"] is not None:
        entries.append(("geology.fault_zone.material", g["fault_zone"]["material"]))
    lines = raw.key_lines if isinstance(raw, LineDict) else {}
    taken = {layer["material"] for layer in d.get("layers") or []}
    issues = []
    for key, name in entries:
        if name not in d["materials"]:
            issues.append(Issue(key, name, "is not a material of the case",
                                f"add materials.{name} (youngs_modulus, poisson_ratio, density, ...), or name one "
                                f"of: {', '.join(m for m in d['materials'] if m not in ('rock', 'lining'))}",
                                lines.get("geology")))
        elif name in ("rock", "lining") or name in taken:
            issues.append(Issue(key, name, "names a region the mesh has already (rock, lining, a layer's or another "
                                "plane region's): each region bounded by planes is its own mesh region",
                                "give it a material of its own (copy the material under another name)",
                                lines.get("geology")))
        taken.add(name)
    po = g.get("portal") or {}
    if po.get("station") is not None:
        if "dynamic_water" in d["conditions"]:
            issues.append(Issue("conditions", d["conditions"], "dynamic_water with geology.portal: the water's mesh "
                                "would end at the portal's face, and no water end condition is modelled there",
                                "run the portal with no_water or static_water", lines.get("conditions")))
        if (d.get("incident_wave") or {}).get("type", "none") not in ("none", None):
            issues.append(Issue("incident_wave.type", d["incident_wave"]["type"], "the free field of a plane wave is "
                                "computed for a flat ground surface only, and a portal cuts it",
                                "use incident_wave.type: none with geology.portal (the free-field columns at the "
                                "sides follow the cut)", lines.get("incident_wave")))
    return issues


WATER_END_KINDS = ("reservoir", "valve", "surge_tank")


def _water_end_section(where: str) -> Section:
    """What closes one end of an open water column (water.ends: open; docs/theory.md "The water column
    along the tunnel")."""
    return Section(fields={
        "kind": Choice(choices=WATER_END_KINDS, default="reservoir",
                       doc=f"the water column's end at {where}: reservoir (the head held, p = 0 hydrodynamic), "
                           "valve (closed: no flow), surge_tank (a free surface of the given area, its level a "
                           "state: dp/dt = rho_w g Q / area)"),
        "area": _positive(U.AREA, "the surge tank's free-surface area, m^2"),
    })


def water_end_kinds(d: dict) -> tuple[str, str]:
    """The kinds of the water column's two ends (y_min, y_max) in a 3D model with open ends."""
    w = d["water"]
    return tuple((w.get(e) or {}).get("kind") or "reservoir" for e in ("end_ymin", "end_ymax"))


def _water_end_checks(d: dict, raw: LineDict) -> list[Issue]:
    """A surge tank needs its area, an area a surge tank; the kinds need a 3D column with open ends, two
    valves leave it no end that fixes its pressure, and a surge tank's level is carried by the solid."""
    issues: list[Issue] = []
    w = d["water"]
    wraw = raw.get("water") if isinstance(raw.get("water"), dict) else LineDict()
    given = [e for e in ("end_ymin", "end_ymax") if e in wraw]
    for e in given:
        end, eraw = w.get(e) or {}, wraw.get(e) if isinstance(wraw.get(e), dict) else LineDict()
        kind, line = end.get("kind") or "reservoir", wraw.key_lines.get(e)
        if kind == "surge_tank" and end.get("area") is None:
            issues.append(Issue(f"water.{e}.area", None, "is missing: a surge tank with no area has no free surface "
                                "(its level rises by the inflow over the area)",
                                f"add the tank's free-surface area, e.g. 'water: {{{e}: {{kind: surge_tank, "
                                "area: 40 m^2}}}', or make the end a reservoir or a valve", line))
        if kind != "surge_tank" and end.get("area") is not None:
            issues.append(Issue(f"water.{e}.area", end["area"], f"is a surge tank's area, but water.{e}.kind is "
                                f"{kind}", "remove area, or use kind: surge_tank",
                                eraw.key_lines.get("area", line)))
    if given and (d["mesh"]["mode"] != "3d" or w["ends"] != "open"):
        e = given[0]
        issues.append(Issue(f"water.{e}.kind", (w[e] or {}).get("kind"), "closes one end of a water column along the tunnel, which needs a "
                            "3D model with water.ends: open (a slice, or closed ends, has no axial flow)",
                            "use mesh.mode: 3d and water.ends: open, or remove it", wraw.key_lines.get(e)))
        return issues
    kinds = water_end_kinds(d)
    if kinds == ("valve", "valve"):
        issues.append(Issue("water.end_ymax.kind", "valve", "closes the column's second end: with valves at both "
                            "ends no end holds the water's pressure level",
                            "make one end a reservoir or a surge tank, or use water.ends: closed",
                            wraw.key_lines.get("end_ymax")))
    if "surge_tank" in kinds and d["coupling"]["volume_law"] == "water":
        e = "end_ymin" if kinds[0] == "surge_tank" else "end_ymax"
        issues.append(Issue(f"water.{e}.kind", "surge_tank", "the surge tank's level is carried by tq-solid's water "
                            "law, but coupling.volume_law water leaves the whole pressure to the water solver",
                            "use coupling.volume_law: solid (the default)", wraw.key_lines.get(e)))
    return issues


def _component_section(what: str) -> Section:
    """A further component of the ground motion: a record file, scaled with the horizontal record's
    factor (the recorded ratio kept) unless it gives a PGA of its own."""
    return Section(fields={
        "file": Text(doc=f"{what}: record path, relative to the case file"),
        "format": Choice(choices=("auto", "at2", "two_column"), default="auto"),
        "units": Choice(choices=("g", "m/s^2", "cm/s^2", "gal"), default=None,
                        doc="units of the record's values (AT2: read from the header)"),
        "pga": _positive(U.ACCELERATION, "its own peak after processing, with its unit (g or m/s^2; default: scaled "
                                         "by the horizontal record's factor)", unit_required=True,
                         unit_example="'0.2 g' or '1.96 m/s^2'"),
    })


def _mesh_plan(d: dict):
    """The case's mesh plan (meshing.params.resolve: divisions and grading, nothing meshed), or None
    where the mesh keys cannot make one (_mesh_checks says why)."""
    from .meshing.params import MeshInputError, resolve

    try:
        return resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    except (MeshInputError, MemoryError, OverflowError):
        return None


def _open_ends_axial_checks(d: dict, raw: LineDict) -> list[Issue]:
    """Open water ends with the volume law in the solid: tq-solid's open-ends law joins the planes of
    wet nodes along the axis by the water's axial flow, and needs at least three of them (two axial
    elements along the lining; a half block's, between its plugs, up to a portal). It refuses fewer
    when it connects to the water, after the static stages; the case check does first."""
    if "dynamic_water" not in d["conditions"] or closed_section(d) or d["coupling"]["volume_law"] == "water":
        return []
    from .meshing.params import lining_extent

    plan = _mesh_plan(d)
    if plan is None:
        return []  # said by _mesh_checks
    y0, y1 = lining_extent(plan)
    tol = 1e-6 * max(1.0, y1 - y0)
    planes = sum(1 for y in plan.y_levels if y0 - tol <= y <= y1 + tol)
    if planes >= 3:
        return []
    m = d["mesh"]
    lines = _section_lines(raw, "mesh")
    half = " in the half block (mesh.symmetry: mid_length)" if half_block(d) else ""
    return [Issue("mesh.elements_along_axis", m["elements_along_axis"],
                  f"leaves the lining {planes - 1} axial element{'s' if planes != 2 else ''}{half} (y = {y0:g} to "
                  f"{y1:g} m), whose wetted face has {planes} plane{'s' if planes != 1 else ''} of nodes along the "
                  "axis: with water.ends open the water's axial flow joins those planes, and tq-solid needs at "
                  "least 3 (it refuses fewer when it connects to the water, after the static stages)",
                  "give more elements_along_axis (two or more along the lining, the plugs and a half block's "
                  "halving counted), or water.ends: closed, or coupling.volume_law: water",
                  lines.get("elements_along_axis") or lines.get("symmetry") or raw.key_lines.get("mesh"))]


def _check_design(des, path, raw, ctx):
    given = getattr(raw, "key_lines", {})
    if not given:
        return
    if not (des.get("concrete") or {}).get("fck"):
        ctx.error(f"{path}.concrete.fck", None, "is required with a design block",
                  "add design: {concrete: {fck: 30 MPa}} (the concrete's characteristic strength)", raw.line)
        return
    from .design.capacity import DesignParameters, design_mapping

    try:
        DesignParameters.from_mapping(design_mapping({"design": des}), path)
    except ValueError as e:
        ctx.error(path, None, str(e), 'correct the value (docs/user_guide.md "Lining design checks")', raw.line)


def _check_ground_motion(gm, path, raw, ctx):
    if gm["source"] == "file" and gm["file"] is None:
        ctx.error(f"{path}.file", None, "is required when source is 'file'",
                  "add 'file: <path to the record>' or use source: synthetic", raw.line)
    lines = raw.key_lines
    for key in ("second_horizontal", "vertical"):
        sub = gm[key]
        if {k for k, v in sub.items() if v not in (None, "auto")} and sub["file"] is None:
            ctx.error(f"{path}.{key}.file", None, f"is required when {key} is given",
                      f"add 'file: <path to the record>' under {key}, or remove {key}", lines.get(key, raw.line))
    if gm["vertical"]["file"] is None and gm["source"] != "none" and gm["vertical_ratio"] is None:
        ctx.error(f"{path}.vertical_ratio", None, "is missing: the vertical motion has no neutral default",
                  "add 'vertical_ratio: <v / h>' (0: no vertical motion; EN 1998-1 §3.2.2.3: 0.9 or 0.45 of the "
                  "horizontal's peak) or a vertical record (vertical: {file: ..., units: ...})", raw.line)
    if gm["vertical"]["file"] is not None and "vertical_ratio" in lines:
        ctx.error(f"{path}.vertical_ratio", gm["vertical_ratio"], "is given together with a vertical record",
                  "keep one: the vertical record (vertical.file) or the ratio", lines.get("vertical_ratio"))
    if gm["source"] == "none":
        if gm["file"] is not None:
            ctx.error(f"{path}.file", gm["file"], "a horizontal record is given but source is 'none'",
                      "use source: file, or remove it", lines.get("file", raw.line))
        if gm["vertical"]["file"] is None and gm["second_horizontal"]["file"] is None:
            ctx.error(f"{path}.vertical", None, "source 'none' leaves no motion at all",
                      "give the vertical record (vertical: {file: ..., units: ...}), or a horizontal source",
                      lines.get("source", raw.line))
        if "azimuth" in lines and gm["second_horizontal"]["file"] is None:
            ctx.error(f"{path}.azimuth", gm["azimuth"], "turns the horizontal records, and source 'none' with no "
                      "second_horizontal leaves none", "remove azimuth, or give a horizontal record",
                      lines.get("azimuth"))
        if "vertical_ratio" in lines:
            ctx.error(f"{path}.vertical_ratio", gm["vertical_ratio"],
                      "scales the horizontal record, and source 'none' has none",
                      "give the vertical motion as a record (vertical.file), or remove vertical_ratio",
                      lines.get("vertical_ratio"))
        if gm["pga"] is not None:
            ctx.error(f"{path}.pga", gm["pga"], "scales the horizontal record, and source 'none' has none",
                      "give the vertical record's own peak as vertical.pga", lines.get("pga"))


def _check_damping(d, path, raw, ctx):
    f1, f2 = d["frequencies"]
    if f1 >= f2 and d["ratio"] > 0 and d["model"] == "rayleigh":
        ctx.error(f"{path}.frequencies", [f1, f2], "must be two increasing frequencies",
                  "give [f1, f2] with f1 < f2, e.g. [1.5, 10] Hz", raw.key_lines.get("frequencies"))


def coupling_predictor(c: dict) -> str:
    """The predictor a coupling section asks for, with `auto` resolved (linear for implicit)."""
    p = c.get("predictor", "auto")
    if p == "auto":
        return "linear" if c["scheme"] == "implicit" else "constant"
    return p


def half_block(d: dict) -> bool:
    """Whether the case meshes the half of its 3D block below the middle of y_range (mesh.symmetry)."""
    return d["mesh"]["mode"] == "3d" and d["mesh"].get("symmetry", "none") != "none"


def closed_section(d: dict) -> bool:
    """Whether the case's water section is closed: a slice (no axial flow), or 3D with closed ends."""
    return d["mesh"]["mode"] == "slice" or d["water"]["ends"] == "closed"


def coupling_window_force_weight(c: dict) -> float:
    """The window force weight a coupling section asks for; absent: 0.75 for implicit windows of several
    steps (damps the period-two mode of the water's added mass; docs/coupler.md "Window force weight"),
    0.5 otherwise (where a weight has no effect)."""
    w = c.get("window_force_weight")
    if w is None:
        return 0.75 if c["scheme"] == "implicit" and int(c["window"]) > 1 else 0.5
    return float(w)


def coupling_defect_correction(c: dict) -> float:
    """The share of the unpaid defect a coupling section adds to each next window (docs/coupler.md
    "Defect correction"); 0: off (the default)."""
    return float(c.get("defect_correction") or 0.0)


#: the implicit scheme's default window and IQN-ILS reuse (steps, windows): the example slice's
#: measured setting (3.7x cheaper than one step a window: docs/benchmarks.md "The paper case's shortcuts")
IMPLICIT_WINDOW = 16


def coupling_window_problem(scheme: str, window: int) -> str | None:
    """Why a coupling window of `window` solid steps cannot go with `scheme`, or None: the paper's
    predictor-corrector makes its two passes for one-step windows. The one rule the case check and
    the coupled run ask; tq-solid's reader refuses the same /coupling (input_staged.cpp)."""
    if int(window) > 1 and scheme == "paper":
        return (f"a window of {int(window)} solid steps needs scheme explicit or implicit (the paper scheme's two "
                "passes are made for one-step windows)")
    return None


def _check_coupling(c, path, raw, ctx):
    if c.get("window") is None:
        c["window"] = IMPLICIT_WINDOW if c["scheme"] == "implicit" else 1
    if c.get("reuse") is None:
        c["reuse"] = IMPLICIT_WINDOW if c["scheme"] == "implicit" and c["acceleration"] == "iqn-ils" else 0
    if c.get("predictor") in ("linear", "damped") and c["scheme"] != "implicit":
        ctx.error(f"{path}.predictor", c["predictor"], f"the {c['predictor']} predictor starts the iterations of the "
                  f"implicit scheme; the {c['scheme']} scheme has none", "use predictor: auto (or constant), or scheme: implicit",
                  raw.key_lines.get("predictor"))
    if c.get("residual_scale") == "largest" and c["scheme"] != "implicit":
        ctx.error(f"{path}.residual_scale", c["residual_scale"], f"the residual scale is the implicit scheme's "
                  f"convergence test; the {c['scheme']} scheme tests none", "use residual_scale: current, or "
                  "scheme: implicit", raw.key_lines.get("residual_scale"))
    if c.get("reuse", 0) and (c["scheme"] != "implicit" or c["acceleration"] != "iqn-ils"):
        ctx.error(f"{path}.reuse", c["reuse"], "reuse keeps IQN-ILS columns from earlier windows",
                  "use scheme: implicit with acceleration: iqn-ils, or reuse: 0", raw.key_lines.get("reuse"))
    if c.get("window_force_weight") not in (None, 0.5) and (c["scheme"] != "implicit" or c["window"] == 1):
        why = (f"the {c['scheme']} scheme applies each answer of the water as it comes" if c["scheme"] != "implicit"
               else "a window of one step applies the window-end force alone")
        ctx.error(f"{path}.window_force_weight", c["window_force_weight"],
                  f"weights the force across the steps of an implicit window of several steps; {why}, so it "
                  f"would have no effect", "use scheme: implicit with window > 1, or leave window_force_weight out",
                  raw.key_lines.get("window_force_weight"))
    if c.get("defect_correction", 0) > 0 and (c["scheme"] != "implicit" or c["window"] == 1):
        ctx.error(f"{path}.defect_correction", c["defect_correction"],
                  "carries an implicit window's accepted defect into the next window of several steps; "
                  f"with scheme {c['scheme']} and window {c['window']} there is none to carry",
                  "use scheme: implicit with window > 1, or defect_correction: 0",
                  raw.key_lines.get("defect_correction"))
    if c["scheme"] == "implicit" and c["max_iterations"] < 2:
        ctx.error(f"{path}.max_iterations", c["max_iterations"], "the implicit scheme needs a pass to compare the "
                  "water's answer with and at least one more to correct the force; tq-solid refuses fewer than 2",
                  "set max_iterations: 2 or more (default 20), or scheme: explicit for one exchange a window",
                  raw.key_lines.get("max_iterations"))
    if (why := coupling_window_problem(c["scheme"], c["window"])) is not None:
        ctx.error(f"{path}.window", c["window"], why, "use scheme: implicit with this window, or window: 1",
                  raw.key_lines.get("window"))


def _check_stages(s, path, raw, ctx):
    seq = s["sequence"]
    order = [STAGES.index(x) for x in seq]
    if order != sorted(order):
        ctx.error(f"{path}.sequence", seq, f"stages are out of order (the order is {', '.join(STAGES)})",
                  "list them in that order, leaving out the ones not wanted", raw.key_lines.get("sequence"))
    if "seismic" not in seq:
        ctx.error(f"{path}.sequence", seq, "has no 'seismic' stage", "end the sequence with seismic",
                  raw.key_lines.get("sequence"))
    if "lining" in seq and "excavation" not in seq:
        ctx.error(f"{path}.sequence", seq, "activates the lining without an excavation",
                  "add 'excavation' before 'lining'", raw.key_lines.get("sequence"))
    if s["release_fraction"] < 1 and not ("excavation" in seq and "lining" in seq):
        ctx.error(f"{path}.release_fraction", s["release_fraction"],
                  "holds part of the excavation load until the lining stage, which the sequence does not have",
                  "add 'excavation' and 'lining' to stages.sequence, or set release_fraction to 1",
                  raw.key_lines.get("release_fraction"))


def _mesh_section() -> Section:
    """Mesh keys: the meshing module's own defaults, so the two cannot disagree."""
    from .meshing import MESH_DEFAULTS, MESH_DOC

    fields: dict = {}
    for key, default in MESH_DEFAULTS.items():
        if key == "mode":
            fields[key] = Choice(choices=("3d", "slice"), default=default,
                                 doc="'3d' full model or 'slice' one element thick (plane strain)")
        elif key == "symmetry":
            fields[key] = Choice(choices=("none", "mid_length"), default=default)
        elif isinstance(default, bool):
            fields[key] = Bool(default=default)
        elif isinstance(default, int):
            fields[key] = Number(integer=True, min=0 if key == "tunnel_end_plugs" else 1, default=default)
        elif isinstance(default, float) or default is None:
            dim = U.LENGTH if key.endswith(("_size", "_radius", "_thickness", "_length", "_width")) else U.DIMENSIONLESS
            # default None: optional, the mesher resolves its absence (e.g. slice_thickness)
            fields[key] = Number(dim=dim, min=0.0, min_open=True, default=default)
        elif isinstance(default, str):
            fields[key] = Text(default=default)
        fields[key].doc = MESH_DOC.get(key, "")
    return Section(fields=fields, doc="mesh controls")


def _suite_section() -> Section:
    """The `suite:` keys (a set of records run as one job); their meaning is in suite.py."""
    from .suite import suite_section

    return suite_section()


def schema() -> Section:
    from .paper import PAPER_DOC, PAPERS

    material = Section(
        fields={
            "model": Choice(choices=MODELS, default="mohr_coulomb_damage",
                            doc="constitutive model (the models tq-solid registers)"),
            "youngs_modulus": _positive(U.PRESSURE, "Young's (deformation) modulus, Pa", required=True),
            "poisson_ratio": Number(min=-1.0, max=0.5, min_open=True, max_open=True, required=True,
                                    doc="Poisson ratio, -1 < nu < 0.5",
                                    why="nu = 0.5 is incompressible: no finite P-wave speed, no explicit step"),
            "density": _positive(U.MASS_DENSITY, "mass density, kg/m^3", required=True),
            "cohesion": Number(dim=U.PRESSURE, min=0.0, doc="Mohr-Coulomb cohesion c, Pa"),
            "friction_angle": Number(min=0.0, max=90.0, max_open=True, doc="friction angle phi, degrees"),
            "dilation_angle": Number(min=0.0, max=90.0, max_open=True, default=0.0,
                                     doc="dilation angle psi, degrees (default 0: non-associated, no dilatancy)"),
            "tensile_strength": Number(dim=U.PRESSURE, min=0.0, doc="tension cut-off sigma_t, Pa"),
            "compressive_strength": Number(dim=U.PRESSURE, min=0.0, min_open=True,
                                           doc="uniaxial compressive strength, Pa (reported only)"),
            "damage_constant": Number(min=0.0, default=100.0,
                                      doc="R in eq. (18), D_i = 1 - exp(-R |eps_i^p|); not given by the paper"),
            "damage_effect": Choice(choices=("cohesion", "cohesion_and_stiffness"), default="cohesion",
                                    doc="what damage reduces: cohesion only (eq. 16) or also the stiffness"),
            "tension_stiffening_beta": Number(min=0.0, max=1.0, default=1.0,
                                              doc="reinforced_concrete: beta of EN 1992-1-1 eq. (7.19), 1 "
                                                  "short-term, 0.5 sustained or repeated loading"),
            "retardation_time": Number(dim=U.TIME, min=0.0,
                                       doc="kelvin_voigt: retardation time tau, s (sigma = C:eps + tau C:deps/dt; "
                                           "damping ratio omega tau / 2 at angular frequency omega)"),
        },
        checks=[_check_material],
    )
    gm_synthetic = Section(fields={
        "seed": Number(integer=True, min=0, default=1940, doc="random seed"),
        "duration": _positive(U.TIME, "length of the synthetic record, s", default=20.0),
        "dt": _positive(U.TIME, "sampling step, s", default=0.01),
        "ground_frequency": _positive(U.FREQUENCY, "Kanai-Tajimi ground frequency, Hz", default=2.5),
        "ground_damping": _positive(U.DIMENSIONLESS, "Kanai-Tajimi ground damping ratio", default=0.6),
    })
    return Section(fields={
        "name": Text(required=True, doc="a short name for the case"),
        "description": Text(doc="free text"),
        "geometry": Section(required=True, checks=[_check_geometry], fields={
            "x_range": Tuple(item=_length(), increasing=True, required=True, doc="block extent across the tunnel, m"),
            "y_range": Tuple(item=_length(), increasing=True, required=True, doc="block extent along the tunnel axis, m"),
            "z_range": Tuple(item=_length(), increasing=True, required=True, doc="block extent vertically (top = ground surface), m"),
            "tunnel_centre_x": _length("x of the tunnel axis, m", default=0.0),
            "tunnel_centre_z": _length("elevation of the tunnel axis, m", required=True),
            "excavated_radius": _positive(U.LENGTH, "radius of the excavation, m", required=True),
            "lining_thickness": _positive(U.LENGTH, "lining thickness, m", required=True),
        }),
        "mesh": _mesh_section(),
        "materials": MapOf(item=material, required_keys=("rock", "lining"), required=True,
                           doc="one entry per mesh region: rock (the ground below any layers), lining, and "
                               "one per ground layer, named by layers[].material"),
        "layers": ListOf(item=Section(checks=[_check_layer], fields={
            "material": Text(required=True, doc="the layer's material: a name in materials other than rock and "
                                                "lining; also its region in the mesh"),
            "bottom": _length("elevation of the layer's bottom, m (or give thickness)"),
            "thickness": _positive(U.LENGTH, "m, counted down from the layer above (the first from the ground "
                                             "surface z_range[1]); or give bottom"),
        }), default=[], doc="horizontal ground layers from the surface down, each its own mesh region; below the "
                            "last the ground is materials.rock, which holds the tunnel and its near-field box "
                            "(docs/solid_solver.md \"Layered ground\")"),
        "geology": _geology_section(),
        "fault_offset": _fault_offset_section(),
        "interface": Section(checks=[_check_interface], fields={
            "model": Choice(choices=("dynamic_contact", "bonded"), default="dynamic_contact",
                            doc="rock-lining interface: the paper's dynamic contact force method, or always bonded"),
            "static_friction": Number(min=0.0, default=0.6, doc="mu_s"),
            "dynamic_friction": Number(min=0.0, default=0.6, doc="mu_d"),
            "cohesion": Number(dim=U.PRESSURE, min=0.0, default=0.5e6, doc="f_c, Pa"),
            "after_failure": Choice(choices=("cohesion_lost", "cohesion_kept"), default="cohesion_lost",
                                    doc="what a pair keeps once its bond has failed"),
        }),
        "lining_joints": _lining_joints_section(),
        "water": Section(fields={
            "density": _positive(U.MASS_DENSITY, "kg/m^3", default=1000.0),
            "viscosity": _positive(U.DYNAMIC_VISCOSITY, "dynamic viscosity, Pa s", default=1.308e-3),
            "head": Number(dim=U.LENGTH, min=0.0, default=0.0,
                           doc="pressure head at the tunnel axis, m of water: p = rho_w g (head - (z - z_axis))"),
            "model": Choice(choices=("incompressible", "compressible"), default="compressible",
                            doc="compressible: real water of bulk modulus K (the default); incompressible: the "
                                "limit K -> infinity (with coupling.volume_law solid the water's volume held by the "
                                "solid: a closed section's, or each plane's with open ends)"),
            "bulk_modulus": _positive(U.PRESSURE, "Pa, for the compressible model",
                                      default=WATER_BULK_MODULUS),
            "ends": Choice(choices=("open", "closed"), default=None,
                           doc="axial ends of the water column: open (pressure) or closed (walls); required by a 3D "
                               "model with dynamic_water (a slice has no axial flow)"),
            "end_ymin": _water_end_section("y_min"),
            "end_ymax": _water_end_section("y_max"),
            "log": Choice(choices=("brief", "verbose"), default="brief",
                          doc="dynamic_water's fluid.log: brief: OpenFOAM's lines and the loads on the lining "
                              "once every log_interval of simulated time (and the run's first and last pass); "
                              "verbose: every water pass, rolled-back ones and the solver residuals included "
                              "(about 1 kB a pass, for debugging; docs/water.md §2 \"Log\")"),
            "log_interval": _positive(U.TIME, "simulated time between the water's printed passes with log: brief, "
                                      "s", default=WATER_LOG_INTERVAL),
        }),
        "ground_motion": Section(required=True, checks=[_check_ground_motion], fields={
            "source": Choice(choices=("file", "synthetic", "none"), required=True,
                             doc="the horizontal motion: 'file' (a record), 'synthetic', or 'none' (no horizontal "
                                 "motion: a vertical-only motion given under vertical)"),
            "file": Text(doc="record path, relative to the case file"),
            "format": Choice(choices=("auto", "at2", "two_column"), default="auto"),
            "units": Choice(choices=("g", "m/s^2", "cm/s^2", "gal"), default=None,
                            doc="units of the record's values (AT2: read from the header)"),
            "if_missing": Choice(choices=("error", "synthetic"), default="error",
                                 doc="what to do when the record file is absent"),
            "duration": _positive(U.TIME, "window kept from the start of the record, s"),
            "pga": _positive(U.ACCELERATION, "peak ground acceleration of the horizontal record after processing, "
                                             "with its unit (g or m/s^2: a bare number is refused)",
                             unit_required=True, unit_example=PGA_EXAMPLE),
            "azimuth": Number(min=-360.0, max=360.0, default=0.0,
                              doc="direction of the horizontal record, degrees from x (across the tunnel) towards y "
                                  "(along its axis): x = cos(azimuth) h, y = sin(azimuth) h; 0: across the tunnel"),
            "second_horizontal": _component_section("a second horizontal record, at azimuth + 90 deg (with azimuth 0: "
                                                    "along the tunnel's axis, y)"),
            "vertical_ratio": Number(min=0.0, default=None,
                                     doc="vertical = ratio x the horizontal record; required unless vertical gives a "
                                         "record of its own (0: no vertical motion)"),
            "vertical": _component_section("a vertical record of its own (instead of vertical_ratio)"),
            "cutoff_frequency": _positive(U.FREQUENCY, "content above is removed, Hz", default=20.0),
            "baseline_correction": Bool(default=True),
            "convention": Choice(choices=("outcrop", "incident"), default="outcrop",
                                 doc="outcrop: incident = half the record; incident: the record itself"),
            "synthetic": gm_synthetic,
        }),
        "in_situ": Section(fields={
            "kx": _positive(U.DIMENSIONLESS, "sigma_x / sigma_z (K0 across the tunnel); required with the in_situ "
                                             "stage"),
            "ky": _positive(U.DIMENSIONLESS, "sigma_y / sigma_z (K0 along the axis); required with the in_situ stage"),
            "kz": _positive(U.DIMENSIONLESS, "vertical factor", default=1.0),
            "gravity": _positive(U.ACCELERATION, "m/s^2", default=9.81),
        }),
        "stages": Section(checks=[_check_stages], fields={
            "sequence": ListOf(item=Choice(choices=STAGES), min_length=1, unique=True, default=list(STAGES)),
            "relaxation_tolerance": Number(min=0.0, min_open=True, max=1.0, max_open=True, default=1e-4,
                                           doc="dynamic relaxation stops when |unbalanced| / |applied| is below "
                                               "this, 0 < tolerance < 1",
                                           why="1 would end each static stage at its start, unrelaxed; "
                                               "tq-solid's input takes 0 < relaxation_tolerance < 1"),
            "relaxation_max_steps": Number(integer=True, min=1, default=50000),
            "release_fraction": Number(min=0.0, max=1.0, default=1.0,
                                       doc="fraction, in [0, 1], of the excavation load (the released core tractions) "
                                           "relaxed with the rock alone before the lining is active; the rest is "
                                           "released in the lining stage on rock and lining together (beta-method, "
                                           "convergence-confinement, PLAXIS Mstage). 1: the lining is installed "
                                           "after full release and takes no excavation load; 0: it takes all of "
                                           "it (docs/theory.md §2)"),
        }),
        "conditions": ListOf(item=Choice(choices=CONDITIONS), min_length=1, unique=True,
                             default=list(CONDITIONS), doc="which of the paper's conditions to run"),
        "coupling": Section(checks=[_check_coupling], fields={
            "scheme": Choice(choices=("explicit", "paper", "implicit"), default="implicit",
                             doc="explicit: one exchange a window (staggered); paper: the paper's predictor-"
                                 "corrector, two passes; implicit: iterated to the tolerance (docs/coupler.md)"),
            "window": Number(integer=True, min=1, default=None,
                             doc="solid steps per coupling window (one water step); implicit: the window is stepped "
                                 "again until the water agrees (over what the water's force can reach within it, "
                                 "docs/coupler.md); k > 1 is refused for scheme paper. Default: "
                                 f"{IMPLICIT_WINDOW} for the implicit scheme (the example's measured setting), 1 "
                                 "otherwise"),
            "tolerance": Number(min=0.0, min_open=True, default=1e-4, doc="implicit scheme: relative residual"),
            "max_iterations": Number(integer=True, min=1, default=20,
                                     doc="implicit scheme: at most this many water passes a window, at least 2 "
                                         "(the first pass and one correction); a window still above the "
                                         "tolerance after them is accepted and counted in the results' "
                                         "/coupling unconverged_windows (docs/coupler.md)"),
            "energy_limit": Number(min=0.0, default=0.05,
                                   doc="stop the run when the energy the coupling created exceeds this fraction "
                                       "of the largest interface work so far (docs/coupler.md \"Energy guard\"); "
                                       "0: no stop"),
            "window_force_weight": Number(min=0.5, max=1.0, default=None,
                                          doc="implicit windows of several steps: weight of the window-end force "
                                              "in the force the solid's steps apply; 0.5: linear ramp from the "
                                              "window's start force, 1: the end force held; default 0.75 for "
                                              "implicit windows of several steps (damps the period-two mode of "
                                              "the water's added mass; docs/coupler.md \"Window force weight\"), "
                                              "0.5 otherwise"),
            "defect_correction": Number(min=0.0, max=1.0, default=0.0,
                                        doc="implicit windows of several steps: the share of the defect not yet "
                                            "repaid (the accepted windows' water answers less the window-end "
                                            "forces the solid stepped with) added to the force of the next "
                                            "window's steps, so that the lining receives the water's impulse "
                                            "and an accepted residual makes little energy at the interface; it "
                                            "costs water passes (docs/coupler.md \"Defect correction\"); 0: off"),
            "volume_law": Choice(choices=("solid", "water"), default="solid",
                                 doc="who carries the volumetric part of the water pressure. solid: tq-solid, "
                                     "implicitly each step (p = -K dV/V, or the volume held for incompressible "
                                     "water): in a closed section (a slice, or 3D with closed ends) one uniform "
                                     "pressure; with open ends one per plane of wet nodes along the axis, joined "
                                     "by the water's axial flow, p = 0 at the ends (docs/coupler.md \"Open "
                                     "ends\"); OpenFOAM sends the rest; stable for any bulk modulus. water: "
                                     "OpenFOAM's whole pressure (compressible water, or open ends; docs/coupler.md "
                                     "\"Volume law in the solid\")"),
            "water_translation": Choice(choices=("solid", "water"), default="solid",
                                        doc="with the volume law in the solid: who carries the water's rigid "
                                            "translation in the section's plane (its whole mass moving with the "
                                            "section's mean motion). solid: tq-solid, implicitly, so the water "
                                            "solver sees only the lining's deformation (any ground displacement); "
                                            "water: the water solver (docs/coupler.md \"Volume law in the "
                                            "solid\")"),
            "acceleration": Choice(choices=("none", "aitken", "iqn-ils"), default="iqn-ils"),
            "reuse": Number(integer=True, min=0, max=1000, default=None,
                            doc="implicit iqn-ils: keep the secant columns of this many earlier windows, so "
                                "a window's first correction is a quasi-Newton step (docs/coupler.md "
                                "\"Windows of several steps\"); 0: each window starts afresh. Default: "
                                f"{IMPLICIT_WINDOW} for implicit iqn-ils, 0 otherwise"),
            "predictor": Choice(choices=("auto", "constant", "linear", "damped"), default="auto",
                                doc="implicit scheme: the force a window starts from — constant: the last "
                                    "window's; linear: 2 R_w - R_(w-1), so a window whose first answer agrees "
                                    "needs one water pass; damped: R_w + 3/4 (R_w - R_(w-1)), the same with "
                                    "three quarters of the slope (docs/coupler.md \"Predictor\"); auto: linear "
                                    "for implicit, constant otherwise"),
            "residual_scale": Choice(choices=("current", "largest"), default="current",
                                     doc="implicit scheme: what a field's residual between passes is relative "
                                         "to — current: the field's norm in this pass; largest: the largest "
                                         "norm it had in any accepted window so far (or this pass's, if "
                                         "larger), so after the strongest motion a window converges to the "
                                         "tolerance of the largest values the interface carried "
                                         "(docs/coupler.md \"Convergence test\")"),
            "transport": Choice(choices=("tcp", "mpi"), default="tcp",
                                doc="tcp: the two processes `tunnelquake run` starts; mpi: tq-solid as one "
                                    "application of an MPMD mpirun job with an MPI-speaking fluid, started by "
                                    "hand (docs/coupler.md \"tq-solid under mpirun\"); OpenFOAM couples over tcp "
                                    "only, so dynamic_water needs tcp"),
            "timeout": _positive(U.TIME, "s; a silent partner for longer stops the run", default=120.0),
        }),
        "damping": Section(checks=[_check_damping], fields={
            "model": Choice(choices=("rayleigh", "mass_proportional"), default="mass_proportional",
                            doc="rayleigh: alpha M + beta K with the ratio at both frequencies; mass_proportional: "
                                "alpha M only, the ratio at the first frequency (no stiffness term, so no cut in the "
                                "stable step: see docs/theory.md §1)"),
            "ratio": Number(min=0.0, max=1.0, max_open=True, default=0.05, doc="damping ratio"),
            "frequencies": Tuple(item=_positive(U.FREQUENCY, "Hz"), default=[1.5, 10.0],
                                 doc="the two frequencies where the ratio is met, Hz"),
        }),
        "time": Section(fields={
            "dt": Number(dim=U.TIME, min=0.0, min_open=True, doc="solid step, s (default: the stable step x safety)"),
            "safety_factor": Number(min=0.0, max=1.0, min_open=True, default=0.9),
            "subcycling": OneOrMap(item=Number(integer=True, min=0, max=8), names=CONDITIONS, absent=0, default=0,
                                   name_kind="condition",
                                   example_map="of conditions to levels, e.g. {static_water: 3, dynamic_water: 3}",
                                   doc="multi-time-step solid: an element steps up to 2^n times the finest step "
                                       "where its own stable step allows (0 = one step for all); n for every "
                                       "condition, or a mapping of conditions to n (a condition left out: 0), e.g. "
                                       "{static_water: 3, dynamic_water: 3} (docs/solid_solver.md \"Subcycling\")"),
            "end_time": _positive(U.TIME, "s (default: the motion's duration)"),
        }),
        "output": Section(fields={
            "directory": Text(default="results",
                              doc="relative to the case file, inside its folder unless allow_outside is true"),
            "allow_outside": Bool(default=False,
                                  doc="let output.directory lie outside the case file's folder (an absolute path "
                                      "or one through ..)"),
            "monitors": MapOf(item=Tuple(item=_length(), length=3), default={},
                              doc="name: [x, y, z] points whose histories are written"),
            "history_interval": _positive(U.TIME, "s between monitor samples", default=0.005),
            "displacement_reference": Choice(
                choices=DISPLACEMENT_REFERENCES, default="absolute",
                doc="what the monitors' displacements in the report, the figures and monitors_<condition>.csv are "
                    "measured against: absolute (the fixed frame), base (the model's base under the tunnel axis) or "
                    "free_field (the free field at the tunnel axis' depth, on the xmin side); each from the start "
                    "of the shaking"),
            "snapshot_times": ListOf(item=Number(dim=U.TIME, min=0.0), default=[]),
            "checkpoint_interval": Number(dim=U.TIME, min=0.0, default=CHECKPOINT_INTERVAL,
                                          doc="s of simulated time between restart checkpoints, which `tunnelquake "
                                              "run --resume` continues from (0 = none; docs/user_guide.md "
                                              "\"Resuming a run\")"),
        }),
        "reference": Section(doc="a published run this case reproduces, compared with in the report", fields={
            "paper": Choice(choices=PAPERS, default=None, doc=PAPER_DOC),
        }),
        "design": Section(checks=[_check_design], fields={
            "code": Choice(choices=("EN1992-1-1",), default="EN1992-1-1",
                           doc="the code of the lining's capacity check (docs/user_guide.md \"Lining design checks\")"),
            "gamma_c": Number(min=0.0, min_open=True, default=1.5, doc="partial factor of concrete"),
            "gamma_s": Number(min=0.0, min_open=True, default=1.15, doc="partial factor of reinforcement"),
            "alpha_cc": Number(min=0.0, min_open=True, default=1.0, doc="long-term factor on fcd, reinforced"),
            "alpha_cc_plain": Number(min=0.0, min_open=True, default=0.8, doc="alpha_cc,pl of plain concrete"),
            "alpha_ct_plain": Number(min=0.0, min_open=True, default=0.8, doc="alpha_ct,pl of plain concrete"),
            "stress_block": Choice(choices=("parabola_rectangle", "rectangular"), default="parabola_rectangle"),
            "cracking_strength": Choice(choices=("fctm", "fctk_005", "fctm_fl", "fctd_pl"), default="fctm",
                                        doc="the tensile strength the cracking check uses"),
            "utilisation": Choice(choices=("radial", "constant_N"), default="radial",
                                  doc="of a reinforced section: along the ray from the origin, or at constant N"),
            "crack_width_limit": _positive(U.LENGTH, "w_max the crack width is checked against, m (e.g. 0.2 mm; "
                                                     "none: widths reported without a verdict)"),
            "seismic_situation": Section(doc="the seismic design situation's factors (EN 1990 eq. 6.12b): E_d = "
                                             "gamma_G E_G + psi2_water E_W + gamma_I dE_seismic", fields={
                "gamma_G": _positive(U.DIMENSIONLESS, "factor of the static state without water (lining, ground)",
                                     default=1.0),
                "psi2_water": Number(min=0.0, default=1.0, doc="factor of the water's static part"),
                "gamma_I": _positive(U.DIMENSIONLESS, "importance factor on the seismic increment (EN 1998-1 §4.2.5)",
                                     default=1.0),
            }),
            "concrete": Section(fields={
                "fck": _positive(U.PRESSURE, "characteristic cylinder strength, Pa (default: the lining's "
                                             "compressive_strength)"),
                "fctm": _positive(U.PRESSURE, "mean tensile strength, Pa (default: from fck, EN 1992-1-1 "
                                              "Table 3.1; without a design block the lining's tensile_strength)"),
            }),
            "reinforcement": Section(fields={
                "fyk": _positive(U.PRESSURE, "characteristic yield strength, Pa", default=500e6),
                "Es": _positive(U.PRESSURE, "Young's modulus of the steel, Pa", default=200e9),
                "eps_ud": Number(min=0.0, min_open=True, doc="steel strain limit (none: no limit)"),
                "As_inner": Number(dim=U.LENGTH, min=0.0, default=0.0, unit_required=True, unit_example="'1005 mm2/m'",
                                   doc="bar area per metre at the inner face, with its unit (mm2/m or m2/m)"),
                "As_outer": Number(dim=U.LENGTH, min=0.0, default=0.0, unit_required=True, unit_example="'1005 mm2/m'",
                                   doc="bar area per metre at the outer face, with its unit (mm2/m or m2/m)"),
                "As_inner_axial": Number(dim=U.LENGTH, min=0.0, default=0.0, unit_required=True,
                                         unit_example="'1005 mm2/m'",
                                         doc="axial bar area per metre of circumference at the inner face, with its "
                                             "unit (mm2/m or m2/m; the analysis' reinforced_concrete lining)"),
                "As_outer_axial": Number(dim=U.LENGTH, min=0.0, default=0.0, unit_required=True,
                                         unit_example="'1005 mm2/m'",
                                         doc="axial bar area per metre of circumference at the outer face, with its "
                                             "unit (mm2/m or m2/m)"),
                "axis_distance": _positive(U.LENGTH, "face to bar centroid, m", default=0.05),
                "bar_diameter": _positive(U.LENGTH, "diameter of the bars, m (the crack width needs it; EN 1992-1-1 "
                                                    "§7.3.4)"),
            }),
        }),
        "suite": _suite_section(),
        "incident_wave": _incident_wave_section(),
        "parallel": Section(fields={
            "threads": Number(integer=True, min=0, default=0, doc="solid OpenMP threads, 0 = the cores divided among the conditions running at once (one on a small mesh)"),
            "fluid_ranks": Number(integer=True, min=1, default=1,
                                  doc="MPI ranks of the water (OpenFOAM) in dynamic_water; above 1 the water "
                                      "case is decomposed (method simple, cut across the tunnel's axis in 3D) "
                                      "and run under mpirun, then reconstructed; at least 20 water cells a "
                                      "rank (docs/coupler.md); the ranks pay from about 1,800 cells a rank "
                                      "(the 3D example's half block, 3,696 cells on 2: 0.69-0.79x one rank's "
                                      "coupled wall; docs/benchmarks.md \"The 3D example's axial mesh\"); a restart checkpoint "
                                      "resumes on the count that wrote it"),
        }),
    })


@dataclass
class Case:
    """A validated case: SI values with defaults filled in."""

    path: Path
    data: dict
    warnings: list[str] = field(default_factory=list)
    #: the name of the `variants:` entry laid over the file, or None
    variant: str | None = None

    @property
    def dir(self) -> Path:
        return self.path.parent

    def __getitem__(self, key):
        return self.data[key]

    @property
    def output_dir(self) -> Path:
        return (self.dir / self.data["output"]["directory"]).resolve()


def subcycling_levels(d: dict, condition: str) -> int:
    """The subcycling levels (time.subcycling) condition `condition` steps its solid with: the one value
    given for every condition, or the condition's entry of a per-condition mapping (0 without one)."""
    levels = d["time"].get("subcycling")
    if isinstance(levels, dict):
        return int(levels.get(condition, 0))
    return int(levels or 0)


def _subcycling_checks(d: dict, raw: LineDict) -> list[Issue]:
    """time.subcycling steps each element at its own elastic step, which tq-solid cannot do for a viscous
    stress (a Kelvin-Voigt material's or Rayleigh's stiffness term: its step bound depends on the
    viscosity, docs/solid_solver.md "Subcycling"); its starter refuses both, so the case check does first.
    Only the conditions that run are asked: a per-condition level of a condition not run steps nothing."""
    on = [c for c in d["conditions"] if subcycling_levels(d, c) > 0]
    if not on:
        return []
    levels = d["time"]["subcycling"]
    line = _section_lines(raw, "time").get("subcycling")
    which = "" if len(on) == len(d["conditions"]) else f" (it subcycles {', '.join(on)})"
    out = []
    for region, m in d["materials"].items():
        tau = m.get("retardation_time") or 0.0
        if m["model"] == "kelvin_voigt" and tau > 0:
            out.append(Issue("time.subcycling", levels,
                             f"needs materials without viscosity{which}: materials.{region} is kelvin_voigt with "
                             f"retardation_time {tau:g} s, whose viscous stress tq-solid steps at the finest step "
                             "only", f"set time.subcycling: 0, or give materials.{region} a model without "
                             "viscosity (elastic)", line))
    dmp = d["damping"]
    if dmp["model"] == "rayleigh" and dmp["ratio"] > 0:
        out.append(Issue("time.subcycling", levels,
                         f"needs damping without the stiffness term{which}: damping.model rayleigh adds beta K, a "
                         "viscous stress tq-solid steps at the finest step only",
                         "use damping.model: mass_proportional (the default), or time.subcycling: 0", line))
    return out


def _bar_axis_checks(d: dict, raw: LineDict, where: int | None) -> list[Issue]:
    """A reinforced_concrete lining's bars lie axis_distance inside each face: tq-solid's material
    refuses an axis at or beyond the lining's mid-thickness (the inner and outer bars would meet or
    cross), when it builds the lining's block at the start of the run."""
    t = float(d["geometry"]["lining_thickness"])
    a = float(((d.get("design") or {}).get("reinforcement") or {}).get("axis_distance") or 0.05)
    if 2 * a < t:
        return []
    line = (_section_lines(raw, "design", "reinforcement").get("axis_distance")
            or _section_lines(raw, "geometry").get("lining_thickness") or where)
    return [Issue("design.reinforcement.axis_distance", a,
                  f"puts the bars' axis {a:g} m inside each face of the {t:g} m lining, at or beyond its "
                  "mid-thickness (the inner and outer bars would meet or cross): the reinforced_concrete lining "
                  "needs 0 < axis_distance < lining_thickness / 2, which tq-solid refuses otherwise",
                  f"give design.reinforcement.axis_distance below {t / 2:g} m (e.g. {min(0.05, t / 4):g} m: face "
                  "to the bars' centroid), or a thicker lining (geometry.lining_thickness)", line)]


def _time_step_checks(d: dict, raw: LineDict) -> list[Issue]:
    """time.dt above the solid's stable step: tq-solid refuses a step above safety_factor x its critical
    step when it builds its solver. The critical step here is critical_step's (the lining's hexahedra
    as tq-solid measures them, volume / largest face: its own bound to round-off where the lining
    limits; a fault zone's shortest axial element; Rayleigh's beta K; a Kelvin-Voigt material's
    retardation time), so a step refused here is one tq-solid refuses."""
    dt = d["time"].get("dt")
    if dt is None:
        return []
    plan = _mesh_plan(d)
    if plan is None:
        return []  # said by _mesh_checks
    safety = float(d["time"]["safety_factor"])
    critical = critical_step(d, plan)
    limit = safety * critical
    if dt <= limit:
        return []
    h1 = lining_layer_step(d, plan)[0]
    return [Issue("time.dt", dt,
                  f"is above the solid's stable step, about {limit:.3g} s (safety_factor {safety:g} x the critical "
                  f"step {critical:.3g} s of the lining's hexahedra, their layers {h1:.3g} m thick, the "
                  "smallest axial elements and the damping): tq-solid refuses a step above safety_factor x its "
                  "critical step",
                  f"leave time.dt out (the stable step x safety_factor), or give at most {limit:.3g} s",
                  _section_lines(raw, "time").get("dt"))]


#: Element rows through a reinforced_concrete lining from which its stresses reach the section's
#: bending resistance within 5 % (a plane-section strip of one-point rows: 4 rows 0.87, 10 rows 0.989).
RC_BENDING_ROWS = 10


def _whole_case_checks(d: dict, raw: LineDict, filename: str) -> tuple[list[Issue], list[str]]:
    """Checks across sections, and the ground-motion file itself."""
    issues: list[Issue] = []
    warnings: list[str] = []
    lines = raw.key_lines
    water, conds = d["water"], d["conditions"]
    if "dynamic_water" in conds and water["model"] == "incompressible" and closed_section(d):
        if d["mesh"]["mode"] == "3d" and d["coupling"]["volume_law"] == "solid":
            warnings.append("water.model incompressible with closed ends in 3D: the solid holds the whole enclosed "
                            "volume; the water solver's remainder (volume moved along the axis between the "
                            "tunnel's parts) is solved with K = 2.2 GPa, not incompressibly (docs/stability.md "
                            "\"Water stiffness\")")
        if d["coupling"]["volume_law"] == "water":
            issues.append(Issue("coupling.volume_law", "water",
                                "incompressible water in a closed section cannot change its volume by itself: the "
                                "solid must hold the enclosed volume (the constraint's multiplier is the uniform "
                                "pressure)", "use volume_law: solid (the default), or water.model: compressible",
                                raw["coupling"].key_lines.get("volume_law") if "coupling" in raw else None))
    if any(c in conds for c in ("static_water", "dynamic_water")) and water["head"] == 0.0:
        warnings.append("water.head is 0: the static and dynamic water conditions carry no hydrostatic load "
                        "(paper: 123 m)")
    if "dynamic_water" in conds and d["coupling"]["transport"] == "mpi":
        issues.append(Issue("coupling.transport", "mpi",
                            "`tunnelquake run` couples OpenFOAM, which cannot be one application of an MPMD mpirun "
                            "job (its Pstream takes all of MPI_COMM_WORLD: docs/coupler.md \"OpenFOAM in an MPMD "
                            "job\")", "use transport: tcp (the water may still run on several ranks: "
                            "parallel.fluid_ranks)",
                            raw["coupling"].key_lines.get("transport") if "coupling" in raw else None))
    for region, m in d["materials"].items():  # the reinforced lining's concrete and bars come from design
        if m["model"] != "reinforced_concrete":
            continue
        des = d.get("design") or {}
        where = raw["materials"].key_lines.get(region) if "materials" in raw else None
        if region != "lining":
            issues.append(Issue(f"materials.{region}.model", "reinforced_concrete",
                                "is the lining's model (its bars are placed about the tunnel axis)",
                                "use it for materials.lining only", where))
        elif not (des.get("concrete") or {}).get("fck"):
            issues.append(Issue("design.concrete.fck", None, "is required by materials.lining.model "
                                "reinforced_concrete (the analysis' concrete is the design block's)",
                                "add design: {concrete: {fck: 30 MPa}}", where))
        elif not ((des.get("reinforcement") or {}).get("As_inner") or (des.get("reinforcement") or {}).get("As_outer")):
            issues.append(Issue("design.reinforcement.As_inner", None, "is required by materials.lining.model "
                                "reinforced_concrete (hoop bars at the inner and outer faces)",
                                "add design: {reinforcement: {As_inner: 1005 mm^2/m, As_outer: 1005 mm^2/m}}", where))
        else:
            issues += _bar_axis_checks(d, raw, where)
    rc = (d["materials"].get("lining") or {}).get("model") == "reinforced_concrete"
    through = lining_rows(d)
    if rc and through < RC_BENDING_ROWS:
        warnings.append(f"mesh.lining_elements_through x refinement_factor {through} with a reinforced_concrete "
                        "lining: each element row "
                        "has one stress, at its centre, so the lining's bending resistance from its stresses stays "
                        f"below the section's M_Rd (a plane-section strip of 4 such rows reaches 0.87 of it, of 10 "
                        f"0.989), and past the bars' yield the elements' own bending modes carry more than the section "
                        f"(the crown of a ring in bending transmits 1.65-1.84 times its section's moment with 4 rows, "
                        f"1.07 with 10: docs/solid_solver.md \"A ring failing in bending\"); where the lining may fail in bending use "
                        f"mesh.lining_elements_through: {RC_BENDING_ROWS} or more")
    issues += _subcycling_checks(d, raw)
    issues += _time_step_checks(d, raw)
    ranks = d["parallel"]["fluid_ranks"]
    if ranks > 1:
        import os

        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        if "dynamic_water" not in conds:
            warnings.append(f"parallel.fluid_ranks {ranks} has no effect: no dynamic_water condition runs the "
                            "water; remove it or add dynamic_water to conditions")
        elif ranks > cores:
            warnings.append(f"parallel.fluid_ranks {ranks} exceeds the {cores} cores this run may use: the ranks "
                            f"will share cores (mpirun --oversubscribe) and run slower than on {cores}; "
                            f"use fluid_ranks <= {cores}")
    issues += _layer_checks(d, raw)
    issues += _geology_checks(d, raw)
    issues += _fault_offset_checks(d, raw)
    issues += _lining_joint_checks(d, raw)
    issues += _water_end_checks(d, raw)
    issues += _open_ends_axial_checks(d, raw)
    if (d.get("fault_offset") or {}).get("rise_time") is not None:
        warnings.append("fault_offset.rise_time: the slip during the run holds the block's faces but the top in x, y "
                        "and z, so the ground motion does not enter: the run is the slip alone (without rise_time "
                        "the offset is static, before the shaking)")
    issues += _no_default_checks(d, raw)
    warnings += _slow_setting_warnings(d)
    from .sanity import case_warnings

    warnings += case_warnings(d)
    out = d["output"]
    here = Path(filename).parent.resolve()
    where = (here / out["directory"]).resolve()
    if not out["allow_outside"] and not where.is_relative_to(here):
        issues.append(Issue("output.directory", out["directory"],
                            f"resolves to {where}, outside the case file's folder {here}",
                            "give a folder inside the case's folder (e.g. results), or set output.allow_outside: "
                            "true to write there on purpose", _section_lines(raw, "output").get("directory")))
    g = d["geometry"]
    (x0, x1), (y0, y1), (z0, z1) = g["x_range"], g["y_range"], g["z_range"]
    for name, p in (d["output"]["monitors"] or {}).items():
        if p is None:
            continue
        if not (x0 <= p[0] <= x1 and y0 <= p[1] <= y1 and z0 <= p[2] <= z1):
            issues.append(Issue(f"output.monitors.{name}", p, "lies outside the model block",
                                "give a point inside the block", lines.get("output")))
    # Mesh resolution for the cut-off frequency (Kuhlemeyer & Lysmer 1973: h <= lambda_min / 8).
    # The slowest ground material (rock or a layer) sets the shortest wavelength.
    ground = [n for n in ["rock"] + [m for m, _ in ground_layers(d)] if n in d["materials"]]
    if ground:
        def shear_speed(m):
            return math.sqrt(m["youngs_modulus"] / (2 * (1 + m["poisson_ratio"])) / m["density"])

        slow = min(ground, key=lambda n: shear_speed(d["materials"][n]))
        cs = shear_speed(d["materials"][slow])
        f = d["ground_motion"]["cutoff_frequency"]
        h = d["mesh"].get("max_element_size")
        if h is not None and h > cs / (8 * f):
            of = "" if slow == "rock" else f" (of layer {slow})"
            warnings.append(f"mesh.max_element_size {h:g} m exceeds lambda_min/8 = cs/(8 f) = {cs:.0f}{of}/(8*{f:g}) "
                            f"= {cs / (8 * f):.2f} m: waves near {f:g} Hz will be under-resolved")
    issues += _monitor_checks(d, raw, warnings)
    from . import paper

    issues += paper.case_issues(d, raw.key_lines.get("reference"))
    issues += _mesh_checks(d, raw, warnings)
    issues += _record_checks(d["ground_motion"], raw, filename, warnings)
    issues += _axial_motion_checks(d, raw)
    issues += _shared_column_checks(d, raw)
    issues += _symmetry_checks(d, raw)
    issues += _incident_wave_checks(d, raw, filename)
    if not issues:
        issues += _within_record_checks(d, raw, filename)
    if d["suite"]["records"] is not None:
        from .suite import suite_checks

        issues += suite_checks(d, raw, filename, warnings)
    return issues, warnings


def _no_default_checks(d: dict, raw: LineDict) -> list[Issue]:
    """Keys without a neutral default, required where the case uses them: the in-situ stress ratios
    (K0) with the in_situ stage, the water's ends in a 3D model with moving water."""
    issues = []
    if "in_situ" in d["stages"]["sequence"]:
        for key, what in (("kx", "across the tunnel"), ("ky", "along its axis")):
            if d["in_situ"][key] is None:
                issues.append(Issue(f"in_situ.{key}", None, f"is missing: the horizontal in-situ stress ratio {what} "
                                    "(K0) has no neutral default", f"add 'in_situ: {{{key}: <sigma_h / sigma_v>}}' "
                                    "from the site's stress measurements (1 - sin(phi) for a normally consolidated "
                                    "ground)", raw.key_lines.get("in_situ") or raw.line))
    if d["mesh"]["mode"] == "3d" and "dynamic_water" in d["conditions"] and d["water"]["ends"] is None:
        issues.append(Issue("water.ends", None, "is missing: a 3D model's water column ends open or closed, and "
                            "neither is a neutral default", "add 'water: {ends: open}' (pressure held at the ends) or "
                            "'water: {ends: closed}' (walls)", raw.key_lines.get("water") or raw.line))
    return issues


# ----------------------------------------------------------------------------------------------
# A plane wave from any direction through a domain-reduction layer (incident_wave.py)
# ----------------------------------------------------------------------------------------------
def _incident_wave_section() -> Section:
    from .incident_wave import section

    return section()


def _within_record_checks(d: dict, raw: LineDict, filename: str) -> list[Issue]:
    """A within record (the total motion at the top of the half-space) is deconvolved to the
    incident wave with the record's own spectrum, which only the processed record tells: the same
    processing and deconvolution the run does, so that a record whose band holds a frequency where
    the within motion vanishes is refused here, not when the run writes its input."""
    from .freefield import FreeFieldError, incident_motion
    from .incident_wave import active, convention, ground_profile, plane_wave
    from .motion import MotionError, from_case

    if not active(d) or convention(d) != "within":
        return []
    try:
        m, _ = from_case(d["ground_motion"], Path(filename).parent)
    except (MotionError, OSError, ValueError):
        return []  # the record's own checks say what is wrong with it
    record = m.ax * (2.0 if m.convention == "outcrop" else 1.0)  # as the run's solid input takes it
    try:
        incident_motion(record, m.dt, plane_wave(d), ground_profile(d, ground_layers(d)), "within")
    except FreeFieldError as e:
        return [Issue("incident_wave.convention", "within", e.problem, e.fix or "see docs/theory.md §6.1",
                      _section_lines(raw, "incident_wave").get("convention"))]
    return []


def _incident_wave_checks(d: dict, raw: LineDict, filename: str) -> list[Issue]:
    """What a run could not honour of the incident wave (incident_wave.checks), then where its DRM
    layer falls in the mesh's bands (when the mesh keys themselves are valid), then an H5DRM file
    against that layer."""
    from .incident_wave import active, band_issue, checks, h5drm_issues, monitor_issues

    issues = checks(d, ground_layers(d), raw.key_lines, lambda name: _section_lines(raw, name))
    if issues or not active(d):
        return issues
    plan = _mesh_plan(d)
    if plan is None:
        return []  # said by _mesh_checks
    bad = band_issue(d, plan, lambda name: _section_lines(raw, name))
    if bad:
        return [bad]
    issues = monitor_issues(d, plan, lambda name: _section_lines(raw, name))
    if d["incident_wave"]["type"] == "h5drm":
        issues += h5drm_issues(d, plan, Path(filename).parent, lambda name: _section_lines(raw, name),
                               seismic_length(d))
    return issues


def seismic_length(d: dict) -> float | None:
    """The seismic stage's length where the keys give it (time.end_time, else the record's window or
    the synthetic record's length); None where only the record file tells."""
    gm = d["ground_motion"]
    if d["time"]["end_time"] is not None:
        return float(d["time"]["end_time"])
    if gm["duration"] is not None:
        return float(gm["duration"])
    if gm["source"] == "synthetic":
        return float(gm["synthetic"]["duration"])
    return None


def _axial_motion_checks(d: dict, raw: LineDict) -> list[Issue]:
    """A motion along the tunnel's axis (y) shears the ground antiplane; tq-solid runs it in a
    slice, whose y faces it ties periodic, or in a 3D model whose tunnel's ends are plugged with
    ground, whose y faces then take free-field columns (the first side's, shared). A 3D model
    without plugs keeps its y faces on rollers (u_y = 0), which would hold that motion back:
    refused there, naming the key that gives it."""
    from .motion import along_axis

    gm = d["ground_motion"]
    if d["mesh"]["mode"] == "slice" or not along_axis(gm) or d["incident_wave"]["type"] != "none":
        return []  # (with an incident wave its own checks name these keys)
    if int(d["mesh"].get("tunnel_end_plugs") or 0) > 0:
        return []  # the y faces take free-field columns (the first side's, shared)
    lines = _section_lines(raw, "ground_motion")
    key, value = _axial_motion_key(gm)
    return [Issue(f"ground_motion.{key}", value,
                  "gives a motion along the tunnel's axis (y), which a 3D model takes only through free-field "
                  "columns on its y faces, and those need the tunnel's ends plugged with ground",
                  "set mesh.tunnel_end_plugs: 1 or more, use mesh.mode: slice (its y faces are tied periodic, so "
                  "the ground shears along the axis), or a motion across the tunnel and vertical only (azimuth 0 "
                  "or 180, no second_horizontal)",
                  lines.get(key))]


def _shared_column_checks(d: dict, raw: LineDict) -> list[Issue]:
    """A motion along the tunnel's axis in a 3D model with plugged ends drives its y faces by the
    free-field column of the first side face, shared (solid_input: /boundaries/free_field
    shared_column_faces; with regions bounded by planes the x faces are cut into strips and the first
    in name order is xmax's at ymin, xmax_strip0000): each y-face node takes the column at its height, each quad the column's layer at its
    centroid. tq-solid refuses, when the shaking starts (after the static stages), a y-face node above
    the column's top (a slope whose ground rises from the xmax side) and a y-face element of another
    material than the column's layer at its height (a fault zone or a dipping layer that cuts the y
    faces otherwise than that strip). The same from the mesh plan, nothing meshed: the surface's
    heights, and the ground's elements of the first and last axial layers as the mesher assigns them
    (meshing.params.ground_regions: the rock ring's and the outer grid's; the plugs' elements inside
    the excavation are not listed). Without regions bounded by planes the ground is horizontal
    layers, which the column follows."""
    import numpy as np

    from .motion import along_axis

    if d["mesh"]["mode"] == "slice" or not along_axis(d["ground_motion"]) or d["incident_wave"]["type"] != "none":
        return []
    geo = case_geology(d)
    if geo is None or not int(d["mesh"].get("tunnel_end_plugs") or 0) or half_block(d):
        return []  # (no plugs, a half block: _axial_motion_checks and _symmetry_checks refuse the motion)
    from .meshing.params import grid_lines, ground_regions, surface_nodes

    plan = _mesh_plan(d)
    if plan is None:
        return []  # said by _mesh_checks
    key, value = _axial_motion_key(d["ground_motion"])
    y = np.asarray(plan.y_levels, float)
    strip = f"the first strip of the xmax side (y = {y[0]:g} to {y[1]:g} m)"
    across = ("or use a motion across the tunnel and vertical only (azimuth 0 or 180, no second_horizontal), which "
              "leaves the y faces on rollers")
    why = (f"under the motion along the tunnel's axis (ground_motion.{key} {value}) the y faces of the 3D model "
           f"share the free-field column of {strip}, and tq-solid refuses a y face the column does not follow when "
           "the shaking starts (after the static stages)")
    glines = _section_lines(raw, "geology")
    # The surface: no y-face node above the column's top (the mean height of the strip's two top nodes).
    column_levels = []
    zs = grid_lines(plan)[2]
    for yk in y[:2]:
        pts = np.stack([np.full(zs.size, plan.xmax), np.full(zs.size, yk), zs], axis=1)
        column_levels.append(surface_nodes(plan, pts)[:, 2])
    levels = 0.5 * (column_levels[0] + column_levels[1])
    tol = 1e-9 * max(1.0, levels[-1] - levels[0])
    if geo.slope is not None:
        for face, yf in (("ymin", y[0]), ("ymax", y[-1])):
            for x in (plan.xmin, plan.xmax):
                z = float(surface_nodes(plan, np.array([[x, yf, plan.zmax]]))[0, 2])
                if z > levels[-1] + tol:
                    sl = d["geology"]["slope"]
                    return [Issue("geology.slope.angle", sl["angle"],
                                  f"with dip_direction {sl['dip_direction']:g} and crest {list(sl['crest'])} leaves "
                                  f"the ground at the {face} face's corner x = {x:g} m at z = {z:.4g} m, above the "
                                  f"top of the column, z = {levels[-1]:.4g} m: {why}",
                                  "turn or move the slope so that the ground is nowhere higher at the y faces than at "
                                  f"the xmax side's end (e.g. descending away from xmax: dip_direction 270), {across}",
                                  _section_lines(raw, "geology", "slope").get("angle") or glines.get("slope"))]
    # The regions: each y-face element of the column's material at its height.
    names = ["rock", "lining"] + [m for m, _ in ground_layers(d)] + geo.materials
    first = 2 + len(ground_layers(d))
    props = [tuple(float(d["materials"][n][k]) for k in ("density", "youngs_modulus", "poisson_ratio")) for n in names]
    same = np.array([props.index(pr) for pr in props])  # regions of one material share an index

    def region_key(region):
        j = region - first
        if j < 0:
            return "geology"
        return f"geology.dipping_layers[{j}].material" if j < len(geo.dipping) else "geology.fault_zone.material"

    pts, reg = ground_regions(plan, [0, plan.axial.count - 1])
    nz = levels.size - 1
    column = reg[len(reg) - nz + np.arange(nz), 0]  # the outer grid's last x column: xmax's
    for face, k in (("ymin", 0), ("ymax", 1)):
        row = np.clip(np.searchsorted(levels, pts[:, k, 2], side="right") - 1, 0, nz - 1)
        bad = np.flatnonzero(same[reg[:, k]] != same[column[row]])
        if bad.size == 0:
            continue
        e = int(bad[0])
        mine, theirs = int(reg[e, k]), int(column[row[e]])
        region = mine if mine >= first else theirs
        rkey = region_key(region)
        fault = rkey.startswith("geology.fault")
        what = "the fault zone" if fault else ("the dipping layer" if rkey != "geology" else "the ground")
        x, z = float(pts[e, k, 0]), float(pts[e, k, 2])
        return [Issue(rkey, names[region],
                      f"makes the ground at the {face} face near x = {x:.4g}, z = {z:.4g} m {names[mine]}, where the "
                      f"column has {names[theirs]} (its layer z = {levels[row[e]]:.4g} to {levels[row[e] + 1]:.4g} "
                      f"m): {why}",
                      f"keep {what} ({names[region]}) out of the block's first and last axial element layers (y = "
                      f"{y[0]:g} to {y[1]:g} m and {y[-2]:g} to {y[-1]:g} m), {across}",
                      glines.get("fault_zone" if fault else "dipping_layers") or raw.key_lines.get("geology"))]
    return []


def _axial_motion_key(gm: dict) -> tuple[str, object]:
    """The ground_motion key (and its value) that gives a motion along the axis: the second
    horizontal record where there is one, else the azimuth."""
    if gm["second_horizontal"]["file"] is not None:
        return "second_horizontal", gm["second_horizontal"]["file"]
    return "azimuth", gm["azimuth"]


def _symmetry_checks(d: dict, raw: LineDict) -> list[Issue]:
    """A half block (mesh.symmetry: mid_length) holds the scene's answer only where the scene is
    symmetric about the middle plane of y_range: its ymax face on rollers and the water's end there a
    symmetry plane. Whatever is not symmetric there, or is not modelled at that plane, is refused,
    naming its key: a motion along the axis or an incident wave (their fields are not), the geology's
    planes (a fault, dipping layers, a slope, a portal), the lining's joints, monitors beyond the
    plane, and open water ends that differ (the half holds the end at ymin; its plane of symmetry has no
    flow through it)."""
    from .motion import along_axis

    if not half_block(d):
        return []  # (a slice with symmetry: the mesher's own error)
    y0, y1 = d["geometry"]["y_range"]
    mid = 0.5 * (y0 + y1)
    mesh_line = _section_lines(raw, "mesh").get("symmetry")
    fix_whole = "or mesh the whole block (mesh.symmetry: none)"
    issues: list[Issue] = []

    def refuse(key, value, why, fix, line=None):
        issues.append(Issue(key, value, f"{why}, so the block is not symmetric about y = {mid:g} m (mesh.symmetry: "
                            "mid_length)", f"{fix}, {fix_whole}", line or mesh_line))

    gm = d["ground_motion"]
    if along_axis(gm):
        key, value = _axial_motion_key(gm)
        refuse(f"ground_motion.{key}", value, "gives a motion along the tunnel's axis", "use a motion across the tunnel and vertical only (azimuth 0 "
               "or 180, no second_horizontal)", _section_lines(raw, "ground_motion").get(key))
    if d["incident_wave"]["type"] != "none":
        refuse("incident_wave.type", d["incident_wave"]["type"], "brings a wave whose field differs along the axis",
               "use incident_wave.type: none (the motion from the base)")
    g = d.get("geology") or {}
    if g.get("fault_zone", {}).get("material") is not None:
        refuse("geology.fault_zone", g["fault_zone"]["material"], "crosses the block at a strike and dip of its own",
               "remove geology.fault_zone")
    if g.get("dipping_layers"):
        refuse("geology.dipping_layers", len(g["dipping_layers"]), "are planes that need not be symmetric",
               "remove geology.dipping_layers (horizontal layers are symmetric)")
    if (g.get("slope") or {}).get("angle") is not None:
        refuse("geology.slope.angle", g["slope"]["angle"], "tilts the ground surface", "remove geology.slope")
    if (g.get("portal") or {}).get("station") is not None:
        refuse("geology.portal.station", g["portal"]["station"], "ends the tunnel at one end only",
               "remove geology.portal")
    if lining_joints_active(d):
        refuse("lining_joints.spacing", d["lining_joints"]["spacing"], "places joints that need not mirror about "
               "the middle plane", "remove lining_joints")
    lines = _section_lines(raw, "output", "monitors")
    for name, p in (d["output"]["monitors"] or {}).items():
        if p is not None and p[1] > mid + 1e-9 * max(1.0, abs(mid)):
            refuse(f"output.monitors.{name}", p, f"lies at y = {p[1]:g} m, beyond the middle plane the half block ends at",
                   f"give its mirror image y = {y0 + y1 - p[1]:g} m (the same answer by symmetry; u_y changes sign)",
                   lines.get(name))
    if d["water"]["ends"] == "open":
        def end(e, kind):
            area = (d["water"].get(e) or {}).get("area")
            return f"kind {kind}" + ("" if area is None else f", area {area:g} m^2")

        ymin, ymax = (end(e, k) for e, k in zip(("end_ymin", "end_ymax"), water_end_kinds(d), strict=True))
        if ymin != ymax:
            refuse("water.end_ymax", ymax, f"differs from water.end_ymin ({ymin})",
                   "give both ends the same kind (and a surge tank the same area)",
                   _section_lines(raw, "water").get("end_ymax"))
    return issues


#: warn when a setting makes the run this many times slower than the alternative named
SLOW_FACTOR = 2.0


def lining_rows(d: dict) -> int:
    """The lining's element rows through its thickness in the mesh: mesh.lining_elements_through times
    mesh.refinement_factor (meshing.params.resolve's lining divisions)."""
    return int(d["mesh"].get("lining_elements_through", 3)) * int(d["mesh"].get("refinement_factor", 1))


def reinforced_lining_step_scale(d: dict) -> float:
    """The factor tq-solid's reinforced_concrete lining puts on its concrete's moduli for the stable
    step (ReinforcedConcreteMaterial's constructor): 1 + rho_max Es / M, M the concrete's constrained
    modulus and rho_max the largest steel ratio of its element rows (lining_rows), hoop or axial
    (rc_law::steelRatio: each bar layer shared between the two rows whose centres straddle it, all of
    it in the face row beyond that row's centre); 1 for any other lining. The bars, Es and axis distance
    of design.reinforcement, absent ones at solid_input.h5's defaults (solver_input_table)."""
    m = d["materials"].get("lining") or {}
    if m.get("model") != "reinforced_concrete":
        return 1.0
    from .solver_input_table import ENTRIES, MATERIALS

    default = {e.name: e.default for e in ENTRIES if e.group == MATERIALS}
    bars = (d.get("design") or {}).get("reinforcement") or {}

    def bar(key, name):
        return float(bars.get(key) if bars.get(key) is not None else default[name])

    n, t, a = lining_rows(d), float(d["geometry"]["lining_thickness"]), bar("axis_distance", "axis_distance")
    h = t / n

    def share(row: int, at: float) -> float:  # this row's share of a bar layer `at` from the inner face
        x = at / h - 0.5
        if x <= 0:
            return 1.0 if row == 0 else 0.0
        if x >= n - 1:
            return 1.0 if row == n - 1 else 0.0
        lo = math.floor(x)
        return 1 - (x - lo) if row == lo else (x - lo) if row == lo + 1 else 0.0

    areas = [(bar("As_inner", "As_inner_hoop"), bar("As_outer", "As_outer_hoop")),
             (bar("As_inner_axial", "As_inner_axial"), bar("As_outer_axial", "As_outer_axial"))]
    rho = max((inner * share(i, a) + outer * share(i, t - a)) / h for i in range(n) for inner, outer in areas)
    return 1 + rho * bar("Es", "Es") / (p_wave_speed(m) ** 2 * float(m["density"]))  # M = rho c_p^2


def lining_layer_step(d: dict, plan=None) -> tuple[float, float]:
    """The lining's thinnest element layer h1 (m) and the critical step of its elements, L / c_p (s),
    as tq-solid's hex8 bound takes it: L = volume / largest face of the mesh's lining hexahedra
    (their faces planar between nodes on the lining's circles; `lining_element_length`), c_p the
    lining's P-wave speed (a reinforced_concrete lining's with its bars: reinforced_lining_step_scale). The divisions come from the case's mesh plan (`plan`, else made here:
    meshing.params.resolve, nothing meshed); where the mesh keys make none (check says why), h1 is
    the thickness over its rows (lining_rows) and L = h1, an upper bound."""
    if plan is None:
        plan = _mesh_plan(d)
    c_p = p_wave_speed(d["materials"]["lining"]) * math.sqrt(reinforced_lining_step_scale(d))
    if plan is None:
        h1 = d["geometry"]["lining_thickness"] / lining_rows(d)
        return h1, h1 / c_p
    h1, length = lining_element_length(plan)
    return h1, length / c_p


def lining_element_length(plan) -> tuple[float, float]:
    """The lining's thinnest radial layer (m) and the shortest characteristic length volume / largest
    face (m) of its hexahedra (tq-solid's hex8 `charLength`, which sets the element's critical step):
    each element spans one angle 2 pi / n (n around) between two circles r_i < r_o, its hoop faces
    the chords 2 r sin(pi / n), the radial edges r_o - r_i, the chords' distance (r_o - r_i) cos(pi / n),
    and an axial length a (the shortest axial layer; the slice's thickness)."""
    from .meshing.params import graded_sizes

    n = 4 * plan.quarter.count
    sizes = graded_sizes(plan.radius_outer - plan.radius_inner, plan.lining)
    axial = shortest_axial_element(plan)
    s, c = math.sin(math.pi / n), math.cos(math.pi / n)
    lengths, r_i = [], plan.radius_inner
    for h in sizes:
        r_o = r_i + h
        ci, co = 2 * r_i * s, 2 * r_o * s
        trapezoid = h * c * (ci + co) / 2
        lengths.append(trapezoid * axial / max(co * axial, h * axial, trapezoid))
        r_i = r_o
    return min(sizes), min(lengths)


def shortest_axial_element(plan) -> float:
    """The mesh plan's shortest axial element, m (a slice's thickness)."""
    import numpy as np

    return float(np.diff(plan.y_levels).min()) if len(plan.y_levels) > 1 else plan.ymax - plan.ymin


def axial_step(d: dict, plan) -> float:
    """The critical step of the shortest axial element, h / c_p with the fastest material (inf when
    the axial grid is uniform: the lining's layer sets the step). A fault zone's refined stretch
    can make it shorter than the lining's (meshing.params.axial_levels)."""
    if plan.geology is None or len(plan.y_levels) < 2:
        return math.inf
    return shortest_axial_element(plan) / max(p_wave_speed(m) for m in d["materials"].values())


def p_wave_speed(m: dict) -> float:
    """A material's P-wave speed sqrt(E (1 - nu) / ((1 + nu) (1 - 2 nu) rho)), m/s."""
    E, nu, rho = m["youngs_modulus"], m["poisson_ratio"], m["density"]
    return math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu) * rho))


def ground_element_size(plan) -> float:
    """The smallest side of the ground's elements beside the excavation, m: the rock ring's hoop size
    at the excavated radius, its first radial size along an axis (meshing.params' near-field
    grading) or the axial size (a slice's thickness, the shortest axial element in 3D)."""
    from .meshing.params import graded_sizes

    radial = min(graded_sizes(plan.box_half_width - plan.radius_outer, plan.near_field))
    hoop = 2 * math.pi * plan.radius_outer / (4 * plan.quarter.count)
    return min(radial, hoop, shortest_axial_element(plan))


def critical_step(d: dict, plan, frequencies: dict | None = None) -> float:
    """The solid's critical step, s, bounded as tq-solid's Solver::stableStep bounds it: the elastic
    bound 2/w_max cut by Rayleigh's beta K (rayleigh_step_cut), and every Kelvin-Voigt region's own
    bound (2/w_b)(sqrt(1 + xi^2) - xi), xi = (beta + tau) w_b / 2 (Belytschko, Liu & Moran §6.3).
    `frequencies` (region -> its hexahedra's largest 2 c_p / L, from the case's mesh:
    subcycle_levels.mesh_frequencies) give w_max and each w_b as tq-solid has them; without them they
    are estimated from the mesh plan: w_max from the lining's hexahedra (lining_layer_step) or a fault
    zone's shortest axial element (axial_step), w_b = 2 c_p / h with h the lining's hexahedra's L for
    the lining, the ground's smallest element side (ground_element_size) for a ground region."""
    import math

    from .references import rayleigh_coefficients

    if frequencies:
        dt_elastic, length = 2 / max(frequencies.values()), None
    else:
        dt_lining = lining_layer_step(d, plan)[1]
        length = dt_lining * p_wave_speed(d["materials"]["lining"])  # the lining's hexahedra's L
        dt_elastic = min(dt_lining, axial_step(d, plan))
    dt = dt_elastic / rayleigh_step_cut(d, dt_elastic)
    dmp = d["damping"]
    beta = (rayleigh_coefficients(dmp["ratio"], *dmp["frequencies"])[1]
            if dmp["model"] == "rayleigh" and dmp["ratio"] > 0 else 0.0)
    h_ground = ground_element_size(plan)
    for region, m in d["materials"].items():
        tau = m.get("retardation_time") or 0.0
        if m["model"] != "kelvin_voigt" or not tau > 0:
            continue
        w = (frequencies[region] if frequencies and region in frequencies
             else 2 * p_wave_speed(m) / (length if region == "lining" else h_ground))
        xi = 0.5 * (beta + tau) * w
        dt = min(dt, 2 / w * (math.sqrt(1 + xi * xi) - xi))
    return dt


def rayleigh_step_cut(d: dict, dt_crit: float) -> float:
    """How many times stiffness-proportional damping shortens a critical step dt_crit = 2/w_max: the
    central difference with beta K is stable to (2/w)(sqrt(1 + xi^2) - xi), xi = beta w / 2
    (Belytschko, Liu & Moran §6.3; tq-solid's stableStep). 1 without Rayleigh damping."""
    dmp = d["damping"]
    if dmp["model"] != "rayleigh" or dmp["ratio"] <= 0:
        return 1.0
    xi = 2 * dmp["ratio"] / sum(2 * math.pi * f for f in dmp["frequencies"]) / dt_crit
    return 1.0 / (math.sqrt(1 + xi * xi) - xi)


def _slow_setting_warnings(d: dict) -> list[str]:
    """Settings that make the run much slower than a measured alternative, each with its factor."""
    out = []
    if d["time"].get("dt") is None:
        dt0 = lining_layer_step(d)[1]
        factor = rayleigh_step_cut(d, dt0)
        if factor > SLOW_FACTOR:
            out.append(f"damping.model rayleigh: its stiffness term cuts the solid's stable step about {factor:.0f}x "
                       f"(to about {d['time']['safety_factor'] * dt0 / factor:.2g} s), so the run takes about {factor:.0f}x longer; "
                       "damping.model: mass_proportional (the default) keeps the step")
    c = d["coupling"]
    if "dynamic_water" in d["conditions"] and c["scheme"] == "implicit" and c["window"] == 1:
        out.append("coupling.window 1: every solid step exchanges with the water; over the example slice's first "
                   f"second one-step windows took 3.7x the CPU time of windows of {IMPLICIT_WINDOW} (the default) "
                   "at the same accuracy (docs/benchmarks.md \"The paper case's shortcuts\")")
    return out


def _section_lines(raw: LineDict, *keys: str) -> dict:
    """The key -> line map of the raw section at `keys` (empty when it is not written out)."""
    node = raw
    for k in keys:
        node = node.get(k) if isinstance(node, dict) else None
    return getattr(node, "key_lines", {}) if isinstance(node, dict) else {}


def _monitor_checks(d: dict, raw: LineDict, warnings: list[str]) -> list[Issue]:
    """Where each monitor is against the lining, the annulus a <= r <= b around the tunnel axis
    (a = excavated_radius - lining_thickness, b = excavated_radius, r measured in the x-z plane
    from (tunnel_centre_x, tunnel_centre_z)). tq-solid records a monitor at the solid mesh's node
    nearest to it and the element whose centroid is nearest (rock or lining alike), and its water
    pressure at the nearest wetted lining node. So a point in the rock records the rock; a point
    in the water (no solid element there) records the lining's inner surface. Such points are
    warnings, except a monitor that a paper comparison (`reference`) reads as the lining's, which
    is an error (paper.py)."""
    from . import paper

    g = d["geometry"]
    cx, cz, b = g["tunnel_centre_x"], g["tunnel_centre_z"], g["excavated_radius"]
    a = b - g["lining_thickness"]
    (x0, x1), (y0, y1), (z0, z1) = g["x_range"], g["y_range"], g["z_range"]
    tol = 1e-6 * max(x1 - x0, z1 - z0)
    lines = _section_lines(raw, "output", "monitors")
    issues: list[Issue] = []
    for name, p in (d["output"]["monitors"] or {}).items():
        if p is None or not (x0 <= p[0] <= x1 and y0 <= p[1] <= y1 and z0 <= p[2] <= z1):
            continue  # outside the block: said above
        dx, dz = p[0] - cx, p[2] - cz
        r = math.hypot(dx, dz)
        if a - tol <= r <= b + tol:
            continue
        ux, uz = (dx / r, dz / r) if r > tol else (0.0, 1.0)
        near = [round(cx + a * ux, 4), p[1], round(cz + a * uz, 4)]
        where = (f"lies {r:.4g} m from the tunnel axis (x = {cx:g}, z = {cz:g} m in the x-z plane); the lining is "
                 f"{a:g} m <= r <= {b:g} m")
        key = f"output.monitors.{name}"
        if r > b:
            # The ground's region at that height: the layer whose bottom lies below it, else rock.
            ground = next((m for m, zb in ground_layers(d) if p[2] > zb), "rock")
            rock = "the rock" if ground == "rock" else f"the ground (layer {ground})"
            what = (f"{where}, so this point is in {rock}: tq-solid records the solid's node and element nearest "
                    f"to it, {'the rock' if ground == 'rock' else 'the layer'}'s (the lining's only within about half "
                    "an element of its outer surface)")
            issue = paper.monitor_in_rock_issue(d, name, p, what, near, lines.get(name))
            if issue is not None:
                issues.append(issue)
            else:
                warnings.append(f"{key} {p}: {what}. If it is meant to monitor the lining, move it there, e.g. "
                                f"{near} on its inner surface in the same direction")
        elif r > tol:
            warnings.append(f"{key} {p}: {where}, so this point is in the water, {a - r:.4g} m inside the lining: "
                            f"the solid has no element there, and tq-solid records the lining's inner surface "
                            f"nearest to it (about {near}). Fix: give that point, to record what is meant")
        else:
            warnings.append(f"{key} {p}: {where}, so this point is on the tunnel's axis, in the water: the whole "
                            "inner surface of the lining is equally near, and tq-solid records whichever of its "
                            f"nodes comes first. Fix: give a point on the lining, e.g. {near} (its crown)")
    return issues


def _layer_checks(d: dict, raw: LineDict) -> list[Issue]:
    """Every layer names a material of its own; every material is a region of the mesh (rock,
    lining, or a layer's). The geometry of the layers (order, thickness, the near-field box below
    them) is the mesher's rule, said by _mesh_checks."""
    issues = []
    mats = d["materials"]
    layers = d.get("layers") or []
    raw_layers = raw.get("layers") if isinstance(raw.get("layers"), list) else []
    seen = set()
    for i, layer in enumerate(layers):
        name = layer["material"]
        line = getattr(raw_layers[i], "line", None) if i < len(raw_layers) else raw.key_lines.get("layers")
        if name in ("rock", "lining"):
            issues.append(Issue(f"layers[{i}].material", name,
                                f"is the region {'below the layers' if name == 'rock' else 'of the lining'}, not a "
                                "layer's", "give the layer a material of its own (e.g. materials.weathered)", line))
        elif name not in mats:
            issues.append(Issue(f"layers[{i}].material", name, "is not a material of the case",
                                f"add materials.{name} (youngs_modulus, poisson_ratio, density, ...)", line))
        elif name in seen:
            issues.append(Issue(f"layers[{i}].material", name, "names the material of another layer: each layer is "
                                "its own mesh region", "merge the two layers, or copy the material under another "
                                "name", line))
        seen.add(name)
    seen |= {m for m in (case_geology(d).materials if case_geology(d) else [])}
    for name in mats:
        if name not in ("rock", "lining") and name not in seen:
            issues.append(Issue(f"materials.{name}", name,
                                "is not a region of the mesh: no entry of layers names it, so this material would "
                                "never be used",
                                f"add a layer with 'material: {name}' (layers: [{{material: {name}, thickness: ...}}]), "
                                "or remove it", _section_lines(raw, "materials").get(name)))
    return issues


#: Below this many water cells a rank parallel.fluid_ranks is refused (fluid_case.decompose): a slab
#: of a few cells is mostly processor faces, and a rank of the simple split could get none.
MIN_CELLS_PER_RANK = 20


def fluid_ranks_problem(cells: int, ranks: int) -> tuple[str, str] | None:
    """(problem, fix) when `ranks` water ranks would get fewer than MIN_CELLS_PER_RANK of the
    water's `cells` cells each; None when they would not. `check` tests it on the mesh's counts,
    `run` on the water case's cells."""
    if ranks <= 1 or cells >= MIN_CELLS_PER_RANK * ranks:
        return None
    return (f"gives the water's {cells} cells fewer than {MIN_CELLS_PER_RANK} a rank",
            f"use fluid_ranks: 1 (at most {max(1, cells // MIN_CELLS_PER_RANK)} for this mesh)")


#: the most element divisions along one edge of the mesh that `check` lets through
MAX_EDGE_DIVISIONS = 100_000


def _mesh_checks(d: dict, raw: LineDict, warnings: list[str]) -> list[Issue]:
    """The mesher's own rules (meshing.params.resolve: multiples of 4 around, element sizes the
    structured blocks can meet, gradings, the near-field box inside the block), said against
    the case file's lines instead of a traceback when meshing starts; then the mesh's size and the
    memory it needs, estimated from the division counts alone, against the machine's memory."""
    from .meshing.params import MeshInputError, element_counts, machine_memory, memory_estimate, resolve

    # Divisions beyond any machine are refused before they are listed (a list of 1e9 sizes alone
    # is 8 GB): more than MAX_EDGE_DIVISIONS along one edge is 1e10 elements in a slice already.
    g, lines = d["geometry"], _section_lines(raw, "mesh")
    extent = max(hi - lo for lo, hi in (g["x_range"], g["y_range"], g["z_range"]))
    h = d["mesh"].get("max_element_size")
    too_many = [(k, v) for k, v in d["mesh"].items()
                if isinstance(v, int) and not isinstance(v, bool) and v > MAX_EDGE_DIVISIONS]
    if h is not None and extent / h > MAX_EDGE_DIVISIONS:
        too_many.insert(0, ("max_element_size", h))
    if too_many:
        k, v = too_many[0]
        what = (f"divides the block's {extent:g} m into {extent / v:.3g} elements" if k == "max_element_size" else
                "is a division count")
        return [Issue(f"mesh.{k}", v, f"{what}, beyond {MAX_EDGE_DIVISIONS:,} along one edge: more elements than any "
                      "machine can hold", "raise mesh.max_element_size, or lower the division counts and "
                      "refinement_factor (docs/meshing.md)", lines.get(k) or raw.key_lines.get("mesh"))]
    try:
        plan = resolve(d["geometry"], d["mesh"], ground_layers(d), case_geology(d))
    except MeshInputError as e:
        key = e.key or "mesh"
        section, _, leaf = key.partition(".")
        line = _section_lines(raw, section).get(leaf) or raw.key_lines.get(section)
        if key.startswith("layers["):
            # layers[i].bottom: the entry's line; a thickness is said as the bottom it makes.
            i = int(key[len("layers["):key.index("]")])
            entry = raw.get("layers")[i] if isinstance(raw.get("layers"), list) else None
            line = getattr(entry, "line", None) or raw.key_lines.get("layers")
            if d["layers"][i]["bottom"] is None:
                key = f"layers[{i}].thickness"
                return [Issue(key, d["layers"][i]["thickness"], f"its bottom at z = {e.value:g} m {e.problem}",
                              (e.fix or "").rstrip(".")[:1].lower() + (e.fix or "").rstrip(".")[1:], line)]
        value = e.value if e.key else d["mesh"]
        fix = (e.fix or "see docs/meshing.md").rstrip(".")
        fix = fix[:1].lower() + fix[1:]
        return [Issue(key, value, e.problem or str(e), fix, line)]
    except (MemoryError, OverflowError):  # divisions beyond any machine: their sizes cannot even be listed
        written = raw.get("mesh") if isinstance(raw.get("mesh"), dict) else {}
        return [Issue("mesh", {k: d["mesh"].get(k) for k in written},
                      "asks for more element divisions than any machine can hold (listing their sizes overflowed)",
                      "raise mesh.max_element_size, or lower the division counts and refinement_factor "
                      "(docs/meshing.md)", raw.key_lines.get("mesh"))]
    counts = element_counts(plan)
    issues = []
    ranks = d["parallel"]["fluid_ranks"]
    bad = fluid_ranks_problem(counts["water"], ranks) if "dynamic_water" in d["conditions"] else None
    if bad is not None:
        issues.append(Issue("parallel.fluid_ranks", ranks, *bad, _section_lines(raw, "parallel").get("fluid_ranks")))
    need = memory_estimate(counts, d["conditions"])
    have = machine_memory()
    if have is not None and max(need.values()) > have["total"]:
        gib = 2.0**30
        n = counts["rock"] + counts["lining"] + counts["water"]
        short = " and ".join(w for w in ("meshing", "the run") if need["run" if w == "the run" else w] > have["total"])
        warnings.append(
            f"mesh: about {n:,} hexahedra (rock {counts['rock']:,}, lining {counts['lining']:,}, water "
            f"{counts['water']:,}) need about {need['meshing'] / gib:.1f} GiB to mesh and {need['run'] / gib:.1f} GiB "
            f"to run, more than this machine's {have['total'] / gib:.1f} GiB of memory ({have['available'] / gib:.1f} "
            f"GiB available now): {short} would run out of memory. Fix: lower mesh.refinement_factor "
            f"({d['mesh']['refinement_factor']}), raise mesh.max_element_size or use fewer divisions, or mesh.mode: "
            "slice")
    return issues


def _record_checks(gm: dict, raw: LineDict, filename: str, warnings: list[str]) -> list[Issue]:
    """Each ground-motion record (the horizontal one, and the transverse and vertical ones when given)
    must exist (unless the case allows the synthetic fallback for the horizontal one), parse with
    finite values and a header that agrees with its data, and last the window
    `ground_motion.duration`: everything `tunnelquake motion` would refuse, or use without a word."""
    from .motion import (
        MotionError,
        check_covers,
        check_filter_length,
        check_moves,
        lowpass_min_samples,
        read_record,
        resolve_path,
    )

    section = raw.get("ground_motion") if isinstance(raw.get("ground_motion"), LineDict) else None
    key_lines = section.key_lines if section is not None else {}
    issues: list[Issue] = []
    components = [("ground_motion", gm, key_lines.get("file"))] if gm["source"] == "file" else []
    for key in ("second_horizontal", "vertical"):
        if gm[key]["file"] is not None:
            sub_lines = getattr(section.get(key) if section is not None else None, "key_lines", {})
            components.append((f"ground_motion.{key}", gm[key], sub_lines.get("file", key_lines.get(key))))
    lengths = []
    synthetic = gm["source"] == "synthetic"
    for where, spec, line in components:
        path = resolve_path(spec["file"], Path(filename).parent)
        if not path.is_file():
            if where == "ground_motion" and gm["if_missing"] == "synthetic":
                warnings.append(f"ground_motion.file {path} is not here: the synthetic motion will be used")
                synthetic = True
                continue
            issues.append(Issue(f"{where}.file", spec["file"], f"file not found ({path})",
                                "give the record's path relative to the case file"
                                + (", or set if_missing: synthetic" if where == "ground_motion" else ""), line))
            continue
        try:
            record = read_record(path, spec["format"], spec["units"])
        except MotionError as e:
            issues.append(Issue(f"{where}.file", spec["file"], f"cannot be read: {e.problem}",
                                e.fix or "check the format and units keys, or the file itself", line))
            continue
        scaled = gm["pga"] is not None or spec.get("pga") is not None
        try:
            if scaled:  # a record of zeros used as recorded is a run without shaking, which run allows
                check_moves(record.acc, record.dt, gm["duration"], str(path))
        except MotionError as e:
            issues.append(Issue(f"{where}.file", spec["file"], e.problem, e.fix, line))
        if not scaled:  # used as recorded: its own peak is the PGA
            from .sanity import pga_warning

            w = pga_warning(f"{where}.file {spec['file']}: its peak (no pga scales it)",
                            float(abs(record.acc).max()) if record.acc.size else None)
            if w is not None:
                warnings.append(w)
        lengths.append((record.npts, record.dt, record.source, line, f"{where}.file", spec["file"]))
    if synthetic:
        syn = gm["synthetic"]  # the synthetic motion: its length, without generating it
        lengths.append((int(round(syn["duration"] / syn["dt"])) + 1, syn["dt"], "synthetic", None,
                        "ground_motion.synthetic.duration", syn["duration"]))
    for npts, dt, source, line, key, value in lengths:
        # the tests `run` makes when it processes the record (motion.check_window), one by one so
        # that each names its key: the window against the record's length, then the window's
        # samples against the low-pass (the record's own key when the record itself is too short)
        try:
            check_covers(npts, dt, gm["duration"], source)
        except MotionError as e:
            issues.append(Issue("ground_motion.duration", gm["duration"], e.problem, e.fix,
                                key_lines.get("duration") or line))
            continue
        try:
            check_filter_length(npts, dt, gm["duration"], gm["cutoff_frequency"], source)
        except MotionError as e:
            if e.key is not None:  # a key of the case's, not the record's length
                leaf = e.key.rsplit(".", 1)[1]
                key, value, line = e.key, gm[leaf], key_lines.get(leaf) or line
            elif npts >= lowpass_min_samples():  # the record has the samples; the window keeps too few
                key, value, line = "ground_motion.duration", gm["duration"], key_lines.get("duration") or line
            issues.append(Issue(key, value, e.problem, e.fix, line))
    return issues

def _merge(base, over):
    """`base` with `over` laid on it: mappings merge key by key (recursively), anything else in
    `over` replaces. YAML line numbers follow the value that wins, so an error in a variant names
    the variant's line."""
    if not (isinstance(base, dict) and isinstance(over, dict)):
        return over
    out = LineDict()
    out.line = getattr(over, "line", 0) or getattr(base, "line", 0)
    out.key_lines = dict(getattr(base, "key_lines", {}))
    for k, v in base.items():
        out[k] = v
    for k, v in over.items():
        out[k] = _merge(base[k], v) if k in base else v
        if k in getattr(over, "key_lines", {}):
            out.key_lines[k] = over.key_lines[k]
    return out


def _variants(raw: LineDict, name: str) -> dict:
    """Take the case file's `variants:` section out of `raw` and check its shape: a mapping of
    variant names to mappings of case keys (each laid over the rest of the file)."""
    line = raw.key_lines.get("variants")
    v = raw.pop("variants", None)
    if v is None:
        return {}
    if not isinstance(v, dict):
        raise CaseError(name, [Issue("variants", v, "must be a mapping of variant names to case keys",
                                     "write e.g. 'variants: {3d: {mesh: {mode: 3d}}}'", line)])
    bad = [Issue(f"variants.{k}", body, "must be a mapping of case sections",
                 f"write the sections the variant changes under 'variants: {k}:', e.g. 'mesh: {{mode: 3d}}'",
                 v.key_lines.get(k, line))
           for k, body in v.items() if not isinstance(body, dict) or "variants" in body]
    if bad:
        raise CaseError(name, bad)
    return dict(v)


def _checked(raw: LineDict, filename: str) -> tuple[dict, list[str]]:
    """The validated data of `raw` and the whole-case warnings; raises CaseError listing every
    problem of either kind."""
    data = validate(schema(), raw, filename)
    issues, warnings = _whole_case_checks(data, raw, filename)
    if issues:
        raise CaseError(filename, issues)
    return data, warnings


def load_case(path: str | Path, variant: str | None = None) -> Case:
    """Read and validate a case file. Raises CaseError listing every problem found.

    `variant`: the name of an entry of the file's `variants:` section, whose keys are laid over
    the rest of the file (docs/user_guide.md "Variants"). Without `variant`, each variant is also
    checked against the schema and its problems are warnings (a typo in one is said before any
    run, but does not stop the base case); the chosen variant's problems are errors. A variant
    that does not set `output.directory` writes to the base directory with `_<variant>` appended,
    so it never overwrites the base case's results."""
    path = Path(path).resolve()
    name = str(path)
    if not path.is_file():
        raise CaseError(name, [Issue("<file>", str(path), "case file not found",
                                     "give the path of an existing case.yaml")])
    import yaml

    try:
        raw = load_yaml(path.read_text())
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        line = mark.line + 1 if mark else None
        problem = getattr(e, "problem", None) or str(e)
        raise CaseError(name, [Issue("<yaml>", None, f"not valid YAML: {problem}",
                                     "fix the YAML syntax at that line (indentation, ':' after keys)", line)]) from None
    if not isinstance(raw, dict):
        raise CaseError(name, [Issue("<top>", raw, "the case file must be a mapping of sections",
                                     "start with 'name:', 'geometry:', ... (see cases/example)", 1)])
    variants = _variants(raw, name)
    if variant is not None and variant not in variants:
        have = ", ".join(sorted(map(str, variants))) or "none"
        raise CaseError(name, [Issue("--variant", variant, f"no such variant in the case file (it has: {have})",
                                     "give one of the names under 'variants:', or add the variant there")])
    # the file as written first (its problems are named as the file's), then every variant
    data, warnings = _checked(raw, name)
    if variant is not None:
        body = variants[variant]
        data, warnings = _checked(_merge(raw, body), f"{name} (variant {variant})")
        if "directory" not in (body.get("output") or {}):
            data["output"]["directory"] = f"{data['output']['directory']}_{variant}"
    else:
        # the variants not chosen: checked against the schema (a misspelt key or a wrong unit is
        # said before any run) but as warnings, so that an edit of the file that no longer suits
        # a variant (incompressible water and the 3d variant's closed ends) stops only a run of it
        for vname, body in variants.items():
            vfile = f"{name} (variant {vname})"
            try:
                validate(schema(), _merge(raw, body), vfile)
            except CaseError as e:
                warnings.extend(f"variant {vname} would not run: {i.format(vfile)}" for i in e.issues)
    return Case(path=path, data=data, warnings=warnings, variant=variant)
