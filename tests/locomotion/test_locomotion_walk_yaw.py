"""Footstep yaws are absolute: a robot that does not face +x walks with its feet as planned.

Before: the feet's and the pelvis's orientation targets were ``Rz(yaw) R_0`` with ``yaw`` the
footstep's absolute yaw and ``R_0`` the foot's initial rotation, which already holds the
robot's initial yaw: G1 facing 0.4 rad, walking straight, was asked to turn its feet and
pelvis to 0.8 rad. Reference: the plan's yaws (``plan_from_robot`` from the robot's feet).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.locomotion import plan_from_robot, walk, walking_reference
from taskspace.model import Robot
from tests.locomotion._walking import G1_FEET as FEET
from tests.locomotion._walking import SHORT_TIMING as TIMING
from tests.locomotion._walking import turned


def _yaw(R: np.ndarray) -> float:
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


def _turned(g1: Robot, yaw: float) -> Robot:
    return turned(g1, yaw)


@pytest.mark.parametrize(("yaw0", "turn"), [(0.4, 0.0), (0.4, 0.15), (-1.2, -0.1), (0.0, 0.1)])
def test_reference_orientations_follow_the_plan(g1: Robot, yaw0: float, turn: float) -> None:
    robot = _turned(g1, yaw0) if yaw0 else g1
    plan = plan_from_robot(
        robot, robot.q_default, 3, step_length=0.08, yaw_per_step=turn, timing=TIMING
    )
    ref = walking_reference(robot, plan, None)
    last = {f.side: f.yaw for f in plan.steps[-2:]}  # each foot's last footstep
    for side in ("left", "right"):
        foot0 = robot.frame_placement(robot.q_default, FEET[0 if side == "left" else 1])
        start = next(f.yaw for f in plan.initial if f.side == side)
        # the foot turns by the plan's change of yaw, from where it stands
        expected = _yaw(foot0.rotation) + (last[side] - start)
        assert _yaw(ref.foot_rotation[side][-1]) == pytest.approx(expected, abs=1e-9)
    pelvis0 = _yaw(robot.frame_placement(robot.q_default, "pelvis").rotation)
    heading0 = math.atan2(
        sum(math.sin(f.yaw) for f in plan.initial), sum(math.cos(f.yaw) for f in plan.initial)
    )
    heading1 = math.atan2(
        sum(math.sin(v) for v in last.values()), sum(math.cos(v) for v in last.values())
    )
    assert _yaw(ref.pelvis_rotation[-1]) == pytest.approx(pelvis0 + heading1 - heading0, abs=1e-9)


@pytest.mark.slow
def test_turned_robot_walks_with_its_feet_as_planned(g1: Robot) -> None:
    robot = _turned(g1, 0.4)
    plan = plan_from_robot(robot, robot.q_default, 2, step_length=0.06, timing=TIMING)
    result = walk(robot, plan)
    q_end = result.q[-1]
    for frame in FEET:
        assert _yaw(robot.frame_placement(q_end, frame).rotation) == pytest.approx(0.4, abs=0.02)
