"""Whole-body walking of Talos (sole frames, 6-D contacts) on a short walk."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.locomotion.footsteps import StepTiming
from taskspace.locomotion.whole_body_walking import WalkingOptions, plan_from_robot, walk


@pytest.mark.slow
def test_talos_walks_two_steps(robot_loader):
    robot = robot_loader("talos")
    opts = WalkingOptions(
        feet=("left_sole_link", "right_sole_link"),
        pelvis="base_link",
        sole_half_length=0.1,
        sole_half_width=0.06,
    )
    timing = StepTiming(
        single_support=0.6,
        double_support=0.2,
        initial_double_support=0.8,
        final_double_support=1.2,
        weight_shift=0.4,
    )
    plan = plan_from_robot(
        robot, robot.q_default, 2, step_length=0.1, feet=opts.feet, timing=timing
    )
    res = walk(robot, plan, opts)
    assert res.success, res.message
    assert res.cone_violation <= 1e-6 and res.zmp_margin.min() >= -1e-6
    assert np.abs(res.com - res.com_reference).max() < 0.01
    left, right = plan.final_feet()
    for foot, frame in ((left, opts.feet[0]), (right, opts.feet[1])):
        p = robot.frame_placement(res.q[-1], frame).translation
        assert p[:2] == pytest.approx(foot.position, abs=0.01)
