"""A structured box of hex8 elements written as tq-solid's mesh.h5 (docs/formats.md "mesh.h5"): one
region, `rock`, and the face groups `bottom` (z min) and `top` (z max). The benchmarks' boxes and
check's subcycling probe are written by it."""
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
