"""solve_ik used as a new user would (audit5): shared tasks, zero weights, zero damping.

References are Pinocchio's own forward kinematics (``pin.framesForwardKinematics``), not
another path of taskspace.
"""

from __future__ import annotations

import sys
import threading

import numpy as np
import pinocchio as pin

from taskspace import features as F
from taskspace.ik import SolveIKOptions, solve_ik
from taskspace.model import Robot, State
from taskspace.tasks import Task
from tests.conftest import load_robot


def _frame(robot: Robot, q: np.ndarray, frame: str) -> pin.SE3:
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return data.oMf[model.getFrameId(frame)].copy()


def _reachable_pose(robot: Robot, frame: str) -> pin.SE3:
    q = robot.q_default.copy()
    q[:4] += [0.3, -0.2, 0.25, 0.3]  # inside the panda's limits
    return _frame(robot, q, frame)


class _RecordingPosition(F.Position):
    """A position feature that records the gain of its task at every evaluation."""

    task: Task
    seen: list[float]

    def value(self, state: State) -> np.ndarray:
        self.seen.append(self.task.gain)
        return super().value(state)


def test_solve_ik_does_not_change_the_task_gain_while_it_runs() -> None:
    # solve_ik's docstring: it "only reads the tasks", so another thread stepping with the same
    # task keeps seeing its gain. It set every task's gain to 1 for the solve and back after.
    robot = load_robot("panda")
    frame = robot.end_effectors[0]
    feature = _RecordingPosition(robot, frame)
    task = Task(feature, _reachable_pose(robot, frame).translation, gain=0.3)
    feature.task, feature.seen = task, []
    result = solve_ik(robot, [task])
    assert result.success
    assert feature.seen and set(feature.seen) == {0.3}
    assert task.gain == 0.3


def test_concurrent_solve_ik_on_shared_tasks_keeps_their_gain() -> None:
    # Two threads solving with one task: one thread saved the gain the other had set to 1 and
    # restored that, so the task's gain ended as 1.0 (it was 0.3).
    robot = load_robot("panda")
    frame = robot.end_effectors[0]
    target = _reachable_pose(robot, frame)
    task = Task(F.FramePose(robot, frame), target, gain=0.3)
    failures: list[BaseException] = []
    gains: list[float] = []

    def work() -> None:
        try:
            for _ in range(15):
                result = solve_ik(robot, [task])
                assert result.success
                gains.append(task.gain)
        except BaseException as exc:  # reported below
            failures.append(exc)

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # threads take turns often: the solves overlap
    try:
        threads = [threading.Thread(target=work) for _ in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    assert not failures
    assert task.gain == 0.3
    assert set(gains) == {0.3}


def test_zero_weight_directions_are_not_required_to_converge() -> None:
    # A pose task with weight [1, 1, 1, 0, 0, 0] asks for the position only: the position was
    # reached to 1e-16 but the result said STALLED, success False (the rotation error, weighted
    # 0, was compared with rotation_tolerance).
    robot = load_robot("panda")
    frame = robot.end_effectors[0]
    target = pin.SE3(pin.exp3(np.array([0.5, 0.3, 0.0])), _reachable_pose(robot, frame).translation)
    task = Task(F.FramePose(robot, frame), target, weight=[1, 1, 1, 0, 0, 0])
    result = solve_ik(robot, [task])
    assert result.success, result.status
    reached = _frame(robot, result.q, frame)
    assert np.linalg.norm(reached.translation - target.translation) < 1e-6
    # the reported error stays the whole residual's norm (the rotation is not reached)
    assert result.errors[task.name] > 0.1


def test_a_task_of_weight_zero_does_not_block_convergence() -> None:
    # A posture task of weight 0 next to a position task: 200 iterations, MAX_ITERATIONS.
    robot = load_robot("panda")
    frame = robot.end_effectors[0]
    target = _reachable_pose(robot, frame).translation
    reach = Task(F.Position(robot, frame), target)
    posture = Task(F.JointConfiguration(robot), robot.q_default + 0.4, weight=0.0)
    result = solve_ik(robot, [reach, posture])
    assert result.success, result.status
    assert np.linalg.norm(_frame(robot, result.q, frame).translation - target) < 1e-6


def test_a_zero_weight_direction_still_counts_when_weighted() -> None:
    # the weighted directions keep their tolerance: an unreachable position is not converged
    robot = load_robot("panda")
    frame = robot.end_effectors[0]
    task = Task(F.FramePose(robot, frame), pin.SE3(np.eye(3), np.array([3.0, 0, 0.5])))
    task.weight = [1, 1, 1, 0, 0, 0]
    result = solve_ik(robot, [task])
    assert not result.success
    assert np.linalg.norm(_frame(robot, result.q, frame).translation - [3.0, 0, 0.5]) > 1.0


def test_initial_damping_zero_is_accepted_on_a_redundant_arm() -> None:
    # SolveIKOptions(initial_damping=0.0) passes the options check (damping >= 0), but the
    # first step of a 3-row task on the 7-joint panda raised SolverError (H not positive
    # definite): the loop floors the damping at 1e-12 only after the first step.
    robot = load_robot("panda")
    frame = robot.end_effectors[0]
    target = _reachable_pose(robot, frame).translation
    result = solve_ik(
        robot,
        [Task(F.Position(robot, frame), target)],
        options=SolveIKOptions(initial_damping=0.0),
    )
    assert result.success
    assert np.linalg.norm(_frame(robot, result.q, frame).translation - target) < 1e-6
