"""New-user inputs to PoseGoalRegion."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.ik.pose_goal_region import PoseGoalRegion
from taskspace.model import Robot


@pytest.fixture(scope="module")
def ur5() -> Robot:
    return Robot.load("ur5")


def test_numpy_integer_attempts_accepted_bool_refused(ur5: Robot) -> None:
    frame = ur5.model.frames[-1].name
    assert PoseGoalRegion(ur5, frame, pin.SE3.Identity(), attempts=np.int64(3)).attempts == 3
    with pytest.raises(InvalidInputError, match="attempts"):
        PoseGoalRegion(ur5, frame, pin.SE3.Identity(), attempts=True)


def test_sample_needs_a_generator(ur5: Robot) -> None:
    region = PoseGoalRegion(ur5, ur5.model.frames[-1].name, pin.SE3.Identity())
    with pytest.raises(InvalidInputError, match="default_rng"):
        region.sample(0)  # type: ignore[arg-type]
