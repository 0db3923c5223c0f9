"""certify_path and motion_bound given what a planner takes: a ConfigurationSpace.

Every planner takes the space, so a student certifies with ``certify_path(space, path)``;
it raised ``AttributeError: 'ConfigurationSpace' object has no attribute 'nq'`` (and
``motion_bound(space)`` one about ``_model``). They now raise taskspace's InvalidInputError
naming the function and what to give instead.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.planning import certify_path, motion_bound, motion_bounds
from taskspace.planning.configuration_space import ConfigurationSpace


def _arm() -> Robot:
    """Two revolute joints, no geometry (built here: nothing to load)."""
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j1")
    model.addJoint(j, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.3])), "j2")
    model.lowerPositionLimit[:] = -2.0
    model.upperPositionLimit[:] = 2.0
    model.appendBodyToJoint(j, pin.Inertia.Random(), pin.SE3.Identity())
    return Robot(
        model,
        pin.GeometryModel(),
        pin.GeometryModel(),
        name="arm",
        default_configuration=pin.neutral(model),
    )


def test_certify_path_of_a_space_names_the_robot_to_give() -> None:
    robot = _arm()
    space = ConfigurationSpace.from_robot(robot)
    path = np.array([[0.0, 0.0], [0.5, 0.5]])
    with pytest.raises(
        InvalidInputError, match=r"certify_path takes a taskspace Robot.*from_robot"
    ):
        certify_path(space, path)  # type: ignore[arg-type]
    assert certify_path(robot, path).certified  # the robot itself: no geometry, free


@pytest.mark.parametrize("fn", [motion_bound, motion_bounds])
def test_motion_bounds_of_a_space_or_a_model_are_refused_clearly(fn) -> None:  # type: ignore[no-untyped-def]
    robot = _arm()
    with pytest.raises(InvalidInputError, match="motion_bound takes a taskspace Robot"):
        fn(ConfigurationSpace.from_robot(robot))
    with pytest.raises(InvalidInputError, match="collision geometry"):
        fn(robot.model)
    assert np.asarray(motion_bounds(robot)).shape == (2,)
