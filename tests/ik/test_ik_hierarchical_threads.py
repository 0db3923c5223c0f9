"""One HierarchicalIK shared by threads gives the sequential results (issue #15, threads).

As in ``test_ik_threads.py``: the reference is the same trajectories run one after the
other on one solver; a feature whose evaluation takes a moment (a Python feature) makes the
threads interleave inside the assembly of a step. Without the solver's lock a thread then
solves levels whose rows belong partly to another thread's state.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import FramePose, JointConfiguration, Position
from taskspace.ik import HierarchicalIK
from taskspace.model import Robot, State
from taskspace.tasks import Task

DT = 0.01
STEPS = 15
THREADS = 4
# Differences left by the cascade's warm starts (another order of the same solves) are
# ~1e-6 rad; rows mixed between threads give errors of 1e-2 rad and more.
TOLERANCE = 1e-4


class SlowPosition(Position):
    """A position feature that takes a moment (as a Python feature would)."""

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[np.ndarray, np.ndarray]:
        out = super().residual_and_jacobian(state, target)
        time.sleep(2e-4)
        return out


@pytest.fixture
def fast_switching() -> Iterator[None]:
    saved = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    yield
    sys.setswitchinterval(saved)


def _solver(robot: Robot) -> HierarchicalIK:
    state = robot.state()
    tcp = Task(FramePose(robot, "panda_hand_tcp"), name="tcp")
    tcp.set_target_from_state(state)
    target = tcp.target.copy()
    target.translation = target.translation + np.array([0.1, -0.1, 0.05])
    tcp.set_target(target)
    elbow = Task(SlowPosition(robot, "panda_link4"), name="elbow")
    elbow.set_target_from_state(state)
    elbow.set_target(elbow.target + np.array([0.0, 0.05, 0.0]))
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    return HierarchicalIK(
        robot,
        [[tcp], [elbow], [posture]],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
    )


def _starts(robot: Robot) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    lo, hi = robot.lower_limits, robot.upper_limits
    return [
        np.clip(robot.q_default + 0.3 * rng.standard_normal(robot.nq), lo, hi)
        for _ in range(THREADS)
    ]


def _trajectory(ik: HierarchicalIK, robot: Robot, q0: np.ndarray) -> np.ndarray:
    state = robot.state(q0)
    out = []
    for _ in range(STEPS):
        q, result = ik.step(state, DT)
        assert result.success
        state.update(q)
        out.append(q)
    return np.array(out)


def test_shared_hierarchical_solver_matches_sequential(panda: Robot, fast_switching) -> None:  # type: ignore[no-untyped-def]
    ik = _solver(panda)
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


def test_hierarchical_solver_docstring_states_thread_safety() -> None:
    assert "Thread safety" in (HierarchicalIK.__doc__ or "")
