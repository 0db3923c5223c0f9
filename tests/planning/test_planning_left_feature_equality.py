"""FeatureGoalRegion with ``lower == upper`` in some coordinate: refused, with what to use.

A zero-width region is reached by the IK only within its tolerance, so ``contains`` never
holds for a sample: 0 valid samples of 30 (150 IK solves) for the Panda's hand at z = 0.4,
where the same box 2 mm tall gives 30 of 30 (measured while writing this test). Planners
then spent their whole budget. It is now an InvalidInputError naming the coordinates and the
alternatives; the band it suggests samples goals, checked by Pinocchio's forward kinematics.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.errors import InvalidInputError
from taskspace.ik import FeatureGoalRegion
from taskspace.model import Robot

FRAME = "panda_hand_tcp"
CENTRE = np.array([0.4, 0.0, 0.4])


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda", geometry=False)


def test_an_equality_in_one_coordinate_is_refused(panda: Robot) -> None:
    lower = CENTRE - [0.02, 0.02, 0.0]
    upper = CENTRE + np.array([0.02, 0.02, 0.0])
    with pytest.raises(InvalidInputError) as error:
        FeatureGoalRegion(F.Position(panda, FRAME), lower, upper)
    text = str(error.value)
    assert "lower == upper for coordinate(s) [2]" in text and "[0.4]" in text
    assert "zero width" in text
    assert "lower = v - 1e-3" in text and "goal configuration" in text
    assert "PoseGoalRegion" in text


def test_scalar_equal_bounds_are_refused_for_every_coordinate(panda: Robot) -> None:
    with pytest.raises(InvalidInputError, match=r"coordinate\(s\) \[0, 1, 2\]"):
        FeatureGoalRegion(F.Position(panda, FRAME), 0.3, 0.3)


def test_the_suggested_band_samples_goals_inside_it(panda: Robot) -> None:
    lower = CENTRE - [0.02, 0.02, 1e-3]
    upper = CENTRE + np.array([0.02, 0.02, 1e-3])
    region = FeatureGoalRegion(F.Position(panda, FRAME), lower, upper)
    rng = np.random.default_rng(0)
    data = panda.model.createData()
    frame = panda.model.getFrameId(FRAME)
    found = 0
    for _ in range(5):
        q = region.sample(rng)
        if q is None:
            continue
        found += 1
        pin.framesForwardKinematics(panda.model, data, q)
        position = data.oMf[frame].translation
        assert np.all(position >= lower - 1e-12) and np.all(position <= upper + 1e-12)
    assert found >= 4


def test_half_open_and_positive_widths_are_still_accepted(panda: Robot) -> None:
    lower = np.array([-np.inf, -0.1, 0.4])
    upper = np.array([0.5, np.inf, 0.4 + 1e-9])  # narrow, not empty
    region = FeatureGoalRegion(F.Position(panda, FRAME), lower, upper)
    assert np.array_equal(region.lower, lower) and np.array_equal(region.upper, upper)
