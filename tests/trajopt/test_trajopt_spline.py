"""Splines through waypoints against scipy and per-segment polynomial references."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline, make_interp_spline

from taskspace.errors import (
    InvalidInputError,
    NotFiniteError,
    ShapeError,
    UnknownNameError,
)
from taskspace.trajopt.spline import cubic_spline, quintic_spline


def _data(seed, m=9, n=3):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.1, 2.0, m)) - 0.5
    q = rng.normal(size=(m, n))
    return t, q


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("bc", ["natural", "clamped"])
def test_cubic_matches_scipy(seed, bc):
    t, q = _data(seed)
    spl = cubic_spline(q, t, boundary=bc)
    ref = CubicSpline(t, q, bc_type=bc)
    tt = np.linspace(t[0], t[-1], 2001)
    for k in range(4):
        scale = max(1.0, np.abs(ref(tt, k)).max())
        np.testing.assert_allclose(spl.evaluate(tt, k), ref(tt, k), atol=1e-10 * scale)


def test_cubic_clamped_with_end_velocities_matches_scipy():
    t, q = _data(4, m=6, n=2)
    v0, v1 = np.array([1.0, -2.0]), np.array([0.5, 3.0])
    spl = cubic_spline(q, t, boundary="clamped", start_velocity=v0, end_velocity=v1)
    ref = CubicSpline(t, q, bc_type=((1, v0), (1, v1)))
    tt = np.linspace(t[0], t[-1], 1001)
    for k in range(3):
        np.testing.assert_allclose(spl.evaluate(tt, k), ref(tt, k), atol=1e-9)


def test_cubic_two_points_and_one_joint():
    spl = cubic_spline([0.0, 2.0], [0.0, 1.0])  # natural through two points is a line
    np.testing.assert_allclose(spl.evaluate([0.0, 0.25, 1.0])[:, 0], [0.0, 0.5, 2.0])
    np.testing.assert_allclose(spl.velocity(0.3), [2.0])


def _knot_jumps(spl, order):
    inner = spl.knots[1:-1]
    left = spl.evaluate(inner, order, side="left")
    right = spl.evaluate(inner, order, side="right")
    return np.abs(left - right).max()


@pytest.mark.parametrize(
    "make",
    [
        lambda t, q: cubic_spline(q, t, boundary="natural"),
        lambda t, q: cubic_spline(q, t, boundary="clamped"),
        lambda t, q: quintic_spline(q, t),
        lambda t, q: quintic_spline(q, t, start_velocity=1.0, end_acceleration=-2.0),
        lambda t, q: quintic_spline(q, t, velocities=np.sin(q), accelerations=np.cos(3 * q)),
    ],
    ids=["cubic-natural", "cubic-clamped", "quintic-c4", "quintic-c4-ends", "quintic-hermite"],
)
def test_continuity_to_stated_order(make):
    t, q = _data(7)
    spl = make(t, q)
    np.testing.assert_allclose(spl.waypoints, q, atol=1e-12)
    for order in range(spl.continuity + 1):
        scale = max(1.0, np.abs(spl.evaluate(t, order)).max())
        assert _knot_jumps(spl, order) <= 1e-9 * scale, f"derivative {order} jumps"
    # the next derivative does jump (shows the check can fail)
    assert _knot_jumps(spl, spl.continuity + 1) > 1e-3


def test_quintic_c4_matches_scipy_degree5_interpolant():
    t, q = _data(3, m=8, n=2)
    v0, a0 = np.array([1.0, 0.0]), np.array([0.0, -1.0])
    v1, a1 = np.array([0.0, 2.0]), np.array([0.5, 0.0])
    spl = quintic_spline(
        q,
        t,
        start_velocity=v0,
        start_acceleration=a0,
        end_velocity=v1,
        end_acceleration=a1,
    )
    ref = make_interp_spline(t, q, k=5, bc_type=([(1, v0), (2, a0)], [(1, v1), (2, a1)]))
    tt = np.linspace(t[0], t[-1], 2001)
    for k in range(5):
        scale = max(1.0, np.abs(ref(tt, k)).max())
        np.testing.assert_allclose(spl.evaluate(tt, k), ref(tt, k), atol=1e-8 * scale)


def test_quintic_hermite_matches_segment_polynomials():
    t, q = _data(5, m=5, n=2)
    rng = np.random.default_rng(11)
    v = rng.normal(size=q.shape)
    a = rng.normal(size=q.shape)
    spl = quintic_spline(q, t, velocities=v, accelerations=a)
    for k in range(len(t) - 1):
        h = t[k + 1] - t[k]
        # reference: the degree-5 polynomial with the 6 end conditions, in local time
        M = np.array(
            [
                [1, 0, 0, 0, 0, 0],
                [0, 1, 0, 0, 0, 0],
                [0, 0, 2, 0, 0, 0],
                [1, h, h**2, h**3, h**4, h**5],
                [0, 1, 2 * h, 3 * h**2, 4 * h**3, 5 * h**4],
                [0, 0, 2, 6 * h, 12 * h**2, 20 * h**3],
            ]
        )
        tau = np.linspace(0, h, 17)
        for j in range(2):
            c = np.linalg.solve(
                M, [q[k, j], v[k, j], a[k, j], q[k + 1, j], v[k + 1, j], a[k + 1, j]]
            )
            poly = np.polynomial.Polynomial(c)
            for order in range(4):
                # segment k owns [t_k, t_k+1]: right limit at t_k, left limits after it
                got = np.concatenate(
                    [
                        spl.evaluate(t[k : k + 1], order)[:, j],
                        spl.evaluate(np.r_[t[k] + tau[1:-1], t[k + 1]], order, side="left")[:, j],
                    ]
                )
                np.testing.assert_allclose(got, poly.deriv(order)(tau), atol=1e-8)
    np.testing.assert_allclose(spl.evaluate(t, 1, side="left")[1:], v[1:], atol=1e-10)
    np.testing.assert_allclose(spl.evaluate(t, 2)[:-1], a[:-1], atol=1e-9)


def test_spline_errors():
    t, q = _data(0, m=4, n=2)
    bad = q.copy()
    bad[2, 1] = np.nan
    with pytest.raises(NotFiniteError, match=r"waypoints has non-finite .* indices \[5\]"):
        cubic_spline(bad, t)
    with pytest.raises(ShapeError, match=r"knots must have shape \(4,\), got \(3,\)"):
        cubic_spline(q, t[:3])
    with pytest.raises(InvalidInputError, match="knots must be strictly increasing"):
        cubic_spline(q, t[::-1])
    with pytest.raises(InvalidInputError, match="at least 2 points"):
        cubic_spline(q[:1], t[:1])
    with pytest.raises(UnknownNameError, match="valid boundary conditions are: clamped, natural"):
        cubic_spline(q, t, boundary="periodic")
    with pytest.raises(InvalidInputError, match="only used with boundary='clamped'"):
        cubic_spline(q, t, start_velocity=1.0)
    with pytest.raises(ShapeError, match=r"start_velocity must have shape \(2,\)"):
        cubic_spline(q, t, boundary="clamped", start_velocity=[1.0, 2.0, 3.0])
    with pytest.raises(InvalidInputError, match="give both velocities and accelerations"):
        quintic_spline(q, t, velocities=q)
    with pytest.raises(ShapeError, match=r"accelerations must have shape \(4, 2\)"):
        quintic_spline(q, t, velocities=q, accelerations=q[:3])
    with pytest.raises(UnknownNameError, match="valid sides are: left, right"):
        cubic_spline(q, t).evaluate(t, side="middle")
