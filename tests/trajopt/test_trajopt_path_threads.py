"""One PathProblem optimized from several threads gives the sequential results (issue #15).

The problem owns its kinematic workspace (one State per slice); without its lock two threads
mixed their kinematics and returned paths up to 1.5e-5 rad (with a slow Python feature: far
more) off the sequential result. Reference: the same work run one thread after the other.
"""

from __future__ import annotations

import numpy as np

from taskspace.model import Robot
from taskspace.tasks import Task
from taskspace.trajopt import (
    PathCost,
    PathEquality,
    PathOptimizationOptions,
    PathProblem,
    optimize_path,
)
from tests._threads import SlowPosition, assert_threads_match_sequential


def test_one_problem_shared_by_threads_matches_the_sequential_run() -> None:
    robot = Robot.load("ur5")
    frame = "tool0"
    goal = np.array([0.3, 0.2, 0.4])
    problem = PathProblem(
        robot,
        robot.q_default,
        6,
        equalities=[PathEquality(Task(SlowPosition(robot, frame), goal), times=-1)],
        costs=[PathCost(Task(SlowPosition(robot, frame), goal + 0.05, weight=0.3))],
    )
    options = PathOptimizationOptions(max_iterations=30)
    rng = np.random.default_rng(0)
    starts = [robot.q_default + 0.05 * rng.standard_normal((3, robot.nq)) for _ in range(4)]
    for s in starts:
        s[0] = robot.q_default

    def work(i: int) -> np.ndarray:
        return optimize_path(problem, starts[i], options=options).path

    assert_threads_match_sequential(work, 1e-12)
