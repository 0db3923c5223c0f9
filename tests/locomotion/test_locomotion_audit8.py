"""Audit 8 (new-user sweep): bad durations of the cart-table sampler and a NaN ground height
of the support polygon raise InvalidInputError naming the input instead of an empty walk, a
bare TypeError, or a ground check that silently passes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import robot_feet, support_polygon
from taskspace.locomotion.lipm import CartTable


@pytest.mark.parametrize("duration", [-1.0, -1e-3, "1", None, True, [1.0, 2.0]])
def test_sample_times_refuses_bad_durations(duration):
    with pytest.raises(InvalidInputError, match="duration"):
        CartTable(dt=0.01).sample_times(duration)


def test_sample_times_covers_duration():
    t = CartTable(dt=0.25).sample_times(1.0)
    np.testing.assert_array_equal(t, [0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(CartTable(dt=0.25).sample_times(0), [0.0])


@pytest.mark.parametrize("height", [math.nan, math.inf, "0"])
def test_support_polygon_refuses_bad_ground_height(robot_loader, height):
    robot = robot_loader("talos")
    feet = list(robot_feet("talos").values())
    with pytest.raises(InvalidInputError, match="ground_height"):
        support_polygon(robot, robot.q_default, feet, ground_height=height)


@pytest.mark.parametrize("frame", [3, None, "", b"left_foot"])
def test_foot_geometry_frame_must_be_a_name(frame: object) -> None:
    """A foot frame that is not a name is refused at construction (it reached support_polygon
    as UnknownNameError for '3')."""
    from taskspace.locomotion.foot import FootGeometry

    with pytest.raises(InvalidInputError, match="frame must be the name"):
        FootGeometry(frame=frame, vertices=np.zeros((1, 3)))  # type: ignore[arg-type]
