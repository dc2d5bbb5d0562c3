"""The coupler's per-field convergence measure with absolute floors (convergenceMeasure,
coupler/include/tq/coupler/scheme.hpp, through its Python module): the relative residual alone
without a floor, and the floor ending the iteration of a field of round-off noise."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tunnelquake.coupling import convergence_measure


def test_relative_test_alone_without_a_floor():
    a = np.array([1.0, 2.0, 3.0, 4.0])
    b = a + np.array([0.0, 0.0, 0.0, 1e-3])
    rel = float(np.linalg.norm(a - b) / np.linalg.norm(a))
    assert convergence_measure(a, b, [(0, 4, 0.0)], 1e-4) == rel


def test_noise_converges_by_the_floor_and_each_field_counts_alone():
    rng = np.random.default_rng(7)
    noise_a, noise_b = 1e-15 * rng.standard_normal(6), 1e-15 * rng.standard_normal(6)
    # field 0 (6 values): round-off noise, relative change O(1), below its floor of 1e-12;
    # field 1 (3 values): large values converged relatively (1e-6 < tolerance 1e-4)
    big = np.array([10.0, 20.0, 30.0])
    a = np.concatenate([noise_a, big])
    b = np.concatenate([noise_b, big * (1 + 1e-6)])
    tol = 1e-4
    no_floor = convergence_measure(a, b, [(0, 6, 0.0), (6, 3, 0.0)], tol)
    assert no_floor > 0.1  # noise never converges relatively
    m = convergence_measure(a, b, [(0, 6, 1e-12), (6, 3, 0.0)], tol)
    rms0 = math.sqrt(float(np.sum((noise_a - noise_b) ** 2)) / 6)
    assert m == pytest.approx(max(tol * rms0 / 1e-12, 1e-6), rel=1e-9)
    assert m < tol

