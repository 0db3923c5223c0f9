"""walk() / walking_reference() compare the plan's initial foot yaws with the robot's feet
(audit4, left open): only the positions were checked against PLAN_START_TOLERANCE, so a plan
whose initial footsteps face another way was followed silently, its turns counted from the
wrong start (G1 facing 0 given a straight plan whose initial feet say 0.5 rad: the reference
turned both feet to -0.5 rad at their first steps).

Reference: the robot's heading from Pinocchio's placements of its two feet (perpendicular to
the line from the right foot to the left one, the convention of plan_from_robot); a robot whose
foot frames point outwards (toe-out) keeps that heading, and its own plan is accepted.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import plan_from_robot, walk, walking_reference
from taskspace.locomotion.footsteps import FootstepPlan
from taskspace.model import Robot
from tests.locomotion._walking import G1_FEET as FEET
from tests.locomotion._walking import SHORT_TIMING as TIMING
from tests.locomotion._walking import turned


def _with_initial_yaw(plan: FootstepPlan, yaw: float) -> FootstepPlan:
    left, right = plan.initial
    return dataclasses.replace(
        plan, initial=(dataclasses.replace(left, yaw=yaw), dataclasses.replace(right, yaw=yaw))
    )


def _turned(g1: Robot, yaw: float) -> Robot:
    return turned(g1, yaw)


def _heading(robot: Robot) -> float:
    left = robot.frame_placement(robot.q_default, FEET[0]).translation
    right = robot.frame_placement(robot.q_default, FEET[1]).translation
    return math.atan2(float(right[0] - left[0]), float(left[1] - right[1]))


def _toe_out(g1: Robot, angle: float) -> Robot:
    """G1 whose foot frames are turned outwards by ``angle`` about their z axes."""
    model = g1.model.copy()
    for frame, sign in zip(FEET, (1.0, -1.0)):
        fid = model.getFrameId(frame)
        placement = model.frames[fid].placement
        placement.rotation = placement.rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, sign * angle)
        model.frames[fid].placement = placement
    return Robot(
        model,
        g1.collision_model,
        g1.visual_model,
        name="g1_toe_out",
        end_effectors=g1.end_effectors,
        default_configuration=g1.q_default,
    )


def test_plan_facing_another_way_is_refused(g1: Robot) -> None:
    good = plan_from_robot(g1, g1.q_default, 2, step_length=0.08, timing=TIMING)
    assert _heading(g1) == pytest.approx(0.0, abs=1e-9)
    bad = _with_initial_yaw(good, 0.5)
    for call in (walk, walking_reference):
        with pytest.raises(
            InvalidInputError,
            match=r"initial left foot has yaw 0\.5000 rad but the robot faces -?0\.0000 rad "
            r".*tolerance 0\.05 rad.*plan_from_robot",
        ):
            call(g1, bad)


def test_turned_robot_given_an_unturned_plan_is_refused(g1: Robot) -> None:
    robot = _turned(g1, 0.4)
    plan = plan_from_robot(robot, robot.q_default, 2, step_length=0.08, timing=TIMING)
    assert plan.initial[0].yaw == pytest.approx(_heading(robot), abs=1e-9)
    assert _heading(robot) == pytest.approx(0.4, abs=1e-9)
    walking_reference(robot, plan)  # its own plan: accepted
    with pytest.raises(InvalidInputError, match=r"yaw 0\.0000 rad but the robot faces 0\.4000 rad"):
        walking_reference(robot, _with_initial_yaw(plan, 0.0))


@pytest.mark.parametrize("offset", [2 * math.pi, -2 * math.pi, 0.03, -0.03])
def test_yaws_within_tolerance_or_a_turn_apart_are_accepted(g1: Robot, offset: float) -> None:
    good = plan_from_robot(g1, g1.q_default, 2, step_length=0.08, timing=TIMING)
    ref = walking_reference(g1, _with_initial_yaw(good, offset))
    assert np.isfinite(ref.com).all()
    if abs(offset) > 1.0:  # a whole turn: the same walk
        same = walking_reference(g1, good)
        for side in ("left", "right"):
            np.testing.assert_allclose(
                ref.foot_rotation[side], same.foot_rotation[side], atol=1e-12
            )


def test_toe_out_robot_walks_its_own_plan(g1: Robot) -> None:
    robot = _toe_out(g1, 0.2)
    R = robot.frame_placement(robot.q_default, FEET[0]).rotation
    assert math.atan2(float(R[1, 0]), float(R[0, 0])) == pytest.approx(0.2, abs=1e-9)
    plan = plan_from_robot(robot, robot.q_default, 2, step_length=0.08, timing=TIMING)
    assert plan.initial[0].yaw == pytest.approx(_heading(robot), abs=1e-9)
    ref = walking_reference(robot, plan)  # refused when the foot frames' yaw was the reference
    assert np.isfinite(ref.com).all()
