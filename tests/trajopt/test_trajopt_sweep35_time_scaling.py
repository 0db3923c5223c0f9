"""time_parametrize on limits and path parameters far from 1 (sweep35).

References: the analytic time-optimal (bang-coast-bang) timing of a straight joint-space line
under velocity and acceleration limits, and the time-scaling / reparametrization invariances
of the optimal timing (q(s) on [0, L] is the path q(s / L) on [0, 1]; limits (c v, c^2 a) give
the timing divided by c).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.trajopt import (
    CallablePath,
    TimeParametrizationOptions,
    TimeParametrizationStatus,
    time_parametrize,
)

D = np.array([2.0, -1.0, 0.5])
GRID = TimeParametrizationOptions(grid_points=2000)


def _line(length: float) -> CallablePath:
    """q(s) = (s / length) D on [0, length]: the straight line from 0 to D."""

    def path(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = np.asarray(s)
        m = len(s)
        return s[:, None] * (D / length), np.tile(D / length, (m, 1)), np.zeros((m, 3))

    return CallablePath(path, 0.0, length)


def _line_duration(v: float, a: float) -> float:
    """Time-optimal rest-to-rest duration along the line q = s D, s in [0, 1]."""
    vs = min(v / abs(d) for d in D)  # largest path velocity [1/s]
    acc = min(a / abs(d) for d in D)  # largest path acceleration [1/s^2]
    if vs < math.sqrt(acc):  # vs^2 / acc < 1 (vs^2 overflows for v = 1e300)
        return 1.0 / vs + vs / acc  # accelerate, coast at vs, brake
    return 2.0 * math.sqrt(1.0 / acc)  # accelerate to the middle, brake


@pytest.mark.parametrize(
    ("v", "a"), [(1e200, 1.0), (1e300, 1e-10), (1e300, 1e200), (1e100, 1e-200)]
)
def test_straight_line_without_velocity_limit(v: float, a: float) -> None:
    # A velocity limit that never binds (1e200: "no limit"): only the acceleration counts.
    # The time scale was the mean of the two limits' (the acceleration's was missing on a
    # straight path): a scaled to 0, every segment stuck, reported INFEASIBLE.
    r = time_parametrize(_line(1.0), v, a, options=GRID)
    assert r.status is TimeParametrizationStatus.SUCCESS
    assert r.duration == pytest.approx(_line_duration(v, a), rel=1e-3)


def test_curved_path_tiny_velocity_huge_acceleration() -> None:
    # v = 1e-300 binds, a = 1e300 does not: the timing is the velocity-only one / v
    # (INFEASIBLE before: a scaled past the floats)
    waypoints = np.array([[0, 0, 0], [1, 2, -1], [2, 1, 0.5], [0.5, -1, 2]], float)
    opts = TimeParametrizationOptions(grid_points=300)
    velocity_only = time_parametrize(waypoints, 1.0, 1e30, options=opts).duration
    r = time_parametrize(waypoints, 1e-300, 1e300, options=opts)
    assert r.status is TimeParametrizationStatus.SUCCESS
    assert r.duration == pytest.approx(velocity_only / 1e-300, rel=1e-9)


@pytest.mark.parametrize("length", [1e-300, 1e-200, 1e200, 1e300])
def test_path_parameter_range_does_not_change_the_timing(length: float) -> None:
    # The same line with s in [0, length]: q' = D / length. On [0, 1e-200] the products
    # q' u overflowed and it returned SUCCESS 2.002 s instead of 2.5 s; on [0, 1e200]
    # INFEASIBLE.
    unit = time_parametrize(_line(1.0), 1.0, 2.0, options=GRID)
    r = time_parametrize(_line(length), 1.0, 2.0, options=GRID)
    assert r.status is TimeParametrizationStatus.SUCCESS
    assert unit.duration == pytest.approx(_line_duration(1.0, 2.0), rel=1e-6)
    assert r.duration == pytest.approx(unit.duration, rel=1e-12)
    np.testing.assert_allclose(r.times, unit.times, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r.qd, unit.qd, atol=1e-12)
    np.testing.assert_allclose(r.qdd, unit.qdd, atol=1e-12)
    # path rates in the units of s: ds/dt = length * dw/dt
    np.testing.assert_allclose(r.s_dot / length, unit.s_dot, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r.s_ddot / length, unit.s_ddot, rtol=1e-12, atol=1e-12)
    sample, unit_sample = r.sample(0.05), unit.sample(0.05)
    np.testing.assert_allclose(sample.q, unit_sample.q, atol=1e-12)
    np.testing.assert_allclose(sample.qd, unit_sample.qd, atol=1e-12)
    np.testing.assert_allclose(sample.qdd, unit_sample.qdd, atol=1e-12)


def test_start_and_end_path_velocities_on_a_short_parameter_range() -> None:
    # start / end path velocities are in the units of s: 0.5 (per unit range) * length
    length = 2.0**-700
    opts = TimeParametrizationOptions(
        grid_points=2000, start_path_velocity=0.5 * length, end_path_velocity=0.5 * length
    )
    r = time_parametrize(_line(length), 1.0, 2.0, options=opts)
    assert r.status is TimeParametrizationStatus.SUCCESS
    # from 0.5 to 0.5 (path velocity per unit range) with vs = 0.5, acc = 1: coast at 0.5
    assert r.duration == pytest.approx(2.0, rel=1e-9)
    np.testing.assert_allclose(r.s_dot[[0, -1]], [0.5 * length, 0.5 * length], rtol=1e-12)
