"""The compiled weighted IK step on a numerically singular Hessian (audit5).

``H = M^T M + mu I`` of a stack with a large weight (1e20 on a 3-row position task of the
7-joint panda, plus a posture of weight 1) or with ``damping=0`` on a rank-deficient stack is
not positive definite in floating point: the kernel's Cholesky fails. The kernel raised
SolverError ("damping 0 and a rank-deficient task stack, or a NaN weight; use a damping > 0",
also for damping 1e-6) where the Python path (proxsuite) solves the same QP. The compiled step
now declines and the Python path answers. Reference: the task rows with Pinocchio's Jacobian.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from taskspace import features as F
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.tasks import Task
from tests.conftest import load_robot


def _tasks(robot: Robot, weight: float) -> list[Task]:
    ee = robot.end_effectors[0]
    target = robot.frame_placement(robot.q_default, ee).translation + np.array([0.05, -0.03, 0.02])
    return [
        Task(F.Position(robot, ee), target, weight=weight, gain=0.5),
        Task(F.JointConfiguration(robot), robot.q_default),
    ]


def _assert_rows_met(robot: Robot, task: Task, q: np.ndarray, dq: np.ndarray) -> None:
    """The heavy task's linearized rows ``J dq = -gain e`` hold (Pinocchio's Jacobian).

    With a weight of 1e20 the rest of the step (the posture's share in the task's nullspace)
    is below the QP solver's relative tolerance: only the task's rows are checked.
    """
    model = robot.model
    data = model.createData()
    frame = model.getFrameId(task.feature.frame)  # type: ignore[attr-defined]
    pin.framesForwardKinematics(model, data, q)
    J = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)[:3]
    e = data.oMf[frame].translation - task.target
    assert np.abs(J @ dq + task.gain * e).max() < 1e-6


def test_compiled_step_declines_a_singular_hessian_of_a_large_weight() -> None:
    robot = load_robot("panda")
    tasks = _tasks(robot, 1e20)
    ik = DifferentialIK(robot, tasks)
    assert ik.native
    q = robot.q_default.copy()
    result = ik.solve(robot.state(q), 0.01)
    assert result.success
    assert "not positive definite" in result.native_declined
    _assert_rows_met(robot, tasks[0], q, result.dq)


def test_compiled_step_declines_damping_zero_on_a_rank_deficient_stack() -> None:
    # DifferentialIKOptions documents damping >= 0; with 0 the 3 rows of a position task on
    # 7 joints leave H singular: any step meeting the rows is a minimizer
    robot = load_robot("panda")
    reach = _tasks(robot, 1.0)[0]
    ik = DifferentialIK(robot, [reach], options=DifferentialIKOptions(damping=0.0))
    state = robot.state(robot.q_default)
    result = ik.solve(state, 0.01)
    assert result.success
    assert "not positive definite" in result.native_declined
    _assert_rows_met(robot, reach, state.q, result.dq)


def test_advance_after_a_declined_step_moves_the_state() -> None:
    # advance (fused, then armed) with the same stack: each step declines and moves the state
    robot = load_robot("panda")
    tasks = _tasks(robot, 1e20)
    ik = DifferentialIK(robot, tasks)
    state = robot.state(robot.q_default)
    for _ in range(3):
        q = state.q.copy()
        result = ik.advance(state, 0.01)
        assert result.success
        expected = pin.integrate(robot.model, q, result.dq)
        assert np.abs(state.q - expected).max() < 1e-12
        _assert_rows_met(robot, tasks[0], q, result.dq)


def test_armed_advance_that_meets_a_singular_hessian_falls_back() -> None:
    # damping 0: the step is defined while the 7 joints see 7 independent rows; the armed
    # lean path then meets a stack whose posture weight was set to 0 (rank 3)
    robot = load_robot("panda")
    ee = robot.end_effectors[0]
    target = robot.frame_placement(robot.q_default, ee).translation + np.array([0.05, -0.03, 0.02])
    reach = Task(F.Position(robot, ee), target, gain=0.5)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2)
    ik = DifferentialIK(robot, [reach, posture], options=DifferentialIKOptions(damping=0.0))
    state = robot.state(robot.q_default)
    for _ in range(3):  # fused, then armed
        assert ik.advance(state, 0.01).success
    posture.weight = 0.0
    q = state.q.copy()
    result = ik.advance(state, 0.01)
    assert result.success
    assert np.abs(state.q - pin.integrate(robot.model, q, result.dq)).max() < 1e-12
    # the minimum-norm solution is not required (damping 0): the task rows are met
    _assert_rows_met(robot, reach, q, result.dq)
