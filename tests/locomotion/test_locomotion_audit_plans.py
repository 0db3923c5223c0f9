"""Footstep plans from odd inputs (audit of session 30): step counts and a turned robot."""

from __future__ import annotations

import numpy as np
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
