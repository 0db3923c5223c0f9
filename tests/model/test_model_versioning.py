"""Model versioning: limits are read-only and change only through ``Robot.set_limits``.

Before, ``robot.lower_limits`` was a writable view of ``robot.model.lowerPositionLimit``:
``robot.lower_limits[i] = x`` edited the model in place, and every object that had copied the
limits (features, constraints, solvers, planning spaces) kept the old ones without a word. Now
the arrays are read-only; ``set_limits`` changes the model and gives the robot a new version
(never reused); derived objects compare it (``JointLimitPenetration`` re-reads its limits,
``Robot.check_version`` raises ``StaleModelError``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace import features as F
from taskspace.errors import InvalidInputError, ModelWarning, ShapeError, StaleModelError
from taskspace.model import Robot


def _fresh(name: str) -> Robot:
    """A robot of its own (these tests change its limits)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load(name, geometry=False)


def test_limit_arrays_are_read_only() -> None:
    robot = _fresh("panda")
    before = np.array(robot.model.lowerPositionLimit)
    for array in (
        robot.lower_limits,
        robot.upper_limits,
        robot.limited_joints_q,
        robot.limited_joints_v,
        robot.q_default,
    ):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0.0
    np.testing.assert_array_equal(robot.model.lowerPositionLimit, before)
    version = robot.version
    robot.velocity_limits[0] = 0.0  # a copy: neither the robot nor its version change
    assert robot.velocity_limits[0] > 0 and robot.version == version


def test_set_limits_changes_the_model_and_the_version() -> None:
    robot, other = _fresh("panda"), _fresh("panda")
    v0 = robot.version
    assert v0 != other.version  # versions are never shared, even by equal models
    lower = robot.lower_limits.copy()
    upper = robot.upper_limits.copy()
    lower[1], upper[1] = -0.5, 0.5
    upper[6] = np.inf  # joint 7 becomes unbounded above: no longer a limited joint
    velocity = robot.velocity_limits.copy()
    velocity[0] = 0.25
    effort = robot.effort_limits.copy()
    effort[2] = 0.0  # joint 3 becomes unactuated
    v1 = robot.set_limits(lower=lower, upper=upper, velocity=velocity, effort=effort)
    assert v1 == robot.version and v1 not in (v0, other.version)
    # Pinocchio's model holds the new limits (the reference every algorithm reads)
    np.testing.assert_array_equal(robot.model.lowerPositionLimit, lower)
    np.testing.assert_array_equal(robot.model.upperPositionLimit, upper)
    np.testing.assert_array_equal(robot.model.velocityLimit, velocity)
    # joint 7, no longer limited, reads -inf below too (the robot does not enforce its lower bound)
    np.testing.assert_array_equal(robot.lower_limits, np.r_[lower[:6], -np.inf])
    assert robot.velocity_limits[0] == 0.25 and robot.effort_limits[2] == 0.0
    assert 6 not in robot.limited_joints_q.tolist() and 1 in robot.limited_joints_q.tolist()
    assert robot.passive_joints == ("panda_joint3",)
    # a random configuration respects the new bounds
    q = robot.random_configuration(np.random.default_rng(0))
    assert -0.5 <= q[1] <= 0.5
    assert robot.set_limits(velocity=velocity) not in (v0, v1)  # every call is a new version


def test_default_posture_follows_the_limits() -> None:
    robot = _fresh("panda")
    lower = robot.lower_limits.copy()
    lower[3] = robot.q_default[3] + 0.1
    with pytest.warns(ModelWarning, match="default posture is outside the joint limits"):
        robot.set_limits(lower=lower)
    assert robot.q_default[3] == pytest.approx(lower[3])


def test_bad_limits_are_refused_and_keep_the_version() -> None:
    robot = _fresh("solo12")
    version = robot.version
    lower, upper = robot.lower_limits.copy(), robot.upper_limits.copy()
    bad_order = lower.copy()
    bad_order[8] = upper[8] + 1.0
    nan = lower.copy()
    nan[8] = np.nan
    based = lower.copy()
    based[0] = -1.0
    cases = [
        ({"lower": lower[:-1]}, ShapeError, "lower limits"),
        ({"lower": nan}, InvalidInputError, "NaN"),
        ({"lower": bad_order}, InvalidInputError, "above upper limits at configuration indices"),
        ({"lower": based}, InvalidInputError, "floating base"),
        ({"effort": -robot.effort_limits}, InvalidInputError, "effort limits must be >= 0"),
        ({"effort": np.ones(robot.nv)}, InvalidInputError, "floating base is not actuated"),
        ({"velocity": [1j] * robot.nv}, InvalidInputError, "real numbers"),
    ]
    for kwargs, error, match in cases:
        with pytest.raises(error, match=match):
            robot.set_limits(**kwargs)
        assert robot.version == version
    np.testing.assert_array_equal(robot.lower_limits, lower)


def test_features_built_before_see_the_new_limits() -> None:
    """JointLimitPenetration against its formula evaluated on Pinocchio's model limits."""
    robot = _fresh("panda")
    feature = F.JointLimitPenetration(robot, margin=0.1)
    q = robot.q_default.copy()

    def reference() -> float:
        idx = robot.limited_joints_q
        lo = np.asarray(robot.model.lowerPositionLimit)[idx]
        hi = np.asarray(robot.model.upperPositionLimit)[idx]
        qi = q[idx]
        m = 0.1
        return float((np.maximum(m - qi + lo, 0).sum() + np.maximum(m + qi - hi, 0).sum()) / m)

    state = robot.state(q)
    assert feature.value(state)[0] == pytest.approx(reference()) == 0.0
    lower = robot.lower_limits.copy()
    lower[0] = q[0] - 0.05  # joint 1 now 5 cm inside its margin
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot.set_limits(lower=lower)
    state = robot.state(q)
    assert reference() == pytest.approx(0.5)
    assert feature.value(state)[0] == pytest.approx(reference())
    J = feature.jacobian(state)
    assert J[0, 0] == pytest.approx(-10.0)


def test_check_version_names_the_stale_object() -> None:
    robot = _fresh("panda")
    built = robot.version
    robot.check_version(built, "MyController")
    robot.set_limits(velocity=robot.velocity_limits)
    with pytest.raises(StaleModelError, match="MyController was built for version") as info:
        robot.check_version(built, "MyController")
    assert info.value.built_version == built and info.value.current_version == robot.version


def test_in_place_edits_of_the_public_model_cannot_reach_the_robot() -> None:
    """``robot.model`` is a copy: editing it changes neither the limits nor the version."""
    robot = _fresh("panda")
    lower, version = robot.lower_limits.copy(), robot.version
    model = robot.model
    model.lowerPositionLimit[0] = 0.0
    np.testing.assert_array_equal(robot.lower_limits, lower)
    assert robot.version == version
    robot.check_version(version, "JointPositionLimits")
    robot.set_limits(lower=np.asarray(model.lowerPositionLimit))  # adopt the edit
    assert robot.lower_limits[0] == 0.0 and robot.version != version
    assert robot.model is not model and robot.model.lowerPositionLimit[0] == 0.0
