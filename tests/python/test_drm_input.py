"""tq-solid's domain reduction layer driven through solid_input.h5's /drm as the Python side writes it
(`tunnelquake.drm_input.write_drm`) from `tunnelquake.freefield`: a layer over a half-space (two
materials), a box of 1 m elements with a free top, a one-element DRM layer on its sides and bottom,
one element of ground and the viscoelastic boundaries outside it. Reference: the free field itself
(Thomson-Haskell, checked against closed forms in test_freefield.py) at the monitors inside the
layer; nothing outside it (Bielak et al. 2003)."""
from __future__ import annotations

import subprocess

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from tunnelquake.drm_input import write_drm  # noqa: E402
from tunnelquake.freefield import FreeFieldError, HalfSpace, Layer, PlaneWave, Profile, free_field  # noqa: E402
from tunnelquake.paths import solid_executable  # noqa: E402

EXE = solid_executable()
pytestmark = pytest.mark.skipif(EXE is None, reason="tq-solid is not built (set TQ_BUILD_DIR)")

N, NZ, TOP = 16, 14, 6  # elements across, down; the top layer's thickness (m); inner region [2, 14]² × [2, 14]
PROFILE = Profile((Layer(TOP, 300.0, 160.0, 1900.0),), HalfSpace(433.0, 250.0, 2000.0), surface=float(NZ))
HEX_FACES = {"bottom": [0, 3, 2, 1], "ymin": [0, 1, 5, 4], "xmax": [1, 2, 6, 5], "ymax": [2, 3, 7, 6],
             "xmin": [3, 0, 4, 7]}


def box(tmp):
    """mesh.h5 of the box, regions 'rock' (below the layer) and 'layer'; node (i, j, k) = i + (N+1)(j + (N+1) k)."""
    idx = np.arange((N + 1) ** 2 * (NZ + 1))
    xyz = np.stack([idx % (N + 1), (idx // (N + 1)) % (N + 1), idx // (N + 1) ** 2], axis=1).astype(float)
    conn, region, faces = [], [], {k: [] for k in HEX_FACES}

    def nid(i, j, k):
        return i + (N + 1) * (j + (N + 1) * k)

    for k in range(NZ):
        for j in range(N):
            for i in range(N):
                c = [nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                     nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)]
                conn.append(c)
                region.append(1 if k >= NZ - TOP else 0)
                for name, on in (("bottom", k == 0), ("ymin", j == 0), ("xmax", i == N - 1),
                                 ("ymax", j == N - 1), ("xmin", i == 0)):
                    if on:
                        faces[name].append([c[q] for q in HEX_FACES[name]])
    with h5py.File(tmp / "mesh.h5", "w") as f:
        f.attrs["format"] = "tunnelquake-solid-mesh"
        f.attrs["version"] = 1
        f["/nodes/coordinates"] = xyz
        f["/elements/connectivity"] = np.array(conn, np.int32)
        f["/elements/region"] = np.array(region, np.int32)
        f["/elements"].attrs["regions"] = ["rock", "layer"]
        for name, q in faces.items():
            f[f"/faces/{name}"] = np.array(q, np.int32)
    inside = np.all((xyz[:, :2] >= 2) & (xyz[:, :2] <= N - 2), axis=1) & (xyz[:, 2] >= 2)
    on_b = inside & (np.any((xyz[:, :2] == 2) | (xyz[:, :2] == N - 2), axis=1) | (xyz[:, 2] == 2))
    outer = np.all((xyz[:, :2] >= 1) & (xyz[:, :2] <= N - 1), axis=1) & (xyz[:, 2] >= 1) & ~inside
    nodes = np.flatnonzero(on_b | outer)
    return xyz, nodes, on_b[nodes]


def elastic(m):
    nu = (m.vp ** 2 - 2 * m.vs ** 2) / (2 * (m.vp ** 2 - m.vs ** 2))
    return {"E": 2 * m.rho * m.vs ** 2 * (1 + nu), "nu": nu, "rho": m.rho, "model": "elastic"}


def ricker_acceleration(dt, n, fc=5.0, amp=1.0):
    t = np.arange(n) * dt
    a = (np.pi * fc * (t - 1.5 / fc)) ** 2
    return amp * (1 - 2 * a) * np.exp(-a)


def solid_input(tmp, xyz, nodes, internal, wave, t_end, monitors):
    acc = ricker_acceleration(2e-3, int(round(t_end / 2e-3)) + 1)
    field = free_field(PROFILE, [(wave, acc)], 2e-3, xyz[nodes])
    with h5py.File(tmp / "solid_input.h5", "w") as f:
        f.attrs.update({"format": "tunnelquake-solid-input", "version": 2, "mesh": "mesh.h5"})
        f.create_group("solver").attrs["t_end"] = t_end
        f.create_group("materials/rock").attrs.update(elastic(PROFILE.halfspace))
        f.create_group("materials/layer").attrs.update(elastic(PROFILE.layers[0]))
        f.create_group("stages").attrs["sequence"] = "seismic"
        hs = PROFILE.halfspace
        f.create_group("boundaries/bottom").attrs.update({"face": "bottom", "type": "viscoelastic", "distance": 600.0,
                                                          "rho": hs.rho, "cp": hs.vp, "cs": hs.vs})
        f.create_group("boundaries/free_field").attrs["faces"] = "xmin,xmax,ymin,ymax"
        f.create_group("output").attrs.update({"monitor_dt": 2e-3, "progress_s": 100.0, "ring_forces": 0})
        f["/monitors/names"] = list(monitors)
        f["/monitors/points"] = np.array(list(monitors.values()), float)
        write_drm(f, nodes, internal, field)
    return field


@pytest.mark.parametrize("wave", [PlaneWave("SV", 0.0, 90.0), PlaneWave("SV", 20.0, 60.0)],
                         ids=["SV_vertical", "SV_20deg"])
def test_a_layered_free_field_written_by_python_drives_tq_solid(tmp_path, wave):
    xyz, nodes, internal = box(tmp_path)
    monitors = {"surface": [8.0, 8.0, float(NZ)], "interface": [5.0, 11.0, float(NZ - TOP)],
                "b": [2.0, 8.0, 4.0], "outside": [0.0, 8.0, 6.0]}
    solid_input(tmp_path, xyz, nodes, internal, wave, 1.2, monitors)
    out = subprocess.run([str(EXE), str(tmp_path / "solid_input.h5"), "-o", str(tmp_path / "results.h5"),
                          "--threads", "1"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "domain reduction layer" in out.stdout
    with h5py.File(tmp_path / "results.h5", "r") as r:
        res = {m: (r[f"/monitors/{m}/time"][:, 0], r[f"/monitors/{m}/u"][...]) for m in monitors}
    t = res["surface"][0]
    pts = np.array([monitors[m] for m in monitors])
    # free_field puts t = 0 where the wave first reaches the top of the half-space among its points;
    # the layer's nodes set it for the run, so the reference is computed with them too.
    ref = free_field(PROFILE, [(wave, ricker_acceleration(2e-3, t.size + 50))], 2e-3,
                     np.vstack([xyz[nodes], pts]), times=t)
    u0 = ref.u[len(nodes):]
    surface = np.sqrt(np.sum(u0[0] ** 2))  # the surface's L2 norm: about twice the incident wave's
    for i, m in enumerate(monitors):
        u = res[m][1]
        if m == "outside":
            ratio = np.sqrt(np.sum(u ** 2)) / surface
            print(f"{wave.kind} {wave.angle:g} deg: outside the layer {ratio:.2e} of the surface motion")
            assert ratio < 0.01  # 2 % of the incident wave, half the surface motion
        else:
            err = np.sqrt(np.sum((u - u0[i]) ** 2) / np.sum(u0[i] ** 2))
            print(f"{wave.kind} {wave.angle:g} deg: {m} L2 error {err:.2e}")
            assert err < 0.01, m


def test_write_drm_refuses_flags_without_inner_nodes(tmp_path):
    xyz, nodes, internal = box(tmp_path)
    field = free_field(PROFILE, [(PlaneWave("SV"), ricker_acceleration(2e-3, 50))], 2e-3, xyz[nodes[:4]])
    with h5py.File(tmp_path / "x.h5", "w") as f, pytest.raises(FreeFieldError, match="inner"):
        write_drm(f, nodes[:4], np.zeros(4, bool), field)
