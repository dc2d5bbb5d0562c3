"""Ground motions: the AT2 and two-column readers, the synthetic model, and the processing chain."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import EL_CENTRO, EL_CENTRO_PEER
from tunnelquake.motion import (
    MotionError,
    SyntheticModel,
    baseline_correct,
    integrate,
    lowpass,
    process,
    read_at2,
    read_record,
    read_two_column,
)

needs_record = pytest.mark.skipif(not EL_CENTRO.is_file(), reason="shared El Centro record not present")
G = 9.80665


@needs_record
def test_el_centro_peknold_record():
    # PROVENANCE.txt: 1559 points, dt 0.02 s, peak -0.31882 g at t = 2.02 s (values in g)
    r = read_at2(EL_CENTRO)
    assert r.npts == 1559
    assert r.dt == pytest.approx(0.02, abs=1e-12)
    peak, t_peak = r.peak()
    assert peak / G == pytest.approx(-0.31882, abs=5e-6)
    assert t_peak == pytest.approx(2.02, abs=1e-9)


@needs_record
def test_el_centro_peer_record():
    # PROVENANCE.txt: 4000 points, dt 0.01 s, peak -0.31288 g at 2.15 s
    r = read_record(EL_CENTRO_PEER)
    assert (r.npts, r.dt) == (4000, pytest.approx(0.01))
    peak, t_peak = r.peak()
    assert peak / G == pytest.approx(-0.31288, abs=5e-6)
    assert t_peak == pytest.approx(2.15, abs=1e-9)


def test_two_column_round_trip(tmp_path):
    t = np.arange(200) * 0.005
    a = 0.1 * np.sin(2 * np.pi * 3 * t)
    p = tmp_path / "m.txt"
    np.savetxt(p, np.c_[t, a], header="time acc(g)")
    r = read_two_column(p, units="g")
    assert r.dt == pytest.approx(0.005, rel=1e-9)
    np.testing.assert_allclose(r.acc, a * G, rtol=1e-9, atol=1e-15)


def test_two_column_rejects_non_uniform_time(tmp_path):
    p = tmp_path / "m.txt"
    p.write_text("0 0\n0.01 1\n0.03 0\n")
    with pytest.raises(MotionError, match="not uniform"):
        read_two_column(p, units="g")


def test_lowpass_removes_content_above_cutoff():
    dt = 0.002  # Nyquist 250 Hz
    t = np.arange(5000) * dt
    low, high = np.sin(2 * np.pi * 5 * t), np.sin(2 * np.pi * 40 * t)
    out = lowpass(low + high, dt, cutoff=20.0)
    core = slice(500, -500)  # away from the ends
    # 4th-order digital Butterworth applied forward and backward: gain |H|^2 = 1/(1 + r^8) with the
    # bilinear-transform frequency ratio r = tan(pi f dt) / tan(pi fc dt): ~1 at 5 Hz, 3.4e-3 at 40 Hz
    spec = np.abs(np.fft.rfft(out[core]))
    f = np.fft.rfftfreq(out[core].size, dt)
    a5 = spec[np.argmin(np.abs(f - 5))] / np.abs(np.fft.rfft(low[core]))[np.argmin(np.abs(f - 5))]
    a40 = spec[np.argmin(np.abs(f - 40))] / np.abs(np.fft.rfft(high[core]))[np.argmin(np.abs(f - 40))]
    def gain(freq):
        r = np.tan(np.pi * freq * dt) / np.tan(np.pi * 20.0 * dt)
        return 1.0 / (1.0 + r**8)

    assert a5 == pytest.approx(gain(5.0), abs=1e-3)
    assert a40 == pytest.approx(gain(40.0), rel=0.05)
    assert a40 < 5e-3


def test_integration_exact_for_linear_acceleration():
    dt = 0.01
    t = np.arange(101) * dt
    a = 2.0 + 3.0 * t  # v = 2t + 1.5 t^2, d = t^2 + 0.5 t^3 (trapezoid/linear-acc exact)
    v, d = integrate(a, dt)
    np.testing.assert_allclose(v, 2 * t + 1.5 * t**2, atol=1e-12)
    np.testing.assert_allclose(d, t**2 + 0.5 * t**3, atol=1e-12)


def test_baseline_correction_removes_drift():
    dt = 0.01
    t = np.arange(2001) * dt
    pulse = np.exp(-((t - 5) / 0.5) ** 2) * np.sin(2 * np.pi * 2 * t)
    drifting = pulse + 0.002  # a constant offset: displacement drifts as 0.001 t^2 (0.4 m at 20 s)
    corrected = baseline_correct(drifting, dt)
    v, d = integrate(corrected, dt)
    _, d_raw = integrate(drifting, dt)
    assert abs(d_raw[-1]) > 0.3
    assert abs(v[-1]) < 1e-3 and abs(d[-1]) < 2e-3


def test_synthetic_motion_is_repeatable_and_has_its_model_frequency():
    a1 = SyntheticModel(seed=7).generate().acc
    a2 = SyntheticModel(seed=7).generate().acc
    a3 = SyntheticModel(seed=8).generate().acc
    np.testing.assert_array_equal(a1, a2)
    assert not np.allclose(a1, a3)
    # Kanai-Tajimi with xi_g = 0.6: the acceleration PSD peaks just below f_g = 2.5 Hz; averaged over
    # seeds the spectral centroid of 0.5-10 Hz must lie within 1-5 Hz
    dt = 0.01
    cents = []
    for seed in range(5):
        a = SyntheticModel(seed=seed).generate().acc
        f = np.fft.rfftfreq(a.size, dt)
        p = np.abs(np.fft.rfft(a)) ** 2
        band = (f > 0.5) & (f < 10)
        cents.append(np.sum(f[band] * p[band]) / np.sum(p[band]))
    assert 1.0 < np.mean(cents) < 5.0


def test_processing_scales_pga_and_splits_outcrop():
    rec = SyntheticModel(seed=3, dt=0.005).generate()
    m = process(rec, duration=10.0, cutoff=20.0, baseline=True, pga=1.575, vertical_ratio=2 / 3,
                convention="outcrop")
    # outcrop record = 2 x incident at the base of a half-space
    assert np.max(np.abs(2 * m.ax)) == pytest.approx(1.575, rel=1e-12)
    np.testing.assert_allclose(m.az, 2 / 3 * m.ax, rtol=1e-12)
    assert m.ax.size == int(10.0 / 0.005) + 1
    m2 = process(rec, duration=None, cutoff=20.0, baseline=False, pga=1.0, vertical_ratio=0.5,
                 convention="incident")
    assert np.max(np.abs(m2.ax)) == pytest.approx(1.0, rel=1e-12)


def test_too_short_a_record_for_the_lowpass_is_refused_with_the_fix():
    """sosfiltfilt needs more samples than its pad (3 x (2 sections + 1) = 15 for order 4): a
    shorter record is refused naming the fewest samples that work (a case's record is refused
    earlier, by motion.check_window, with the case key that applies: test_one_validation_path.py)."""
    from tunnelquake.motion import MotionError, lowpass, lowpass_min_samples

    assert lowpass_min_samples() == 16
    with pytest.raises(MotionError, match=r"needs at least 16\. Fix: give at least 16 samples \(0\.3 s at this step\)"):
        lowpass(np.ones(2), 0.02, 20.0)
    out = lowpass(np.ones(16), 0.02, 5.0)  # 16 > 15 samples: filtered; a constant stays constant
    np.testing.assert_allclose(out, 1.0, rtol=1e-9)
