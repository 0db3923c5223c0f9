"""One DifferentialIK shared by threads gives the sequential results (issue #15, threads).

The reference is the same trajectories run one after the other on one solver. A task whose
rows take a moment to compute (as a user-defined feature written in Python does) makes the
threads interleave inside the assembly of a step, reliably: without the solver's lock a thread
then solves a QP whose rows belong partly to another thread's state.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import FramePose, JointConfiguration
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot, State
from taskspace.tasks import Task

DT = 0.01
STEPS = 25
THREADS = 4
# Differences left by the QP warm start (another order of the same solves) are ~1e-6 rad;
# rows mixed between threads give errors of 1e-2 rad and more.
TOLERANCE = 1e-4


class SlowTask(Task):
    """A task whose rows take a moment (a Python feature): the thread switches inside."""

    def rows(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        time.sleep(2e-4)
        return super().rows(state)


@pytest.fixture
def fast_switching() -> Iterator[None]:
    saved = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    yield
    sys.setswitchinterval(saved)


def _solver(robot: Robot, native: bool) -> DifferentialIK:
    state = robot.state()
    tcp = Task(FramePose(robot, "panda_hand_tcp"), name="tcp")
    tcp.set_target_from_state(state)
    target = tcp.target.copy()
    target.translation = target.translation + np.array([0.1, -0.1, 0.05])
    tcp.set_target(target)
    task_type = Task if native else SlowTask
    posture = task_type(JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    return DifferentialIK(
        robot,
        [tcp, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=native),
    )


def _starts(robot: Robot) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    lo, hi = robot.lower_limits, robot.upper_limits
    return [
        np.clip(robot.q_default + 0.3 * rng.standard_normal(robot.nq), lo, hi)
        for _ in range(THREADS)
    ]


def _trajectory(ik: DifferentialIK, robot: Robot, q0: np.ndarray) -> np.ndarray:
    state = robot.state(q0)
    out = []
    for _ in range(STEPS):
        q, result = ik.step(state, DT)
        assert result.success
        state.update(q)
        out.append(q)
    return np.array(out)


@pytest.mark.parametrize("native", [False, True])
def test_shared_solver_matches_sequential(panda: Robot, native: bool, fast_switching) -> None:  # type: ignore[no-untyped-def]
    ik = _solver(panda, native)
    if native and not ik.native:
        pytest.skip("compiled IK kernel not built")
    starts = _starts(panda)
    sequential = [_trajectory(ik, panda, q0) for q0 in starts]
    threaded: list[np.ndarray | None] = [None] * THREADS
    errors: list[BaseException] = []

    def work(i: int) -> None:
        try:
            threaded[i] = _trajectory(ik, panda, starts[i])
        except BaseException as exc:  # reported below with the thread's index
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert not errors, errors
    for i in range(THREADS):
        got = threaded[i]
        assert got is not None
        assert np.abs(got - sequential[i]).max() < TOLERANCE, f"thread {i} drifted"


def test_solver_docstrings_state_thread_safety() -> None:
    from taskspace.planning.collision_checker import CollisionChecker

    for cls in (DifferentialIK, State, CollisionChecker):
        assert "Thread safety" in (cls.__doc__ or ""), cls.__name__
