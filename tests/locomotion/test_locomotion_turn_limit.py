"""turn_in_place / arc_walk refuse more than max_yaw_step of turn per step (left by audit2).

Before: ``turn_in_place(3.0, 2)`` was a plan turning 3 rad in one step, its swing foot landing
on the stance foot. Reference: the yaw change between consecutive body poses of the plan.
"""

from __future__ import annotations

import itertools
import math

import pytest

from taskspace.errors import InvalidInputError
from taskspace.locomotion import arc_walk, turn_in_place
from taskspace.locomotion.footsteps import MAX_YAW_STEP


@pytest.mark.parametrize(("angle", "n_steps", "needed"), [(3.0, 2, 5), (-3.0, 3, 5), (1.6, 2, 4)])
def test_too_fast_turns_name_the_steps_needed(angle: float, n_steps: int, needed: int) -> None:
    with pytest.raises(InvalidInputError, match=rf"max_yaw_step.*n_steps >= {needed}"):
        turn_in_place(angle, n_steps)
    # the suggestion works
    plan = turn_in_place(angle, needed)
    yaws = [f.yaw for f in plan.steps]
    assert max(abs(b - a) for a, b in itertools.pairwise(yaws)) <= MAX_YAW_STEP + 1e-12


def test_limit_is_inclusive_and_adjustable() -> None:
    turn_in_place(math.pi / 2, 3)  # exactly 45 degrees per step
    with pytest.raises(InvalidInputError, match="n_steps >= 4"):
        turn_in_place(math.pi / 2, 3, max_yaw_step=0.6)
    turn_in_place(3.0, 2, max_yaw_step=3.0)  # a user who knows their robot
    with pytest.raises(InvalidInputError, match="max_yaw_step"):
        turn_in_place(0.5, 3, max_yaw_step=0.0)


def test_arc_walk() -> None:
    with pytest.raises(InvalidInputError, match=r"arc_walk turns 3 rad in 3 steps"):
        arc_walk(3, radius=1.0, angle=3.0)
    arc_walk(5, radius=1.0, angle=3.0)
