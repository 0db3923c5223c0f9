"""What pink, mink and placo users rely on (issue #16, item 5): a damping task,
Levenberg-Marquardt damping per task, posture tasks that leave a floating base free,
floating-base velocity limits, validated setters. References: closed-form least squares
(numpy), KKT residuals, Pinocchio's ``difference``."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import JointVelocityLimits
from taskspace.errors import TaskspaceError
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.qp import QPSolverOptions
from taskspace.tasks import Task
from tests.conftest import load_robot

DT = 0.01


def _tcp(robot, q):  # type: ignore[no-untyped-def]
    task = Task(F.FramePose(robot, "panda_hand_tcp"))
    T = robot.frame_placement(q, "panda_hand_tcp")
    task.set_target(T * pin.exp6(np.array([0.1, -0.05, 0.08, 0.2, -0.1, 0.3])))
    return task


def _closed_form(Ms: list[np.ndarray], rs: list[np.ndarray], mu: float) -> np.ndarray:
    M, r = np.vstack(Ms), np.concatenate(rs)
    return np.linalg.solve(M.T @ M + mu * np.eye(M.shape[1]), M.T @ r)


def test_damping_task_equals_closed_form() -> None:
    robot = load_robot("panda")
    q = robot.q_default + 0.1
    state = robot.state(q)
    tcp = _tcp(robot, q)
    rho = np.linspace(0.01, 0.5, robot.nv)  # one weight per joint
    damping = Task(F.Damping(robot), weight=rho)
    mu = 1e-6
    ik = DifferentialIK(robot, [tcp, damping], options=DifferentialIKOptions(damping=mu))
    result = ik.solve(state, DT)
    e, J = tcp.feature.residual_and_jacobian(state, tcp.target)
    expected = _closed_form([J, np.diag(np.sqrt(rho))], [-e, np.zeros(robot.nv)], mu)
    np.testing.assert_allclose(result.dq, expected, atol=1e-10)
    assert result.qp.kkt.within(1e-9, 1e-9)
    # the damping changes the step (the test can fail)
    plain = DifferentialIK(robot, [tcp], options=DifferentialIKOptions(damping=mu)).solve(state, DT)
    assert np.abs(plain.dq - result.dq).max() > 1e-3
    with pytest.raises(TaskspaceError, match="target is zero"):
        damping.set_target(np.ones(robot.nv))


def test_levenberg_marquardt_damping_equals_closed_form() -> None:
    robot = load_robot("panda")
    q = robot.q_default - 0.05
    state = robot.state(q)
    tcp = _tcp(robot, q)
    tcp.weight = 4.0
    tcp.gain = 0.5
    tcp.lm_damping = 0.3
    mu = 1e-6
    python = DifferentialIK(robot, [tcp], options=DifferentialIKOptions(damping=mu, native=False))
    native = DifferentialIK(robot, [tcp], options=DifferentialIKOptions(damping=mu))
    e, J = tcp.feature.residual_and_jacobian(state, tcp.target)
    w = 2.0  # sqrt of the weight
    lm = 0.3 * float((w * e) @ (w * e))  # pink: lm_damping |weighted error|^2
    expected = _closed_form([w * J], [-0.5 * w * e], mu + lm)
    for ik in (python, native):
        result = ik.solve(state, DT)
        np.testing.assert_allclose(result.dq, expected, atol=1e-10)
        assert result.qp.backend != "native"  # the kernel's damping is fixed: Python path
    # at the target the LM term vanishes: the step is the plain one
    tcp.lm_damping = 0.0
    undamped = python.solve(state, DT).dq
    assert np.abs(undamped - expected).max() > 1e-4
    for bad in (float("nan"), -1.0, "x", np.inf):
        with pytest.raises(TaskspaceError, match="lm_damping"):
            tcp.lm_damping = bad
    assert tcp.lm_damping == 0.0


@pytest.mark.skipif(ik_kernel() is None, reason="native kernel not built")
def test_kernel_resumes_when_lm_damping_is_switched_off() -> None:
    robot = load_robot("panda")
    tcp = _tcp(robot, robot.q_default)
    ik = DifferentialIK(robot, [tcp])
    state = robot.state(robot.q_default)
    assert ik.solve(state, DT).qp.backend == "native"
    tcp.lm_damping = 1.0
    assert ik.solve(state, DT).qp.backend != "native"
    tcp.lm_damping = 0.0
    assert ik.solve(state, DT).qp.backend == "native"


def test_posture_skips_the_floating_base_by_default() -> None:
    robot = load_robot("g1")
    assert robot.is_floating
    rng = np.random.default_rng(2)
    q = robot.random_configuration(rng, base_box=0.5)
    target = robot.random_configuration(rng, base_box=0.5)
    state = robot.state(q)
    joints = F.JointConfiguration(robot)
    full = F.JointConfiguration(robot, floating_base=True)
    assert joints.dim == robot.nv - 6 and full.dim == robot.nv
    diff = pin.difference(robot.model, target, q)
    np.testing.assert_allclose(joints.residual(state, target), diff[6:], atol=1e-12)
    np.testing.assert_allclose(full.residual(state, target), diff, atol=1e-12)
    J = joints.residual_jacobian(state, target)
    assert np.all(J[:, :6] == 0.0)
    # IK with the posture alone: the base does not move (it is not regulated), the joints do
    for native in (False, True):
        ik = DifferentialIK(
            robot, [Task(joints, target)], options=DifferentialIKOptions(native=native)
        )
        dq = ik.solve(state, DT).dq
        np.testing.assert_allclose(dq[:6], 0.0, atol=1e-12)
        np.testing.assert_allclose(dq[6:], -diff[6:] / (1.0 + 1e-6), rtol=1e-6, atol=1e-9)
    moved = DifferentialIK(robot, [Task(full, target)]).solve(state, DT).dq
    assert np.abs(moved[:6]).max() > 1e-2
    # fixed-base robots are unchanged
    panda = load_robot("panda")
    assert F.JointConfiguration(panda).dim == panda.nv
    with pytest.raises(TaskspaceError, match="floating_base"):
        F.JointConfiguration(robot, floating_base="yes")  # type: ignore[arg-type]


@pytest.mark.parametrize("native", [False, True])
def test_floating_base_velocity_limits_bind(native: bool) -> None:
    robot = load_robot("g1")
    q = robot.q_default.copy()
    state = robot.state(q)
    pelvis = Task(F.FramePose(robot, "pelvis"))
    pelvis.set_target(
        robot.frame_placement(q, "pelvis") * pin.exp6(np.array([0.3, 0.2, -0.1, 0.2, 0.1, 0.4]))
    )
    base = np.array([0.5, 0.5, 0.5, 1.0, 1.0, 1.0])
    limits = JointVelocityLimits(robot, base_limits=base)
    ik = DifferentialIK(
        robot,
        [pelvis],
        [limits],
        options=DifferentialIKOptions(
            solver=QPSolverOptions(backend="quadprog"), native=native, native_residuals=True
        ),
    )
    result = ik.solve(state, DT)
    assert result.success
    assert np.all(np.abs(result.dq[:6]) <= base * DT + 1e-12)
    assert np.any(np.abs(result.dq[:6]) >= base * DT - 1e-12)  # active
    assert result.qp.kkt.within(1e-9, 1e-9), result.qp.kkt
    free = DifferentialIK(robot, [pelvis], [JointVelocityLimits(robot)]).solve(state, DT)
    assert np.any(np.abs(free.dq[:6]) > base * DT + 1e-3)  # the bound matters
    with pytest.raises(TaskspaceError, match="no floating base"):
        JointVelocityLimits(load_robot("panda"), base_limits=np.ones(6))
    with pytest.raises(TaskspaceError):
        JointVelocityLimits(robot, base_limits=[1.0, -1.0, 1.0, 1.0, 1.0, 1.0])
    with pytest.raises(TaskspaceError):
        JointVelocityLimits(robot, base_limits=[1.0, 1.0])


@pytest.mark.parametrize(
    ("attribute", "value", "text"),
    [
        ("weight", float("nan"), "weight"),
        ("weight", -1.0, "weight"),
        ("weight", np.ones(5), "weight"),
        ("weight", [1.0, -1.0, 1.0, 1.0, 1.0, 1.0], "weight"),
        ("gain", 0.0, "gain"),
        ("gain", float("nan"), "gain"),
        ("gain", 1.5, "gain"),
        ("kp", -1.0, "kp"),
        ("kp", float("nan"), "kp"),
        ("kd", float("inf"), "kd"),
        ("priority", -1, "priority"),
        ("priority", 1.5, "priority"),
        ("lm_damping", -0.1, "lm_damping"),
    ],
)
def test_setters_refuse_bad_values_and_keep_the_old_one(
    attribute: str, value: object, text: str
) -> None:
    robot = load_robot("panda")
    task = Task(F.FramePose(robot, "panda_hand_tcp"), name="tcp")
    before = getattr(task, attribute)
    with pytest.raises(TaskspaceError, match=text) as info:
        setattr(task, attribute, value)
    assert "tcp" in str(info.value)  # names the task
    after = getattr(task, attribute)
    assert np.array_equal(np.asarray(after), np.asarray(before))


@pytest.mark.parametrize("level", [0, 1])
def test_levenberg_marquardt_damping_in_a_hierarchy(level: int) -> None:
    """The LM term damps the task's level: closed-form damped least squares per level."""
    from taskspace.ik import HierarchicalIK

    robot = load_robot("panda")
    q = robot.q_default + 0.05
    state = robot.state(q)
    tcp = Task(F.Position(robot, "panda_hand_tcp"))
    offset = np.array([0.1, -0.05, 0.08])
    tcp.set_target(robot.frame_placement(q, "panda_hand_tcp").translation + offset)
    posture = Task(F.JointConfiguration(robot), robot.q_default + 0.2, weight=0.5)
    task = tcp if level == 0 else posture
    task.lm_damping = 0.7
    ik = HierarchicalIK(robot, [[tcp], [posture]])
    mu = ik.solver.options.damping
    result = ik.solve(state, DT)
    e1, J1 = tcp.feature.residual_and_jacobian(state, tcp.target)
    e2, J2 = posture.feature.residual_and_jacobian(state, posture.target)
    w2 = np.sqrt(0.5)
    lm = 0.7 * float(e1 @ e1) if level == 0 else 0.7 * float((w2 * e2) @ (w2 * e2))
    mu1 = mu + lm if level == 0 else 0.0  # level 0: damped, or the exact least squares
    mu2 = mu + lm if level == 1 else mu
    z1 = (
        np.linalg.solve(J1.T @ J1 + mu1 * np.eye(7), -J1.T @ e1)
        if mu1
        else np.linalg.lstsq(J1, -e1, rcond=None)[0]
    )
    # level 1 in the nullspace of J1 (an orthonormal basis from the exact projector)
    U, s, _ = np.linalg.svd(np.eye(7) - np.linalg.pinv(J1) @ J1)
    Z = U[:, s > 0.5]
    M = w2 * J2 @ Z
    y = np.linalg.solve(M.T @ M + mu2 * np.eye(Z.shape[1]), M.T @ (-w2 * e2 - w2 * J2 @ z1))
    expected = z1 + Z @ y
    np.testing.assert_allclose(result.dq, expected, atol=1e-8)
    task.lm_damping = 0.0
    assert np.abs(ik.solve(state, DT).dq - expected).max() > 1e-4  # the term matters
