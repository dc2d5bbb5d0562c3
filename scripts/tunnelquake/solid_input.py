"""solid_input.h5 (version 2) for tq-solid, from a validated case, its mesh.h5 and motion.h5.

The layout is docs/formats.md "## solid_input.h5"; tq-solid rejects any group or attribute it does
not know, so this writer and that table change together.

    write_solid_input(case, mesh_h5, motion_h5, condition, out,
                      coupling_address=None, coupling_token=None) -> Path

Per condition (the paper's §3.2):

    no_water        stages without the hydrostatic one (no internal pressure)
    static_water    hydrostatic internal pressure p(z) = rho_w g (head - (z - z_axis)) on lining_inner
    dynamic_water   the same static pressure; the hydrodynamic part comes from the coupled water:
                    with ``coupling_address`` (the TCP address file tq-solid publishes its port in)
                    and ``coupling_token`` (the run's secret, given to the fluid too) a ``/coupling``
                    group from the case's ``coupling`` section (docs/coupler.md "Solid adapter")

Choices made here (docs/solid_solver.md "Staged initial state", "Seismic boundaries"):

* supports during the static stages: base fixed in x, y, z; the four sides on rollers (normal
  direction fixed); at the seismic stage the base becomes the viscoelastic boundary and xmin/xmax
  the free-field boundaries, each support replaced by its reaction. The ymin/ymax faces stay on
  rollers (u_y = 0): for a vertically incident x/z wave along a long tunnel the y-faces are
  symmetry planes, and their layers are not horizontal where the tunnel crosses them. A motion
  with a component along the axis (y, an SH wave shearing the ground antiplane) needs u_y free:
  in a slice the ymin/ymax faces are then tied periodic (/boundaries/periodic: u equal on both,
  all three directions, which keeps eps_yy = 0 and plane strain in x-z); a 3D model refuses it;
* the spring distance R of the viscoelastic base is the depth of the tunnel axis above the base;
* materials: the elastic constants plus the case's ``model`` and the Mohr-Coulomb damage
  parameters as attributes (tq-solid builds the Mohr-Coulomb damage material from them when
  ``model`` is ``mohr_coulomb_damage``);
* in slice mode (mesh attribute slice = 1) the monitors' y is moved into the slice's mid-plane;
* with the case's monitors go the two reference points of `output.displacement_reference`
  (`reference_points`): the base under the tunnel axis and the free field at the axis' depth.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from . import children
from .case import coupling_predictor, coupling_window_force_weight
from .files import h5_in_memory

FORMAT = "tunnelquake-solid-input"
VERSION = 2
CONDITIONS = ("no_water", "static_water", "dynamic_water")
#: Mohr-Coulomb damage parameters passed through to tq-solid (its damage material reads them).
MOHR_COULOMB_KEYS = ("model", "cohesion", "friction_angle", "dilation_angle", "tensile_strength",
                     "damage_constant", "damage_effect")


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
            "pairs": int(f["/interfaces/rock_lining"].shape[0]) if "/interfaces/rock_lining" in f else 0,
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


#: Coupling schemes tq-solid's adapter runs (the case schema offers the same).
COUPLING_SCHEMES = ("explicit", "paper", "implicit")


def write_solid_input(case, mesh_h5: Path, motion_h5: Path, condition: str, out: Path,
                      coupling_address: str | Path | None = None, coupling_token: str | None = None) -> Path:
    """Write tq-solid's input for one condition of a validated case. Returns `out`.

    For ``dynamic_water`` with ``coupling_address`` and ``coupling_token`` given, the ``/coupling``
    group is written from the case's ``coupling`` section (the fluid must be given the same)."""
    import h5py

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
    with h5_in_memory(tmp, 0o600 if coupling_token else 0o666) as f:
        f.attrs["format"] = FORMAT
        f.attrs["version"] = VERSION
        f.attrs["mesh"] = os.path.relpath(mesh_h5.resolve(), out.parent.resolve())
        f.attrs["condition"] = condition

        s = f.create_group("solver")
        s.attrs["t_end"] = float(t_end)
        s.attrs["dt"] = float(d["time"]["dt"] or 0.0)
        s.attrs["safety"] = float(d["time"]["safety_factor"])
        if d["time"]["subcycling"]:
            s.attrs["subcycling_levels"] = float(d["time"]["subcycling"])

        damp = d["damping"]
        if damp["ratio"] > 0:
            dm = f.create_group("damping")
            if damp["model"] == "rayleigh":
                dm.attrs["ratio"] = float(damp["ratio"])
                dm.attrs["f1"], dm.attrs["f2"] = (float(x) for x in damp["frequencies"])
            else:  # mass-proportional only: the ratio at f1, falling as f1/f above it
                dm.attrs["alpha"] = 2 * float(damp["ratio"]) * 2 * np.pi * float(damp["frequencies"][0])
                dm.attrs["beta"] = 0.0

        for region in mesh["regions"]:
            m = d["materials"][region]
            mg = f.create_group(f"materials/{region}")
            mg.attrs["E"] = float(m["youngs_modulus"])
            mg.attrs["nu"] = float(m["poisson_ratio"])
            mg.attrs["rho"] = float(m["density"])
            # `model` is the case's choice (elastic or mohr_coulomb_damage); the Mohr-Coulomb damage
            # parameters go along (the Mohr-Coulomb damage material reads them; an elastic material ignores them).
            for key in MOHR_COULOMB_KEYS:
                if m.get(key) is not None:
                    mg.attrs[key] = m[key] if isinstance(m[key], str) else float(m[key])

        supports = {"bottom": "xyz", "xmin": "x", "xmax": "x"}
        if not mesh["slice"]:
            supports.update({"ymin": "y", "ymax": "y"})
        for face, dirs in supports.items():
            f.create_group(f"boundary/fixed/{face}").attrs["directions"] = dirs

        st = f.create_group("stages")
        st.attrs["sequence"] = ",".join(sequence)
        st.attrs["relaxation_tolerance"] = float(stages["relaxation_tolerance"])
        st.attrs["relaxation_max_steps"] = int(stages["relaxation_max_steps"])
        # Fraction of the excavation load released with the rock alone before the lining is active.
        st.attrs["release_fraction"] = float(stages["release_fraction"])

        if "in_situ" in sequence:
            i = f.create_group("in_situ")
            for k in ("kx", "ky", "kz"):
                i.attrs[k] = float(ins[k])
            i.attrs["gravity"] = float(g)
            i.attrs["z_top"] = float(geo["z_range"][1])
        if hydrostatic:
            h = f.create_group("hydrostatic")
            h.attrs["face"] = "lining_inner"
            h.attrs["unit_weight"] = float(water["density"] * g)
            h.attrs["pressure_at_axis"] = float(water["density"] * g * water["head"])
            h.attrs["z_axis"] = float(geo["tunnel_centre_z"])
        if mesh["pairs"]:
            it = d["interface"]
            r = f.create_group("interfaces/rock_lining")
            r.attrs["model"] = it["model"]
            r.attrs["static_friction"] = float(it["static_friction"])
            r.attrs["dynamic_friction"] = float(it["dynamic_friction"])
            r.attrs["cohesion"] = float(it["cohesion"])
            r.attrs["after_failure"] = it["after_failure"]

        if "seismic" in sequence:
            b = f.create_group("boundaries/bottom")
            b.attrs["face"] = "bottom"
            b.attrs["type"] = "viscoelastic"
            b.attrs["distance"] = float(geo["tunnel_centre_z"] - geo["z_range"][0])
            f.create_group("boundaries/free_field").attrs["faces"] = "xmin,xmax"
            axial = motion["ay"] is not None and bool(np.any(motion["ay"]))
            if axial:
                if not mesh["slice"]:
                    raise SolidInputError("the motion has a component along the tunnel's axis (y), which a 3D "
                                          "model's y faces (rollers) would hold back; use mesh.mode: slice")
                f.create_group("boundaries/periodic").attrs["faces"] = "ymin,ymax"
            mo = f.create_group("motion")
            mo["time"] = motion["time"]
            mo["ax"] = motion["ax"]
            if axial:
                mo["ay"] = motion["ay"]
            mo["az"] = motion["az"]
            mo.attrs["cutoff_frequency"] = float(d["ground_motion"]["cutoff_frequency"])
            if motion["convention"]:
                mo.attrs["convention"] = motion["convention"]

        if condition == "dynamic_water" and (coupling_address is not None or coupling_token is not None):
            if coupling_address is None or not coupling_token:
                raise SolidInputError("dynamic_water coupling needs both coupling_address (the TCP address file) "
                                      "and coupling_token (the run's secret)")
            if "seismic" not in sequence:
                raise SolidInputError("dynamic_water couples the water in the seismic stage; add seismic to "
                                      "stages.sequence")
            cs = d["coupling"]
            if cs["scheme"] not in COUPLING_SCHEMES:
                raise SolidInputError(f"coupling.scheme {cs['scheme']!r} is not available in tq-solid's adapter "
                                      f"(it runs {', '.join(COUPLING_SCHEMES)}); choose implicit or paper")
            if int(cs["window"]) > 1 and cs["scheme"] == "paper":
                raise SolidInputError(f"coupling.window = {cs['window']} solid steps needs scheme explicit or "
                                      "implicit (the paper scheme's two passes are made for one-step windows); "
                                      "use window: 1")
            c = f.create_group("coupling")
            c.attrs["scheme"] = cs["scheme"]
            c.attrs["window"] = int(cs["window"])
            c.attrs["tolerance"] = float(cs["tolerance"])
            c.attrs["max_iterations"] = int(cs["max_iterations"])
            if coupling_window_force_weight(cs) != 0.5:  # absent in the solid input = 0.5, the linear ramp
                c.attrs["window_force_weight"] = coupling_window_force_weight(cs)
            if float(cs.get("energy_limit", 0)) > 0:  # absent = no energy guard
                c.attrs["energy_limit"] = float(cs["energy_limit"])
            c.attrs["acceleration"] = cs["acceleration"]
            if coupling_predictor(cs) != "constant":  # absent = constant
                c.attrs["predictor"] = coupling_predictor(cs)
            if int(cs.get("reuse", 0)):  # absent = 0
                c.attrs["reuse"] = int(cs["reuse"])
            c.attrs["transport"] = cs["transport"]
            c.attrs["timeout"] = float(cs["timeout"])
            c.attrs["address_file"] = str(coupling_address)
            c.attrs["token"] = str(coupling_token)
            c.attrs["face"] = "lining_inner"

        monitors = dict(d["output"]["monitors"] or {})
        if monitors:
            monitors.update(reference_points(geo, mesh["lo"], next(iter(monitors.values()))[1]))
            names = list(monitors)
            pts = np.array([monitors[n] for n in names], float)
            if mesh["slice"]:
                pts[:, 1] = 0.5 * (mesh["lo"][1] + mesh["hi"][1])
            mg = f.create_group("monitors")
            mg["names"] = np.array(names, dtype=h5py.string_dtype())
            mg["points"] = pts
        o = f.create_group("output")
        o.attrs["monitor_dt"] = float(d["output"]["history_interval"])
        if float(d["output"]["checkpoint_interval"]) > 0:  # written when tq-solid gets --checkpoint-dir
            o.attrs["checkpoint_interval"] = float(d["output"]["checkpoint_interval"])
        o["snapshot_times"] = snapshot_times(d["output"]["snapshot_times"], t_end)
    if coupling_token:  # the run's coupling secret: readable by its owner only
        os.chmod(tmp, 0o600)
    os.replace(tmp, out)
    return out


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
    and its end (the end state is what the paper's Figs. 9 and 10 show; post's XDMF animates the rest)."""
    if given:
        return np.asarray(given, float)
    t = np.arange(SNAPSHOT_INTERVAL, t_end, SNAPSHOT_INTERVAL)
    return np.append(t[t < t_end - 1e-9], float(t_end))


def solid_step(exe, solid_input) -> float:
    """The solid step tq-solid will take (its --check: safety x the stable step, or the case's dt)."""
    import math
    import re

    out = children.run([str(exe), str(solid_input), "--check"], capture_output=True, text=True, timeout=300)
    m = re.search(r"dt = ([0-9.eE+-]+) s", out.stdout + out.stderr)
    if out.returncode != 0 or not m:
        raise RuntimeError(f"tq-solid --check failed on {solid_input}:\n{(out.stdout + out.stderr)[-2000:]}")
    # printed to 6 significant digits, i.e. possibly rounded *up* by up to 5e-6 relative (9.30806e-05
    # can print as 9.3081e-05): step back by 1e-5 relative, then round down to 5 digits, so that the
    # pinned step is never above the limit (a 5-digit value such as 9.3081e-05 was refused as above
    # a limit of 9.30806e-05)
    dt = float(m.group(1)) * (1.0 - 1e-5)
    q = 10.0 ** (math.floor(math.log10(dt)) - 4)
    return math.floor(dt / q) * q


#: Below this many solid elements `parallel.threads: 0` runs one thread: on the paper's slice
#: (1,464 elements, 1 s of shaking) 2 threads took 1.3x the wall time of one (docs/benchmarks.md).
SMALL_MESH_ELEMENTS = 20000


def solid_threads(case, mesh_h5, share: int = 1) -> int:
    """OpenMP threads for tq-solid: the case's `parallel.threads`, or for 0 one thread on a small
    mesh (SMALL_MESH_ELEMENTS) and otherwise the cores divided among the `share` solvers that run
    at once (conditions side by side): a team of threads on cores it shares with another solver
    waits at each parallel loop for a thread that is not running (three 3D runs side by side on 2
    cores: 1 thread each 1.3-1.45x the steps a second of 2 threads each, docs/benchmarks.md "Threads of
    solvers side by side")."""
    import os

    import h5py

    threads = int(case.data["parallel"]["threads"])
    if threads:
        return threads
    with h5py.File(mesh_h5, "r") as f:
        elements = f["elements/connectivity"].shape[0]
    return 1 if elements < SMALL_MESH_ELEMENTS else max(1, len(os.sched_getaffinity(0)) // max(1, share))
