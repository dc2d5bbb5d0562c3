"""solid_input.h5 (version 2) for tq-solid, from a validated case, its mesh.h5 and motion.h5.

Every attribute and dataset goes through `solver_input_schema.put`, which takes its type and bounds
from the one table of the file's layout (scripts/tunnelquake/solver_input_schema.py; docs/formats.md
"## solid_input.h5" and tq-solid's reader are generated from it). Values come from the case; what is
derived (mesh facts, the motion, the stages run) is computed here.

    write_solid_input(case, mesh_h5, motion_h5, condition, out, coupling=None) -> Path

Per condition (the paper's §3.2):

    no_water        stages without the hydrostatic one (no internal pressure)
    static_water    hydrostatic internal pressure p(z) = rho_w g (head - (z - z_axis)) on lining_inner
    dynamic_water   the same static pressure; the hydrodynamic part comes from the coupled water:
                    with ``coupling`` (fluid_case.coupling_settings: the case's ``coupling`` section,
                    the window, the TCP address file, the run's secret) a ``/coupling`` group
                    (docs/coupler.md "Solid adapter")

Choices made here (docs/solid_solver.md "Staged initial state", "Seismic boundaries"):

* supports during the static stages: base fixed in x, y, z; the four sides on rollers (normal
  direction fixed); at the seismic stage the base becomes the viscoelastic boundary and xmin/xmax
  the free-field boundaries, each support replaced by its reaction. The ymin/ymax faces stay on
  rollers (u_y = 0): for a vertically incident x/z wave along a long tunnel the y-faces are
  symmetry planes, and their layers are not horizontal where the tunnel crosses them. A motion
  with a component along the axis (y, an SH wave shearing the ground antiplane) needs u_y free:
  in a slice the ymin/ymax faces are then tied periodic (/boundaries/periodic: u equal on both,
  all three directions, which keeps eps_yy = 0 and plane strain in x-z); a 3D model takes it with
  the tunnel's ends plugged with ground, its y faces then on free-field columns too (the first
  side's column shared: /boundaries/free_field shared_column_faces), and refuses it otherwise;
* the spring distance R of the viscoelastic base is the depth of the tunnel axis above the base;
* materials: every material row of the table, from the case key it is linked to (else its default),
  given or not by the model (tq-solid builds the material the ``model`` names from the ones it reads);
* in slice mode (mesh attribute slice = 1) the monitors' y is moved into the slice's mid-plane;
* with the case's monitors go the two reference points of `output.displacement_reference`
  (`reference_points`): the base under the tunnel axis and the free field at the axis' depth.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from . import children, fingerprint, incident_wave
from .case import CONDITIONS, case_geology, fault_offset_slip, lining_joints_active, subcycling_levels
from .cores import SMALL_MESH_ELEMENTS, solid_thread_count  # noqa: F401 - SMALL_MESH_ELEMENTS kept for its users
from .drm_input import write_drm_group, write_drm_group_from_file
from .files import h5_in_memory
from .freefield import FreeFieldError
from .solver_input_schema import FORMAT, MATERIALS, VERSION, entries, linked, put, write_schema


class SolidInputError(ValueError):
    """The case, mesh or motion cannot make a solid input; the message says what and how to fix it."""


def _mesh_facts(mesh_h5: Path) -> dict:
    import h5py

    with h5py.File(mesh_h5, "r") as f:
        if f.attrs.get("format") != "tunnelquake-solid-mesh":
            raise SolidInputError(f"{mesh_h5}: not a tunnelquake solid mesh (attribute format is "
                                  f"{f.attrs.get('format')!r}); run `tunnelquake mesh` first")
        xyz = f["/nodes/coordinates"][...]
        regions = [r.decode() if isinstance(r, bytes) else str(r) for r in f["/elements"].attrs["regions"]]
        return {
            "slice": int(f.attrs.get("slice", 0)) == 1,
            "regions": regions,
            "faces": sorted(f["/faces"].keys()) if "faces" in f else [],
            "strips": sorted(k for k in (f["/faces"].keys() if "faces" in f else []) if "_strip" in k),
            "pairs": int(f["/interfaces/rock_lining"].shape[0]) if "/interfaces/rock_lining" in f else 0,
            "joints": int(f["/interfaces/lining_joint_y"].shape[0]) if "/interfaces/lining_joint_y" in f else 0,
            "lo": xyz.min(axis=0),
            "hi": xyz.max(axis=0),
        }


def _motion(motion_h5: Path) -> dict:
    import h5py

    with h5py.File(motion_h5, "r") as f:
        if f.attrs.get("format") != "tunnelquake-motion":
            raise SolidInputError(f"{motion_h5}: not a tunnelquake motion file; run `tunnelquake motion` first")
        conv = f.attrs.get("convention", "")
        return {
            "time": np.asarray(f["time"][...], float),
            "ax": np.asarray(f["incident_ax"][...], float),
            "az": np.asarray(f["incident_az"][...], float),
            "ay": np.asarray(f["incident_ay"][...], float) if "incident_ay" in f else None,
            "convention": conv.decode() if isinstance(conv, bytes) else str(conv),
        }


def _from_case(obj, group: str, section: dict, table) -> None:
    """Write a group's rows that are linked to a case key from that key's case section."""
    for e in linked(group, table):
        put(obj, group, e.name, section[e.case.rsplit(".", 1)[1]], table)


def _reinforced_concrete_values(d: dict, m: dict) -> dict:
    """The material map of a `reinforced_concrete` region completed from the case's design block
    (concrete and bars: the same keys the design check reads) and the ring's geometry and mesh."""
    from .case import lining_rows
    from .design.capacity import Concrete

    des = d.get("design") or {}
    conc, bars = des.get("concrete") or {}, des.get("reinforcement") or {}
    if not conc.get("fck"):
        raise SolidInputError("materials.lining.model: reinforced_concrete needs the concrete's strength; "
                              "add design: {concrete: {fck: 30 MPa}}")
    if not (bars.get("As_inner") or bars.get("As_outer")):
        raise SolidInputError("materials.lining.model: reinforced_concrete needs hoop bars; add "
                              "design.reinforcement.As_inner and As_outer (m^2/m)")
    c = Concrete(conc["fck"], conc.get("fctm"))
    g = d["geometry"]
    out = dict(m)
    out.update({k: v for k, v in bars.items() if v is not None})
    out.update(fck=c.fck, fctm=c.fctm_value, tunnel_centre_x=g["tunnel_centre_x"],
               tunnel_centre_z=g["tunnel_centre_z"], lining_thickness=g["lining_thickness"],
               ring_inner_radius=g["excavated_radius"] - g["lining_thickness"],
               lining_elements_through=float(lining_rows(d)))
    return out


def _material_values(m: dict, table, d: dict | None = None) -> dict:
    """A region's material attributes: each material row of the table from its case key (else its
    default); rows whose value is neither given nor defaulted are left out. Rows fed from outside
    the materials section (a reinforced_concrete lining's design and geometry values) are written
    for the models that read them only."""
    rc = m.get("model") == "reinforced_concrete"
    if rc and d is not None:
        m = _reinforced_concrete_values(d, m)
    out = {}
    for e in table:
        if e.group != MATERIALS:
            continue
        if e.models and m.get("model") not in e.models and not (e.case or "").startswith("materials."):
            continue
        v = m.get(e.case.rsplit(".", 1)[1] if e.case else e.name)
        v = e.default if v is None else v
        if v is not None:
            out[e.name] = v
    if rc and d is not None:
        from .design.capacity import Concrete

        c = Concrete(d["design"]["concrete"]["fck"])
        out.update(eps_c2=c.eps_c2, eps_cu2=c.eps_cu2)
    return out


def write_solid_input(case, mesh_h5: Path, motion_h5: Path, condition: str, out: Path,
                      coupling: dict | None = None) -> Path:
    """Write tq-solid's input for one condition of a validated case. Returns `out`.

    ``coupling``: for ``dynamic_water``, the coupling settings both sides are given
    (fluid_case.coupling_settings), written once as the ``/coupling`` group (fluid_case.solid_coupling_attrs)."""
    import h5py

    from .fluid_case import solid_coupling_attrs

    table = entries()
    if condition not in CONDITIONS:
        raise SolidInputError(f"condition {condition!r} is not one of {', '.join(CONDITIONS)}")
    d = case.data
    mesh_h5, motion_h5, out = Path(mesh_h5), Path(motion_h5), Path(out)
    mesh = _mesh_facts(mesh_h5)
    motion = _motion(motion_h5)
    geo, ins, water, stages = d["geometry"], d["in_situ"], d["water"], d["stages"]

    missing = [r for r in mesh["regions"] if r not in d["materials"]]
    if missing:
        raise SolidInputError(f"mesh {mesh_h5} has region(s) {missing} without a material in the case; "
                              f"add materials.{missing[0]}")
    sequence = list(stages["sequence"])
    if fault_offset_slip(d) is not None and d["fault_offset"]["rise_time"] is None:  # the offset before the shaking
        sequence.insert(sequence.index("seismic") if "seismic" in sequence else len(sequence), "fault_offset")
    hydrostatic = condition in ("static_water", "dynamic_water") and water["head"] > 0
    if not hydrostatic:
        sequence = [s for s in sequence if s != "hydrostatic"]
    if "lining" in sequence and mesh["pairs"] == 0:
        raise SolidInputError(f"mesh {mesh_h5} has no rock-lining node pairs (/interfaces/rock_lining), which "
                              "the lining stage needs; rebuild it with `tunnelquake mesh --force`")
    g = ins["gravity"]
    t_end = d["time"]["end_time"] if d["time"]["end_time"] is not None else float(motion["time"][-1])

    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.part")
    # built in memory: HDF5 never meets a full disk (files.h5_in_memory); the token's file is 0600 from the start
    secret = coupling is not None and bool(coupling.get("token"))
    with h5_in_memory(tmp, 0o600 if secret else 0o666) as f:
        def w(obj, group, name, value):  # every value through the table
            put(obj, group, name, value, table)

        w(f, "/", "format", FORMAT)
        w(f, "/", "version", VERSION)
        w(f, "/", "mesh", os.path.relpath(mesh_h5.resolve(), out.parent.resolve()))
        w(f, "/", "condition", condition)
        w(f, "/", "input_fingerprint", fingerprint.to_text(fingerprint.condition_inputs(case, condition)))

        s = f.create_group("solver")
        w(s, "/solver", "t_end", t_end)
        w(s, "/solver", "dt", d["time"]["dt"] or 0.0)
        w(s, "/solver", "safety", d["time"]["safety_factor"])
        if subcycling_levels(d, condition):
            w(s, "/solver", "subcycling_levels", subcycling_levels(d, condition))

        damp = d["damping"]
        if damp["ratio"] > 0:
            dm = f.create_group("damping")
            if damp["model"] == "rayleigh":
                w(dm, "/damping", "ratio", damp["ratio"])
                w(dm, "/damping", "f1", damp["frequencies"][0])
                w(dm, "/damping", "f2", damp["frequencies"][1])
            else:  # mass-proportional only: the ratio at f1, falling as f1/f above it
                w(dm, "/damping", "alpha", 2 * float(damp["ratio"]) * 2 * np.pi * float(damp["frequencies"][0]))
                w(dm, "/damping", "beta", 0.0)

        for region in mesh["regions"]:
            mg = f.create_group(f"materials/{region}")
            for name, value in _material_values(d["materials"][region], table, d).items():
                w(mg, MATERIALS, name, value)

        # The side faces: whole, or (a ground that changes along y) in strips one element wide, each
        # its own support group and free-field column (meshing/build.py side_strips).
        sides = mesh["strips"] or ["xmin", "xmax"]
        supports = {"bottom": "xyz", **{side: "x" for side in sides}}
        if not mesh["slice"]:
            supports.update({"ymin": "y", "ymax": "y"})
            supports.update({face: "y" for face in _tied_lining_ends(d, mesh["faces"])})
        for face, dirs in supports.items():
            w(f.create_group(f"boundary/fixed/{face}"), "/boundary/fixed/*", "directions", dirs)

        st = f.create_group("stages")
        w(st, "/stages", "sequence", ",".join(sequence))
        _from_case(st, "/stages", stages, table)

        if "in_situ" in sequence:
            i = f.create_group("in_situ")
            _from_case(i, "/in_situ", ins, table)
            w(i, "/in_situ", "z_top", geo["z_range"][1])
            rho = overburden_density(d)
            if rho is not None:
                w(i, "/in_situ", "density", rho)
        if hydrostatic:
            h = f.create_group("hydrostatic")
            w(h, "/hydrostatic", "face", "lining_inner")
            w(h, "/hydrostatic", "unit_weight", water["density"] * g)
            w(h, "/hydrostatic", "pressure_at_axis", water["density"] * g * water["head"])
            w(h, "/hydrostatic", "z_axis", geo["tunnel_centre_z"])
        offset = fault_offset_displacements(d, mesh_h5)
        if offset is not None:
            fo = f.create_group("fault_offset")
            w(fo, "/fault_offset", "nodes", offset[0])
            w(fo, "/fault_offset", "displacement", offset[1])
            w(fo, "/fault_offset", "increments", int(d["fault_offset"]["increments"]))
            if d["fault_offset"]["rise_time"] is not None:  # the slip during the run
                w(fo, "/fault_offset", "rise_time", d["fault_offset"]["rise_time"])
                w(fo, "/fault_offset", "start_time", d["fault_offset"]["start_time"] or 0.0)
        if mesh["pairs"]:
            it = d["interface"]
            r = f.create_group("interfaces/rock_lining")
            _from_case(r, "/interfaces/rock_lining", it, table)
        if mesh["joints"]:
            lj = d["lining_joints"]
            if not lining_joints_active(d):
                raise SolidInputError(f"mesh {mesh_h5} has lining joints but the case has no lining_joints; rebuild "
                                      "the mesh with `tunnelquake mesh --force`")
            r = f.create_group("interfaces/lining_joints")
            _from_case(r, "/interfaces/lining_joints", lj, table)
            put(r, "/interfaces/lining_joints", "friction", -1.0 if lj["friction"] is None else lj["friction"], table)
        elif lining_joints_active(d):
            raise SolidInputError(f"mesh {mesh_h5} has no lining joints, which the case's lining_joints asks for; "
                                  "rebuild it with `tunnelquake mesh --force`")

        wave = incident_wave.active(d) and "seismic" in sequence
        if wave and mesh["slice"]:
            raise SolidInputError("incident_wave needs a 3D mesh (mesh.mode: 3d); this one is a slice")
        if "seismic" in sequence:
            b = f.create_group("boundaries/bottom")
            w(b, "/boundaries/bottom", "face", "bottom")
            w(b, "/boundaries/bottom", "type", "viscoelastic")
            w(b, "/boundaries/bottom", "distance", geo["tunnel_centre_z"] - geo["z_range"][0])
            # with an incident wave the base and the x sides absorb what the tunnel scatters (the wave
            # enters through the DRM layer); the y faces stay on rollers, which hold that scattered
            # field's u_y only (the shared columns a plugged tunnel's y faces can take are not used
            # with a DRM layer: not verified there)
            w(f.create_group("boundaries/free_field"), "/boundaries/free_field", "faces", ",".join(sides))
        if wave:
            from .case import ground_layers

            # the processed horizontal record: motion.h5 keeps the vertical-incidence incident
            # wave (half an outcrop record)
            record = motion["ax"] * (2.0 if motion["convention"] == "outcrop" else 1.0)
            try:
                if d["incident_wave"]["type"] == "h5drm":  # the free field from a file
                    write_drm_group_from_file(f, d, mesh_h5, case.dir, t_end)
                else:
                    write_drm_group(f, d, ground_layers(d), mesh_h5, record,
                                    float(motion["time"][1] - motion["time"][0]),
                                    out.parent / "free_field.h5drm" if d["incident_wave"]["write_h5drm"] else None)
            except (incident_wave.DrmLayerError, FreeFieldError) as e:
                raise SolidInputError(f"incident_wave: {e}") from None
        elif "seismic" in sequence:
            axial = motion["ay"] is not None and bool(np.any(motion["ay"]))
            if axial:
                if not mesh["slice"]:
                    # a 3D model takes it through free-field columns on its y faces too: their quads
                    # follow the tunnel's O-grid, so they share the first side's column, and the
                    # tunnel's ends must be plugged with ground there (tq-solid refuses another material)
                    if not int(d["mesh"].get("tunnel_end_plugs") or 0):
                        raise SolidInputError("the motion has a component along the tunnel's axis (y), which a "
                                              "3D model takes through free-field columns on its y faces, and "
                                              "those need the tunnel's ends plugged with ground; set "
                                              "mesh.tunnel_end_plugs: 1 or more, or use mesh.mode: slice")
                    w(f["boundaries/free_field"], "/boundaries/free_field", "shared_column_faces", "ymin,ymax")
                else:
                    w(f.create_group("boundaries/periodic"), "/boundaries/periodic", "faces", "ymin,ymax")
            mo = f.create_group("motion")
            w(mo, "/motion", "time", motion["time"])
            w(mo, "/motion", "ax", motion["ax"])
            if axial:
                w(mo, "/motion", "ay", motion["ay"])
            w(mo, "/motion", "az", motion["az"])
            w(mo, "/motion", "cutoff_frequency", d["ground_motion"]["cutoff_frequency"])
            if motion["convention"]:
                w(mo, "/motion", "convention", motion["convention"])

        if coupling is not None:
            if condition != "dynamic_water":
                raise SolidInputError(f"condition {condition} runs without the water's coupling; only "
                                      "dynamic_water takes a /coupling group")
            if "seismic" not in sequence:
                raise SolidInputError("dynamic_water couples the water in the seismic stage; add seismic to "
                                      "stages.sequence")
            c = f.create_group("coupling")
            for key, value in solid_coupling_attrs(coupling).items():
                w(c, "/coupling", key, value)

        monitors = dict(d["output"]["monitors"] or {})
        if monitors:
            monitors.update(reference_points(geo, mesh["lo"], next(iter(monitors.values()))[1]))
            names = list(monitors)
            pts = np.array([monitors[n] for n in names], float)
            if mesh["slice"]:
                pts[:, 1] = 0.5 * (mesh["lo"][1] + mesh["hi"][1])
            mg = f.create_group("monitors")
            w(mg, "/monitors", "names", np.array(names, dtype=h5py.string_dtype()))
            w(mg, "/monitors", "points", pts)
        o = f.create_group("output")
        w(o, "/output", "monitor_dt", d["output"]["history_interval"])
        if float(d["output"]["checkpoint_interval"]) > 0:  # written when tq-solid gets --checkpoint-dir
            w(o, "/output", "checkpoint_interval", d["output"]["checkpoint_interval"])
        w(o, "/output", "snapshot_times", snapshot_times(d["output"]["snapshot_times"], t_end))
        write_schema(f, table)
    if secret:  # the run's coupling secret: readable by its owner only
        os.chmod(tmp, 0o600)
    os.replace(tmp, out)
    return out


#: The block's faces a fault offset moves: all but the ground surface (top), which stays free.
FAULT_OFFSET_FACES = ("bottom", "xmin", "xmax", "ymin", "ymax")


def _tied_lining_ends(d: dict, faces) -> list[str]:
    """The mesh's lining end faces (meshing.build.LINING_END_FACES: a block crossed by a fault zone)
    when a bonded interface ties the lining's outer nodes to the rock's: those ends are then held as
    the y faces are (the tie would otherwise join a held node to a free one); [] with the dynamic
    contact, whose lining ends are free and follow the rock through the interface alone."""
    from .meshing.build import LINING_END_FACES

    bonded = (d.get("interface") or {}).get("model") == "bonded"
    return [LINING_END_FACES] if bonded and LINING_END_FACES in faces else []


def fault_offset_displacements(d: dict, mesh_h5: Path):
    """The fault_offset stage's nodes and their displacements ([N] int, [N, 3] m) for a case with a
    fault_offset, else None: every node of the block's faces but the top (FAULT_OFFSET_FACES; the
    lining's end faces only when a bonded interface ties them to the rock, _tied_lining_ends) takes
    the hanging wall's slip times its share (meshing.geology.hanging_wall_share: 1 above the band,
    0 below, linear across it), so the footwall's boundary is held, the hanging wall's moved as one
    and the band's sheared uniformly (docs/solid_solver.md "Fault offset")."""
    import h5py

    from .meshing.geology import hanging_wall_share

    slip = fault_offset_slip(d)
    if slip is None:
        return None
    with h5py.File(mesh_h5, "r") as f:
        missing = [name for name in FAULT_OFFSET_FACES if f"faces/{name}" not in f]
        if missing:
            raise SolidInputError(f"mesh {mesh_h5} has no face group(s) {missing}, which the fault offset moves; "
                                  "rebuild it with `tunnelquake mesh --force`")
        moved = FAULT_OFFSET_FACES + tuple(_tied_lining_ends(d, f["faces"].keys()))
        nodes = np.unique(np.concatenate([f[f"faces/{name}"][...].ravel() for name in moved]))
        xyz = f["/nodes/coordinates"][...][nodes]
    share = hanging_wall_share(case_geology(d).fault, xyz)
    return nodes.astype(np.int64), share[:, None] * np.asarray(slip, float)[None, :]


def overburden_density(d: dict) -> float | None:
    """The one overburden density the in-situ stress starts from when the ground has regions
    bounded by planes of different densities (dipping layers, a fault zone): tq-solid's layered
    overburden needs regions that are horizontal layers, so the stress is set with materials.rock's
    density and the static relaxation carries the difference (each region's own weight is its body
    force); None when the layered profile applies (docs/meshing.md "Regions bounded by planes")."""
    from .case import case_geology

    geology = case_geology(d)
    if geology is None:
        return None
    ground = ["rock"] + [layer["material"] for layer in d.get("layers") or []] + geology.materials
    densities = {float(d["materials"][m]["density"]) for m in ground}
    return float(d["materials"]["rock"]["density"]) if len(densities) > 1 else None


def reference_points(geo: dict, lo, y: float) -> dict[str, list[float]]:
    """The points whose displacement histories are the references of
    `output.displacement_reference` (post.REFERENCES), written with the case's monitors: the base
    under the tunnel axis, and the free field at the axis' depth, the node of the xmin side
    (a free-field boundary in the shaking, which follows the 1D column there); both at `y`, a
    monitor's (tq-solid's lining rings are taken at the monitors' y: no ring of their own)."""
    from .post import REFERENCES

    y = float(y)
    x_c, z_c = float(geo["tunnel_centre_x"]), float(geo["tunnel_centre_z"])
    return {REFERENCES["base"]: [x_c, y, float(lo[2])], REFERENCES["free_field"]: [float(lo[0]), y, z_c]}


#: Seconds between the default field snapshots (`output.snapshot_times` empty).
SNAPSHOT_INTERVAL = 1.0


def snapshot_times(given, t_end: float) -> np.ndarray:
    """The field snapshot times: those given, else every SNAPSHOT_INTERVAL s of the seismic stage
    from its start and its end (the start holds the static state, which the hydraulic-jacking
    check reads; the end state is what the paper's Figs. 9 and 10 show; post's XDMF animates the rest)."""
    if given:
        return np.asarray(given, float)
    t = np.arange(0.0, t_end, SNAPSHOT_INTERVAL)
    return np.append(t[t < t_end - 1e-9], float(t_end))


def solid_step(exe, solid_input) -> float:
    """The solid step tq-solid takes on `solid_input` (safety x its stable step, or the input's
    /solver dt), as its `--check --json` writes it: to full double precision, never read from text."""
    import json
    import tempfile

    solid_input = Path(solid_input)
    with tempfile.TemporaryDirectory(prefix=".step-", dir=solid_input.parent) as tmp:
        report = Path(tmp) / "check.json"
        out = children.run([str(exe), str(solid_input), "--check", "--json", str(report)], capture_output=True,
                           text=True, timeout=300)
        if out.returncode != 0 or not report.is_file():
            raise RuntimeError(f"tq-solid --check failed on {solid_input}:\n{(out.stdout + out.stderr)[-2000:]}")
        return float(json.loads(report.read_text())["dt"])


def solid_threads(case, mesh_h5, share: int = 1) -> int:
    """OpenMP threads for tq-solid: cores.solid_thread_count of the case's `parallel.threads` and
    the mesh's solid elements."""
    import h5py

    with h5py.File(mesh_h5, "r") as f:
        elements = f["elements/connectivity"].shape[0]
    return solid_thread_count(int(case.data["parallel"]["threads"]), elements, share)
