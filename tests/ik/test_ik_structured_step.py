"""The compiled weighted IK step's structured factorization (floating-base robots).

Without dampers, the kernel factors the part of H that follows the kinematic tree (frame
tasks, damping, posture) without fill in and adds tasks on every column (the CoM) as a
low-rank correction for the unconstrained minimizer; the dense H is assembled only when that
minimizer leaves the box. References, independent of the kernel: quadprog's minimizer of the
QP the Python path builds (``DifferentialIK.build``) and that QP's KKT residuals at the step.
``structured_counts`` shows which path each step took: the tests require the structured one
(with no dense fallback), both with the box inactive and active.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.ik import DifferentialIK
from taskspace.model import Robot, State
from taskspace.qp.kkt import box_kkt_residuals
from taskspace.tasks import Task
from tests.conftest import load_robot

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")

DT = 0.01
FRAMES = {
    "g1": (
        ["left_ankle_roll_link", "right_ankle_roll_link"],
        ["left_rubber_hand", "right_rubber_hand"],
    ),
    "talos": (["leg_left_6_link", "leg_right_6_link"], ["gripper_left_base_link", "head_2_link"]),
}


def _reference(ik: DifferentialIK, state: State, dt: float) -> np.ndarray:
    """quadprog's minimizer of the Python path's QP at ``state``."""
    p = ik.build(state, dt)
    n = p.n
    lo, hi = p.lb > -1e19, p.ub < 1e19
    C = np.hstack([np.eye(n)[lo].T, -np.eye(n)[hi].T])
    b = np.concatenate([p.lb[lo], -p.ub[hi]])
    return np.asarray(quadprog.solve_qp(p.H, -p.g, C, b, 0)[0])


class SlowVelocityLimits(JointVelocityLimits):
    """A fraction of the velocity limits (state-independent): the box is often active."""

    bounds_read_state = False

    def __init__(self, robot: Robot, fraction: float) -> None:
        super().__init__(robot)
        self.fraction = fraction

    def bounds(self, state: State, dt: float) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[override]
        lb, ub = super().bounds(state, dt)
        return self.fraction * lb, self.fraction * ub


def _stack(
    robot: Robot, name: str, rng: np.random.Generator, coms: int, q: np.ndarray, reach: float
) -> list[Task]:
    """Feet and hand (or head) poses or positions with random weights, ``coms`` CoM tasks,
    a posture; targets up to ``reach`` [m, rad] from their value at ``q``."""
    state = robot.state(q)
    feet, hands = FRAMES[name]
    tasks = []
    for frame in (*feet, *hands):
        position = rng.random() < 0.3
        feature = F.Position(robot, frame) if position else F.FramePose(robot, frame)
        task = Task(feature, weight=float(rng.uniform(0.2, 3)), gain=float(rng.uniform(0.3, 1)))
        M = state.frame_placement(robot.frame_id(frame)) * pin.exp6(rng.uniform(-reach, reach, 6))
        task.set_target(M.translation if position else M)
        tasks.append(task)
    for _ in range(coms):
        com = Task(F.CenterOfMass(robot), weight=float(rng.uniform(0.5, 20)))
        com.set_target(state.com() + rng.uniform(-reach, reach, 3))
        tasks.append(com)
    weight = float(rng.uniform(1e-4, 1e-2))
    tasks.append(Task(F.JointConfiguration(robot), robot.q_default, weight=weight))
    return tasks


@pytest.mark.parametrize("name", ["g1", "talos"])
def test_structured_steps_match_quadprog_with_the_box_inactive_and_active(name: str) -> None:
    """CoM + feet + hands + posture: every step equals quadprog and meets the KKT
    conditions; steps with the box inactive and active both went the structured way."""
    robot = load_robot(name)
    rng = np.random.default_rng(7)
    unconstrained = active = 0
    trials = [(1, 1.0, 0.002), (1, 0.05, 0.1), (0, 1.0, 0.002), (2, 0.3, 0.05)]
    for trial, (coms, fraction, reach) in enumerate(trials):
        q = pin.integrate(robot.model, robot.q_default, 0.05 * rng.standard_normal(robot.nv))
        tasks = _stack(robot, name, rng, coms, q, reach)
        tasks[-1].set_target(q)  # the posture at q: small steps when the reach is small
        boxes = [JointPositionLimits(robot), SlowVelocityLimits(robot, fraction)]
        ik = DifferentialIK(robot, tasks, boxes)
        assert ik.native
        state = robot.state(q) if trial % 2 else robot.state(q, np.zeros(robot.nv))
        for k in range(5):
            before = robot.state(state.q)
            x = _reference(ik, before, DT)
            result = ik.advance(state, DT) if k % 2 else ik.solve(before, DT)
            if not k % 2:
                state = robot.state(pin.integrate(robot.model, before.q, result.dq))
            assert result.success and result.qp.backend == "native"
            np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
            kkt = box_kkt_residuals(ik.build(before, DT), result.dq)
            assert kkt.primal < 1e-9 and kkt.dual < 1e-8 and kkt.complementarity < 1e-9
        used, rows, free, boxed, dense = ik._native.kernel.structured_counts()  # type: ignore[union-attr]
        assert used and rows == 3 * coms
        assert dense == 0  # never fell back to the dense factorization
        assert free + boxed == 5
        unconstrained += free
        active += boxed
    assert unconstrained > 0 and active > 0


def test_structured_step_is_planned_only_where_it_pays() -> None:
    """A serial arm (Panda: every column on one chain, H dense) keeps the dense Cholesky."""
    robot = load_robot("panda")
    state = robot.state(robot.q_default)
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"))
    tcp.set_target(state.frame_placement(robot.frame_id("panda_hand_tcp")))
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    ik = DifferentialIK(robot, [tcp, posture], [JointPositionLimits(robot)])
    x = _reference(ik, state, DT)
    np.testing.assert_allclose(ik.solve(state, DT).dq, x, atol=1e-8, rtol=0)
    used, _, free, boxed, dense = ik._native.kernel.structured_counts()  # type: ignore[union-attr]
    assert not used and free == boxed == dense == 0
