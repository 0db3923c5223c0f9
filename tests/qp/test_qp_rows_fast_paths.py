"""The per-step fast paths of the stacking layer against independent references.

* :class:`~taskspace.qp.rows.BoxStack` (the box of the IK step in preallocated buffers)
  against the rules of :func:`~taskspace.qp.rows.combine_boxes` written out joint by joint,
  with conflicts, NaN bounds and a constraint that has a box on some steps only.
* :meth:`TaskRowStack.velocity` (rows written in place) against ``sqrt(rho) J`` and
  ``-gain sqrt(rho) e`` from the features' own values, and a ``Task`` subclass overriding
  ``rows``.
* ``JointConfiguration`` on floating-base and partial postures (``q[iq] - q*[iq]``, identity
  rows) against Pinocchio's ``difference`` and ``dDifference``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Constraint, JointPositionLimits, JointVelocityLimits
from taskspace.features.rows import INF, Box, TaskRows
from taskspace.qp.rows import BoxStack, TaskRowStack
from taskspace.tasks import Task
from tests.conftest import load_robot


def _reference_box(hard: list[Any], soft: list[Any], n: int) -> tuple[np.ndarray, np.ndarray]:
    """The documented rules of ``combine_boxes``, one joint at a time (plain floats)."""
    lb, ub = np.empty(n), np.empty(n)
    for i in range(n):
        hl = max([-INF] + [float(b[0][i]) for b in hard]) if hard else -INF
        hu = min([INF] + [float(b[1][i]) for b in hard]) if hard else INF
        if hard and len(hard) == 1:
            hl, hu = float(hard[0][0][i]), float(hard[0][1][i])
        if hl > hu:  # conflicting hard boxes: midpoint of the gap
            hl = hu = 0.5 * (hl + hu)
        if not soft:
            lb[i], ub[i] = hl, hu
            continue
        sl = float(soft[0][0][i]) if len(soft) == 1 else max(float(b[0][i]) for b in soft)
        su = float(soft[0][1][i]) if len(soft) == 1 else min(float(b[1][i]) for b in soft)
        if not hard:
            lb[i], ub[i] = (sl, su) if not sl > su else (0.5 * (sl + su),) * 2
            continue
        lo, hi = np.maximum(hl, sl), np.minimum(hu, su)  # NaN propagates as in numpy
        if lo > hi:
            if sl > su:  # empty soft box (even one reaching past both sides of the hard
                lo = hi = min(max(0.5 * (sl + su), hl), hu)  # box): its midpoint, clipped
            elif su < hl:  # soft box below the hard one: the hard lower bound
                lo = hi = hl
            else:  # above: the hard upper bound
                lo = hi = hu
        lb[i], ub[i] = lo, hi
    return lb, ub


class _Box(Constraint):
    """A box given by the test (``None``: no box this step)."""

    def __init__(self, robot: Any, name: str, hard: bool) -> None:
        super().__init__(robot, name)
        self.hard_bounds = hard
        self.box: Box | None = None

    def bounds(self, state: Any, dt: float) -> Box | None:
        return self.box


def test_box_stack_follows_the_rules_on_random_boxes() -> None:
    robot = load_robot("panda")
    nv = robot.nv
    state = robot.state(robot.q_default)
    rng = np.random.default_rng(7)
    velocity = _Box(robot, "velocity", hard=True)
    position = _Box(robot, "position", hard=False)
    other = _Box(robot, "sometimes", hard=True)
    stack = BoxStack([velocity, position, Constraint(robot, "no box")], nv)
    stack3 = BoxStack([velocity, position, other], nv)
    assert [c.name for c in stack.constraints] == ["velocity", "position"]
    for trial in range(300):
        v = rng.uniform(0.1, 1.0, nv)
        centre = rng.uniform(-1.5, 1.5, nv)
        half = rng.uniform(-0.3, 1.0, nv)  # negative: an empty position box
        velocity.box = Box(-v, v) if trial % 7 else Box(v, -v)  # conflicting hard box
        position.box = Box(centre - half, centre + half)
        if trial % 11 == 0:
            position.box.lower[rng.integers(nv)] = np.nan
        lb, ub, blocks = stack.fill(state, 0.01)
        ref_lb, ref_ub = _reference_box([velocity.box], [position.box], nv)
        np.testing.assert_array_equal(lb, ref_lb)
        np.testing.assert_array_equal(ub, ref_ub)
        assert [b.name for b in blocks] == ["velocity", "position"]
        other.box = Box(-2 * v, 0.5 * v) if trial % 2 else None
        lb, ub, blocks = stack3.fill(state, 0.01)
        hard = [velocity.box] + ([other.box] if other.box is not None else [])
        ref_lb, ref_ub = _reference_box(hard, [position.box], nv)
        np.testing.assert_array_equal(lb, ref_lb)
        np.testing.assert_array_equal(ub, ref_ub)
        expected = ["velocity", "position"] + (["sometimes"] if other.box is not None else [])
        assert [b.name for b in blocks] == expected


def test_box_stack_of_the_joint_limits_is_their_intersection() -> None:
    robot = load_robot("panda")
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    stack = BoxStack(limits, robot.nv)
    q = robot.q_default.copy()
    q[3] = robot.upper_limits[3] - 1e-3  # the velocity box reaches past the limit
    state = robot.state(q)
    lb, ub, _ = stack.fill(state, 0.01)
    step = robot.velocity_limits * 0.01
    np.testing.assert_array_equal(lb, np.maximum(-step, robot.lower_limits - q))
    np.testing.assert_array_equal(ub, np.minimum(step, robot.upper_limits - q))


class _Doubled(Task):
    """A task whose rows are twice the plain ones (a user override of ``rows``)."""

    def rows(self, state: Any) -> TaskRows:
        J, r = super().rows(state)
        return TaskRows(2.0 * J, 2.0 * r)


@pytest.mark.parametrize("name", ["panda", "g1"])
def test_task_row_stack_velocity_rows_from_the_features(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(3)
    q = pin.integrate(robot.model, robot.q_default, 0.3 * rng.standard_normal(robot.nv))
    state = robot.state(q)
    frame = robot.model.frames[robot.model.nframes - 1].name
    pose = F.FramePose(robot, frame)
    com = F.CenterOfMass(robot)
    posture = F.JointConfiguration(robot)
    target = pin.SE3(pin.exp6(0.1 * rng.standard_normal(6)))
    tasks = [
        Task(pose, target, weight=1.0, gain=0.5),
        Task(com, [0.1, 0.0, 0.6], weight=4.0, gain=0.3),
        Task(posture, robot.q_default, weight=rng.uniform(0.0, 2.0, posture.dim), gain=0.7),
        _Doubled(com, [0.0, 0.1, 0.5], weight=9.0),
    ]
    stack = TaskRowStack(tasks, robot.nv)
    J, r = stack.velocity(state)
    k = 0
    for t in tasks:
        e = t.feature.residual(state, t.target)
        Jf = t.feature.residual_jacobian(state, t.target)
        w = np.sqrt(np.broadcast_to(t.weight, (t.dim,)))[:, None]
        scale = 2.0 if isinstance(t, _Doubled) else 1.0
        np.testing.assert_allclose(J[k : k + t.dim], scale * w * Jf, rtol=1e-15, atol=1e-15)
        np.testing.assert_allclose(
            r[k : k + t.dim], -scale * t.gain * w[:, 0] * e, rtol=1e-15, atol=1e-15
        )
        k += t.dim
    assert k == stack.size


def _posture_reference(robot: Any, feature: Any, q: Any, target: Any) -> tuple[Any, Any]:
    diff = np.asarray(pin.difference(robot.model, target, q))
    jac = np.asarray(pin.dDifference(robot.model, target, q, pin.ARG1))
    if feature.rows is None:
        return diff, jac
    return diff[feature.rows], jac[feature.rows]


@pytest.mark.parametrize("name", ["g1", "solo12", "tiago"])
def test_posture_rows_are_pinocchio_difference(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(5)
    features = [F.JointConfiguration(robot), F.JointConfiguration(robot, floating_base=True)]
    joints = [robot.model.names[j] for j in range(2, robot.model.njoints)]
    features.append(F.JointConfiguration(robot, joints[-3:] + joints[:2]))  # any order
    for feature in features:
        for _ in range(5):
            q = robot.random_configuration(rng)
            target = robot.random_configuration(rng)
            state = robot.state(q)
            e_ref, J_ref = _posture_reference(robot, feature, q, target)
            e, J = feature.residual_and_jacobian(state, target)
            np.testing.assert_array_equal(e, e_ref)
            np.testing.assert_array_equal(J, J_ref)
            np.testing.assert_array_equal(feature.residual(state, target), e_ref)
            np.testing.assert_array_equal(feature.residual_jacobian(state, target), J_ref)


def test_posture_with_a_continuous_joint_keeps_the_lie_group_difference() -> None:
    robot = load_robot("tiago")  # wheels: unbounded revolute joints (nq 2, nv 1)
    feature = F.JointConfiguration(robot, ["arm_1_joint", "wheel_left_joint"])
    rng = np.random.default_rng(1)
    q, target = robot.random_configuration(rng), robot.random_configuration(rng)
    e, J = feature.residual_and_jacobian(robot.state(q), target)
    e_ref, J_ref = _posture_reference(robot, feature, q, target)
    np.testing.assert_array_equal(e, e_ref)
    np.testing.assert_array_equal(J, J_ref)
    wheel = robot.model.joints[robot.joint_id("wheel_left_joint")].idx_q
    angle = math.atan2(q[wheel + 1], q[wheel]) - math.atan2(target[wheel + 1], target[wheel])
    assert e[1] == pytest.approx(math.remainder(angle, 2 * math.pi), abs=1e-12)
    assert e[0] == q[robot.model.joints[robot.joint_id("arm_1_joint")].idx_q] - target[1]


def test_compiled_step_result_fields_and_residuals() -> None:
    from taskspace._native import ik_kernel
    from taskspace.ik import DifferentialIK, DifferentialIKOptions
    from taskspace.qp.result import QPStatus

    if ik_kernel() is None:
        pytest.skip("compiled kernel not built")
    robot = load_robot("panda")
    state = robot.state(robot.q_default)
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"), gain=0.5)
    tcp.set_target_from_state(state)
    tcp.set_target(pin.SE3(tcp.target.rotation, tcp.target.translation + np.array([0.05, 0, 0])))
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    for residuals in (False, True):
        options = DifferentialIKOptions(native_residuals=residuals)
        result = DifferentialIK(robot, [tcp], limits, options=options).solve(state, 0.01)
        qp = result.qp
        assert qp is result.qp  # made once, then kept (a later qp.kkt = ... sticks)
        assert qp.backend == "native" and qp.success and qp.x is result.dq
        assert qp.status in (QPStatus.UNCONSTRAINED, QPStatus.SOLVED)
        np.testing.assert_array_equal(result.velocity, result.dq / 0.01)
        assert math.isfinite(qp.objective)
        assert math.isfinite(qp.kkt.dual) is residuals
        if residuals:
            assert qp.kkt.dual < 1e-9 and qp.kkt.primal < 1e-12


def test_box_stack_passes_boxes_of_another_size_on_as_before() -> None:
    robot = load_robot("panda")
    state = robot.state(robot.q_default)
    hard, soft = _Box(robot, "hard", hard=True), _Box(robot, "soft", hard=False)
    hard.box = Box(-np.ones(3), np.ones(3))  # a user box of the wrong size
    soft.box = Box(np.array([-2.0, 0.5, -0.5]), np.array([0.5, 3.0, 0.5]))
    lb, ub, _ = BoxStack([hard, soft], robot.nv).fill(state, 0.01)
    ref_lb, ref_ub = _reference_box([hard.box], [soft.box], 3)
    np.testing.assert_array_equal(lb, ref_lb)  # what the QP then refuses by its shapes
    np.testing.assert_array_equal(ub, ref_ub)
