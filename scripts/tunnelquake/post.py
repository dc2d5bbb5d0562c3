"""Post-processing of condition results: monitors as CSV, peaks with their times, the figures
(input motion, water pressure, peak displacements, principal stress, damage histories, damage over
the section, interface states), and ParaView files (XDMF). Everything here works on the case's own
monitors; a comparison with a published run adds its marks through the figures' optional
reference arguments (paper.py).

Works on whatever a run left: a results file cut off by a crash is read up to its last written
row (rows are appended and flushed as the solver goes; rows whose time does not advance are the
fill of an extension that was never written and are dropped), snapshots missing their `time`
attribute (written last) are skipped, and the status attribute and the planned end are reported.
A file with no monitor row (a run stopped before the shaking) reads as such, with the static
stages it completed and the one it stopped in.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .files import atomic_path, h5_in_memory

CONDITION_LABELS = {"no_water": "(1) no water", "static_water": "(2) static water",
                    "dynamic_water": "(3) dynamic water"}
#: /interface attr `states`, in the order of the integer codes of /snapshots/<k>/interface/state
CONTACT_STATES = ("bonded", "separated", "slipping", "stuck", "inactive")
#: `output.displacement_reference`: what the monitors' displacements are measured against.
#: absolute: the fixed frame (each history from its value at the start of the shaking); base: the
#: model's base under the tunnel axis; free_field: the free field at the tunnel axis' depth (the
#: xmin side, a free-field boundary). The two references are histories tq-solid writes beside the
#: case's monitors, under these names (solid_input.reference_points).
DISPLACEMENT_REFERENCES = ("absolute", "base", "free_field")
REFERENCES = {"base": "@base", "free_field": "@free_field"}
REFERENCE_WORDS = {"absolute": "absolute (the fixed frame)", "base": "relative to the base under the tunnel axis",
                   "free_field": "relative to the free field at the tunnel axis' depth"}

@dataclass
class Monitor:
    time: np.ndarray
    u: np.ndarray  # [T, 3] m
    principal: np.ndarray  # [T, 3] Pa, sigma1 <= sigma2 <= sigma3
    extra: dict = field(default_factory=dict)  # damage [T], water_pressure [T] (Pa) when present
    attrs: dict = field(default_factory=dict)


@dataclass
class ConditionResult:
    condition: str
    path: Path
    status: str
    monitors: dict[str, Monitor]
    attrs: dict = field(default_factory=dict)
    planned_end: float | None = None  # t_end of the solid input, when it can be read
    snapshots: list[tuple[str, float]] = field(default_factory=list)  # complete ones, by time
    incomplete_snapshots: list[str] = field(default_factory=list)
    mesh: dict | None = None  # coordinates [N, 3], connectivity [E, 8], region [E], regions
    interface: dict | None = None  # pairs [P, 2], normal, area, states, history [T, 7]
    joints: dict | None = None  # the lining's joints (read_joints): y [J], time [T], opening [T, J], ...
    water_column: dict | None = None  # the water along the axis (read_water_column): y [S], p [T, S], levels
    input_attrs: dict = field(default_factory=dict)  # /materials/lining attrs of the solid input
    coupling: dict = field(default_factory=dict)  # /coupling attrs (condition 3: scheme, windows, ...)
    stages_done: list[str] = field(default_factory=list)  # /stages/<k>_<name> converged, in order
    stages_failed: list[str] = field(default_factory=list)  # /stages/<k>_<name> not converged
    stages_planned: list[str] = field(default_factory=list)  # /stages `sequence` of the solid input
    references: dict[str, Monitor] = field(default_factory=dict)  # base / free_field histories (absolute)
    displacement_reference: str = "absolute"  # what the monitors' u are relative to

    @property
    def complete(self) -> bool:
        return self.status == "completed"

    @property
    def t_end(self) -> float:
        return max((float(m.time[-1]) for m in self.monitors.values() if m.time.size), default=0.0)

    @property
    def samples(self) -> int:
        return min((m.time.size for m in self.monitors.values()), default=0)

    def stage_state(self) -> str:
        """Where the run got to, in words, for a file without a monitor sample (empty once the
        shaking has written samples). tq-solid records its static stages together once they have
        all ended (or one failed), so a file with none recorded stopped inside them."""
        if self.samples:
            return ""
        planned = f"planned: {', '.join(self.stages_planned)}" if self.stages_planned else "stages unknown"
        if not self.stages_done and not self.stages_failed:
            return f"in the static stages, none recorded as finished; {planned}"
        done = [s for s in self.stages_done if s != "switch"]
        text = f"static stages finished: {', '.join(done)}" if done else "no static stage finished"
        if self.stages_failed:
            return text + f"; stage {self.stages_failed[0]} did not converge; {planned}"
        if "switch" in self.stages_done:
            return text + "; stopped at the start of the seismic stage, before its first sample"
        return text + f"; {planned}"


def _rows(ds) -> np.ndarray:
    """A dataset as rows [T, k]; T may be 0 (nothing appended yet)."""
    a = np.asarray(ds[...])
    if a.ndim > 1:
        return a.reshape(a.shape[0], int(np.prod(a.shape[1:])))
    return a.reshape(-1, 1)


def _advancing(t: np.ndarray) -> int:
    """Rows up to the first whose time does not advance (fill of an unwritten extension)."""
    if t.size < 2:
        return t.size
    bad = np.nonzero(np.diff(t) <= 0)[0]
    return int(bad[0]) + 1 if bad.size else t.size


def _text(v) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def _planned_end(input_path) -> float | None:
    import h5py

    try:
        with h5py.File(input_path, "r") as f:
            return float(f["solver"].attrs["t_end"])
    except (OSError, KeyError, TypeError, ValueError):
        return None


def _stage_name(key: str) -> str:
    """/stages/<k>_<name> -> name."""
    head, _, name = key.partition("_")
    return name if head.isdigit() and name else key


def read_condition(path: Path, condition: str, reference: str = "absolute") -> ConditionResult:
    """Read a condition's results.h5; monitor arrays are cut to the rows all of them share. The
    reference histories (REFERENCES) go to `references`, not `monitors`; with `reference` base or
    free_field every monitor's u becomes its displacement relative to that reference (a file
    without the reference's history is a ValueError naming it)."""
    import h5py

    with h5py.File(path, "r") as f:
        status = _text(f.attrs.get("status", "unknown"))
        attrs = {k: (_text(v) if isinstance(v, (str, bytes)) else v) for k, v in f.attrs.items()}
        mons: dict[str, Monitor] = {}
        for name, g in f.get("monitors", {}).items():
            t = _rows(g["time"])[:, 0]
            u = _rows(g["u"])
            pr = _rows(g["principal"]) if "principal" in g else np.zeros((t.size, 3))
            n = min(_advancing(t), u.shape[0], pr.shape[0])
            extra = {}
            if "damage" in g:
                d = _rows(g["damage"])[:, 0]
                n = min(n, d.size)
                extra["damage"] = d
            if "water_pressure" in g:  # [T, 2] = (time, p): its own time column
                w = _rows(g["water_pressure"])
                k = _advancing(w[:, 0])
                extra["water_pressure_time"], extra["water_pressure"] = w[:k, 0], w[:k, 1]
            extra = {k: (v[:n] if k in ("damage",) else v) for k, v in extra.items()}
            mons[name] = Monitor(time=t[:n], u=u[:n], principal=pr[:n], extra=extra, attrs=dict(g.attrs))
        # the rows all monitors share: the last step written everywhere
        common = min((mo.time.size for mo in mons.values()), default=0)
        for mo in mons.values():
            mo.time, mo.u, mo.principal = mo.time[:common], mo.u[:common], mo.principal[:common]
            if "damage" in mo.extra:
                mo.extra["damage"] = mo.extra["damage"][:common]
        snaps, broken = [], []
        for key, g in f.get("snapshots", {}).items():
            if "time" in g.attrs and "u" in g:
                snaps.append((key, float(g.attrs["time"])))
            else:
                broken.append(key)
        snaps.sort(key=lambda s: s[1])
        mesh = None
        if "mesh/coordinates" in f and "mesh/connectivity" in f:
            mesh = {"coordinates": f["mesh/coordinates"][...], "connectivity": f["mesh/connectivity"][...],
                    "region": f["mesh/region"][...] if "mesh/region" in f else None,
                    "regions": [_text(r) for r in f["mesh"].attrs.get("regions", [])]}
        coupling = {k: (_text(v) if isinstance(v, (str, bytes)) else v)
                    for k, v in f["coupling"].attrs.items()} if "coupling" in f else {}
        stage_keys = sorted(f.get("stages", {}), key=lambda k: int(k.partition("_")[0]) if k[:1].isdigit() else 0)
        stages_done = [_stage_name(k) for k in stage_keys if int(f["stages"][k].attrs.get("converged", 1))]
        stages_failed = [_stage_name(k) for k in stage_keys if not int(f["stages"][k].attrs.get("converged", 1))]
        iface = None
        if "interface/pairs" in f:
            g = f["interface"]
            iface = {"pairs": g["pairs"][...], "states": [_text(s) for s in g.attrs.get("states", CONTACT_STATES)]}
            for k in ("normal", "area"):
                if k in g:
                    iface[k] = g[k][...]
            if "history" in g:
                h = _rows(g["history"])
                iface["history"] = h[:_advancing(h[:, 0])]
                iface["history_columns"] = [_text(c) for c in g.attrs.get("history_columns", [])]
        joints = read_joints(f)
        water_column = read_water_column(f)
    refs = {key: mons.pop(name) for key, name in REFERENCES.items() if name in mons}
    if reference not in DISPLACEMENT_REFERENCES:
        raise ValueError(f"displacement reference {reference!r}: expected one of {', '.join(DISPLACEMENT_REFERENCES)}")
    if reference != "absolute":
        ref = refs.get(reference)
        if ref is None:
            raise ValueError(f"{path.name} has no {reference} history ({REFERENCES[reference]}), which "
                             f"output.displacement_reference: {reference} needs; run the condition again to "
                             "record it, or set output.displacement_reference: absolute")
        for mo in mons.values():
            mo.u = mo.u - ref.u[:mo.u.shape[0]]
    input_path = Path(str(attrs.get("input", "")))
    if not input_path.is_absolute():
        input_path = path.parent / input_path
    planned, mat, sequence = None, {}, []
    if input_path.is_file():
        planned = _planned_end(input_path)
        try:
            with h5py.File(input_path, "r") as f:
                if "materials/lining" in f:
                    mat = dict(f["materials/lining"].attrs)
                if "stages" in f:
                    sequence = [s for s in _text(f["stages"].attrs.get("sequence", "")).split(",") if s]
        except OSError:
            pass
    return ConditionResult(condition, path, status, mons, attrs=attrs, planned_end=planned, snapshots=snaps,
                           incomplete_snapshots=broken, mesh=mesh, interface=iface, input_attrs=mat,
                           joints=joints, water_column=water_column, coupling=coupling, stages_done=stages_done, stages_failed=stages_failed,
                           stages_planned=sequence, references=refs, displacement_reference=reference)


#: a surge tank's level series in /coupling, by end
SURGE_LEVELS = {"ymin": "surge_level_ymin", "ymax": "surge_level_ymax"}


def read_water_column(f) -> dict | None:
    """The water column along the tunnel of an open results file (tq-solid's volume law with open
    ends, docs/coupler.md "Open ends"): y [S] (m) the stations along the axis, time [T], p [T, S] (Pa)
    each station's pressure (the pressure along the axis), and per end with a surge tank
    level_<end> [T] (m) its level above rest (the tank's own series); None without open ends."""
    if "coupling/axial_pressure" not in f:
        return None
    g = f["coupling/axial_pressure"]
    names = sorted(g)
    if not names:
        return None
    cols = [_rows(g[n]) for n in names]
    k = min(_advancing(c[:, 0]) for c in cols)
    out = {"y": np.array([float(g.attrs[f"{n}_y"]) for n in names]), "time": cols[0][:k, 0],
           "p": np.column_stack([c[:k, 1] for c in cols])}
    for end, name in SURGE_LEVELS.items():
        if f"coupling/{name}" in f:
            r = _rows(f[f"coupling/{name}"])
            out[f"level_{end}"] = r[:min(k, r.shape[0]), 1]
    return out


def water_column_csv(W: dict, out: Path) -> Path:
    """water_column_<condition>.csv: one row per output time, each station's pressure (Pa) along the
    axis and each surge tank's level above rest (m)."""
    levels = [e for e in SURGE_LEVELS if f"level_{e}" in W]
    header = ["time_s"] + [f"p{j}_Pa" for j in range(len(W["y"]))] + [f"surge_level_{e}_m" for e in levels]
    n = min([W["time"].size] + [W[f"level_{e}"].size for e in levels])
    with atomic_path(out, 16 * len(header) * (n + 2)) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["# stations y (m): " + " ".join(f"p{j}={y:.6g}" for j, y in enumerate(W["y"]))])
        w.writerow(header)
        for i in range(n):
            w.writerow([f"{W['time'][i]:.6g}"] + [f"{v:.6e}" for v in W["p"][i]]
                       + [f"{W[f'level_{e}'][i]:.6e}" for e in levels])
    return out


def fig_water_column(res: ConditionResult, out: Path) -> Path | None:
    """The water along the tunnel (dynamic water with open ends): its pressure along the axis against
    time (each station's, coloured by y), and a surge tank's level against time. None without it."""
    W = res.water_column
    if W is None or not W["time"].size:
        return None
    plt = _plt()
    levels = [e for e in SURGE_LEVELS if f"level_{e}" in W]
    fig, axes = plt.subplots(1, 2 if levels else 1, figsize=(10 if levels else 6, 3.6), squeeze=False)
    ax = axes[0][0]
    t, y = W["time"], W["y"]
    im = ax.pcolormesh(t, y, W["p"].T / 1e3, shading="nearest", cmap="RdBu_r",
                       vmin=-np.abs(W["p"]).max() / 1e3 or None, vmax=np.abs(W["p"]).max() / 1e3 or None)
    fig.colorbar(im, ax=ax, label="pressure (kPa)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("y along the axis (m)")
    ax.set_title("the water's pressure along the axis")
    if levels:
        ax = axes[0][1]
        big = max(float(np.abs(W[f"level_{e}"]).max(initial=0.0)) for e in levels) >= 1.0
        scale, unit = (1.0, "m") if big else (1e3, "mm")
        for e in levels:
            ax.plot(t[:W[f"level_{e}"].size], W[f"level_{e}"] * scale, lw=0.9, label=f"surge tank at y {e[1:]}")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(f"level above rest ({unit})")
        ax.set_title("the surge tank's level")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{CONDITION_LABELS[res.condition]}: the water along the tunnel")
    return _finish(fig, out)


#: /joints/history's quantities per joint (after the time column), their units
JOINT_QUANTITIES = {"opening": "m", "opening_max": "m", "opening_min": "m", "slip": "m", "slip_max": "m",
                    "axial_force": "N", "rotation_x": "rad", "rotation_z": "rad"}


def read_joints(f) -> dict | None:
    """The lining's joints of an open results file (tq-solid's /joints, docs/solid_solver.md "Lining
    joints"): y [J], area [J] (m^2), the law's parameters, time [T] and per quantity of
    JOINT_QUANTITIES a [T, J] history; None without joints."""
    if "joints/y" not in f:
        return None
    g = f["joints"]
    out = {"y": g["y"][...], "area": g["area"][...],
           "params": {k: float(v) for k, v in g.attrs.items() if k != "history_columns"}}
    cols = [_text(c) for c in g.attrs.get("history_columns", [])]
    if cols[1:] != list(JOINT_QUANTITIES):
        raise ValueError(f"/joints history_columns {cols} are not {['time', *JOINT_QUANTITIES]}: results of another "
                         "tq-solid version")
    h = _rows(g["history"]) if "history" in g else np.zeros((0, 1 + len(JOINT_QUANTITIES) * len(out["y"])))
    h = h[:_advancing(h[:, 0])] if len(h) else h
    out["time"] = h[:, 0]
    q = h[:, 1:].reshape(len(h), len(out["y"]), len(JOINT_QUANTITIES))
    for k, name in enumerate(JOINT_QUANTITIES):
        out[name] = q[:, :, k]
    return out


def joints_csv(joints: dict, out: Path) -> Path:
    """joints_<condition>.csv: one row per output time, per joint its opening (area-weighted mean,
    largest, smallest over its pairs), slip (of the mean, largest), axial force and the opening's
    gradients across it (docs/formats.md)."""
    J = len(joints["y"])
    header = ["time_s"] + [f"j{j}_{k}_{u}" for j in range(J) for k, u in JOINT_QUANTITIES.items()]
    with atomic_path(out, 16 * len(header) * (len(joints["time"]) + 2)) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["# joint planes y (m): " + " ".join(f"j{j}={y:.6g}" for j, y in enumerate(joints["y"]))])
        w.writerow(header)
        for i, t in enumerate(joints["time"]):
            w.writerow([f"{t:.6g}"] + [f"{joints[k][i, j]:.6e}" for j in range(J) for k in JOINT_QUANTITIES])
    return out


def displacement_against(res: ConditionResult, monitor: str, reference: str) -> np.ndarray | None:
    """A monitor's displacement history [T, 3] against another reference than the one it was read
    with (DISPLACEMENT_REFERENCES); None when the results lack a reference history it needs."""
    u = res.monitors[monitor].u
    if res.displacement_reference != "absolute":
        u = u + res.references[res.displacement_reference].u[:u.shape[0]]
    if reference == "absolute":
        return u
    ref = res.references.get(reference)
    return None if ref is None else u - ref.u[:u.shape[0]]


def read_snapshot(res: ConditionResult, key: str) -> dict:
    """The fields of /snapshots/<key>: u, v [N, 3]; stress [E, 6]; damage [E] and
    interface/{state, failed, opening, slip, ...} [P] when written."""
    import h5py

    out: dict = {}
    with h5py.File(res.path, "r") as f:
        g = f[f"snapshots/{key}"]
        out["time"] = float(g.attrs["time"])
        for k in ("u", "v", "stress", "damage", "plastic_strain"):
            if k in g:
                out[k] = g[k][...]
        if "interface" in g:
            out["interface"] = {k: g["interface"][k][...] for k in g["interface"]}
    return out


def principal_stresses(stress: np.ndarray) -> np.ndarray:
    """[E, 6] (xx, yy, zz, xy, yz, zx) -> [E, 3] ascending (sigma1 most compressive), as tq-solid."""
    s = np.asarray(stress, float)
    m = np.empty((s.shape[0], 3, 3))
    m[:, 0, 0], m[:, 1, 1], m[:, 2, 2] = s[:, 0], s[:, 1], s[:, 2]
    m[:, 0, 1] = m[:, 1, 0] = s[:, 3]
    m[:, 1, 2] = m[:, 2, 1] = s[:, 4]
    m[:, 0, 2] = m[:, 2, 0] = s[:, 5]
    return np.linalg.eigvalsh(m)


def monitors_csv(res: ConditionResult, out: Path) -> Path:
    """One CSV per condition: time and, per monitor, ux, uy, uz (m), sigma1..3 (Pa), and damage D
    and the hydrodynamic water pressure (Pa) where the file has them."""
    names = sorted(res.monitors)
    n = res.samples
    header = ["time_s"]
    cols = []
    for m in names:
        mo = res.monitors[m]
        header += [f"{m}_ux_m", f"{m}_uy_m", f"{m}_uz_m", f"{m}_s1_Pa", f"{m}_s2_Pa", f"{m}_s3_Pa"]
        extra = []
        if "damage" in mo.extra:
            header.append(f"{m}_damage")
            extra.append(mo.extra["damage"])
        if "water_pressure" in mo.extra:
            header.append(f"{m}_hydrodynamic_pressure_Pa")
            extra.append(_on_monitor_time(mo, mo.extra["water_pressure_time"], mo.extra["water_pressure"]))
        cols.append((mo, extra))
    with atomic_path(out, 14 * len(header) * (n + 1)) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for i in range(n):
            row = [f"{res.monitors[names[0]].time[i]:.6g}"]
            for mo, extra in cols:
                row += [f"{v:.6e}" for v in (*mo.u[i], *mo.principal[i])]
                row += [f"{e[i]:.6e}" if i < e.size else "" for e in extra]
            w.writerow(row)
    return out


#: the lining's resultants along the axis (tunnelquake.lining_axis), their units
AXIS_RESULTANTS = {"N": "N", "M_h": "N m", "M_v": "N m", "V_h": "N", "V_v": "N", "T": "N m"}


def lining_along_axis(res: ConditionResult) -> dict | None:
    """The lining as a beam along the axis (3D results with more than one axial layer of lining;
    None otherwise): per layer its resultants (lining_axis.axis_resultants) at the first snapshot
    (the seismic start: the static state, a fault's offset included) and their largest |value|
    over every snapshot; per station of rock-lining pairs the largest interface slip at the last
    snapshot (the contact's own `slip`; none for a bonded interface)."""
    from .lining_axis import axis_resultants

    if res.mesh is None or not res.snapshots:
        return None
    lin = lining_elements(res)
    if lin.size == 0:
        return None
    c, conn = res.mesh["coordinates"], res.mesh["connectivity"]
    centre = tunnel_centre(res)
    first = read_snapshot(res, res.snapshots[0][0])
    if "stress" not in first:
        return None
    start = axis_resultants(c, conn, lin, first["stress"], centre)
    if start.y.size < 2:
        return None
    env = {k: np.abs(getattr(start, k)) for k in AXIS_RESULTANTS}
    for key, _ in res.snapshots[1:]:
        snap = read_snapshot(res, key)
        if "stress" in snap:
            r = axis_resultants(c, conn, lin, snap["stress"], centre)
            env = {k: np.maximum(env[k], np.abs(getattr(r, k))) for k in AXIS_RESULTANTS}
    out = {"y": start.y, "start": {k: getattr(start, k) for k in AXIS_RESULTANTS}, "envelope": env,
           "start_time": res.snapshots[0][1], "end_time": res.snapshots[-1][1], "slip": None}
    if res.interface is not None:
        last = read_snapshot(res, res.snapshots[-1][0])
        slip = (last.get("interface") or {}).get("slip")
        if slip is not None:
            y = c[res.interface["pairs"][:, 1], 1]
            ys = np.unique(np.round(y, 6))
            idx = np.searchsorted(ys, np.round(y, 6))
            peak = np.zeros(ys.size)
            np.maximum.at(peak, idx, np.abs(np.asarray(slip, float)))
            out["slip"] = {"y": ys, "max": peak}
    return out


def lining_axis_csv(axis: dict, out: Path) -> Path:
    """lining_axis_<condition>.csv: per axial layer of lining its y, the resultants at the seismic
    start and their largest |value| over the snapshots (docs/formats.md)."""
    header = ["y_m"] + [f"{k}_start_{u.replace(' ', '')}" for k, u in AXIS_RESULTANTS.items()] + \
        [f"{k}_maxabs_{u.replace(' ', '')}" for k, u in AXIS_RESULTANTS.items()]
    with atomic_path(out, 16 * len(header) * (axis["y"].size + 1)) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for i, y in enumerate(axis["y"]):
            w.writerow([f"{y:.6g}"] + [f"{axis['start'][k][i]:.6e}" for k in AXIS_RESULTANTS] +
                       [f"{axis['envelope'][k][i]:.6e}" for k in AXIS_RESULTANTS])
    return out


#: the panels of the lining-along-the-axis figure: (quantities, axis label, scale to its unit)
AXIS_PANELS = ((("N",), "axial force N (MN)", 1e-6), (("T",), "torsion T (MN m)", 1e-6),
               (("M_h", "M_v"), "moment (MN m)", 1e-6), (("V_h", "V_v"), "shear (MN)", 1e-6))


def fig_lining_axis(axes: dict, out: Path) -> Path | None:
    """The lining's section forces against distance along the tunnel (lining_along_axis per
    condition, `axes` {condition: axis}): a panel per quantity, per condition the largest |value|
    over the snapshots (solid) and the value at the seismic start (dashed); None with no 3D lining."""
    if not axes:
        return None
    plt = _plt()
    fig, grid = plt.subplots(2, 2, figsize=(11, 6.4), sharex=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (keys, ylabel, scale) in zip(grid.ravel(), AXIS_PANELS, strict=True):
        k = 0
        for cond, axis in axes.items():
            for q in keys:
                c = colours[k % len(colours)]
                k += 1
                name = f"{CONDITION_LABELS.get(cond, cond)} {q}" if len(keys) > 1 else CONDITION_LABELS.get(cond, cond)
                ax.plot(axis["y"], scale * axis["envelope"][q], color=c, lw=1.2, marker="o", ms=2.5,
                        label=f"{name}, max |value|")
                ax.plot(axis["y"], scale * axis["start"][q], color=c, lw=0.8, ls="--",
                        label=f"{name}, at t = {axis['start_time']:.3g} s")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    for ax in grid[1]:
        ax.set_xlabel("y, distance along the tunnel (m)")
    first = next(iter(axes.values()))
    fig.suptitle("The lining along the axis: section forces per axial element layer (max |value| over the "
                 f"snapshots {first['start_time']:.3g}–{first['end_time']:.3g} s)", fontsize=9)
    fig.tight_layout()
    _save(fig, out)
    plt.close(fig)
    return out


def _on_monitor_time(mo: Monitor, t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A series with its own time column put on the monitor's rows (same sampling in tq-solid)."""
    n = min(t.size, mo.time.size)
    if n and np.allclose(t[:n], mo.time[:n], rtol=0, atol=1e-9):
        return v[:n]
    return np.interp(mo.time, t, v, left=np.nan, right=np.nan) if t.size else np.full(mo.time.size, np.nan)


def _argmax_first(a: np.ndarray) -> int:
    """Index of the first occurrence of the largest value."""
    return int(np.argmax(a))


def peaks(res: ConditionResult, t_max: float | None = None) -> dict[str, dict[str, float]]:
    """Per monitor: max |ux|, |uy|, |uz| (m), max tension = max sigma3 (Pa), the most compressive
    min sigma1 (Pa), max damage D, and the peak |hydrodynamic pressure| (Pa), each with the time of
    its first occurrence (`t_<key>`; the pressure's `hydrodynamic_pressure_peak_time`), where
    recorded; over t <= t_max when given (to compare conditions over the window they share)."""
    out = {}
    for m, mo in res.monitors.items():
        if t_max is not None:
            k = int(np.searchsorted(mo.time, t_max + 1e-9, side="right"))
            ex = dict(mo.extra)
            if "damage" in ex:
                ex["damage"] = ex["damage"][:k]
            if "water_pressure" in ex:
                kw = int(np.searchsorted(ex["water_pressure_time"], t_max + 1e-9, side="right"))
                ex["water_pressure"], ex["water_pressure_time"] = ex["water_pressure"][:kw], ex["water_pressure_time"][:kw]
            mo = Monitor(time=mo.time[:k], u=mo.u[:k], principal=mo.principal[:k], extra=ex, attrs=mo.attrs)
        pk: dict[str, float] = {}
        if mo.u.size:
            for c, name in ((0, "max_ux"), (1, "max_uy"), (2, "max_uz")):
                k = _argmax_first(np.abs(mo.u[:, c]))
                pk[name], pk[f"t_{name}"] = float(abs(mo.u[k, c])), float(mo.time[k])
        else:
            pk.update(max_ux=float("nan"), max_uz=float("nan"))
        if mo.principal.size:
            k = _argmax_first(mo.principal[:, 2])
            pk["max_tension"], pk["t_max_tension"] = float(mo.principal[k, 2]), float(mo.time[k])
            k = _argmax_first(-mo.principal[:, 0])
            pk["min_sigma1"], pk["t_min_sigma1"] = float(mo.principal[k, 0]), float(mo.time[k])
        else:
            pk["max_tension"] = float("nan")
        d = mo.extra.get("damage")
        pk["max_damage"] = float(np.max(d)) if d is not None and d.size else float("nan")
        if d is not None and d.size:
            pk["t_max_damage"] = float(mo.time[_argmax_first(d)])
        p = mo.extra.get("water_pressure")
        if p is not None and p.size:
            k = _argmax_first(np.abs(p))
            pk["hydrodynamic_pressure_peak"] = float(abs(p[k]))
            pk["hydrodynamic_pressure_peak_time"] = float(mo.extra["water_pressure_time"][k])
        out[m] = pk
    return out


def _save(fig, out: Path) -> None:
    """A figure as PNG, put in place only once complete (a full disk leaves no partial image)."""
    try:
        with atomic_path(out) as tmp:
            fig.savefig(tmp, dpi=120, format="png")
    except BaseException:
        _plt().close(fig)
        raise


def _finish(fig, out: Path) -> Path:
    """A drawn figure laid out (tight), saved (_save) and closed; returns its path."""
    fig.tight_layout()
    _save(fig, out)
    _plt().close(fig)
    return out


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def monitor_order(results: list[ConditionResult], order: list[str] | None = None) -> list[str]:
    """The monitors of `results` in the order given (the case file's), then any others by name."""
    have = sorted({m for r in results for m in r.monitors})
    first = [m for m in (order or []) if m in have]
    return first + [m for m in have if m not in first]


def _label(m: str) -> str:
    return m.replace("_", " ")


def fig_max_displacements(results: list[ConditionResult], out: Path, order: list[str] | None = None,
                          reference=None, reference_label: str = "reference", unit: str = "mm") -> Path:
    """Maximum x and z displacements of the monitors, a bar per condition, in `unit` (mm or cm);
    `reference(condition, key)` -> {monitor: m} draws a published run's bars beside each (key max_ux
    or max_uz)."""
    plt = _plt()
    scale = {"mm": 1e3, "cm": 1e2, "m": 1.0}[unit]
    names = monitor_order(results, order)
    fig, axes = plt.subplots(1, 2, figsize=(max(10, 1.6 * len(names) + 5), 3.8))
    per = 2 if reference is not None else 1
    width = 0.8 / max(1, per * len(results))
    for ax, key, title in ((axes[0], "max_ux", "x-direction"), (axes[1], "max_uz", "z-direction")):
        xs = np.arange(len(names))
        for k, res in enumerate(results):
            pk = peaks(res)
            ours = [scale * pk.get(m, {}).get(key, np.nan) for m in names]
            ax.bar(xs + (per * k) * width, ours, width,
                   label=f"{CONDITION_LABELS[res.condition]}" + (" ours" if reference is not None else ""))
            if reference is not None:
                ref = reference(res.condition, key)
                ax.bar(xs + (per * k + 1) * width, [scale * ref.get(m, np.nan) for m in names], width, alpha=0.45,
                       label=f"{CONDITION_LABELS[res.condition]} {reference_label}")
        ax.set_xticks(xs + width * (per * len(results) - 1) / 2, [_label(m) for m in names])
        ax.set_ylabel(f"max displacement ({unit})")
        ax.set_title(title)
        ax.grid(alpha=0.3, axis="y")
    axes[1].legend(fontsize=7)
    return _finish(fig, out)


def fig_principal_stress(results: list[ConditionResult], out: Path, order: list[str] | None = None,
                         strength: float | None = None) -> Path:
    """Maximum principal (most tensile) stress histories at the monitors, a panel per condition,
    with the lining's tensile strength (Pa) as a line when given."""
    plt = _plt()
    names = monitor_order(results, order)
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.4), squeeze=False)
    for ax, res in zip(axes[0], results, strict=True):
        for m in names:
            if m in res.monitors:
                mo = res.monitors[m]
                ax.plot(mo.time, mo.principal[:, 2] / 1e6, lw=0.8, label=_label(m))
        if strength is not None:
            ax.axhline(strength / 1e6, color="k", ls=":", lw=0.8,
                       label=f"lining tensile strength {strength / 1e6:.3g} MPa")
        ax.set_title(CONDITION_LABELS[res.condition])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("max principal stress (MPa)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return _finish(fig, out)


def read_fluid_interface(fluid_dir: Path) -> dict | None:
    """The water side's own record of the interface (OpenFOAM function object tqInterface,
    postProcessing/<name>/<start>/interface.dat): time and area-mean wall pressure pMean (Pa) of
    the accepted steps (rolled-back attempts left out), over all start times, sorted. None if absent."""
    rows = []
    for f in sorted(Path(fluid_dir).glob("postProcessing/*/*/interface.dat")):
        cols = None
        with open(f) as fh:
            for line in fh:
                if line.startswith("#"):
                    head = line[1:].split()
                    if "pMean" in head and "accepted" in head:
                        cols = (head.index("t"), head.index("accepted"), head.index("pMean"))
                    continue
                v = line.split()
                if cols is None or len(v) <= max(cols):
                    continue
                try:
                    if float(v[cols[1]]) == 1:
                        rows.append((float(v[cols[0]]), float(v[cols[2]])))
                except ValueError:
                    continue  # a line cut off by a crash
    if not rows:
        return None
    a = np.array(sorted(dict(rows).items()))
    return {"time": a[:, 0], "p_mean": a[:, 1]}


def fig_hydrodynamic_pressure(res: ConditionResult, out: Path, fluid: dict | None = None,
                              order: list[str] | None = None, marks: dict | None = None,
                              mark_label: str = "reference peak") -> Path | None:
    """Hydrodynamic pressure histories at the monitors (the dynamic-water condition), and, when
    given, the water side's area-mean wall pressure of the accepted steps as a cross-check and
    `marks` {monitor: (time s, pressure Pa)} of a published run. None when the file has no water
    pressure."""
    series = {m: mo for m, mo in res.monitors.items() if "water_pressure" in mo.extra}
    if not series:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for k, m in enumerate(monitor_order([res], order)):
        if m not in series:
            continue
        mo = series[m]
        line, = ax.plot(mo.extra["water_pressure_time"], mo.extra["water_pressure"] / 1e6, lw=0.8, label=_label(m))
        if marks and m in marks:
            t, p = marks[m]
            ax.plot([t], [p / 1e6], marker="o^sDvp"[k % 6], ls="none", mfc="none", color=line.get_color(),
                    label=f"{_label(m)} {mark_label}")
    if fluid is not None:
        ax.plot(fluid["time"], fluid["p_mean"] / 1e6, "k--", lw=0.7, label="water side: mean wall pressure")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("hydrodynamic pressure (MPa)")
    ax.set_title(f"{CONDITION_LABELS[res.condition]}: water pressure on the lining minus hydrostatic")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    return _finish(fig, out)


def fig_damage_histories(results: list[ConditionResult], out: Path, order: list[str] | None = None) -> Path | None:
    """Damage coefficient histories at the monitors, one panel per condition."""
    have = [r for r in results if any("damage" in mo.extra for mo in r.monitors.values())]
    if not have:
        return None
    plt = _plt()
    names = monitor_order(have, order)
    fig, axes = plt.subplots(1, len(have), figsize=(4.2 * len(have), 3.4), squeeze=False)
    for ax, res in zip(axes[0], have, strict=True):
        for m in names:
            mo = res.monitors.get(m)
            if mo is not None and "damage" in mo.extra:
                ax.plot(mo.time, mo.extra["damage"], lw=0.9, label=_label(m))
        ax.set_title(CONDITION_LABELS[res.condition])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("damage coefficient D")
        top = max(float(np.nanmax(mo.extra["damage"])) if mo.extra.get("damage", np.zeros(0)).size else 0.0
                  for mo in res.monitors.values())
        ax.set_ylim(-0.02, max(0.1, 1.1 * top))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return _finish(fig, out)


# ---- the lining's middle section -------------------------------------------------------------

def _section_y(res: ConditionResult) -> float:
    ys = [float(mo.attrs["y"]) for mo in res.monitors.values() if "y" in mo.attrs]
    if ys:
        return float(np.mean(ys))
    c = res.mesh["coordinates"]
    return 0.5 * float(c[:, 1].min() + c[:, 1].max())


def tunnel_centre(res: ConditionResult) -> tuple[float, float]:
    """(x, z) of the tunnel axis: the mean of the lining's nodes (a full ring)."""
    c, conn = res.mesh["coordinates"], res.mesh["connectivity"]
    lin = lining_elements(res)
    nodes = np.unique(conn[lin]) if lin.size else np.arange(c.shape[0])
    return float(c[nodes, 0].mean()), float(c[nodes, 2].mean())


def lining_elements(res: ConditionResult) -> np.ndarray:
    regions = res.mesh.get("regions") or []
    if "lining" not in regions or res.mesh.get("region") is None:
        return np.zeros(0, int)
    return np.nonzero(res.mesh["region"] == regions.index("lining"))[0]


def damage_section(res: ConditionResult, snap: dict) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The lining elements of the middle section (centroid y nearest the monitors' y): their
    outlines in the x–z plane [k, 2], their damage D from the snapshot, and their element indices."""
    c, conn = res.mesh["coordinates"], res.mesh["connectivity"]
    lin = lining_elements(res)
    if lin.size == 0 or "damage" not in snap:
        return [], np.zeros(0), np.zeros(0, int)
    yc = c[conn[lin], 1].mean(axis=1)
    y0 = _section_y(res)
    dist = np.abs(yc - y0)
    tol = 1e-6 * max(1.0, float(np.ptp(c[:, 1])))
    sel = lin[dist <= dist.min() + tol]
    polys = []
    for e in sel:
        p = c[conn[e]][:, [0, 2]]
        q = np.unique(np.round(p, 9), axis=0)  # an element extruded along y projects to 4 points
        ctr = q.mean(axis=0)
        q = q[np.argsort(np.arctan2(q[:, 1] - ctr[1], q[:, 0] - ctr[0]))]
        polys.append(q)
    return polys, np.asarray(snap["damage"])[sel], sel


def fig_damage_section(results: list[ConditionResult], out: Path) -> Path | None:
    """Damage D over the lining's middle section at the last snapshot, per condition."""
    from matplotlib.collections import PolyCollection

    items = []
    for res in results:
        if res.mesh is None or not res.snapshots:
            continue
        snap = read_snapshot(res, res.snapshots[-1][0])
        polys, d, _ = damage_section(res, snap)
        if polys:
            items.append((res, snap["time"], polys, d))
    if not items:
        return None
    plt = _plt()
    dmax = max(float(d.max()) for *_, d in items)
    vmax = dmax if dmax > 0 else 1.0  # the scale fitted to the data (0 to 1 when nothing is damaged)
    fig, axes = plt.subplots(1, len(items), figsize=(4.0 * len(items) + 0.8, 4.0), squeeze=False)
    for ax, (res, t, polys, d) in zip(axes[0], items, strict=True):
        pc = PolyCollection(polys, array=d, cmap="inferno_r", edgecolors="0.6", linewidths=0.2)
        pc.set_clim(0.0, vmax)
        ax.add_collection(pc)
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_title(f"{CONDITION_LABELS[res.condition]}\nt = {t:.2f} s, max D = {d.max():.3g}", fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("z (m)")
    fig.colorbar(pc, ax=axes[0].tolist(), label="damage coefficient D", shrink=0.8)
    _save(fig, out)
    plt.close(fig)
    return out


def interface_section(res: ConditionResult, snap: dict) -> dict | None:
    """The rock–lining pairs of the middle section with their angle around the tunnel axis
    (degrees from the crown towards +x: crown 0, springline 90, invert 180), final state
    (index into CONTACT_STATES) and `failed` (the bond broken at some time: the envelope)."""
    if res.interface is None or "interface" not in snap or res.mesh is None:
        return None
    c = res.mesh["coordinates"]
    pairs = res.interface["pairs"]
    pos = c[pairs[:, 1]]
    # the node plane nearest the section (of two at the same distance, as in a slice, the first)
    y_pick = pos[int(np.argmin(np.abs(pos[:, 1] - _section_y(res)))), 1]
    sel = np.nonzero(np.abs(pos[:, 1] - y_pick) <= 1e-6 * max(1.0, float(np.ptp(c[:, 1]))))[0]
    xc, zc = tunnel_centre(res)
    ang = np.degrees(np.arctan2(pos[sel, 0] - xc, pos[sel, 2] - zc))
    st = snap["interface"]
    return {"index": sel, "angle": ang, "x": pos[sel, 0], "z": pos[sel, 2],
            "state": np.asarray(st["state"])[sel],
            "failed": np.asarray(st.get("failed", np.zeros(pairs.shape[0])))[sel].astype(bool),
            "opening": np.asarray(st["opening"])[sel] if "opening" in st else None,
            "slip": np.asarray(st["slip"])[sel] if "slip" in st else None}


def fig_interface_zones(results: list[ConditionResult], out: Path) -> Path | None:
    """Per rock–lining pair of the middle section, the state at the last snapshot
    (outer ring) and whether its bond failed at any time (inner ring: the envelope)."""
    items = []
    for res in results:
        if not res.snapshots:
            continue
        snap = read_snapshot(res, res.snapshots[-1][0])
        sec = interface_section(res, snap)
        if sec is not None and sec["index"].size:
            items.append((res, snap["time"], sec))
    if not items:
        return None
    plt = _plt()
    colours = {"bonded": "tab:green", "separated": "tab:red", "slipping": "tab:orange", "stuck": "tab:blue",
               "inactive": "0.6"}
    fig, axes = plt.subplots(1, len(items), figsize=(4.2 * len(items), 4.4), squeeze=False)
    for ax, (res, t, sec) in zip(axes[0], items, strict=True):
        xc, zc = tunnel_centre(res)
        r = np.hypot(sec["x"] - xc, sec["z"] - zc)
        th = np.radians(sec["angle"])
        for code, name in enumerate(CONTACT_STATES):
            k = sec["state"] == code
            ax.scatter(xc + 1.08 * r[k] * np.sin(th[k]), zc + 1.08 * r[k] * np.cos(th[k]), s=22,
                       color=colours[name], label=f"{name} ({int(k.sum())})")
        f = sec["failed"]
        ax.scatter(xc + 0.92 * r * np.sin(th), zc + 0.92 * r * np.cos(th), s=10, marker="s",
                   c=np.where(f, "k", "white"), edgecolors="k", linewidths=0.4)
        ax.scatter([], [], s=10, marker="s", c="k", label=f"bond failed at some time ({int(f.sum())})")
        ax.set_aspect("equal")
        ax.set_title(f"{CONDITION_LABELS[res.condition]}, t = {t:.2f} s", fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("z (m)")
        ax.legend(fontsize=6, loc="center")
    return _finish(fig, out)


# ---- ParaView ---------------------------------------------------------------------------------

def write_xdmf(res: ConditionResult, out_xdmf: Path) -> Path | None:
    """XDMF 3 (+ HDF5 heavy data beside it, `<name>.h5`) of the solid mesh with the snapshot fields
    over time: displacement and velocity (nodes), stress, principal stresses, damage (cells), and
    the region. None when the file has no mesh or no complete snapshot. Both files are written
    under temporary names and moved into place."""
    import os


    if res.mesh is None or not res.snapshots:
        return None
    out_xdmf = Path(out_xdmf)
    out_xdmf.parent.mkdir(parents=True, exist_ok=True)
    heavy = out_xdmf.with_suffix(".h5")
    tmp_h5 = heavy.with_name(f".{heavy.name}.part")
    tmp_x = out_xdmf.with_name(f".{out_xdmf.name}.part")
    c = np.asarray(res.mesh["coordinates"], float)
    conn = np.asarray(res.mesh["connectivity"], np.int64)
    N, E = c.shape[0], conn.shape[0]
    hn = heavy.name

    def item(path, shape, kind="Float"):
        dims = " ".join(str(s) for s in shape)
        prec = 8
        return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{prec}" Format="HDF">'
                f"{hn}:{path}</DataItem>")

    def attr(name, centre, path, shape):
        typ = {1: "Scalar", 3: "Vector", 6: "Tensor6"}[1 if len(shape) == 1 else shape[1]]
        return (f'<Attribute Name="{name}" AttributeType="{typ}" Center="{centre}">'
                f"{item(path, shape)}</Attribute>")

    grids = []
    try:
        with h5_in_memory(tmp_h5) as h:  # HDF5 never meets a full disk (files.h5_in_memory)
            h["mesh/coordinates"] = c
            h["mesh/connectivity"] = conn
            region = res.mesh.get("region")
            if region is not None:
                h["mesh/region"] = np.asarray(region, float)
            for k, (key, t) in enumerate(res.snapshots):
                s = read_snapshot(res, key)
                g = h.create_group(f"step{k}")
                g.attrs["time"] = t
                fields = []
                g["displacement"] = s["u"]
                fields.append(attr("displacement", "Node", f"/step{k}/displacement", (N, 3)))
                if "v" in s:
                    g["velocity"] = s["v"]
                    fields.append(attr("velocity", "Node", f"/step{k}/velocity", (N, 3)))
                if "stress" in s:
                    g["stress"] = s["stress"]
                    g["principal_stress"] = principal_stresses(s["stress"])
                    g["max_principal_stress"] = g["principal_stress"][:, 2]
                    fields.append(attr("stress", "Cell", f"/step{k}/stress", (E, 6)))
                    fields.append(attr("principal_stress", "Cell", f"/step{k}/principal_stress", (E, 3)))
                    fields.append(attr("max_principal_stress", "Cell", f"/step{k}/max_principal_stress", (E,)))
                if "damage" in s:
                    g["damage"] = s["damage"]
                    fields.append(attr("damage", "Cell", f"/step{k}/damage", (E,)))
                if region is not None:
                    fields.append(attr("region", "Cell", "/mesh/region", (E,)))
                grids.append(
                    f'      <Grid Name="t{k}" GridType="Uniform">\n'
                    f'        <Time Value="{t:.9g}"/>\n'
                    f'        <Topology TopologyType="Hexahedron" NumberOfElements="{E}">'
                    f'{item("/mesh/connectivity", (E, 8), "Int")}</Topology>\n'
                    f'        <Geometry GeometryType="XYZ">{item("/mesh/coordinates", (N, 3))}</Geometry>\n'
                    + "".join(f"        {a}\n" for a in fields)
                    + "      </Grid>\n")
        xml = ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n  <Domain>\n'
               f'    <Grid Name="{res.condition}" GridType="Collection" CollectionType="Temporal">\n'
               + "".join(grids) + "    </Grid>\n  </Domain>\n</Xdmf>\n")
        tmp_x.write_text(xml)
        os.replace(tmp_h5, heavy)
        os.replace(tmp_x, out_xdmf)
    finally:
        for p in (tmp_h5, tmp_x):
            if p.exists():
                p.unlink()
    return out_xdmf
