"""Motion profiles (slides 2:32-2:34) against analytic formulas and an LP reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import linprog

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, UnknownNameError
from taskspace.trajopt.motion_profile import (
    MinimumJerkProfile,
    RampProfile,
    SCurveProfile,
    SineProfile,
    SyncMode,
    TrapezoidalProfile,
    plan_motion,
    profile_for_limits,
    synchronize,
)

S = np.linspace(0.0, 1.0, 100_001)
TOL = 1e-9

SHAPES = [
    RampProfile(),
    SineProfile(),
    MinimumJerkProfile(),
    TrapezoidalProfile(0.5),
    TrapezoidalProfile(0.2),
    SCurveProfile(0.125, 0.25),
    SCurveProfile(0.05, 0.4),
    SCurveProfile(0.25, 0.5),
]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda p: f"{p.name}")
def test_boundary_values_and_monotone(shape):
    assert abs(shape.position(0.0) - 0.0) < TOL
    assert abs(shape.position(1.0) - 1.0) < TOL
    p = shape.position(S)
    assert np.all(np.diff(p) >= -TOL)
    assert p.min() >= -TOL and p.max() <= 1.0 + TOL


@pytest.mark.parametrize("shape", SHAPES[1:], ids=lambda p: f"{p.name}")
def test_derivatives_match_finite_differences(shape):
    # reference: central differences of the position (away from the segment breaks)
    s = np.linspace(0.013, 0.987, 157)
    breaks = getattr(shape, "breaks", np.array([]))
    if breaks.size:
        s = s[np.min(np.abs(s[:, None] - breaks[None, :]), axis=1) > 1e-3]
    h = 1e-5
    for order in (1, 2, 3):
        fd = (shape.derivative(s + h, order - 1) - shape.derivative(s - h, order - 1)) / (2 * h)
        scale = max(1.0, np.abs(fd).max())
        np.testing.assert_allclose(shape.derivative(s, order), fd, atol=1e-5 * scale)


def test_rest_to_rest_profiles_start_and_end_at_rest():
    for shape in SHAPES[2:]:
        for s in (0.0, 1.0):
            assert abs(shape.velocity(s)) < TOL
    for shape in (MinimumJerkProfile(), *SHAPES[5:]):
        for s in (0.0, 1.0):
            assert abs(shape.acceleration(s)) < 1e-8


def test_sine_matches_slide_formula():
    np.testing.assert_allclose(SineProfile().position(S), 0.5 * (1 - np.cos(np.pi * S)), atol=TOL)


def test_minimum_jerk_is_the_quintic_with_rest_boundary_conditions():
    # reference: solve the 6 boundary conditions for a quintic directly
    A = np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 2, 0, 0, 0],
            [1, 1, 1, 1, 1, 1],
            [0, 1, 2, 3, 4, 5],
            [0, 0, 2, 6, 12, 20],
        ],
        dtype=float,
    )
    c = np.linalg.solve(A, [0, 0, 0, 1, 0, 0])
    poly = np.polynomial.Polynomial(c)
    prof = MinimumJerkProfile()
    for k in range(4):
        np.testing.assert_allclose(prof.derivative(S, k), poly.deriv(k)(S), atol=1e-9)
    pv, pa, pj = prof.peaks
    assert pv == pytest.approx(np.abs(poly.deriv(1)(S)).max(), rel=1e-9)
    assert pa == pytest.approx(np.abs(poly.deriv(2)(S)).max(), rel=1e-6)
    assert pj == pytest.approx(np.abs(poly.deriv(3)(S)).max(), rel=1e-9)


LIMIT_CASES = [
    # distance, v, a, j
    (10.0, 2.0, 1.0, 1.0),
    (1.0, 10.0, 10.0, 1.0),
    (5.0, 1.0, 10.0, 1.0),
    (4.0, 10.0, 1.0, 1.0),
    (0.3, 1.5, 4.0, 50.0),
    (-2.0, 1.0, 3.0, 20.0),
]


@pytest.mark.parametrize("name", ["ramp", "sine", "trapezoidal", "minimum_jerk", "scurve"])
@pytest.mark.parametrize("case", LIMIT_CASES)
def test_physical_motion_respects_limits_and_one_is_tight(name, case):
    d, v, a, j = case
    motion = plan_motion(1.0, 1.0 + d, v, a, j, profile=name)
    t = np.linspace(0.0, motion.duration, 200_001)
    smp = motion.evaluate(t)
    assert smp.position[0] == pytest.approx(1.0, abs=TOL)
    assert smp.position[-1] == pytest.approx(1.0 + d, abs=TOL)
    ratios = [np.abs(smp.velocity).max() / v]
    if name != "ramp":
        ratios.append(np.abs(smp.acceleration).max() / a)
    if name in ("sine", "minimum_jerk", "scurve"):
        ratios.append(np.abs(smp.jerk).max() / j)
    assert max(ratios) <= 1.0 + TOL
    # shortest duration for the shape: some limit is reached
    assert max(ratios) >= 0.999


@pytest.mark.parametrize(
    ("case", "expected"),
    [
        ((10.0, 2.0, 1.0, 1.0), 8.0),  # all limits reached: Tj=1, Ta=3, Tv=2
        ((5.0, 1.0, 10.0, 1.0), 7.0),  # a_max not reached: Tj=1, Ta=2, Tv=3
        ((1.0, 10.0, 10.0, 1.0), 4.0 * 0.5 ** (1.0 / 3.0)),  # neither v nor a reached
        ((4.0, 10.0, 1.0, 1.0), 1.0 + math.sqrt(17.0)),  # v_max not reached, a_max reached
    ],
)
def test_scurve_duration_analytic_cases(case, expected):
    _, duration = SCurveProfile.for_limits(*case)
    assert duration == pytest.approx(expected, rel=1e-12)


def test_trapezoidal_duration_analytic_cases():
    assert TrapezoidalProfile.for_limits(10.0, 2.0, 1.0)[1] == pytest.approx(7.0)  # 10/2 + 2/1
    assert TrapezoidalProfile.for_limits(1.0, 2.0, 1.0)[1] == pytest.approx(2.0)  # 2 sqrt(1/1)


def _triple_integrator_feasible(T, d, v, a, j, n=160):
    """LP reference: piecewise-constant jerk on n steps reaching d at rest within limits."""
    h = T / n
    # state after step k is linear in the jerk sequence: x = sum_i G[k, i] jerk_i
    P = np.zeros((n, n))
    V = np.zeros((n, n))
    A = np.zeros((n, n))
    for k in range(n):
        for i in range(k + 1):
            r = (k - i) * h  # time from end of step i to end of step k
            A[k, i] = h
            V[k, i] = h * r + h * h / 2
            P[k, i] = h * r * r / 2 + h * h * r / 2 + h**3 / 6
    A_ub = np.vstack([V, -V, A, -A])
    b_ub = np.concatenate([np.full(2 * n, v), np.full(2 * n, a)])
    A_eq = np.vstack([P[-1], V[-1], A[-1]])
    res = linprog(
        np.zeros(n), A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=[d, 0, 0], bounds=[(-j, j)] * n
    )
    return res.status == 0


@pytest.mark.parametrize("case", LIMIT_CASES[:4])
def test_scurve_is_time_optimal_against_lp_reference(case):
    d, v, a, j = case
    _, T = SCurveProfile.for_limits(d, v, a, j)
    assert _triple_integrator_feasible(1.03 * T, d, v, a, j)
    assert not _triple_integrator_feasible(0.97 * T, d, v, a, j)


def test_scurve_degenerate_limits_report_reached_peaks():
    # a not reached: peak acceleration = sqrt(v j) < a
    prof, T = SCurveProfile.for_limits(5.0, 1.0, 10.0, 1.0)
    assert prof.peaks[1] * 5.0 / T**2 == pytest.approx(1.0, rel=1e-12)
    # v not reached: peak velocity (-a^2/j + sqrt(a^4/j^2 + 4 d a)) / 2
    prof, T = SCurveProfile.for_limits(4.0, 10.0, 1.0, 1.0)
    assert prof.peaks[0] * 4.0 / T == pytest.approx((-1 + math.sqrt(17.0)) / 2, rel=1e-12)


@pytest.mark.parametrize("mode", ["straight_line", "time_scaled"])
@pytest.mark.parametrize("name", ["sine", "trapezoidal", "minimum_jerk", "scurve"])
def test_synchronized_joints_arrive_together_within_limits(mode, name):
    q0 = np.array([0.0, 1.0, -0.5, 0.2])
    q1 = np.array([1.5, 0.2, -0.5, 2.0])
    v = np.array([1.0, 0.5, 1.0, 2.0])
    a = np.array([2.0, 3.0, 1.0, 1.0])
    j = np.array([10.0, 5.0, 10.0, 20.0])
    m = synchronize(q0, q1, v, a, j, profile=name, mode=mode)
    own = [profile_for_limits(name, q1[i] - q0[i], v[i], a[i], j[i])[1] for i in range(4)]
    assert m.duration >= max(own) - 1e-12
    if mode == "time_scaled":
        assert m.duration == pytest.approx(max(own))
    t = np.linspace(0.0, m.duration, 50_001)
    smp = m.evaluate(t)
    np.testing.assert_allclose(smp.position[0], q0, atol=TOL)
    np.testing.assert_allclose(smp.position[-1], q1, atol=TOL)
    np.testing.assert_allclose(smp.velocity[-1], 0.0, atol=1e-9)
    assert np.all(np.abs(smp.velocity) <= v * (1 + TOL))
    assert np.all(np.abs(smp.acceleration) <= a * (1 + TOL))
    if name in ("sine", "minimum_jerk", "scurve"):
        assert np.all(np.abs(smp.jerk) <= j * (1 + TOL))
    assert np.all(smp.position[:, 2] == -0.5)  # the joint that does not move stays
    # every moving joint is still moving until the end (arrive together)
    late = smp.position[t > 0.98 * m.duration]
    moving = np.abs(q1 - q0) > 0
    assert np.all(np.abs(late[0, moving] - q1[moving]) > 0)
    if mode == "straight_line":
        # q(t) - q0 stays parallel to q1 - q0 (slide 2:34)
        d = q1 - q0
        lam = (smp.position - q0) @ d / (d @ d)
        np.testing.assert_allclose(smp.position, q0 + lam[:, None] * d, atol=1e-9)


def test_synchronize_straight_line_is_optimal_for_common_shape():
    # trapezoid along a line: common normalized limits v_s = min v_i/|d_i|, a_s = min a_i/|d_i|
    q0, q1 = np.zeros(2), np.array([2.0, 1.0])
    v, a = np.array([1.0, 1.0]), np.array([1.0, 4.0])
    m = synchronize(q0, q1, v, a, profile="trapezoidal")
    vs, as_ = min(1 / 2, 1 / 1), min(1 / 2, 4 / 1)
    assert m.duration == pytest.approx(1 / vs + vs / as_)


def test_errors_have_clear_messages():
    with pytest.raises(UnknownNameError, match="valid motion profiles are: minimum_jerk"):
        plan_motion(0, 1, 1, 1, 1, profile="cubic")
    with pytest.raises(InvalidInputError, match="max_velocity must be finite and > 0"):
        plan_motion(0, 1, 0.0, 1, 1)
    with pytest.raises(InvalidInputError, match="max_acceleration must be finite and > 0"):
        plan_motion(0, 1, 1.0, -1.0, 1)
    with pytest.raises(InvalidInputError, match="profile 'scurve' needs max_jerk"):
        plan_motion(0, 1, 1.0, 1.0)
    with pytest.raises(NotFiniteError, match="non-finite"):
        plan_motion(0, float("nan"), 1.0, 1.0, 1.0)
    with pytest.raises(ShapeError, match=r"goal must have shape \(3,\), got \(2,\)"):
        synchronize([0, 0, 0], [1, 1], 1.0, 1.0, 1.0)
    with pytest.raises(InvalidInputError, match=r"max_jerk must be > 0 for every joint; .*\[1\]"):
        synchronize([0, 0], [1, 1], 1.0, 1.0, [1.0, 0.0])
    with pytest.raises(NotFiniteError, match="start has non-finite"):
        synchronize([0, np.nan], [1, 1], 1.0, 1.0, 1.0)
    with pytest.raises(UnknownNameError, match="valid sync modes are"):
        synchronize([0], [1], 1.0, 1.0, 1.0, mode="fastest")
    with pytest.raises(InvalidInputError, match="accel_fraction must be in"):
        TrapezoidalProfile(0.7)
    with pytest.raises(InvalidInputError, match="S-curve fractions"):
        SCurveProfile(0.3, 0.4)


def test_zero_motion_has_zero_duration():
    m = synchronize([1.0, 2.0], [1.0, 2.0], 1.0, 1.0, 1.0, mode=SyncMode.STRAIGHT_LINE)
    assert m.duration == 0.0
    smp = m.evaluate([0.0, 1.0])
    np.testing.assert_allclose(smp.position, [[1, 2], [1, 2]])
    np.testing.assert_allclose(smp.velocity, 0.0)
