"""One HierarchicalIK shared by threads gives the sequential results (issue #15, threads).

As in ``test_ik_threads.py``: the reference is the same trajectories run one after the
other on one solver; a feature whose evaluation takes a moment (a Python feature) makes the
threads interleave inside the assembly of a step. Without the solver's lock a thread then
solves levels whose rows belong partly to another thread's state (tests/_threads.py).
"""

from __future__ import annotations

import numpy as np

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import JointConfiguration
from taskspace.ik import HierarchicalIK
from taskspace.model import Robot
from taskspace.tasks import Task
from tests._threads import (
    SlowPosition,
    assert_threads_match_sequential,
    ik_trajectory,
    offset_tcp_task,
    random_starts,
)

DT = 0.01
STEPS = 15
# Differences left by the cascade's warm starts (another order of the same solves) are
# ~1e-6 rad; rows mixed between threads give errors of 1e-2 rad and more.
TOLERANCE = 1e-4


def _solver(robot: Robot) -> HierarchicalIK:
    elbow = Task(SlowPosition(robot, "panda_link4"), name="elbow")
    elbow.set_target_from_state(robot.state())
    elbow.set_target(elbow.target + np.array([0.0, 0.05, 0.0]))
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    return HierarchicalIK(
        robot,
        [[offset_tcp_task(robot)], [elbow], [posture]],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
    )


def test_shared_hierarchical_solver_matches_sequential(panda: Robot) -> None:
    ik = _solver(panda)
    starts = random_starts(panda)

    def trajectory(i: int) -> np.ndarray:
        return ik_trajectory(ik, panda, starts[i], STEPS, DT)

    assert_threads_match_sequential(trajectory, TOLERANCE)


def test_hierarchical_solver_docstring_states_thread_safety() -> None:
    assert "Thread safety" in (HierarchicalIK.__doc__ or "")
