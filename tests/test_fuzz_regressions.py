"""Defects found by running tests/test_fuzz_api.py with thousands of examples, as explicit cases."""

from __future__ import annotations

import math

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
