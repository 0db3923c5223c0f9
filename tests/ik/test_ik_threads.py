"""One DifferentialIK shared by threads gives the sequential results (issue #15, threads).

The reference is the same trajectories run one after the other on one solver. A task whose
rows take a moment to compute (as a user-defined feature written in Python does) makes the
threads interleave inside the assembly of a step, reliably: without the solver's lock a thread
then solves a QP whose rows belong partly to another thread's state (tests/_threads.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import JointConfiguration
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot, State
from taskspace.tasks import Task
from tests._threads import (
    SlowTask,
    assert_threads_match_sequential,
    ik_trajectory,
    offset_tcp_task,
    random_starts,
)

DT = 0.01
STEPS = 25
# Differences left by the QP warm start (another order of the same solves) are ~1e-6 rad;
# rows mixed between threads give errors of 1e-2 rad and more.
TOLERANCE = 1e-4


def _solver(robot: Robot, native: bool) -> DifferentialIK:
    task_type = Task if native else SlowTask
    posture = task_type(JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    return DifferentialIK(
        robot,
        [offset_tcp_task(robot), posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=native),
    )


@pytest.mark.parametrize("native", [False, True])
def test_shared_solver_matches_sequential(panda: Robot, native: bool) -> None:
    ik = _solver(panda, native)
    if native and not ik.native:
        pytest.skip("compiled IK kernel not built")
    starts = random_starts(panda)

    def trajectory(i: int) -> np.ndarray:
        return ik_trajectory(ik, panda, starts[i], STEPS, DT)

    assert_threads_match_sequential(trajectory, TOLERANCE)


def test_solver_docstrings_state_thread_safety() -> None:
    from taskspace.planning.collision_checker import CollisionChecker

    for cls in (DifferentialIK, State, CollisionChecker):
        assert "Thread safety" in (cls.__doc__ or ""), cls.__name__
