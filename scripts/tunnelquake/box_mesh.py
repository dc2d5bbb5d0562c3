"""A structured box of hex8 elements written as tq-solid's mesh.h5 (docs/formats.md "mesh.h5": one
region, `rock`, and the face groups `bottom` (z min) and `top` (z max)) and a solid input that loads
it. The benchmarks' boxes and check's subcycling probe are written by it."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def write_box_mesh(path: Path, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
    """mesh.h5 at `path` of the box whose node planes lie at the ascending coordinates x, y, z (m)."""
    import h5py

    nx, ny, nz = len(x) - 1, len(y) - 1, len(z) - 1
    zz, yy, xx = np.meshgrid(np.asarray(z, float), np.asarray(y, float), np.asarray(x, float), indexing="ij")
    coords = np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)

    def nid(i, j, k):
        return i + (nx + 1) * (j + (ny + 1) * k)

    k, j, i = (a.ravel() for a in np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij"))
    conn = np.stack([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                     nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)], axis=1)
    bi, bj = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij"))
    bottom = np.stack([nid(bi, bj, 0), nid(bi, bj + 1, 0), nid(bi + 1, bj + 1, 0), nid(bi + 1, bj, 0)], axis=1)
    top = np.stack([nid(bi, bj, nz), nid(bi + 1, bj, nz), nid(bi + 1, bj + 1, nz), nid(bi, bj + 1, nz)], axis=1)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "tunnelquake-solid-mesh"
        f.attrs["version"] = np.int64(1)
        f.attrs["slice"] = np.int64(0)
        f.create_dataset("nodes/coordinates", data=coords)
        el = f.create_group("elements")
        el.create_dataset("connectivity", data=conn.astype(np.int32))
        el.create_dataset("region", data=np.zeros(len(conn), np.int32))
        el.attrs["regions"] = np.array(["rock"], dtype=h5py.string_dtype())
        f.create_dataset("faces/bottom", data=bottom.astype(np.int32))
        f.create_dataset("faces/top", data=top.astype(np.int32))


def write_loaded_box_input(path: Path, *, E: float, nu: float, rho: float, dt: float, steps: int, top_force: float,
                           monitor_dt: float, subcycling_levels: int = 0,
                           monitors: dict[str, list[float]] | None = None) -> Path:
    """tq-solid's input at `path` for the box of mesh.h5 beside it: one rock material (E Pa, nu, rho
    kg/m^3), its base fixed, gravity, `top_force` N down on its top ramped up over half the `steps`
    steps of `dt` s; monitors (name -> point) sampled every `monitor_dt` s."""
    import h5py

    from .solver_input_schema import FORMAT, MATERIALS, VERSION, put, write_schema

    with h5py.File(path, "w") as f:
        put(f, "/", "format", FORMAT)
        put(f, "/", "version", VERSION)
        put(f, "/", "mesh", "mesh.h5")
        s = f.create_group("solver")
        put(s, "/solver", "t_end", steps * dt)
        put(s, "/solver", "dt", dt)
        put(s, "/solver", "safety", 0.9)
        put(s, "/solver", "gravity_z", -9.81)
        if subcycling_levels:
            put(s, "/solver", "subcycling_levels", subcycling_levels)
        mg = f.create_group("materials/rock")
        put(mg, MATERIALS, "E", E)
        put(mg, MATERIALS, "nu", nu)
        put(mg, MATERIALS, "rho", rho)
        put(f.create_group("boundary/fixed/bottom"), "/boundary/fixed/*", "directions", "xyz")
        lg = f.create_group("loads/top")
        put(lg, "/loads/*", "target", "top")
        put(lg, "/loads/*", "direction", "z")
        put(lg, "/loads/*", "force", top_force)
        put(lg, "/loads/*", "time", np.array([0.0, 0.5 * steps * dt]))
        put(lg, "/loads/*", "value", np.array([0.0, 1.0]))
        if monitors:
            mo = f.create_group("monitors")
            put(mo, "/monitors", "names", np.array(list(monitors), dtype=h5py.string_dtype()))
            put(mo, "/monitors", "points", np.array(list(monitors.values()), dtype=float))
        o = f.create_group("output")
        put(o, "/output", "monitor_dt", monitor_dt)
        put(o, "/output", "progress_s", 1e9)
        write_schema(f)
    return path
