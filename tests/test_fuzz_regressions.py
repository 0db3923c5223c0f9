"""Defects found by running tests/test_fuzz_api.py with thousands of examples, as explicit cases."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from taskspace.errors import TaskspaceError
from taskspace.estimation.consistency import chi2_bounds
from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.process_noise import continuous_white_noise


def test_velocity_motion_model_scalar_control_is_refused() -> None:
    # before: bare IndexError (0-d array indexed)
    model = VelocityMotionModel(dt=0.1)
    with pytest.raises(TaskspaceError, match="u"):
        model.mean(np.array([0.0, 0.0, 0.0]), math.nan)


def test_chi2_bounds_bad_arguments() -> None:
    # before: bare ValueError (truth value of an empty array)
    with pytest.raises(TaskspaceError, match="dof"):
        chi2_bounds(np.array([]), None, None)  # type: ignore[arg-type]
    with pytest.raises(TaskspaceError, match="confidence"):
        chi2_bounds(2, 1, None)  # type: ignore[arg-type]
    lo, hi = chi2_bounds(2, 1, 0.95)
    # reference: chi2(2) is exponential with mean 2, ppf(p) = -2 ln(1 - p)
    assert lo == pytest.approx(-2 * math.log(1 - 0.025))
    assert hi == pytest.approx(-2 * math.log(1 - 0.975))


def test_continuous_white_noise_large_dim() -> None:
    # before: bare OverflowError (factorial too large for a float)
    Q = continuous_white_noise(99, 1.0, 0)
    assert Q.shape == (99, 99)
    assert np.all(Q == 0.0)
    # small dim still matches the closed form [[dt^3/3, dt^2/2], [dt^2/2, dt]] q
    Q2 = continuous_white_noise(2, 0.5, 2.0)
    np.testing.assert_allclose(Q2, 2.0 * np.array([[0.5**3 / 3, 0.5**2 / 2], [0.5**2 / 2, 0.5]]))


def test_angle_residual_refuses_none() -> None:
    # before: bare UFuncTypeError (np.subtract on None with dtype=float64)
    from taskspace.estimation.angles import angle_residual

    with pytest.raises(TaskspaceError, match="a"):
        angle_residual(0)(None, None)  # type: ignore[arg-type]
    d = angle_residual(0)(np.array([3.0, 1.0]), np.array([-3.0, 0.5]))
    np.testing.assert_allclose(d, [6.0 - 2 * math.pi, 0.5])


def test_angle_mean_zero_d_index() -> None:
    # before: bare TypeError (iteration over a 0-d array)
    from taskspace.estimation.angles import angle_mean

    with pytest.raises(TaskspaceError, match="angular"):
        angle_mean(np.array(0.5))  # type: ignore[arg-type]
    with pytest.raises(TaskspaceError):
        angle_mean(np.array(0))(None, None)  # type: ignore[arg-type]


def test_kinematic_car_scalar_control_is_refused() -> None:
    # before: bare IndexError (0-d array indexed)
    from taskspace.estimation.motion_models import KinematicCarModel

    with pytest.raises(TaskspaceError, match="u"):
        KinematicCarModel().mean(np.array([0.0, 0.0, 0.0]), math.nan)


def test_discrete_white_noise_large_dim() -> None:
    # before: bare OverflowError (171! does not fit a float)
    from taskspace.estimation.process_noise import discrete_white_noise

    Q = discrete_white_noise(172, 1.0, 0)
    assert Q.shape == (172, 172) and np.all(Q == 0.0)
    # closed form for dim 2: G = (dt^2/2, dt), Q = var G G^T
    G = np.array([0.5**2 / 2, 0.5])
    np.testing.assert_allclose(discrete_white_noise(2, 0.5, 3.0), 3.0 * np.outer(G, G))


# ---- found by the fuzz tests at 800 examples (lead, stop 16) ----------------------------


def test_spline_refuses_two_dimensional_times():
    from taskspace.errors import InvalidInputError
    from taskspace.trajopt.spline import cubic_spline

    spline = cubic_spline([[0.0, 1.0], [1.0, 0.5], [0.5, 0.0]])
    for t in (np.empty((0, 1)), np.array([[0.1], [0.2]])):
        with pytest.raises(InvalidInputError, match="1-D array of times"):
            spline.evaluate(t)
    assert spline.evaluate(np.array([0.1, 0.2])).shape == (2, 2)
    assert spline.evaluate(np.empty(0)).shape == (0, 2)


def test_snapshot_size_refuses_a_zero_dimensional_array():
    from taskspace.errors import InvalidInputError
    from taskspace.viz.snapshots import check_size

    with pytest.raises(InvalidInputError, match="width, height"):
        check_size(np.array(0.0))
    assert check_size(np.array([640, 480])) == (640, 480)


# ---- plan_motion at extreme scales (D-fuzz) ----------------------------------------------


def test_plan_motion_huge_distance_is_exact() -> None:
    # before: T^3 overflowed (bare OverflowError in evaluate) for d = 3e102, vmax = 1
    from fractions import Fraction

    from taskspace.trajopt import plan_motion

    m = plan_motion(0.0, 3.0e102, 1.0, profile="minimum_jerk")
    # reference: MP = 10 s^3 - 15 s^4 + 6 s^5 peaks at MP'(1/2) = 15/8, so T = 15/8 d / v
    assert m.duration == pytest.approx(15 / 8 * 3.0e102, rel=1e-15)
    s = m.evaluate([0.0, 0.5 * m.duration, m.duration])
    assert s.position.tolist() == [0.0, pytest.approx(1.5e102, rel=1e-15), 3.0e102]
    assert s.velocity[1] == pytest.approx(1.0, rel=1e-12)
    # MP'''(0) = 60: jerk d 60 / T^3, in exact rational arithmetic
    T = Fraction(m.duration)
    assert s.jerk[0] == pytest.approx(float(Fraction(3.0e102) * 60 / T**3), rel=1e-12)


def test_plan_motion_far_from_origin_ends_exactly() -> None:
    # before: the end position was start + 1 * (goal - start) = 0.0 instead of -1
    from taskspace.trajopt import plan_motion

    m = plan_motion(1e30, -1.0, 1.0, profile="minimum_jerk")
    s = m.evaluate([0.0, m.duration])
    assert s.position.tolist() == [1e30, -1.0]


def test_plan_motion_trapezoid_keeps_vmax_when_v_squared_overflows() -> None:
    # before: v^2/a overflowed to inf, the triangular branch was taken and the peak velocity
    # was 1.41e300 > vmax = 1e300 (silently wrong). Reference: scale invariance, the same
    # motion in units 1e300 times larger (d = v = 1, a = 2) has d/v >= v/a, T = d/v + v/a = 1.5
    from taskspace.trajopt import plan_motion

    m = plan_motion(0.0, 1e300, 1e300, 2e300, None, "trapezoidal")
    assert m.duration == pytest.approx(1.5, rel=1e-15)
    s = m.evaluate(np.linspace(0.0, m.duration, 301))
    assert np.abs(s.velocity).max() <= 1e300 * (1 + 1e-12)
    assert np.abs(s.velocity).max() == pytest.approx(1e300, rel=1e-12)


def test_plan_motion_scurve_scale_invariant() -> None:
    # before: bare OverflowError (a**3); the duration does not depend on the length unit
    from taskspace.trajopt import plan_motion

    big = plan_motion(0.0, 1e300, 1e300, 2e300, 1e300, "scurve")
    unit = plan_motion(0.0, 1.0, 1.0, 2.0, 1.0, "scurve")
    # by hand for d = v = j = 1, a = 2: sqrt(v/j) = 1 < a/j, no cruise (d/v < 2), d/a < 2 (a/j)^2
    # so T_j = (d / 2j)^(1/3), T = 4 T_j
    assert unit.duration == pytest.approx(4 * 0.5 ** (1 / 3), rel=1e-14)
    assert big.duration == pytest.approx(unit.duration, rel=1e-14)


@pytest.mark.parametrize(
    ("start", "goal", "vmax", "match"),
    [
        (0.0, 1e308, 1e308, "jerk"),  # peak jerk 60 d / T^3 = 9e308 is not a float64
        (-1e308, 1e308, 1.0, "overflows"),  # goal - start is not a float64
        (0.0, 1e10, 1e-300, "not representable"),  # T = 1.9e310 s
    ],
)
def test_plan_motion_refuses_unrepresentable_motions(
    start: float, goal: float, vmax: float, match: str
) -> None:
    # before: a motion with an inf duration or inf peak rates (evaluate then raised or gave inf)
    from taskspace.errors import InvalidInputError
    from taskspace.trajopt import plan_motion

    with pytest.raises(InvalidInputError, match=match):
        plan_motion(start, goal, vmax, profile="minimum_jerk")


def test_synchronize_far_from_origin_ends_exactly() -> None:
    from taskspace.trajopt import synchronize

    for mode in ("straight_line", "time_scaled"):
        m = synchronize([1e30, 0.0], [-1.0, 2.0], 1.0, 1.0, 1.0, mode=mode)
        s = m.evaluate([0.0, m.duration])
        assert s.position.tolist() == [[1e30, 0.0], [-1.0, 2.0]]


# ---- filters: user callbacks and model outputs (D-fuzz) ----------------------------------


def test_particle_filter_wraps_a_failing_log_likelihood() -> None:
    # before: ParticleFilter.update(None) gave the bare TypeError of the user's function
    from taskspace.errors import CallbackError
    from taskspace.estimation import ParticleFilter

    def loglik(p: np.ndarray, z: float) -> np.ndarray:
        return -0.5 * np.sum((p[:, :1] - z) ** 2, axis=1)

    pf = ParticleFilter(np.zeros((5, 2)), lambda p, u, g: p, loglik, np.random.default_rng(0))
    weights = pf.log_weights.copy()
    with pytest.raises(CallbackError, match="log_likelihood") as info:
        pf.update(None)
    assert isinstance(info.value.__cause__, TypeError)
    assert info.value.callback == "log_likelihood"
    assert np.array_equal(pf.log_weights, weights)  # belief unchanged

    pf2 = ParticleFilter(
        np.zeros((5, 2)), lambda p, u, g: p + float(u), loglik, np.random.default_rng(0)
    )
    with pytest.raises(CallbackError, match="motion_sampler"):
        pf2.predict("u")


@pytest.mark.parametrize("filt", ["ekf", "ukf"])
def test_nonlinear_filter_ragged_model_output(filt: str) -> None:
    # before (EKF): a ragged list returned by h gave a bare ValueError (inhomogeneous array)
    from taskspace.errors import CallbackError, InvalidInputError
    from taskspace.estimation import ExtendedKalmanFilter, UnscentedKalmanFilter

    def h(x: np.ndarray) -> list[list[float]]:
        return [[1.0], [2.0, 3.0]]

    if filt == "ekf":
        kf = ExtendedKalmanFilter(
            lambda x, u=None: x,
            lambda x, u: np.eye(2),
            h,
            lambda x: np.array([[1.0, 0.0]]),
            0.1 * np.eye(2),
            0.2,
            [0.0, 1.0],
            np.eye(2),
        )
    else:
        kf = UnscentedKalmanFilter(
            lambda x, u=None: x, h, 0.1 * np.eye(2), 0.2, [0.0, 1.0], np.eye(2)
        )
    with pytest.raises(InvalidInputError, match="h output"):
        kf.update(math.nan)

    def failing_h(x: np.ndarray) -> np.ndarray:
        raise ZeroDivisionError("boom")

    with pytest.raises(CallbackError, match="h raised ZeroDivisionError: boom"):
        kf.update(
            0.5, h=failing_h, **({"H_jacobian": lambda x: np.eye(1, 2)} if filt == "ekf" else {})
        )
    assert kf.x.tolist() == [0.0, 1.0]


# ---- PID (D-fuzz) --------------------------------------------------------------------------


def test_pid_output_overflow_is_refused_and_state_kept() -> None:
    # before: u = -kd v = -inf returned as a control (silently wrong)
    from taskspace.control import PIDController, PIDGains, PIDOptions
    from taskspace.errors import InvalidInputError

    pid = PIDController(PIDGains(kp=0.0, kd=1e308, ki=1.0), 0.0)
    pid(0.0, 0.0, 0.0)
    with pytest.raises(InvalidInputError, match="overflows"):
        pid(1.0, 1.0, 1e308)
    assert pid.integral.tolist() == [0.0]  # the failed call did not integrate
    # by hand: e = -1 over dt = 1 s, u = kp e + kd (0 - v) + ki e dt = -1e308 * 0.5 - 1
    assert pid(1.0, 1.0, 0.5).tolist() == [-0.5e308 - 1.0]
    # a saturated output is finite: accepted
    sat = PIDController(PIDGains(kp=0.0, kd=1e308), 0.0, options=PIDOptions(output_limit=2.0))
    assert sat(0.0, 0.0, 1e308).tolist() == [-2.0]


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_pid_output_with_an_overflowing_term_is_the_exact_sum() -> None:
    # before: kp e = 2e308 overflowed to +inf: the sum was +inf, clipped to +1, where the exact
    # 2e308 - 1.7e308 - 1.7e308 = -1.4e308 saturates at -1 (SILENTLY WRONG sign); without a
    # limit, a representable 3e307 was refused; RuntimeWarnings at pid.py:187
    from fractions import Fraction

    from taskspace.control import PIDController, PIDGains, PIDOptions
    from taskspace.errors import InvalidInputError

    gains = PIDGains(kp=1e308, kd=1.7e308, ki=1.7e308)
    pid = PIDController(gains, [2.0], options=PIDOptions(output_limit=1.0, anti_windup=False))
    pid(0.0, [2.0], [0.0])  # e = 0: the integral stays 0
    pid.integral[:] = -1.0
    exact = Fraction(1e308) * 2 - Fraction(1.7e308) * 1 - Fraction(1.7e308)  # by hand
    assert exact < 0
    assert pid(0.0, [0.0], [1.0]).tolist() == [-1.0]
    pd = PIDController(PIDGains(kp=1e308, kd=1e308), [2.0])
    by_hand = Fraction(1e308) * 2 - Fraction(1e308) * Fraction(1.7)  # kp e + kd (0 - v)
    assert pd(0.0, [0.0], [1.7]).tolist() == [float(by_hand)]
    # an integral beyond float64 is refused, the state kept
    pi = PIDController(PIDGains(kp=0.0, ki=1e-300), [1e308])
    pi(0.0, [-1e308], [0.0])
    with pytest.raises(InvalidInputError, match="integral overflows"):
        pi(1.0, [-1e308], [0.0])
    assert pi.integral.tolist() == [0.0]


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_plan_motion_overflowing_distance_is_refused_without_a_warning() -> None:
    # before: goal - start = inf raised a RuntimeWarning before the (right) refusal
    from taskspace.errors import InvalidInputError
    from taskspace.trajopt import plan_motion, synchronize

    with pytest.raises(InvalidInputError, match="goal - start overflows"):
        plan_motion(-1e308, 1e308, 1.0, profile="minimum_jerk")
    with pytest.raises(InvalidInputError, match="goal - start overflows"):
        synchronize([-1e308, 0.0], [1e308, 1.0], 1.0)


# ---- features, IK, splines, viewer (D-fuzz, test_fuzz_api at 800 examples) ----------------


def test_joint_limit_penetration_huge_margin_is_finite() -> None:
    # before: value [inf] (the raw terms ~1e308 were summed before dividing by the margin)
    from taskspace.features import JointLimitPenetration
    from tests.conftest import load_robot

    ur5 = load_robot("ur5")
    feature = JointLimitPenetration(ur5, 1e308)
    value = feature.value(ur5.state(ur5.q_default))
    # by hand: every limited joint is within 1e308 of both limits, each side counts
    # (1e308 - |q - limit|) / 1e308 = 1 (to rounding)
    assert value.tolist() == [pytest.approx(2.0 * len(ur5.limited_joints_q), rel=1e-12)]


def test_frame_and_joint_lookup_with_an_unhashable_name() -> None:
    # before: bare TypeError (unhashable type: 'list') from Robot.frame_id
    from taskspace.errors import UnknownNameError
    from taskspace.features import Alignment
    from tests.conftest import load_robot

    ur5 = load_robot("ur5")
    with pytest.raises(UnknownNameError, match=r"unknown frame '\['tool0'\]'"):
        Alignment(ur5, ["tool0"], None, None)  # type: ignore[arg-type]
    with pytest.raises(UnknownNameError, match="unknown joint"):
        ur5.joint_id({"a": 1})  # type: ignore[arg-type]


def test_solve_ik_from_outside_the_limits_ends_inside() -> None:
    # before: q0 with wrist_3 = 10 (limit 2 pi) converged to wrist_3 = 7, outside the limits,
    # reported as success
    from taskspace.features import Position
    from taskspace.ik import solve_ik
    from taskspace.tasks import Task
    from tests.conftest import load_robot

    ur5 = load_robot("ur5")
    target = ur5.state(ur5.q_default).frame_placement(ur5.frame_id("tool0")).translation + 0.05
    task = Task(Position(ur5, "tool0"), target=target)
    result = solve_ik(ur5, [task], np.array([0.0, 0.0, 0.0, 0.0, 0.0, 10.0]))
    assert result.success
    ur5.check_limits(result.q, tolerance=1e-9)
    # independent check of the answer: forward kinematics of the returned q
    reached = ur5.state(result.q).frame_placement(ur5.frame_id("tool0")).translation
    assert np.linalg.norm(reached - target) < 1e-5


def test_spline_far_extrapolation_overflow_is_refused() -> None:
    # before: evaluate(3.9e102) returned [inf, -3.9e102] (silently wrong)
    from taskspace.errors import InvalidInputError
    from taskspace.trajopt import cubic_spline

    spline = cubic_spline([[0.0, 1.0], [1.0, 0.5], [0.5, 0.0]])
    with pytest.raises(InvalidInputError, match="overflows"):
        spline.evaluate(3.913194505524736e102)
    # nearby extrapolation is still given (end polynomial continued): at the knot it is exact
    assert spline.evaluate(1.0).tolist() == pytest.approx([0.5, 0.0], abs=1e-12)


def test_viewer_add_segments_refuses_complex() -> None:
    # before: ComplexWarning (imaginary part silently dropped) or a bare error
    pytest.importorskip("meshcat")
    from taskspace.errors import InvalidInputError
    from taskspace.viz import Viewer
    from tests.conftest import load_robot

    viewer = Viewer(load_robot("ur5"))
    with pytest.raises(InvalidInputError, match="complex"):
        viewer.add_segments("m", np.complex128(1 + 0j))
    with pytest.raises(InvalidInputError, match="complex"):
        viewer.add_segments("m", np.zeros((1, 2, 3)) + 0j)


def test_continuous_white_noise_large_dim_matches_exact_rationals() -> None:
    # before: a double Python loop (38 s for dim 2000, ~30 min at the cap dim 10000: the fuzz
    # run hung in test_estimation_functions), and entries whose 1/(a! b!) underflowed were 0
    from fractions import Fraction

    d, dt, q = 300, 2.0, 1.5
    Q = continuous_white_noise(d, dt, q)
    # reference: Q_ij = q dt^p / ((d-1-i)! (d-1-j)! p), p = 2d - 1 - i - j, in exact rationals
    for i, j in [(0, 0), (299, 299), (299, 119), (150, 160), (250, 10)]:
        p = 2 * d - 1 - i - j
        exact = Fraction(q) * Fraction(dt) ** p
        exact /= math.factorial(d - 1 - i) * math.factorial(d - 1 - j) * p
        assert Q[i, j] == pytest.approx(float(exact), rel=1e-12, abs=0.0), (i, j)
    assert Q[299, 119] > 0.0  # dt^181 / 180! = 1.6e-274: was lost to underflow


@pytest.mark.parametrize("block_size", [1, 2])
def test_white_noise_memory_stays_near_its_result(block_size: int) -> None:
    # before: a second d x d array for the denominators and np.kron(I_1, Q1) copying the
    # result: the peak was 2x the result for one axis (1.6 GB at the cap dim 10000)
    import tracemalloc

    from taskspace.estimation.process_noise import discrete_white_noise

    for make in (continuous_white_noise, discrete_white_noise):
        tracemalloc.start()
        try:
            Q = make(1200 // block_size, 0.01, 1.0, block_size)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert Q.shape == (1200, 1200) and np.isfinite(Q).all()
        # one axis: the result and a block of 256 rows; several: the result and Q1
        assert peak <= 1.3 * Q.nbytes, (make.__name__, peak / Q.nbytes)


@pytest.mark.parametrize(
    ("profile", "args"),
    [("TrapezoidalProfile", (2.2250738585e-313,)), ("SCurveProfile", (1e-200, 2e-200))],
)
def test_profiles_with_subnormal_fractions_are_refused(
    profile: str, args: tuple[float, ...]
) -> None:
    # before: TrapezoidalProfile(2.2e-313).derivative(0) gave NaN (0 * inf); the S-curve gave
    # a bare ZeroDivisionError (t_j (t_a - t_j) (1 - t_a) underflowed to 0)
    from taskspace import trajopt
    from taskspace.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match="too small"):
        getattr(trajopt, profile)(*args)


def test_object_arrays_with_complex_or_text_entries_are_refused() -> None:
    # before: plan_motion(10**30, np.complex128(1 + 0j), ...) gave a ComplexWarning and a
    # silently dropped imaginary part (the big int made NumPy keep an object array)
    import warnings

    from taskspace._validation import as_float_array
    from taskspace.errors import InvalidInputError
    from taskspace.trajopt import plan_motion

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InvalidInputError, match="complex"):
            plan_motion(10**30, np.complex128(1 + 0j), 1.0, profile="minimum_jerk")
        with pytest.raises(InvalidInputError, match="complex"):
            as_float_array(np.array([1.0, 1j], dtype=object), "x")
        with pytest.raises(InvalidInputError, match="text"):
            as_float_array([10**30, "a"], "x")
        assert as_float_array([10**30, 2], "x").tolist() == [1e30, 2.0]


@pytest.mark.parametrize("which", ["lqr", "dlqr", "care", "dare"])
def test_linear_systems_without_states_or_inputs_are_refused(which: str) -> None:
    # before: A 0 x 0 gave a bare ValueError (max of an empty array)
    from taskspace.control import dlqr, lqr
    from taskspace.control.riccati import solve_continuous_riccati, solve_discrete_riccati
    from taskspace.errors import InvalidInputError

    fn = {
        "lqr": lqr,
        "dlqr": dlqr,
        "care": solve_continuous_riccati,
        "dare": solve_discrete_riccati,
    }[which]
    with pytest.raises(InvalidInputError, match="at least one state and one input"):
        fn(np.zeros((0, 0)), np.array([]), math.nan, None)
    with pytest.raises(InvalidInputError, match="at least one state and one input"):
        fn(np.zeros((2, 2)), np.zeros((2, 0)), 1.0, 1.0)


@pytest.mark.parametrize("model", ["velocity", "odometry", "car"])
def test_motion_models_refuse_non_finite_poses_and_controls(model: str) -> None:
    # before: OdometryMotionModel().mean([0, 0, 0], [0, 0, nan]) returned [0, 0, nan]
    from taskspace.errors import NotFiniteError
    from taskspace.estimation import KinematicCarModel, OdometryMotionModel

    m: Any = {
        "velocity": VelocityMotionModel(dt=0.1),
        "odometry": OdometryMotionModel(),
        "car": KinematicCarModel(dt=0.1, wheelbase=1.0),
    }[model]
    k = 3 if model == "odometry" else 2
    with pytest.raises(NotFiniteError, match="u"):
        m.mean(np.zeros(3), np.array([0.0] * (k - 1) + [math.nan]))
    with pytest.raises(NotFiniteError, match="x"):
        m.mean(np.array([0.0, math.inf, 0.0]), np.zeros(k))


def test_scurve_end_of_a_very_long_motion_is_at_rest() -> None:
    # before: a 1e17 s S-curve (jerk phases of 3e-18 of the motion, below the 1e-16 rounding
    # of the normalized breaks) had a velocity of 165 > vmax = 70 at t = T (evaluated past the
    # end of its last segment)
    from taskspace.trajopt import plan_motion

    goal = 6_822_376_050_898_684_417.0
    m = plan_motion(0.0, goal, 70.0, 1.0, 3.0, "scurve")
    # by hand: v j = 210 >= a^2 = 1, so T_j = a/j = 1/3, T_a = 1/3 + 70, T = d/v + T_a
    assert m.duration == pytest.approx(goal / 70.0 + 1.0 / 3.0 + 70.0, rel=1e-15)
    s = m.evaluate(np.linspace(0.0, m.duration, 7))
    assert np.abs(s.velocity).max() <= 70.0 * (1 + 1e-9)
    assert abs(s.velocity[-1]) < 1e-9 and s.velocity[3] == pytest.approx(70.0, rel=1e-12)
    assert s.position[-1] == goal


def test_spline_evaluate_refuses_a_ragged_time_list() -> None:
    # before: bare ValueError (inhomogeneous shape) from np.ndim(t)
    from taskspace.errors import InvalidInputError
    from taskspace.trajopt import cubic_spline

    spline = cubic_spline([0.0, 2.0])
    with pytest.raises(InvalidInputError, match="t must be"):
        spline.evaluate([[1], [2, 3]])
    # two waypoints: the straight line 2 t (natural end conditions), by hand
    assert spline.evaluate(0.5).tolist() == pytest.approx([1.0], abs=1e-12)


def test_viewer_floor_line_count_is_bounded() -> None:
    # before: add_floor((-1e6, -1e6, 1e6, 1e6)) built 8 million tube meshes per axis (hang);
    # an automatic extent around a far marker did the same
    pytest.importorskip("meshcat")
    from taskspace.errors import InvalidInputError
    from taskspace.viz import Viewer
    from tests.conftest import load_robot

    viewer = Viewer(load_robot("ur5"))
    with pytest.raises(InvalidInputError, match="lines per axis"):
        viewer.add_floor((-1e6, -1e6, 1e6, 1e6))
    viewer.add_floor((-1.0, -1.0, 1.0, 1.0))  # 9 lines per axis at 0.25 m
    viewer.add_points("far", [[1e6, 1e6, 0.0]])
    viewer.add_floor()  # automatic extent: a coarser grid, not an error


def test_angle_residual_refuses_non_finite_inputs() -> None:
    # before: angle_residual(0)(nan, zeros(3)) returned [nan, nan, nan]
    from taskspace.errors import NotFiniteError
    from taskspace.estimation import angle_residual

    residual = angle_residual(0)
    with pytest.raises(NotFiniteError, match="a"):
        residual(math.nan, np.zeros(3))
    with pytest.raises(NotFiniteError, match="b"):
        residual(np.zeros(3), np.array([0.0, math.inf, 0.0]))
    # by hand: the angle 3 - (-3) = 6 wraps to 6 - 2 pi, the others are plain differences
    out = residual(np.array([3.0, 1.0, 2.0]), np.array([-3.0, 0.5, 2.5]))
    assert out.tolist() == pytest.approx([6.0 - 2 * math.pi, 0.5, -0.5], abs=1e-15)


def test_angle_mean_refuses_non_finite_inputs() -> None:
    # before: a NaN point or weight gave a NaN mean
    from taskspace.errors import NotFiniteError
    from taskspace.estimation import angle_mean

    mean = angle_mean(0)
    with pytest.raises(NotFiniteError, match="points"):
        mean(np.array([[math.nan, 0.0, 0.0]]), np.array([1.0]))
    with pytest.raises(NotFiniteError, match="weights"):
        mean(np.zeros((1, 3)), np.array([math.nan]))
    # by hand: angles 3 and -3 average to pi (circular), the others arithmetically
    out = mean(np.array([[3.0, 1.0, 0.0], [-3.0, 3.0, 2.0]]), np.array([0.5, 0.5]))
    assert abs(abs(out[0]) - math.pi) < 1e-12 and out[1:].tolist() == [2.0, 1.0]


def test_chi2_bounds_huge_dof() -> None:
    # before: dof * num_runs = 2**64 (a Python int past int64) gave a bare TypeError in scipy
    dof = num_runs = 2**32
    lo, hi = chi2_bounds(dof, num_runs, 0.5)
    # reference: chi2(k) ~ N(k, 2k) for huge k; z_0.75 = 0.6744897501960817
    k = float(dof * num_runs)
    half = 0.6744897501960817 * math.sqrt(2.0 * k)
    assert lo * num_runs == pytest.approx(k - half, rel=1e-15, abs=1e3)
    assert hi * num_runs == pytest.approx(k + half, rel=1e-15, abs=1e3)


def test_dubins_straight_segment_exact_when_start_and_goal_nearly_coincide() -> None:
    # (0,0,0) -> (0, y, 0): L(pi/2) S(p) L(3 pi/2) ends at (0, p): p = y exactly (circles of
    # unit radius). The expanded p^2 = 2 + d^2 - 2 cos(a-b) + 2 d (sa - sb) cancelled to a
    # straight of 4.09e-8 for y = 1e-10 (found by test_invariances_and_bounds, seed 3).
    from taskspace.planning.dubins import (
        dubins_shortest,
        dubins_shortest_numpy,
        dubins_word_lengths,
    )

    for y in (1e-10, 1e-12, 3e-9):
        lengths, valid = dubins_word_lengths(np.array([0.0]), np.array([y]), np.array([0.0]))
        assert valid[0, 0] and valid[1, 0]
        assert abs(lengths[0, 0, 1] - y) <= 1e-16 and abs(lengths[1, 0, 1] - y) <= 1e-16
        # the compiled kernel computes the same straight segment
        for theta in (0.0, 1.0, -2.5):
            c, s = np.cos(theta), np.sin(theta)
            goal = (-s * y, c * y, theta)
            native = dubins_shortest((0.0, 0.0, theta), goal, 1.0).length
            reference = dubins_shortest_numpy((0.0, 0.0, theta), goal, 1.0).length
            assert native == pytest.approx(reference, rel=0, abs=1e-12)


def test_private_task_target_is_validated_like_set_target() -> None:
    # before: ``task._target = np.eye(4)`` made the compiled IK step fail with a bare Boost
    # TypeError and the Python path with an AttributeError ('numpy.ndarray' ... 'actInv')
    import pinocchio as pin

    from taskspace import features as F
    from taskspace.errors import InvalidInputError
    from taskspace.ik import DifferentialIK, DifferentialIKOptions
    from taskspace.model import Robot
    from taskspace.tasks import Task

    robot = Robot.load("panda")
    state = robot.state(robot.q_default)
    T = state.frame_placement(robot.frame_id("panda_hand_tcp")) * pin.SE3(
        np.eye(3), np.array([0.05, 0.0, 0.02])
    )
    for native in (True, False):
        reference = Task(F.FramePose(robot, "panda_hand_tcp"))
        reference.set_target(T.homogeneous)
        private = Task(F.FramePose(robot, "panda_hand_tcp"))
        private._target = T.homogeneous
        assert isinstance(private._target, pin.SE3)
        options = DifferentialIKOptions(native=native)
        a = DifferentialIK(robot, [reference], options=options).solve(state, 0.01)
        b = DifferentialIK(robot, [private], options=options).solve(state, 0.01)
        np.testing.assert_array_equal(a.dq, b.dq)
        with pytest.raises(InvalidInputError, match="real numbers"):
            private._target = "x"
        assert private._target.isApprox(T)  # unchanged


@pytest.mark.parametrize(
    "kwargs",
    [
        {"eps_abs": 1e300},
        {"eps_rel": 0.5},
        {"feasibility_tolerance": 1e300},
        {"proxsuite_eps_rel": 1.0},
        {"proxsuite_eps_primal_inf": 10.0},
    ],
)
def test_qp_tolerances_that_certify_nothing_are_refused(kwargs: dict[str, float]) -> None:
    # before: eps_abs=1e300 was accepted and every point of every QP came back SOLVED
    from taskspace.errors import InvalidInputError
    from taskspace.qp.solver import QPSolverOptions

    with pytest.raises(InvalidInputError, match=next(iter(kwargs))):
        QPSolverOptions(**kwargs)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"rank_tolerance": math.nan},
        {"row_tolerance": 1e300},
        {"damping": -1.0},
        {"solver": 3},
        {"exact_first": "daqp"},
    ],
)
def test_hierarchy_options_are_validated(kwargs: dict[str, object]) -> None:
    # before: HierarchyOptions(row_tolerance=1e300) was accepted (every projected row of
    # every level counts as vanished) and NaN tolerances made every rank decision False
    from taskspace.errors import InvalidInputError
    from taskspace.qp.hierarchy import HierarchyOptions

    with pytest.raises(InvalidInputError, match=next(iter(kwargs))):
        HierarchyOptions(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize("scale", [1e160, 1e200, 1e300])
def test_grasp_epsilon_is_scale_free_without_overflow(scale: float) -> None:
    # before: a grasp of size 1e160 m scored 0 (|p|^2 overflowed in the default torque
    # scale: moments / inf); epsilon with the default torque scale is scale free (moments
    # are divided by the grasp radius), so every size scores as the unit grasp
    from taskspace import grasping as g

    ang = np.array([0.3, 1.9, 4.0, 5.2])
    P = np.stack([np.cos(ang), np.sin(ang), 0.2 * np.cos(3 * ang)], 1)
    N = -P / np.linalg.norm(P, axis=1, keepdims=True)
    for k in (3, 4):  # three contacts: closed-form facets; four: a hull
        unit = g.grasp_epsilon_batch(P[None, :k], N[None, :k])
        big = g.grasp_epsilon_batch(scale * P[None, :k], N[None, :k])
        assert unit[0] > 0.05
        np.testing.assert_allclose(big, unit, rtol=1e-9)
        contacts = [g.GraspContact(scale * p, n) for p, n in zip(P[:k], N[:k])]
        W, _ = g.primitive_wrenches(contacts)
        unit_contacts = [g.GraspContact(p, n) for p, n in zip(P[:k], N[:k])]
        W1, _ = g.primitive_wrenches(unit_contacts)
        np.testing.assert_allclose(W, W1, rtol=1e-12, atol=1e-15)
        assert g.epsilon_l1(W) == pytest.approx(g.epsilon_l1(W1), rel=1e-9)


@pytest.mark.parametrize(
    ("model", "kwargs"),
    [
        ("KneedWalker", {"a1": 1e300}),  # before: find_kneed_limit_cycle ran forever
        ("KneedWalker", {"hip_mass": True}),
        ("KneedWalker", {"slope": 1.6}),
        ("CompassGait", {"slope": math.inf}),  # before: accepted, a step "fell" at once
        ("CompassGait", {"a": "x"}),  # before: a bare TypeError from the comparison
        ("CompassGait", {"leg_mass": 1e7}),
    ],
)
def test_walker_parameters_out_of_scale_are_refused(model: str, kwargs: dict[str, object]) -> None:
    from taskspace import locomotion
    from taskspace.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match=next(iter(kwargs))):
        getattr(locomotion, model)(**kwargs)


def test_environment_actions_and_sizes_are_validated() -> None:
    # before: Pendulum-v0 stepped a NaN torque into NaN observations and rewards; a text
    # action or a wrong-sized batch gave bare ValueErrors; num_envs=2.5 made 2 copies and
    # num_envs=10**9 tried to allocate them
    import gymnasium as gym

    from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
    from taskspace.learning.envs import CartPoleVectorEnv, PendulumVectorEnv

    env = gym.make("taskspace/Pendulum-v0")
    env.reset(seed=0)
    with pytest.raises(NotFiniteError):
        env.step(np.array([np.nan]))
    with pytest.raises(InvalidInputError, match="real numbers"):
        env.step("x")
    with pytest.raises(ShapeError):
        env.step(np.array([0.1, 0.2]))  # was: silently the first entry
    obs, reward, *_ = env.step(np.array([np.inf]))  # clipped to the torque limit
    assert np.isfinite(obs).all() and np.isfinite(reward)
    vec = CartPoleVectorEnv(num_envs=4)
    vec.reset(seed=0)
    with pytest.raises(ShapeError):
        vec.step(np.array([0, 1]))
    pend = PendulumVectorEnv(num_envs=3)
    pend.reset(seed=0)
    with pytest.raises(NotFiniteError):
        pend.step(np.array([0.0, np.nan, 0.0]))
    for n in (2.5, 10**9, True):
        with pytest.raises(InvalidInputError, match="num_envs"):
            CartPoleVectorEnv(num_envs=n)  # type: ignore[arg-type]


def test_walking_patterns_refuse_sample_counts_and_margins_out_of_range() -> None:
    # before: CartTable(dt=1e-9) made mpc_walking_pattern allocate 44 GiB (bare MemoryError);
    # zmp_margin=-0.1 was accepted (the ZMP allowed 10 cm outside the feet), NaN gave a NaN
    # QP and constrain_zmp="no" counted as True
    from taskspace import locomotion as L
    from taskspace.errors import InvalidInputError

    plan = L.straight_walk(3)
    for pattern in (L.mpc_walking_pattern, L.preview_walking_pattern):
        with pytest.raises(InvalidInputError, match="samples"):
            pattern(plan, L.CartTable(dt=1e-9))
    for kwargs in ({"zmp_margin": -0.1}, {"zmp_margin": math.nan}, {"constrain_zmp": "no"}):
        with pytest.raises(InvalidInputError, match=next(iter(kwargs))):
            L.ZmpMpcOptions(**kwargs)  # type: ignore[arg-type]
    times = L.CartTable(dt=0.05).sample_times(plan.duration)
    assert times[0] == 0.0 and times[-1] >= plan.duration > times[-2]
