"""Coupled verification on the example's geometry: the paper's lined
tunnel in rock (slice, compressible water, dynamic contact, viscoelastic base and free-field sides,
the full staged initial state) run by `tunnelquake run` as tq-solid + rhoPimpleFoam through the
coupler, implicit IQN-ILS every solid step.

Check 4 — shaken as a rigid body at low frequency, the total water force on the lining equals the
water mass times the lining's acceleration: F = −ρw Vw a within 2 % (VERIFICATION.md: "n = 1 gives
added mass ρπR², the rigid-container result"; at 1 Hz the lining (10.5 m across) moves rigidly in
a wave 1 km long, and the water's first acoustic mode, 1.84 c/(2πR) = 97 Hz, is far above, so the
compressible correction (f/97 Hz)² is 1e-4). Vw is the water mesh's own volume (the polygon of
the wetted nodes × slice thickness), so the check is of the coupling, not of the polygon. Rock and
lining are elastic here (the example's E, ν, ρ; contact, boundaries and stages as the example):
with the example's Mohr–Coulomb damage the lining (damaged by the static water pressure) yields
further even under 0.5 m/s², its accelerations become broadband (the monitors differ from the
lining's mean by 40–55 % of its peak) and it is no longer shaken as a rigid body (measured: max
|F + m a| 9.1 % x / 7.0 % z of the peak, least-squares F / (−m a) 1.005 / 1.002; docs/verification.md).

Check 5 — hydrostatic equilibrium held with no shaking: the lining's spurious velocity stays below
1e-6 m/s. In CI for HOLD_S (3 s, the affordable part); the issue's 10 s is
`TQ_HYDROSTATIC_HOLD_S=10 pytest tests/python/test_coupled_checks.py -k hydrostatic`
(measured: docs/verification.md).

The mesh is the example's coarsened for time (`COARSE`: 24 × 1 lining elements, 84 water cells,
350 solid elements; the stable step is the lining's, 1.8e-4 s).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
yaml = pytest.importorskip("yaml")
from conftest import COARSE_EXAMPLE_MESH, EXAMPLE, coupled_run_missing  # noqa: E402
from tunnelquake.cli import main  # noqa: E402

coupled = pytest.mark.skipif(coupled_run_missing() is not None, reason=str(coupled_run_missing()))

#: the example's mesh coarsened (its 13.5 m outer elements are enough for the 5 Hz cut-off below:
#: c_s/(8 f) = 27 m)
COARSE = COARSE_EXAMPLE_MESH

#: check 4: one cycle of a 1 Hz sine under a Hann window, a(t) = A sin²(πt/T) sin(2πt/T), T = 1 s,
#: incident at the base in x and (2/3) in z; run to RIGID_END_S (past both peaks at the tunnel)
RIGID_FREQUENCY, RIGID_PGA, RIGID_END_S = 1.0, 0.5, 0.8
RIGID_SAMPLE_S = 5e-4  # monitor and series sampling (the default 5 ms would skip most steps)
RIGID_TOL = 0.02
#: check 5
HOLD_S = float(os.environ.get("TQ_HYDROSTATIC_HOLD_S", "3.0"))
SPURIOUS_VELOCITY = 1e-6  # m/s


def _write_case(folder: Path, motion: np.ndarray, end_time: float, pga: float | None,
                snapshots: list[float], elastic: bool = False, history_interval: float | None = None) -> Path:
    """The example case with the coarse mesh, condition 3 only, and `motion` (time, m/s²) as the
    incident wave (no baseline correction: the record is already smooth and at rest at both ends).
    `elastic`: rock and lining elastic with the example's E, ν, ρ (no Mohr–Coulomb yield)."""
    data = yaml.safe_load(EXAMPLE.read_text())
    data["mesh"].update(COARSE)
    if elastic:
        for m in data["materials"].values():
            m["model"] = "elastic"
    if history_interval is not None:
        data["output"]["history_interval"] = f"{history_interval} s"
    data["conditions"] = ["dynamic_water"]
    # The checks measure the interface physics at the finest coupling: one-step windows, tolerance
    # 1e-4 (the example's windows of 16 steps, 2.9 ms on this coarse mesh, give 2.3 % in check 4:
    # docs/verification.md; their effect on the example is measured in docs/benchmarks.md).
    data["coupling"].update({"window": 1, "reuse": 0, "tolerance": 1e-4})
    np.savetxt(folder / "motion.txt", motion, fmt="%.6f %.12e")
    gm = {"source": "file", "file": "motion.txt", "format": "two_column", "units": "m/s^2",
          "duration": f"{motion[-1, 0]} s", "vertical_ratio": data["ground_motion"]["vertical_ratio"],
          "cutoff_frequency": "5 Hz", "baseline_correction": False, "convention": "incident"}
    if pga is not None:
        gm["pga"] = f"{pga} m/s^2"
    data["ground_motion"] = gm
    data["time"] = {"end_time": f"{end_time} s"}
    data["output"]["snapshot_times"] = snapshots
    p = folder / "case.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def _run(case: Path) -> Path:
    assert main(["run", str(case)]) == 0
    res = case.parent / "results" / "results_dynamic_water.h5"
    with h5py.File(res, "r") as f:
        assert f.attrs["status"] == "completed", f.attrs["status"]
    return res


def _water_mass(res: Path, rho: float) -> float:
    """ρw × the water's volume: the polygon of the wetted nodes (the water mesh's boundary, its
    points the lining_inner nodes) in x–z times the slice thickness."""
    with h5py.File(res.parent / "mesh" / "mesh.h5", "r") as f:
        xyz = f["nodes/coordinates"][:]
        quads = f["faces/lining_inner"][:]
    y = xyz[:, 1]
    thickness = float(np.ptp(y))
    nodes = np.unique(quads)
    ring = nodes[np.isclose(y[nodes], y.min())]
    x, z = xyz[ring, 0], xyz[ring, 2]
    order = np.argsort(np.arctan2(z - z.mean(), x - x.mean()))
    x, z = x[order], z[order]
    area = 0.5 * abs(np.dot(x, np.roll(z, -1)) - np.dot(z, np.roll(x, -1)))
    return rho * area * thickness


def _lining_nodes(f) -> np.ndarray:
    regions = [r.decode() if isinstance(r, bytes) else r for r in f["mesh"].attrs["regions"]]
    conn = f["mesh/connectivity"][:]
    return np.unique(conn[f["mesh/region"][:] == regions.index("lining")])


@coupled
def test_rigidly_shaken_lining_feels_the_water_mass_times_its_acceleration(tmp_path):
    """Check 4: ΣR3 over the wetted nodes = −ρw Vw ā (ā the wetted nodes' mass-weighted mean
    acceleration, same step) in x and z, to 2 % of the peak ρw Vw |ā|, at every sample."""
    T = 1.0 / RIGID_FREQUENCY
    t = np.arange(0.0, T + 5e-4, 1e-3)
    motion = np.c_[t, np.sin(np.pi * t / T) ** 2 * np.sin(2 * np.pi * t / T)]
    res = _run(_write_case(tmp_path, motion, RIGID_END_S, RIGID_PGA, [RIGID_END_S], elastic=True,
                           history_interval=RIGID_SAMPLE_S))
    rho = float(yaml.safe_load(EXAMPLE.read_text())["water"]["density"].split()[0])
    mw = _water_mass(res, rho)
    with h5py.File(res, "r") as f:
        for d in "xz":
            force = f[f"coupling/force_{d}"][:]
            acc = f[f"coupling/acceleration_{d}"][:]
            np.testing.assert_array_equal(force[:, 0], acc[:, 0])
            expected = -mw * acc[:, 1]
            peak = np.max(np.abs(expected))
            err = np.max(np.abs(force[:, 1] - expected)) / peak
            ratio = np.dot(force[:, 1], expected) / np.dot(expected, expected)
            print(f"\n{d}: water mass {mw:.6g} kg, peak mean acceleration {peak / mw:.4g} m/s², peak force "
                  f"{np.max(np.abs(force[:, 1])):.6g} N; max |F + m a| / peak = {100 * err:.3f} %, "
                  f"least-squares F / (−m a) = {ratio:.5f}")
            # the lining was shaken: its acceleration is of the motion's size (incident 0.5 m/s² in x)
            assert peak / mw > 0.1 * (1.0 if d == "x" else 2.0 / 3.0) * RIGID_PGA
            assert err < RIGID_TOL, d
            assert abs(ratio - 1) < RIGID_TOL, d
        # how rigidly the lining moves: its monitors (crown, springline, invert) against the mean
        ax = f["coupling/acceleration_x"][:, 1]
        for m in ("top_arch", "haunch", "bottom_arch"):
            am = f[f"monitors/{m}/a"][:, 0]
            print(f"{m}: max |a_x - mean| / peak = {np.max(np.abs(am - ax)) / np.max(np.abs(ax)):.2e}")


@coupled
def test_hydrostatic_equilibrium_is_held_without_shaking(tmp_path):
    """Check 5: no shaking (a record of zeros), HOLD_S of coupled time; the lining's monitors and
    every lining node of the snapshots (each second and the end) move below 1e-6 m/s."""
    t = np.arange(0.0, HOLD_S + 5e-3, 1e-2)
    snaps = [float(s) for s in np.arange(1.0, HOLD_S + 1e-9, 1.0)]
    res = _run(_write_case(tmp_path, np.c_[t, np.zeros_like(t)], HOLD_S, None, sorted(set(snaps + [HOLD_S]))))
    with h5py.File(res, "r") as f:
        c = dict(f["coupling"].attrs)
        assert c["windows"] * c["window_size"] >= HOLD_S - 1e-9
        vmax_mon = max(np.max(np.abs(f[f"monitors/{m}/v"][:])) for m in ("top_arch", "haunch", "bottom_arch"))
        lining = _lining_nodes(f)
        snaps = sorted(f["snapshots"], key=int)
        vmax_nodes = max(np.max(np.abs(f[f"snapshots/{k}/v"][:][lining])) for k in snaps)
        last = float(f[f"snapshots/{snaps[-1]}"].attrs["time"])
        wp = max(np.max(np.abs(f[f"monitors/{m}/water_pressure"][:, 1])) for m in ("top_arch", "haunch", "bottom_arch"))
        print(f"\nheld {HOLD_S} s ({int(c['windows'])} windows, {c['passes'] / c['windows']:.2f} passes a window): "
              f"max |v| monitors {vmax_mon:.3e} m/s, lining nodes at {len(snaps)} snapshots {vmax_nodes:.3e} m/s; "
              f"max |water pressure| at the monitors {wp:.3e} Pa")
        assert last == pytest.approx(HOLD_S, abs=1e-3)
        assert vmax_mon < SPURIOUS_VELOCITY
        assert vmax_nodes < SPURIOUS_VELOCITY
