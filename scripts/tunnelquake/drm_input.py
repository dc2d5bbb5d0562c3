"""solid_input.h5's `/drm` group: the free field at the nodes of a domain-reduction layer, which
tq-solid turns into the layer's effective forces (docs/theory.md §6.2, docs/formats.md). The field
comes from `tunnelquake.freefield.free_field` at the layer's nodes, or from an H5DRM file through
`freefield.read_h5drm` (which matches every node to a file point first). `write_drm_group` does
it for a case's `incident_wave` (tunnelquake.incident_wave)."""
from __future__ import annotations

import numpy as np

from .freefield import FreeField, FreeFieldError
from .solver_input_schema import entries, put

GROUP = "/drm"
#: Nodes free_field computes at once: its work arrays (each chunk's acceleration, velocity and
#: displacement on the padded clock, and the complex spectra) scale with it. cases/axial_wave (1,558
#: nodes, 42.9 MiB of field): free_field's traced peak 83.9 MiB with 256, 51.1 MiB with 64 (tracemalloc).
FREE_FIELD_CHUNK = 64
#: Nodes of the field written to /drm at once (write_drm): the transposed block is its only copy.
WRITE_BLOCK = 256


def write_drm(f, nodes, internal, field: FreeField, release: bool = False) -> None:
    """Write `/drm` into the open solid_input.h5 `f` (h5py): `nodes` (N,) mesh node indices, `internal`
    (N,) true for the layer's inner nodes (b) and false for its outer ones (e), `field` the free field
    at those nodes in the same order (u, v, a of shape (N, nt, 3); stored [nt, N, 3], written a block
    of nodes at a time so that no whole transposed copy is made). `release`: drop each of the field's
    arrays from `field` once written (the file, built in memory, then holds the only copy)."""
    nodes = np.asarray(nodes, dtype=np.int64).ravel()
    flags = np.asarray(internal, dtype=bool).ravel()
    n = nodes.size
    if flags.size != n:
        raise FreeFieldError(f"/drm: {flags.size} inner/outer flags for {n} nodes", "give one flag a node")
    if not flags.any() or flags.all():
        raise FreeFieldError(f"/drm: {int(flags.sum())} of {n} nodes are inner (b): the layer needs both inner "
                             "and outer nodes", "flag the layer's inner boundary true and its outer one false")
    if len(np.unique(nodes)) != n or nodes.min() < 0:
        raise FreeFieldError("/drm: node indices must be distinct and non-negative", "list each layer node once")
    g = f.require_group(GROUP.strip("/"))
    for e in (x for x in entries() if x.group == GROUP):
        if e.name == "nodes":
            value = nodes.astype(np.int32)
        elif e.name == "internal":
            value = flags.astype(np.int8)
        else:  # the field's own arrays under the same names: time [nt], u, v, a (N, nt, 3)
            value = getattr(field, e.name)
            if np.ndim(value) == 3:
                value = np.asarray(value, dtype=float)
                if value.shape[0] != n or value.shape[2] != 3:
                    raise FreeFieldError(f"/drm: {e.name} has shape {value.shape} for {n} nodes; needs (N, nt, 3)",
                                         "compute the free field at the layer's nodes, in their order")
                ds = g.create_dataset(e.name, shape=(value.shape[1], n, 3), dtype=float)
                for lo in range(0, n, WRITE_BLOCK):
                    ds[:, lo:lo + WRITE_BLOCK, :] = np.swapaxes(value[lo:lo + WRITE_BLOCK], 0, 1)
                del value
                if release:
                    setattr(field, e.name, None)
                continue
            value = np.asarray(value, dtype=float)
        put(g, GROUP, e.name, value)


def _layer(d: dict, mesh_h5):
    """(xyz of every mesh node, the layer's nodes, their inner flags) of the case's DRM layer in
    `mesh_h5`; refused where a lining element touches it (the tunnel crosses the layer)."""
    import h5py

    from .incident_wave import DrmLayerError, drm_layer

    with h5py.File(mesh_h5, "r") as m:
        xyz = m["/nodes/coordinates"][...]
        conn = m["/elements/connectivity"][...].astype(np.int64)
        faces = {k: m[f"/faces/{k}"][...] for k in ("xmin", "xmax", "ymin", "ymax", "bottom")}
        regions = [r.decode() if isinstance(r, bytes) else str(r) for r in m["/elements"].attrs["regions"]]
        region = m["/elements/region"][...]
    nodes, internal = drm_layer(xyz, conn, int(d["incident_wave"]["drm_offset"]), faces)
    # the tunnel must lie inside the layer: no lining element may touch it
    lining = regions.index("lining") if "lining" in regions else -1
    touch = np.zeros(xyz.shape[0], bool)
    touch[nodes] = True
    bad = (region == lining) & touch[conn].any(axis=1)
    if bad.any():
        raise DrmLayerError(f"{int(bad.sum())} lining element(s) touch the DRM layer: the tunnel crosses it; raise "
                            "mesh.tunnel_end_plugs or lower incident_wave.drm_offset")
    return xyz, nodes, internal


def write_drm_group(f, case_data: dict, layers, mesh_h5, record_acc: np.ndarray, dt: float,
                    h5drm=None) -> dict:
    """Compute the free field at the DRM layer's nodes of `mesh_h5` and write `/drm` into the open
    solid_input.h5 `f`. `record_acc`: the processed record (the wave's defining component, under
    convention(d)) sampled every dt from the seismic stage's start. `h5drm`: a path to write the same
    free field to in the H5DRM layout as well (freefield.write_h5drm). Returns a summary."""
    from .freefield import free_field, incident_motion
    from .incident_wave import convention, ground_profile, plane_wave

    d = case_data
    xyz, nodes, internal = _layer(d, mesh_h5)
    profile = ground_profile(d, layers)
    wave = plane_wave(d)
    inc = incident_motion(np.asarray(record_acc, float), dt, wave, profile, convention(d))
    field = free_field(profile, [(wave, inc)], dt, xyz[nodes], chunk=FREE_FIELD_CHUNK)
    samples = int(field.time.size)
    if h5drm is not None:
        from .freefield import write_h5drm

        write_h5drm(h5drm, field, internal)
    write_drm(f, nodes, internal, field, release=True)
    return {"nodes": int(nodes.size), "inner": int(internal.sum()), "samples": samples}


def write_drm_group_from_file(f, case_data: dict, mesh_h5, case_dir, t_end: float) -> dict:
    """Write `/drm` into the open solid_input.h5 `f` from the case's H5DRM file
    (incident_wave.h5drm): every node of the DRM layer of `mesh_h5` matched to a file point
    (freefield.read_h5drm through OpenSees' mapping, incident_wave.h5drm_options), the file's first
    sample at the seismic stage's start. Refused (FreeFieldError) where the file ends before t_end.
    Returns a summary."""
    from pathlib import Path

    from .freefield import read_h5drm
    from .incident_wave import h5drm_options

    d = case_data
    given = Path(d["incident_wave"]["h5drm"]["file"])
    path = given if given.is_absolute() else Path(case_dir) / given
    xyz, nodes, internal = _layer(d, mesh_h5)
    field = read_h5drm(path, xyz[nodes], internal, **h5drm_options(d))
    time = field.time - field.time[0]
    if time[-1] < t_end - 1e-9 * max(t_end, 1.0):
        raise FreeFieldError(f"{path}: the free field lasts {time[-1]:g} s from its first sample, shorter than the "
                             f"seismic stage's {t_end:g} s", "give a file that lasts the run, or a shorter "
                             "time.end_time")
    write_drm(f, nodes, internal, FreeField(points=field.points, time=time, u=field.u, v=field.v, a=field.a))
    return {"nodes": int(nodes.size), "inner": int(internal.sum()), "samples": int(time.size)}
