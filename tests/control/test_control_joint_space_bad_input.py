"""Joint-space controllers and references on bad inputs (#15, new-user sweep).

Before: JointPDController / ComputedTorqueController gave NaN torques for a NaN
configuration, a bare Boost ArgumentError for text, and a bare ValueError for kp="x";
SinusoidalReference gave a NaN reference at t=NaN, a bare error for frequency="x" and
overflow warnings for huge frequencies; SampledReference raised a bare ValueError at t=NaN
and a bare OverflowError for tau=1e300. References: Pinocchio's rnea / gravity, the
analytic sinusoid.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import (
    ComputedTorqueController,
    JointPDController,
    SampledReference,
    SinusoidalReference,
)
from taskspace.errors import InvalidInputError

BAD_Q = [np.array([np.nan, 0.0]), np.array([np.inf, 0.0]), "x", None, np.zeros(3), [1j, 0.0]]


@pytest.fixture(scope="module")
def robot(robot_loader: Any) -> Any:
    return robot_loader("planar_2link")


@pytest.mark.parametrize("q", BAD_Q)
@pytest.mark.parametrize("cls", [JointPDController, ComputedTorqueController])
def test_controllers_check_q_and_v(robot: Any, cls: type, q: Any) -> None:
    ctrl = cls(robot, np.zeros(2))
    with pytest.raises(InvalidInputError, match="q"):
        ctrl(0.0, q, np.zeros(2))
    with pytest.raises(InvalidInputError, match="v"):
        ctrl(0.0, np.zeros(2), q)


@pytest.mark.parametrize("gain", ["x", 1j, [1.0, "a"], -1.0, np.nan])
@pytest.mark.parametrize("cls", [JointPDController, ComputedTorqueController])
def test_gains_are_checked(robot: Any, cls: type, gain: Any) -> None:
    with pytest.raises(InvalidInputError, match="kp"):
        cls(robot, np.zeros(2), kp=gain)


def test_valid_controllers_match_pinocchio(robot: Any) -> None:
    model, data = robot.model, robot.model.createData()
    q, v, target = np.array([0.3, -0.2]), np.array([0.1, 0.4]), np.array([0.5, 0.1])
    pd = JointPDController(robot, target, kp=50.0, kd=5.0)
    expected = 50.0 * (target - q) + 5.0 * (0.0 - v) + pin.computeGeneralizedGravity(model, data, q)
    np.testing.assert_allclose(pd(0.0, q, v), expected, atol=1e-12)
    ct = ComputedTorqueController(robot, target, kp=50.0, kd=5.0)
    a = 50.0 * (target - q) - 5.0 * v
    np.testing.assert_allclose(ct(0.0, q, v), pin.rnea(model, data, q, v, a), atol=1e-12)


@pytest.mark.parametrize("t", [np.nan, np.inf, "x", None, 1j])
def test_references_check_time(t: Any) -> None:
    with pytest.raises(InvalidInputError, match="t"):
        SinusoidalReference(np.zeros(2), 1.0, 1.0)(t)
    with pytest.raises(InvalidInputError, match="t"):
        SampledReference(np.zeros((4, 2)), 0.1)(t)


@pytest.mark.parametrize(
    ("field", "value"), [("frequency", "x"), ("amplitude", 1j), ("phase", "p")]
)
def test_sinusoid_parameters_are_numbers(field: str, value: Any) -> None:
    kwargs: dict[str, Any] = {"center": np.zeros(2), "amplitude": 1.0, "frequency": 1.0}
    kwargs[field] = value
    with pytest.raises(InvalidInputError, match=field):
        SinusoidalReference(**kwargs)


def test_sinusoid_acceleration_overflow_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="overflows"):
        SinusoidalReference(np.zeros(2), 1.0, 1e300)


def test_sinusoid_matches_the_analytic_reference() -> None:
    ref = SinusoidalReference(np.array([0.1, 0.2]), 0.5, 2.0, 0.3)(0.7)
    arg = 2 * np.pi * 2.0 * 0.7 + 0.3
    np.testing.assert_allclose(ref.q, [0.1, 0.2] + 0.5 * np.sin(arg))
    np.testing.assert_allclose(ref.a, -0.5 * (4 * np.pi) ** 2 * np.sin(arg) * np.ones(2))


def test_sampled_reference_with_a_huge_spacing() -> None:
    samples = np.array([[0.0], [1.0], [3.0], [3.0]])
    ref = SampledReference(samples, 1e300)  # tau**2 overflowed (bare OverflowError)
    np.testing.assert_allclose(ref(0.5e300).q, [0.5])
    assert np.isfinite(ref.a).all()
