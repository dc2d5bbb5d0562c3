"""tunnelquake.ring_forces: the lining section forces tq-solid writes, read back on the paper's slice.

End to end on the example's slice mesh (48 x 3 lining elements, elastic, bonded), the case of
test_solid_input: the rings are found on the real gmsh mesh (one closed ring, 48 sections, 24
diameters), the histories and envelopes agree, and the thrust the water adds (static_water minus
no_water at the seismic start, elastic superposition) averaged around the ring is the closed form's
p_i a - p_c b within 2 % (the hydrostatic gradient's part averages out around the ring). The
free-body forces written beside the design forces differ from them by the O(dtheta^2) that the C++
test measures at the same lining mesh (0.14-0.21 % of max|N| in N and V): here on the gmsh mesh
within 0.5 % of max|N| at every sample. The closed-form checks of N, M and V and the equilibrium are the C++ tests
tests/cpp/test_ring_forces.cpp. Runs only when tq-solid is built with the staged-seismic capability.
"""
from __future__ import annotations

import subprocess

import numpy as np
import pytest
from test_solid_input import _case, _solid_with_stages, prepared  # noqa: F401  (module fixture)

from tunnelquake.references import lined_tunnel_internal_pressure
from tunnelquake.ring_forces import read_ring_forces, ring_forces_note
from tunnelquake.solid_input import write_solid_input


@pytest.mark.skipif(_solid_with_stages() is None, reason="tq-solid with staged-seismic is not built")
def test_ring_forces_on_the_example_slice(prepared, tmp_path):  # noqa: F811
    exe = _solid_with_stages()
    case = _case(tmp_path, end=0.012)
    rings = {}
    for cond in ("no_water", "static_water"):
        inp = write_solid_input(case, prepared / "mesh.h5", prepared / "motion.h5", cond, tmp_path / f"{cond}.h5")
        res = tmp_path / f"results_{cond}.h5"
        run = subprocess.run([str(exe), str(inp), "-o", str(res), "--threads", "1"], capture_output=True,
                             text=True, timeout=600)
        assert run.returncode == 0, run.stdout + run.stderr
        assert ring_forces_note(res) == ""
        (ring,) = read_ring_forces(res)
        rings[cond] = ring
        assert ring.closed and ring.angle.shape == (48,) and ring.diameter_angle.shape == (24,)
        assert np.all(np.diff(ring.angle) > 0) and np.all((ring.diameter_angle >= 0) & (ring.diameter_angle < np.pi))
        assert ring.r_inner == pytest.approx(4.5, rel=1e-6) and ring.r_outer == pytest.approx(5.25, rel=1e-6)
        assert ring.centre == pytest.approx((0.0, 32.0), abs=1e-9)
        T = len(ring.time)
        assert T >= 2 and ring.N.shape == ring.M.shape == ring.V.shape == (T, 48)
        assert ring.diameter_change.shape == (T, 24)
        assert np.all(np.isfinite(ring.M))
        np.testing.assert_array_equal(ring.diameter_change[0], 0.0)  # relative to the seismic start
        for q in ("N", "M", "V", "diameter_change"):
            h, e = getattr(ring, q), ring.envelopes[q]
            # the envelopes are of the float64 values, the histories float32
            np.testing.assert_allclose(e.max, h.max(axis=0), rtol=1e-6, atol=1e-6 * np.abs(h).max() + 1e-30)
            np.testing.assert_allclose(e.min, h.min(axis=0), rtol=1e-6, atol=1e-6 * np.abs(h).max() + 1e-30)
            assert np.all(np.isin(e.time_of_max, ring.time)) and np.all(np.isin(e.time_of_min, ring.time))
        assert set(ring.ovaling) >= {"elongation", "elongation_angle", "elongation_time", "shortening"}
        fb = ring.free_body
        assert fb is not None and fb.N.shape == fb.M.shape == fb.V.shape == (T, 48)
        nmax, mmax = np.abs(ring.N).max(), np.abs(ring.M).max()
        dN, dV = (np.abs(getattr(ring, q) - getattr(fb, q)).max(axis=1) / nmax for q in ("N", "V"))
        dM = np.abs(ring.M - fb.M).max(axis=1) / mmax
        print(f"{cond}: design - free body at the seismic start / largest over {T} samples: N {100 * dN[0]:.3f} / "
              f"{100 * dN.max():.3f} %, V {100 * dV[0]:.3f} / {100 * dV.max():.3f} % of max|N|, M {100 * dM[0]:.2f} / "
              f"{100 * dM.max():.2f} % of max|M|")
        assert dN.max() < 0.005 and dV.max() < 0.005
    a, b = 4.5, 5.25
    p_i = 1000 * 9.81 * 123
    ref = lined_tunnel_internal_pressure(p_i, a, b, 28e9, 0.17, 8e9, 0.27)
    dN = rings["static_water"].N[0] - rings["no_water"].N[0]
    expected = p_i * a - ref["contact_pressure"] * b
    print(f"thrust from the water, mean around the ring: {dN.mean():.6g} N/m against {expected:.6g} N/m "
          f"({100 * (dN.mean() / expected - 1):+.2f} %)")
    assert dN.mean() == pytest.approx(expected, rel=0.02), (dN.mean(), expected)
