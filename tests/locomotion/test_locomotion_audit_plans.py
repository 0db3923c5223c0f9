"""Footstep plans from odd inputs (audit of session 30): step counts and a turned robot."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import arc_walk, plan_from_robot, straight_walk, turn_in_place

TALOS_FEET = ("left_sole_link", "right_sole_link")


def _feet(plan):
    return [(f.side, f.x, f.y, f.yaw) for f in (*plan.initial, *plan.steps)]


def test_step_counts_accept_integral_floats_and_name_the_others():
    assert _feet(straight_walk(3.0)) == _feet(straight_walk(3))
    assert _feet(turn_in_place(0.5, np.float64(4.0))) == _feet(turn_in_place(0.5, 4))
    assert _feet(arc_walk(3.0, radius=1.0, angle=0.3)) == _feet(arc_walk(3, radius=1.0, angle=0.3))
    for bad in (2.5, True, "3", None, float("nan")):
        for make in (
            lambda n: straight_walk(n),
            lambda n: turn_in_place(0.5, n),
            lambda n: arc_walk(n, radius=1.0, angle=0.3),
        ):
            with pytest.raises(InvalidInputError, match="n_steps"):
                make(bad)


def test_plan_from_robot_counts_steps_like_the_other_plans(talos):
    q = talos.q_default
    three = plan_from_robot(talos, q, 3, feet=TALOS_FEET)
    assert _feet(plan_from_robot(talos, q, 3.0, feet=TALOS_FEET)) == _feet(three)
    with pytest.raises(InvalidInputError, match="n_steps"):
        plan_from_robot(talos, q, 2.5, feet=TALOS_FEET)


@pytest.mark.parametrize("yaw", [0.0, math.pi / 2, math.pi, -2.5])
def test_plan_from_robot_starts_on_the_feet_of_a_turned_robot(talos, yaw):
    q = talos.q_default.copy()
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, yaw)).coeffs()
    plan = plan_from_robot(talos, q, 3, step_length=0.1, feet=TALOS_FEET)
    for foot, frame in zip(plan.initial, TALOS_FEET, strict=True):
        placement = talos.frame_placement(q, frame)
        # where the foot stands and where it points (the sole frame's x axis on the ground)
        assert foot.position == pytest.approx(placement.translation[:2], abs=1e-9)
        x_axis = placement.rotation[:2, 0]
        assert (math.cos(foot.yaw), math.sin(foot.yaw)) == pytest.approx(x_axis, abs=1e-6)
    # the walk goes forward: every step lands step_length ahead along the robot's heading
    heading = np.array([math.cos(yaw), math.sin(yaw)])
    start = {f.side: f.position for f in plan.initial}
    first = plan.steps[0]
    assert (first.position - start[first.side]) @ heading == pytest.approx(0.1, abs=1e-9)
