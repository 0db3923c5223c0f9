"""Bad and extreme inputs to time parametrization and path optimization (issue #15): a right
answer or a TaskspaceError, never a bare exception, a hang or a "successful" absurd result.

Reference for the time parametrization: a path is at rest at both ends of a 2-point grid
(clamped spline, zero start/end path velocity), so no finite timing exists on that grid; a
finer grid gives the finite time-optimal duration, which scales as ``1 / c`` when the
velocity limit is multiplied by ``c`` and the acceleration limit by ``c^2`` (time scaling).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.trajopt import (
    PathOptimizationOptions,
    PathProblem,
    TimeParametrizationOptions,
    TimeParametrizationStatus,
    optimize_path,
    time_parametrize,
)

WAYPOINTS = np.linspace(np.zeros(2), np.array([0.5, -0.3]), 4)


@pytest.mark.filterwarnings("error::RuntimeWarning")  # valid inputs: no numpy overflow warning
def test_time_scaling_reference() -> None:
    # c = 1e150: x = sdot^2 hit the internal cap 1e300 and the duration came back 27 % off
    # with SUCCESS; c = 1e-150 / path scale 1e-200: sdot^2 near underflow
    base = time_parametrize(WAYPOINTS, 1.0, 2.0)
    assert base.success
    for scale in (1e-200, 1e200):  # path and limits scaled together: same timing
        same = time_parametrize(WAYPOINTS * scale, scale, 2.0 * scale)
        assert same.success
        assert same.duration == pytest.approx(base.duration, rel=1e-9)
    for c in (1e-150, 1e-3, 1e3, 1e150):
        scaled = time_parametrize(WAYPOINTS, c, 2.0 * c * c)
        assert scaled.success
        assert scaled.duration * c / base.duration == pytest.approx(1.0, rel=1e-9)


def test_segment_at_rest_at_both_ends_is_infeasible_not_2e300_seconds() -> None:
    # 2 grid points, start and end at rest: dt = 2 delta / 1e-300 gave SUCCESS, duration 2e300
    res = time_parametrize(WAYPOINTS, 1.0, 2.0, options=TimeParametrizationOptions(grid_points=2))
    assert not res.success and res.status is TimeParametrizationStatus.INFEASIBLE
    with pytest.raises(InvalidInputError):
        res.sample(0.1)


def test_path_function_errors_and_sampling_limits() -> None:
    def broken(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise ZeroDivisionError("boom")

    with pytest.raises(InvalidInputError, match="ZeroDivisionError"):  # bare before
        time_parametrize(broken, 1.0, 2.0)
    res = time_parametrize(WAYPOINTS, 1.0, 2.0)
    with pytest.raises(InvalidInputError, match="samples"):  # bare "Maximum allowed size"
        res.sample(1e-300)
    assert res.sample(res.duration / 4).time.shape == (5,)


@pytest.fixture(scope="module")
def ur5() -> Robot:
    return Robot.load("ur5")


@pytest.mark.parametrize(
    "kw",
    [
        {"horizon": 10**9},  # built 2e9 kinematic states (ran for ever)
        {"duration": 1e-300},  # bare ZeroDivisionError (dt**2 underflow)
        {"duration": 1e300},  # bare OverflowError
        {"costs": 5},  # bare TypeError
        {"costs": [5]},  # bare AttributeError
        {"equalities": ["a"]},
        {"inequalities": [None]},
    ],
)
def test_path_problem_arguments_are_checked(ur5: Robot, kw: dict[str, object]) -> None:
    args: dict[str, object] = {"horizon": 10}
    args.update(kw)
    horizon = args.pop("horizon")
    with pytest.raises(InvalidInputError):
        PathProblem(ur5, ur5.q_default, horizon, **args)  # type: ignore[arg-type]


def test_optimize_path_argument_types(ur5: Robot) -> None:
    problem = PathProblem(ur5, ur5.q_default, 5)
    with pytest.raises(InvalidInputError, match="PathProblem"):
        optimize_path(5)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="PathOptimizationOptions"):
        optimize_path(problem, options=5)  # type: ignore[arg-type]
    res = optimize_path(problem, options=PathOptimizationOptions(max_iterations=5))
    np.testing.assert_allclose(res.path, np.tile(ur5.q_default, (6, 1)), atol=1e-12)  # at rest
