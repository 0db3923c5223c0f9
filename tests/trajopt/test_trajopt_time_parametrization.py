"""Time-optimal path parametrization against analytic bang-bang solutions and brute force DP.

Tolerances: limits hold at the grid points to 1e-9 (relative). Between grid points (dense
sampling of the constant-``sddot`` reconstruction) they hold to 3 % with 100 grid points.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, UnknownNameError
from taskspace.trajopt.spline import cubic_spline
from taskspace.trajopt.time_parametrization import (
    CallablePath,
    TimeParametrizationOptions,
    TimeParametrizationStatus,
    time_parametrize,
)

GRID_TOL = 1e-9
DENSE_TOL = 0.03
VMAX7 = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
AMAX7 = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])


def _line(d):
    d = np.atleast_1d(np.asarray(d, dtype=float))

    def f(s):
        return s[:, None] * d, np.ones((s.size, 1)) * d, np.zeros((s.size, d.size))

    return CallablePath(f)


def _curve(s):
    """A 2-DoF curved path q(s) on [0, 1] with analytic derivatives."""
    w = 2.0 * np.pi
    q = np.stack([np.sin(w * s) * 0.6 + s, 0.8 * s**2 - 0.3 * np.cos(w * s)], axis=1)
    dq = np.stack([w * np.cos(w * s) * 0.6 + 1.0, 1.6 * s + 0.3 * w * np.sin(w * s)], axis=1)
    ddq = np.stack([-(w**2) * np.sin(w * s) * 0.6, 1.6 + 0.3 * w**2 * np.cos(w * s)], axis=1)
    return q, dq, ddq


def _random_waypoints(seed=1, m=10, n=7):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (m, n))


@pytest.mark.parametrize(
    ("length", "v", "a"),
    [(2.0, 1.0, 2.0), (0.2, 1.0, 2.0), (3.0, 0.5, 0.4)],
)
def test_one_dof_line_is_the_bang_bang_trapezoid(length, v, a):
    # analytic optimum: trapezoid L/v + v/a if L >= v^2/a, else triangle 2 sqrt(L/a)
    expected = length / v + v / a if length >= v * v / a else 2.0 * np.sqrt(length / a)
    res = time_parametrize(_line(length), v, a)
    assert res.success
    assert expected * (1 - 1e-9) <= res.duration <= 1.02 * expected
    assert np.abs(res.qd).max() <= v * (1 + GRID_TOL)
    assert np.abs(res.qdd).max() <= a * (1 + GRID_TOL)
    # active sets: accelerating at the start, and cruising when the trapezoid has a plateau
    assert res.active_acceleration[0, 0]
    assert res.active_velocity[:, 0].any() == (length > v * v / a * 1.05)


def test_two_dof_straight_line_matches_synchronized_trapezoid():
    d = np.array([2.0, -1.0])
    v, a = np.array([1.0, 1.0]), np.array([1.0, 4.0])
    vs, as_ = np.min(v / np.abs(d)), np.min(a / np.abs(d))
    expected = 1.0 / vs + vs / as_
    res = time_parametrize(_line(d), v, a)
    assert expected * (1 - 1e-9) <= res.duration <= 1.02 * expected


def _dp_reference(path_fn, v, a, n_grid=241, n_levels=401):
    """Brute-force time-optimal DP on a grid of s and sdot^2 levels (rest to rest).

    Transition x_i -> x_j on [s_k, s_k+1] uses u = (x_j - x_i) / (2 ds), checks the velocity
    limits at both points and the acceleration limits at both ends of the segment, and costs
    2 ds / (sqrt(x_i) + sqrt(x_j)).
    """
    s = np.linspace(0.0, 1.0, n_grid)
    _, dq, ddq = path_fn(s)
    ds = s[1] - s[0]
    xv = np.min((v / np.maximum(np.abs(dq), 1e-12)) ** 2, axis=1)
    # levels uniform in sdot (dense near rest), up to the largest velocity-limited sdot
    levels = np.linspace(0.0, np.sqrt(min(xv.max(), 100.0)), n_levels) ** 2
    cost = np.full(n_levels, np.inf)
    cost[0] = 0.0
    xi, xj = levels[:, None], levels[None, :]
    u = (xj - xi) / (2 * ds)
    with np.errstate(divide="ignore"):
        step = 2 * ds / (np.sqrt(xi) + np.sqrt(xj))
    for k in range(n_grid - 1):
        ok = (xi <= xv[k]) & (xj <= xv[k + 1])
        for i in range(dq.shape[1]):
            ok &= np.abs(dq[k, i] * u + ddq[k, i] * xi) <= a[i]
            ok &= np.abs(dq[k + 1, i] * u + ddq[k + 1, i] * xj) <= a[i]
        total = np.where(ok, cost[:, None] + step, np.inf)
        cost = total.min(axis=0)
    return cost[0]


def test_two_dof_curved_path_matches_brute_force_dp():
    v, a = np.array([1.0, 1.5]), np.array([3.0, 2.0])
    reference = _dp_reference(_curve, v, a)
    assert np.isfinite(reference)
    res = time_parametrize(CallablePath(_curve), v, a)
    assert res.success
    assert res.duration <= 1.02 * reference
    # the DP is quantized in sdot and converges from above (3.607 s here, 3.596 s with twice
    # the resolution) while TOPP converges to 3.487 s; a large gap means a wrong constraint
    assert res.duration >= 0.95 * reference
    smp = res.sample(1e-3)
    assert np.all(np.abs(smp.qd) <= v * (1 + DENSE_TOL))
    assert np.all(np.abs(smp.qdd) <= a * (1 + DENSE_TOL))
    # finer grid converges to the same optimum
    fine = time_parametrize(
        CallablePath(_curve), v, a, options=TimeParametrizationOptions(grid_points=400)
    )
    assert fine.duration <= 1.02 * reference


@pytest.mark.parametrize("disc", ["interpolation", "collocation"])
def test_seven_dof_limits_hold_at_grid_points(disc):
    res = time_parametrize(
        _random_waypoints(),
        VMAX7,
        AMAX7,
        options=TimeParametrizationOptions(discretization=disc),
    )
    assert res.success
    assert np.all(np.abs(res.qd) <= VMAX7 * (1 + GRID_TOL))
    assert np.all(np.abs(res.qdd) <= AMAX7 * (1 + GRID_TOL))
    assert np.all(np.diff(res.times) > 0)
    # the time-optimal solution saturates some limit at (almost) every grid point inside
    active = res.active_velocity | res.active_acceleration
    assert active[1:-1].any(axis=1).mean() > 0.7


def test_seven_dof_dense_samples_within_stated_tolerance():
    res = time_parametrize(_random_waypoints(), VMAX7, AMAX7)
    smp = res.sample(1e-3)
    assert np.all(np.abs(smp.qd) <= VMAX7 * (1 + DENSE_TOL))
    assert np.all(np.abs(smp.qdd) <= AMAX7 * (1 + DENSE_TOL))
    np.testing.assert_allclose(smp.q[0], _random_waypoints()[0], atol=1e-12)
    np.testing.assert_allclose(smp.q[-1], _random_waypoints()[-1], atol=1e-12)
    np.testing.assert_allclose(smp.qd[[0, -1]], 0.0, atol=1e-12)
    # the samples are consistent: finite differences of q reproduce qd
    fd = np.gradient(smp.q, smp.time, axis=0)
    assert np.abs(fd[1:-1] - smp.qd[1:-1]).max() < 1e-2 * VMAX7.max()


def test_waypoints_spline_and_callable_inputs_agree():
    w = _random_waypoints(3, m=6, n=3)
    spl = cubic_spline(w, boundary="clamped")
    r1 = time_parametrize(w, 1.0, 2.0)
    r2 = time_parametrize(spl, 1.0, 2.0)
    r3 = time_parametrize(lambda s: tuple(spl.evaluate_derivatives(s, 2)), 1.0, 2.0)
    assert r1.duration == pytest.approx(r2.duration, rel=1e-12)
    assert r1.duration == pytest.approx(r3.duration, rel=1e-12)


def test_jerk_limit_slows_down_and_holds():
    w = _random_waypoints(2, m=6, n=3)
    vmax, amax = np.full(3, 2.0), np.full(3, 8.0)
    free = time_parametrize(w, vmax, amax)
    loose = time_parametrize(w, vmax, amax, max_jerk=np.abs(free.qddd).max() * 1.01)
    assert loose.jerk_iterations == 0
    assert loose.duration == pytest.approx(free.duration, rel=1e-12)
    jmax = 60.0
    assert np.abs(free.qddd).max() > jmax  # the limit is binding
    res = time_parametrize(w, vmax, amax, max_jerk=jmax)
    assert res.success and res.jerk_iterations > 0
    assert np.abs(res.qddd).max() <= jmax * (1 + 1e-6)
    assert np.abs(res.qd).max() <= 2.0 * (1 + GRID_TOL)
    assert np.abs(res.qdd).max() <= 8.0 * (1 + GRID_TOL)
    assert res.duration > free.duration


def test_jerk_limit_not_met_is_reported():
    w = _random_waypoints(2, m=6, n=3)
    res = time_parametrize(
        w, 2.0, 8.0, max_jerk=1.0, options=TimeParametrizationOptions(jerk_max_iterations=2)
    )
    assert not res.success
    assert res.status is TimeParametrizationStatus.JERK_LIMIT_NOT_MET


def test_start_and_end_path_velocities():
    opts = TimeParametrizationOptions(start_path_velocity=0.5, end_path_velocity=0.8)
    res = time_parametrize(_line(1.0), 1.0, 1.0, options=opts)
    assert res.success
    assert res.s_dot[0] == pytest.approx(0.5) and res.s_dot[-1] == pytest.approx(0.8)
    # analytic: accelerate 0.5 -> 1, cruise, decelerate 1 -> 0.8 at a = 1
    d_acc, d_dec = (1 - 0.25) / 2, (1 - 0.64) / 2
    expected = 0.5 + (1 - d_acc - d_dec) / 1.0 + 0.2
    assert res.duration == pytest.approx(expected, rel=1e-3)
    # too fast to stop within the path: not controllable
    bad = time_parametrize(
        _line(1.0), 5.0, 1.0, options=TimeParametrizationOptions(start_path_velocity=3.0)
    )
    assert not bad.success and bad.status is TimeParametrizationStatus.INFEASIBLE
    assert bad.duration == float("inf")
    with pytest.raises(InvalidInputError, match="infeasible"):
        bad.sample(0.01)


def test_error_paths():
    w = _random_waypoints(m=4, n=3)
    with pytest.raises(InvalidInputError, match=r"max_velocity must be > 0 for every joint.*\[2\]"):
        time_parametrize(w, [1.0, 1.0, 0.0], 1.0)
    with pytest.raises(InvalidInputError, match="max_acceleration must be > 0"):
        time_parametrize(w, 1.0, -2.0)
    with pytest.raises(ShapeError, match=r"max_acceleration must have shape \(3,\), got \(7,\)"):
        time_parametrize(w, 1.0, AMAX7)
    bad = w.copy()
    bad[1, 1] = np.nan
    with pytest.raises(NotFiniteError, match="waypoints has non-finite"):
        time_parametrize(bad, 1.0, 1.0)
    with pytest.raises(NotFiniteError, match="max_velocity has non-finite"):
        time_parametrize(w, [1.0, np.inf, 1.0], 1.0)
    with pytest.raises(InvalidInputError, match="grid_points must be an integer >= 2"):
        time_parametrize(w, 1.0, 1.0, options=TimeParametrizationOptions(grid_points=1))
    with pytest.raises(UnknownNameError, match="valid discretizations are: collocation"):
        time_parametrize(w, 1.0, 1.0, options=TimeParametrizationOptions(discretization="x"))
    with pytest.raises(InvalidInputError, match="start_path_velocity must be finite and >= 0"):
        time_parametrize(w, 1.0, 1.0, options=TimeParametrizationOptions(start_path_velocity=-1.0))
    with pytest.raises(ShapeError, match="path function output dq/ds"):
        time_parametrize(lambda s: (np.zeros((s.size, 2)), np.zeros((s.size, 3)), 0), 1.0, 1.0)
    with pytest.raises(InvalidInputError, match="must return"):
        time_parametrize(lambda s: None, 1.0, 1.0)
    with pytest.raises(InvalidInputError, match="s_start < s_end"):
        time_parametrize(CallablePath(_curve, s_start=1.0, s_end=0.0), 1.0, 1.0)
