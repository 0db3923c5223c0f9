"""Acceleration-level controllers shared by threads give the sequential results (#15).

``InverseDynamicsQP`` (weighted and hierarchical) and ``OperationalSpaceController`` keep
preallocated buffers (task rows, the QP's arrays, the controller's state). The reference is
the same sequence of states solved one after the other; a feature whose evaluation takes a
moment (a Python feature) makes the threads interleave inside the assembly of a step.
Without the controller's lock a thread then solves rows that belong to another thread's
state (tests/_threads.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.control.operational_space import OperationalSpaceController
from taskspace.features import FramePose, JointConfiguration
from taskspace.model import Robot
from taskspace.tasks import Task
from tests._threads import (
    THREADS,
    SlowCenterOfMass,
    SlowPosition,
    assert_threads_match_sequential,
)
from tests.conftest import load_robot

STATES = 6
# Differences left by the QP warm start (another order of the same solves) are far below
# this; rows mixed between threads give errors of the order of the accelerations.
TOLERANCE = 1e-5


def _states(robot: Robot, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(STATES):
        q = robot.q_default.copy()
        start = 7 if robot.is_floating else 0
        q[start:] += rng.normal(scale=0.1, size=robot.nq - start)
        out.append((q, rng.normal(scale=0.3, size=robot.nv)))
    return out


def _g1_controller(hierarchical: bool) -> InverseDynamicsQP:
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    feet = ["left_ankle_roll_link", "right_ankle_roll_link"]
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in feet]
    com = Task(SlowCenterOfMass(robot), kp=50.0, priority=0)
    com.set_target_from_state(s)
    hand = Task(FramePose(robot, "left_rubber_hand"), kp=50.0, weight=0.1, priority=1)
    hand.set_target_from_state(s)
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=2)
    options = InverseDynamicsOptions(hierarchical=hierarchical)
    return InverseDynamicsQP(robot, [com, hand, posture], contacts, options)


@pytest.mark.parametrize("hierarchical", [False, True])
def test_shared_inverse_dynamics_qp_matches_sequential(hierarchical: bool) -> None:
    ctrl = _g1_controller(hierarchical)
    robot = ctrl.robot
    inputs = [_states(robot, seed) for seed in range(THREADS)]

    def solve_all(i: int) -> np.ndarray:
        state = robot.state(robot.q_default, np.zeros(robot.nv))
        out = []
        for q, v in inputs[i]:
            state.update(q, v)
            result = ctrl.solve(state)
            out.append(np.concatenate([result.a, result.tau]))
        return np.array(out)

    assert_threads_match_sequential(solve_all, TOLERANCE, relative=True)


def test_shared_operational_space_controller_matches_sequential() -> None:
    robot = load_robot("panda")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    tcp = Task(SlowPosition(robot, "panda_hand_tcp"), kp=100.0)
    tcp.set_target_from_state(s)
    tcp.set_target(tcp.target + np.array([0.05, 0.0, -0.05]))
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-2, kp=10.0)
    ctrl = OperationalSpaceController(robot, [tcp, posture])
    inputs = [_states(robot, 10 + seed) for seed in range(THREADS)]

    def run(i: int) -> np.ndarray:
        return np.array([ctrl(0.0, q, v) for q, v in inputs[i]])

    assert_threads_match_sequential(run, TOLERANCE, relative=True)


def test_controller_docstrings_state_thread_safety() -> None:
    assert "Thread safety" in (InverseDynamicsQP.__doc__ or "")
    assert "threads" in (OperationalSpaceController.__doc__ or "")
