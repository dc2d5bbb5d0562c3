"""Coupled verification: free n = 2 ovaling of a thin ring, empty and water-filled, through the real
chain tq-solid + coupler + OpenFOAM (libtqFoam) (tests/verification/coupled_ring).

Reference: VERIFICATION.md "Coupled" (thin ring, plane strain, E 30 GPa, ν 0.2, ρs 2500, h 0.3 m,
R 3 m): vacuum ω² = D n²(n²−1)²/(R⁴ m(n²+1)) = (2π 14.53 Hz)²; with incompressible water of radius
a the added mass per wall area is ρf a²/(R n) (energy argument; the table's ρf R n takes a = R, an
O(h/R) choice: 9.01 Hz; with the water's true radius a = R − h/2: 9.29 Hz) —
`references.ring_ovaling_frequency(..., fluid_radius=a)`.

Tolerances (the issue's): 2 % empty, 3 % filled. Discretisation error measured by refinement
(tests/verification/coupled_ring/README.md): the converged hex8 ring is −0.4 % from the thin-ring
formula (thick-ring effects); 64 × 1 elements is +0.2 % from it, 32 × 1 (the coupled tests, for
time) +1.6 %; the coupled refinement is in the README.
"""
from __future__ import annotations

import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
h5py = pytest.importorskip("h5py")
pytest.importorskip("scipy")
from tunnelquake import paths  # noqa: E402
from tunnelquake.references import open_tube_added_mass, open_tube_mu_max, ring_ovaling_frequency  # noqa: E402
from tunnelquake.verification.ring import Ring, run_ring  # noqa: E402

solid = pytest.mark.skipif(paths.solid_executable() is None, reason="tq-solid is not built (set TQ_BUILD_DIR)")
water = pytest.mark.skipif(paths.openfoam_library() is None or not Path("/usr/share/openfoam").is_dir(),
                           reason="libtqFoam.so or OpenFOAM v1912 missing")

#: the verification ring (VERIFICATION.md "Coupled"); one element through the wall (the step doubles,
#: the frequency moves 0.2 %: README), 64 around for the solid alone, 32 around for the coupled runs
BASE = Ring(n_around=64, n_through=1, length=0.5, periods=3.0)
COUPLED = Ring(n_around=32, n_through=1, length=0.5, periods=3.0, scheme="implicit", acceleration="iqn-ils")
EMPTY_TOL, FILLED_TOL = 0.02, 0.03


def _report(res):
    print(f"\n{res.ring['mode']} water={res.ring['water']}: f = {res.frequency:.4f} Hz vs {res.expected:.4f} Hz "
          f"({100 * res.error():+.2f} %), growth {res.growth:.3f}, fit rms {res.fit_rms:.2e}, passes {res.passes}, "
          f"{res.wall_s:.1f} s")


def test_references_of_the_ring():
    """The closed forms used below: 14.53 Hz empty, 9.01 Hz with ρf R n (VERIFICATION.md)."""
    assert ring_ovaling_frequency(2, 30e9, 0.2, 2500, 0.3, 3.0) == pytest.approx(14.53, abs=0.005)
    assert ring_ovaling_frequency(2, 30e9, 0.2, 2500, 0.3, 3.0, 1000) == pytest.approx(9.01, abs=0.005)
    assert BASE.expected_frequency() == pytest.approx(
        ring_ovaling_frequency(2, 30e9, 0.2, 2500, 0.3, 3.0, 1000, fluid_radius=2.85), rel=1e-12)


def test_open_tube_added_mass_limits():
    """The open tube of the incompressible stability map (docs/stability.md; references.open_tube_*)
    against its limits. Mid-length of a long tube and the uniform-mode (Rayleigh) value for L ≫ a:
    the 2D ring's added mass ρf a/n (VERIFICATION.md "Coupled"); the end zones (length ~ a/n,
    p = 0) take 1 − O(a/L) off the mean. Breathing mode: the 1D plug flow (continuity
    πa² ∂u/∂y = −2πa ẇ sin(πy/L), momentum ρ ∂u/∂t = −∂p/∂y) gives μ = 2L²/(π² a) for L ≫ a,
    corrections O((πa/L)²) (1D plug flow, as references.open_pipe_contraction); every n ≥ 1 mode
    has μ ≤ a/n (so the closed circle's μ_max = a is exceeded by the open tube's breathing)."""
    a = 2.85
    assert open_tube_added_mass(2, a, 100 * a, y=50 * a) == pytest.approx(1.0, abs=1e-6)
    assert open_tube_added_mass(2, a, 1000 * a) == pytest.approx(1.0, abs=2e-3)
    assert 0 < open_tube_added_mass(2, a, 4 * a) < open_tube_added_mass(2, a, 8 * a) < 1
    assert open_tube_added_mass(2, a, 4 * a, y=2 * a) == pytest.approx(1.0, abs=5e-3)  # the map's tube, mid-length
    L = 20 * a
    assert open_tube_mu_max(a, L) == pytest.approx(2 * L * L / (math.pi**2 * a), rel=1e-2)
    assert open_tube_mu_max(a, 2 * a) > a
    # the ring driver: the tube's n = 2 frequency between the 2D filled ring's and the vacuum's
    tube = Ring(mode="3d", ends="open", length=4 * a, n_axial=6)
    assert ring_ovaling_frequency(2, 30e9, 0.2, 2500, 0.3, 3.0, 1000, fluid_radius=a) < tube.expected_frequency() \
        < ring_ovaling_frequency(2, 30e9, 0.2, 2500, 0.3, 3.0)
    assert tube.meshed_length == pytest.approx(2 * a) and tube.monitor_layer == 0


@solid
def test_empty_ring_n2_frequency(tmp_path):
    """(a) No water: tq-solid alone, free vibration after the pulse; 2 % of the vacuum formula."""
    res = run_ring(Ring(**{**BASE.__dict__, "water": False}), tmp_path / "empty")
    _report(res)
    assert res.status == "completed", res.reason
    assert res.fit_rms < 0.05  # a clean single-mode signal
    assert abs(res.frequency / ring_ovaling_frequency(2, 30e9, 0.2, 2500, 0.3, 3.0) - 1) < EMPTY_TOL


@solid
@water
@pytest.mark.parametrize("mode", ["slice", "3d"])
def test_water_filled_ring_n2_frequency(tmp_path, mode):
    """(b) 2D slice (water ends `empty`) and (c) 3D prism of 2 elements (ring ends u_y = 0, water ends
    symmetry planes): compressible water (K 2.2 GPa), implicit coupling with IQN-ILS every solid
    step (the explicit scheme is unstable here and the paper's predictor-corrector 12 % low:
    docs/stability.md); 3 % of the filled-ring formula with the water's radius."""
    ring = Ring(**{**COUPLED.__dict__, "mode": mode, "n_axial": 1 if mode == "slice" else 2,
                   "length": 0.5 if mode == "slice" else 1.0})
    res = run_ring(ring, tmp_path / mode)
    _report(res)
    assert res.status == "completed", res.reason
    assert res.fit_rms < 0.05
    assert abs(res.error()) < FILLED_TOL


@solid
@water
def test_water_filled_ring_implicit_windows_of_8_steps(tmp_path):
    """Implicit windows of k = 8 solid steps (tq-solid saves its state at each window start
    and steps a window the water did not accept again from it; libtqFoam takes one water step a
    window) with IQN-ILS keeping the secant columns of 8 earlier windows (coupling.reuse 8): the
    slice of (b) against the same reference and tolerance, the filled-ring formula with the water's
    radius, 3 %.

    Measured on the 32 × 1 slice, compressible water, solid step 7.0e-5 s (2026-11-21, 2 shared
    cores; `python -m tunnelquake.verification.ring run --water --mode slice --scheme implicit
    --n-around 32 --window K [--reuse 8]`):
      k = 1 (test (b)):  f 9.4814 Hz, +2.02 %; 4664 windows, 3.24 passes a window (max 5); growth
                         0.976; 32 s wall;
      k = 8, reuse 8:    f 9.4665 Hz, +1.86 %; 583 windows, 2.79 passes a window (max 5); growth
                         0.878; 6 s wall;
      k = 8, reuse 0:    f 9.4664 Hz, +1.86 %; 583 windows, 3.31 passes a window (max 5); 7 s wall.
    What differs from k = 1: the water sees the wall once a window (the window's mean velocity and
    end displacement) and answers with one force, which the solid's steps of the next pass apply
    ramped from the window's start force (docs/coupler.md "Windows of several steps"); the water's
    step is 8 solid steps, so the water's time discretisation is coarser and the free vibration
    loses more amplitude over the 3 periods (growth 0.88 against 0.98). The frequency stays within
    the tolerance (−0.16 % from k = 1); reuse only saves passes."""
    ring = Ring(**{**COUPLED.__dict__, "window": 8, "reuse": 8})
    res = run_ring(ring, tmp_path / "k8")
    _report(res)
    assert res.status == "completed", res.reason
    assert res.fit_rms < 0.05
    # the repeat path ran: some windows were stepped again (the linear predictor lets a window whose
    # first answer agrees with it end after one pass)
    assert res.windows > 0 and res.max_passes >= 2
    assert abs(res.error()) < FILLED_TOL
    # tq-solid's stepping split by pass: the re-passes took time here, and first passes and
    # re-passes are parts of the solid's wall outside the coupler (the rest: the windows' ends)
    with h5py.File(Path(res.folder) / "results.h5", "r") as f:
        c = f["coupling"].attrs
        assert c["solid_first_passes_s"] > 0 and c["solid_repasses_s"] > 0
        assert c["solid_first_passes_s"] + c["solid_repasses_s"] <= c["solid_s"]
