"""DifferentialIK.advance / solve from several threads on one solver (issue #15, threads).

Each thread moves its own State with ``advance`` (or alternates ``solve`` + ``State.update``
with ``advance``) on one shared solver; the reference is the same trajectories run one after
the other. The Python path uses a task whose rows take a moment (tests/_threads.py) so that
threads interleave inside a step; the compiled kernel is checked too. The returned steps must
stay each thread's own (kept and compared after all threads end: a buffer shared between
calls would show another thread's step).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import JointConfiguration
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.tasks import Task
from tests._threads import (
    SlowTask,
    assert_threads_match_sequential,
    offset_tcp_task,
    random_starts,
)

DT = 0.01
STEPS = 20
TOLERANCE = 1e-4  # warm-start differences ~1e-6 rad; mixed rows give 1e-2 rad and more


def _solver(robot: Robot, native: bool) -> DifferentialIK:
    task_type = Task if native else SlowTask
    posture = task_type(JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    return DifferentialIK(
        robot,
        [offset_tcp_task(robot), posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=native),
    )


def _run(ik: DifferentialIK, robot: Robot, q0: np.ndarray, mixed: bool) -> np.ndarray:
    """Configurations and steps of one trajectory, (STEPS, nq + nv); each step checked."""
    state = robot.state(q0)
    rows: list[tuple[np.ndarray, Any]] = []
    for k in range(STEPS):
        q_before = state.q.copy()
        if mixed and k % 2:
            result = ik.solve(state, DT)
            state.update(pin.integrate(robot.model, state.q, result.dq))
        else:
            result = ik.advance(state, DT)
        assert result.success
        # the state moved by exactly the returned step (its own, not another thread's)
        expected = pin.integrate(robot.model, q_before, result.dq)
        np.testing.assert_allclose(state.q, expected, atol=1e-12)
        rows.append((state.q.copy(), result))
    # steps read back after the whole trajectory (and the other threads' calls)
    return np.array([np.concatenate([q, r.dq]) for q, r in rows])


@pytest.mark.parametrize("mixed", [False, True], ids=["advance", "solve+advance"])
@pytest.mark.parametrize("native", [False, True], ids=["python", "compiled"])
def test_shared_solver_advance_matches_sequential(panda: Robot, native: bool, mixed: bool) -> None:
    ik = _solver(panda, native)
    if native and not ik.native:
        pytest.skip("compiled IK kernel not built")
    starts = random_starts(panda)
    assert_threads_match_sequential(lambda i: _run(ik, panda, starts[i], mixed), TOLERANCE)
