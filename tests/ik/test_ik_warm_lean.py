"""The compiled box QP's warm start and factor updates, and ``DifferentialIK.advance``'s lean path.

The kernel's box QP starts from the previous solve's active set and updates the Cholesky
factor of the free block when a bound is added or released; ``advance`` keeps, between
steps, what depends only on the stack, the tasks' assignments, ``dt`` and the robot's
version. References, independent of the kernel: quadprog's solution of the QP the Python
path builds at the state before each step, and that QP's KKT residuals at the kernel's step
(multipliers recovered from stationarity, :func:`taskspace.qp.kkt.box_kkt_residuals`).
"""

from __future__ import annotations

from itertools import pairwise

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


def _reference(ik: DifferentialIK, state: State, dt: float) -> tuple[np.ndarray, frozenset[int]]:
    """quadprog's minimizer of the Python path's QP and its active bounds (index, side)."""
    p = ik.build(state, dt)
    n = p.n
    lo, hi = p.lb > -1e19, p.ub < 1e19
    C = np.hstack([np.eye(n)[lo].T, -np.eye(n)[hi].T])
    b = np.concatenate([p.lb[lo], -p.ub[hi]])
    x = np.asarray(quadprog.solve_qp(p.H, -p.g, C, b, 0)[0])
    active = {i for i in range(n) if abs(x[i] - p.lb[i]) < 1e-9}
    active |= {n + i for i in range(n) if abs(x[i] - p.ub[i]) < 1e-9}
    return x, frozenset(active)


def _far_stack(robot: Robot) -> tuple[list[Task], list[Task]]:
    """Pose tasks on the robot's end frames (targets set by the test) and a posture."""
    names = (
        ["panda_hand_tcp"]
        if robot.name == "panda"
        else ["left_rubber_hand", "right_rubber_hand", "left_ankle_roll_link"]
    )
    moving = [Task(F.FramePose(robot, name), name=name) for name in names]
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    return moving, [*moving, posture]


def _set_targets(robot: Robot, state: State, moving: list[Task], k: int) -> None:
    """Targets that swing far (limits engage) and back (they release) with the step ``k``."""
    s = robot.state(robot.q_default)
    reach = 0.6 * np.sin(0.35 * k)
    for j, task in enumerate(moving):
        M = s.frame_placement(robot.frame_id(task.name))
        offset = np.array([reach, -0.5 * reach, 0.3 * np.cos(0.5 * k + j)])
        task.set_target(M * pin.SE3(pin.exp3(np.array([0.0, reach, 0.0])), offset))


@pytest.mark.parametrize("name", ["panda", "g1"])
def test_warm_started_steps_match_quadprog_while_the_active_set_changes(name: str) -> None:
    """``advance`` and ``solve`` (also at unrelated states: a wrong warm start) vs quadprog."""
    robot = load_robot(name)
    moving, tasks = _far_stack(robot)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    assert ik.native
    rng = np.random.default_rng(3)
    state = robot.state(robot.q_default)
    sets = []
    for k in range(40):
        _set_targets(robot, state, moving, k)
        before = robot.state(state.q)
        if k % 5 == 4:  # solve at an unrelated in-limit state: the previous set is wrong
            q = pin.integrate(robot.model, robot.q_default, 0.5 * rng.standard_normal(robot.nv))
            idx = robot.limited_joints_q
            q[idx] = np.clip(q[idx], robot.lower_limits[idx], robot.upper_limits[idx])
            other = robot.state(q)
            x, _ = _reference(ik, other, DT)
            result = ik.solve(other, DT)
            assert result.qp.backend == "native"
            np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
        x, active = _reference(ik, before, DT)
        result = ik.advance(state, DT)
        assert result.success and result.qp.backend == "native"
        np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
        kkt = box_kkt_residuals(ik.build(before, DT), result.dq)
        assert kkt.primal < 1e-9 and kkt.dual < 1e-8 and kkt.complementarity < 1e-9
        assert (result.qp.status.name == "UNCONSTRAINED") == (not active)
        np.testing.assert_allclose(
            state.q, pin.integrate(robot.model, before.q, result.dq), atol=1e-14, rtol=0
        )
        sets.append(active)
    changes = sum(a != b for a, b in pairwise(sets))
    assert changes >= 10  # the active set changed often, bounds added and released
    assert sum(1 for a, b in pairwise(sets) if a and b and a != b) >= 3  # warm, not cold


def test_lean_results_are_independent() -> None:
    """A kept result is not changed by later steps (nothing in it is shared or reused)."""
    robot = load_robot("panda")
    moving, tasks = _far_stack(robot)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(robot.q_default)
    kept = []
    for k in range(6):
        _set_targets(robot, state, moving, k)
        result = ik.advance(state, DT)
        kept.append((result, result.dq.copy(), result.qp.objective, result.velocity.copy()))
    for result, dq, objective, velocity in kept:
        np.testing.assert_array_equal(result.dq, dq)
        np.testing.assert_array_equal(result.velocity, velocity)
        np.testing.assert_array_equal(result.velocity, dq / DT)
        assert result.qp.objective == objective and result.culprits == []
    assert len({id(r.dq) for r, *_ in kept}) == len(kept)
    assert len({id(r.culprits) for r, *_ in kept}) == len(kept)


def test_lean_path_follows_limits_weights_dt_and_damping() -> None:
    """What the lean path keeps is renewed after set_limits, an assignment, another dt."""
    robot = Robot.load("panda")  # its own: set_limits below
    moving, tasks = _far_stack(robot)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(robot.q_default)

    def step(dt: float = DT) -> np.ndarray:
        x, _ = _reference(ik, robot.state(state.q), dt)
        result = ik.advance(state, dt)
        np.testing.assert_allclose(result.dq, x, atol=1e-8, rtol=0)
        return result.dq

    _set_targets(robot, state, moving, 3)
    step()
    step()  # the lean path
    slow = 0.2 * robot.velocity_limits
    robot.set_limits(velocity=slow)  # the velocity box shrinks
    dq = step()
    assert np.all(np.abs(dq) <= slow * DT + 1e-12) and np.isclose(np.abs(dq / slow).max(), DT)
    top = np.maximum(state.q, robot.q_default) + 1e-3
    robot.set_limits(upper=np.where(np.isfinite(robot.upper_limits), top, np.inf))
    step()  # the position box (the kernel's copy) follows
    moving[0].weight = 7.0
    step()
    step(0.02)
    step(0.02)
    moving[0].lm_damping = 1e-3  # the kernel has no LM damping: the Python path
    result = ik.advance(state, DT)
    assert result.qp.backend != "native"
    moving[0].lm_damping = 0.0
    assert ik.advance(state, DT).qp.backend == "native"


def test_lean_path_refuses_what_the_full_path_refuses() -> None:
    robot = load_robot("panda")
    moving, tasks = _far_stack(robot)
    ik = DifferentialIK(robot, tasks, [JointPositionLimits(robot), JointVelocityLimits(robot)])
    state = robot.state(robot.q_default)
    _set_targets(robot, state, moving, 2)
    ik.advance(state, DT)
    ik.advance(state, DT)  # armed
    q = state.q
    with pytest.raises(InvalidInputError):
        ik.advance(load_robot("g1").state(load_robot("g1").q_default), DT)
    for dt in (-DT, float("nan"), np.array([DT, DT])):
        with pytest.raises(InvalidInputError):
            ik.advance(state, dt)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError):
        ik.advance(q, DT)  # type: ignore[arg-type]
    np.testing.assert_array_equal(state.q, q)
    assert ik.advance(state, np.float64(DT)).qp.backend == "native"  # a float subclass
