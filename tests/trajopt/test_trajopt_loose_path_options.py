"""PathOptimizationOptions at their edges (audit4, left open): valid with a defined meaning or
refused with a message naming the option, never a silently different problem.

Found on a Panda reach (10 slices, final pose equality):
- constraint_tolerance=0 (or 1e-300) reported INFEASIBLE at a violation of 3e-16;
- initial_damping=0 never damped a rejected step (the damping grows by factors from it): the
  collision reach with duration 3 s ran its 200 iterations (MAX_ITERATIONS, violation 0.07)
  where 1e-6 converges in 17;
- max_penalty < initial_penalty started the penalty above its maximum;
- violation_decrease > 1 is no decrease.

Reference: the final pose against Pinocchio's ``log6`` of the goal error, not the solver's own
violation.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import taskspace.features as F
from taskspace.constraints import FeatureBounds
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.tasks import Task
from taskspace.trajopt import (
    PathEquality,
    PathInequality,
    PathOptimizationOptions,
    PathOptimizationStatus,
    PathProblem,
    optimize_path,
)

TCP = "panda_hand_tcp"


@pytest.fixture(scope="module")
def reach() -> tuple[Robot, np.ndarray, pin.SE3]:
    robot = Robot.load("panda")
    q0 = robot.q_default.copy()
    qg = q0.copy()
    qg[0] = 0.8
    return robot, q0, robot.frame_placement(qg, TCP)


def reach_problem(reach: tuple[Robot, np.ndarray, pin.SE3]) -> PathProblem:
    robot, q0, goal = reach
    task = Task(F.FramePose(robot, TCP), goal)
    return PathProblem(robot, q0, 10, equalities=[PathEquality(task, times=-1)])


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"constraint_tolerance": 0.0}, r"constraint_tolerance must be >= 1e-12"),
        ({"constraint_tolerance": 1e-300}, r"constraint_tolerance must be >= 1e-12"),
        ({"initial_damping": 0.0}, r"initial_damping must be finite and > 0"),
        ({"max_penalty": 1e3}, r"max_penalty \(1000.0\) must be >= initial_penalty \(10000.0\)"),
        ({"violation_decrease": 1.5}, r"violation_decrease must be in \(0, 1\]"),
    ],
)
def test_edge_options_are_refused(reach, options: dict[str, float], message: str) -> None:
    with pytest.raises(InvalidInputError, match=message):
        optimize_path(reach_problem(reach), options=PathOptimizationOptions(**options))


@pytest.mark.parametrize(
    "options",
    [
        {"constraint_tolerance": 1e-12},
        {"max_penalty": 1e4},  # = initial_penalty: the penalty never grows
        {"violation_decrease": 1.0},
        {"initial_damping": 1e-300},
    ],
)
def test_edge_options_that_remain_valid_converge(reach, options: dict[str, float]) -> None:
    robot, _, goal = reach
    result = optimize_path(reach_problem(reach), options=PathOptimizationOptions(**options))
    assert result.status is PathOptimizationStatus.CONVERGED
    error = pin.log6(goal.actInv(robot.frame_placement(result.path[-1], TCP))).vector
    tolerance = max(PathOptimizationOptions(**options).constraint_tolerance, 1e-12)
    assert np.abs(error).max() <= 2 * tolerance


def test_tiny_damping_recovers_from_rejected_steps() -> None:
    # initial_damping=0 stayed at 0 after every rejection: 200 iterations, violation 0.07
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.sphere("ball", 0.12, [0.35, 0.0, 0.4]))
    q0, qg = robot.q_default.copy(), robot.q_default.copy()
    q0[0], qg[0] = -0.8, 0.8
    pairs = [p for p in robot.collision_pairs if "ball" in p]
    problem = PathProblem(
        robot,
        q0,
        20,
        equalities=[PathEquality(Task(F.FramePose(robot, TCP), robot.frame_placement(qg, TCP)))],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), 0.02, np.inf))
        ],
        duration=3.0,
    )
    result = optimize_path(problem, options=PathOptimizationOptions(initial_damping=1e-300))
    assert result.success and result.iterations < 100, (result.status, result.iterations)


def test_zero_budgets_have_a_defined_meaning(reach) -> None:
    problem = reach_problem(reach)
    none = optimize_path(problem, options=PathOptimizationOptions(max_iterations=0))
    assert none.status is PathOptimizationStatus.MAX_ITERATIONS and none.iterations == 0
    np.testing.assert_array_equal(none.path, problem.initial_path(None))
    inner = optimize_path(problem, options=PathOptimizationOptions(max_outer_iterations=0))
    assert inner.outer_iterations == 0 and inner.iterations > 0
    assert inner.status is PathOptimizationStatus.MAX_ITERATIONS  # no multiplier update left
