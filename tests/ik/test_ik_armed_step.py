"""``DifferentialIK.advance``'s armed kernel step (``WeightedIKKernel.arm`` / ``step``).

When every box is constant at a ``dt`` (``bounds_read_state = False``), the kernel keeps the
model, the tasks, the boxes and the damping, and the lean call passes only the state's data,
``q`` and ``dt``. References, independent of the kernel: quadprog's minimizer of the QP the
Python path builds at the state before each step, that QP's KKT residuals at the step
(multipliers recovered from stationarity), Pinocchio's ``integrate`` and a fresh
``pin.Data`` at the new configuration.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.errors import InvalidInputError
from taskspace.ik import DifferentialIK
from taskspace.model import Robot, State
from taskspace.qp.kkt import box_kkt_residuals
from taskspace.tasks import Task
from tests.conftest import load_robot

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")

DT = 0.01


class SoftVelocityBox(JointVelocityLimits):
    """A soft, state-independent box: a fraction of the velocity limits (declared constant)."""

    hard_bounds = False
    bounds_read_state = False

    def bounds(self, state: State, dt: float) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[override]
        lb, ub = super().bounds(state, dt)
        return 0.6 * lb, 0.6 * ub


def _reference(ik: DifferentialIK, state: State, dt: float) -> np.ndarray:
    """quadprog's minimizer of the Python path's QP at ``state``."""
    p = ik.build(state, dt)
    n = p.n
    lo, hi = p.lb > -1e19, p.ub < 1e19
    C = np.hstack([np.eye(n)[lo].T, -np.eye(n)[hi].T])
    b = np.concatenate([p.lb[lo], -p.ub[hi]])
    return np.asarray(quadprog.solve_qp(p.H, -p.g, C, b, 0)[0])


def _assert_kinematics(robot: Robot, state: State) -> None:
    """The state's data equal Pinocchio's at (state.q, state.v), computed afresh."""
    model = robot.model
    ref = model.createData()
    if state.has_velocity:
        pin.forwardKinematics(model, ref, state.q, state.v, np.zeros(robot.nv))
        pin.computeJointJacobians(model, ref)
    else:
        pin.computeJointJacobians(model, ref, state.q)
    pin.updateFramePlacements(model, ref)
    data = state.data
    for f in range(model.nframes):
        np.testing.assert_allclose(data.oMf[f].homogeneous, ref.oMf[f].homogeneous, atol=1e-12)
    np.testing.assert_allclose(data.J, ref.J, atol=1e-12)
    if state.has_velocity:
        for j in range(model.njoints):
            np.testing.assert_allclose(data.v[j].vector, ref.v[j].vector, atol=1e-12)


def _random_stack(robot: Robot, rng: np.random.Generator) -> tuple[list[Task], list[Task]]:
    """Pose/position tasks on random frames, maybe the CoM, a posture; random weights, gains."""
    state = robot.state(robot.q_default)
    bodies = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    tasks = []
    for kind in rng.permutation(["pose", "position", "com", "pose"])[: rng.integers(2, 5)]:
        if kind == "com":
            task = Task(F.CenterOfMass(robot), weight=float(rng.uniform(0.1, 2)))
            task.set_target(state.com() + rng.uniform(-0.05, 0.05, 3))
        else:
            name = str(rng.choice(bodies))
            feature = F.FramePose(robot, name) if kind == "pose" else F.Position(robot, name)
            task = Task(feature, weight=float(rng.uniform(0.1, 2)), gain=float(rng.uniform(0.2, 1)))
            M = state.frame_placement(robot.frame_id(name))
            shift = pin.exp6(rng.uniform(-0.3, 0.3, 6))
            task.set_target(M * shift if kind == "pose" else (M * shift).translation)
        tasks.append(task)
    weight = float(rng.uniform(1e-4, 1e-2))
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=weight)
    return tasks, [*tasks, posture]


def _random_q(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    q = pin.integrate(robot.model, robot.q_default, 0.4 * rng.standard_normal(robot.nv))
    idx = robot.limited_joints_q
    q[idx] = np.clip(q[idx], robot.lower_limits[idx] + 0.01, robot.upper_limits[idx] - 0.01)
    return q


def _moving_targets(tasks: list[Task], rng: np.random.Generator) -> None:
    """Move every non-posture task's target a little (the kernel reads them at each call)."""
    for task in tasks:
        T = task.target
        if isinstance(T, pin.SE3):
            task.set_target(T * pin.exp6(rng.uniform(-0.05, 0.05, 6)))
        else:
            task.set_target(np.asarray(T) + rng.uniform(-0.02, 0.02, 3))


@pytest.mark.parametrize("name", ["panda", "g1"])
def test_armed_steps_match_quadprog_kkt_and_pinocchio(name: str) -> None:
    """Random stacks, states (with and without velocity) and boxes (hard and soft)."""
    robot = load_robot(name)
    rng = np.random.default_rng(11)
    armed = constrained = 0
    for trial in range(4):
        moving, tasks = _random_stack(robot, rng)
        boxes = [JointPositionLimits(robot), JointVelocityLimits(robot)]
        if trial % 2:
            boxes.append(SoftVelocityBox(robot))
        ik = DifferentialIK(robot, tasks, boxes)
        assert ik.native
        q = _random_q(robot, rng)
        v = 0.1 * rng.standard_normal(robot.nv)
        state = robot.state(q, v) if trial >= 2 else robot.state(q)
        for _ in range(6):
            _moving_targets(moving, rng)
            before = robot.state(state.q, state.v) if state.has_velocity else robot.state(state.q)
            x = _reference(ik, before, DT)
            was_armed = ik._lean_step is not None and ik._lean_dt == DT
            result = ik.advance(state, DT)
            armed += was_armed
            assert result.success and result.qp.backend == "native"
            constrained += result.qp.status.name != "UNCONSTRAINED"
            np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
            kkt = box_kkt_residuals(ik.build(before, DT), result.dq)
            assert kkt.primal < 1e-9 and kkt.dual < 1e-8 and kkt.complementarity < 1e-9
            expected = pin.integrate(robot.model, before.q, result.dq)
            np.testing.assert_allclose(state.q, expected, atol=1e-14, rtol=0)
            assert state.has_velocity == (trial >= 2)
            if state.has_velocity:
                np.testing.assert_allclose(state.v, result.dq / DT, atol=1e-14, rtol=0)
            _assert_kinematics(robot, state)
            # the new q (and v) are read-only for good, and nobody else's
            for a in (state.q, state.v) if state.has_velocity else (state.q,):
                assert not a.flags.writeable
                with pytest.raises(ValueError):
                    a.setflags(write=True)
            assert result.dq.flags.writeable and not np.shares_memory(result.dq, state.q)
    assert armed == 4 * 5  # every step after the first ran the armed kernel step
    assert constrained > 0


def test_armed_step_is_renewed_after_dt_assignments_and_the_robot_version() -> None:
    """Each key of the arming (dt, a task assignment, Robot.version) re-arms the kernel."""
    robot = Robot.load("panda")  # its own: set_limits below
    rng = np.random.default_rng(5)
    moving, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(_random_q(robot, rng))

    def step(dt: float = DT) -> None:
        x = _reference(ik, robot.state(state.q), dt)
        result = ik.advance(state, dt)
        np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)

    step()
    step()
    first = ik._lean_step
    assert first is not None
    step(0.05)  # another dt: the velocity box is 5x wider
    step(0.05)
    step(0.002)  # and narrower (active)
    step(0.002)
    moving[0].weight = 5.0  # an assignment: the weights are sent again, the kernel re-armed
    step(0.002)
    step(0.002)
    slow = 0.05 * robot.velocity_limits
    robot.set_limits(velocity=slow)  # a new version: a new box
    step(0.002)
    dq = ik.advance(state, 0.002).dq
    assert np.all(np.abs(dq) <= slow * 0.002 + 1e-12) and np.isclose(np.abs(dq / slow).max(), 0.002)
    # a target changed in place between armed steps is read (the kernel keeps the task)
    moving[0].set_target(moving[0].target)  # type: ignore[arg-type]
    step(0.002)


def test_disarmed_kernel_refuses_the_armed_step() -> None:
    robot = load_robot("panda")
    rng = np.random.default_rng(2)
    _, tasks = _random_stack(robot, rng)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(robot.q_default)
    ik.advance(state, DT)
    kernel = ik._native.kernel  # type: ignore[union-attr]
    kernel.disarm()
    with pytest.raises(InvalidInputError):
        kernel.step(state._data, state._q, 0.0)
