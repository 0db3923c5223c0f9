"""``DifferentialIK.advance``: the fused step (solve, integrate, kinematics) in one kernel call.

References, all independent of the kernel: the step is quadprog's solution of the QP the
Python path builds at the state before the step; the new configuration is Pinocchio's
``integrate``; the state's data after the step equal a fresh ``pin.Data`` given
``forwardKinematics`` + ``computeJointJacobians`` + ``updateFramePlacements`` at the new
``q`` (and ``v``); everything the state derives from its data (cached Jacobians, center of
mass, distances) equals a new state's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import CollisionAvoidance, JointPositionLimits, JointVelocityLimits
from taskspace.errors import InvalidInputError
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Obstacle, Robot, State
from taskspace.tasks import Task
from tests.conftest import load_robot

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")

DT = 0.01


def _quadprog_step(ik: DifferentialIK, state: State, dt: float) -> np.ndarray:
    """Exact minimizer of the Python path's QP (box only) by quadprog."""
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
    for j in range(model.njoints):
        np.testing.assert_allclose(data.oMi[j].homogeneous, ref.oMi[j].homogeneous, atol=1e-12)
        if state.has_velocity:
            np.testing.assert_allclose(data.v[j].vector, ref.v[j].vector, atol=1e-12)
            np.testing.assert_allclose(data.a[j].vector, ref.a[j].vector, atol=1e-12)
    for f in range(model.nframes):
        np.testing.assert_allclose(data.oMf[f].homogeneous, ref.oMf[f].homogeneous, atol=1e-12)
    np.testing.assert_allclose(data.J, ref.J, atol=1e-12)


def _random_stack(robot: Robot, rng: np.random.Generator) -> list[Task]:
    """Pose and position tasks on random frames, maybe the CoM, a posture; random weights."""
    state = robot.state(robot.q_default)
    bodies = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    tasks = []
    for kind in rng.permutation(["pose", "position", "com"])[: rng.integers(1, 4)]:
        if kind == "com":
            task = Task(F.CenterOfMass(robot), weight=float(rng.uniform(0.1, 2)))
            task.set_target(state.com() + rng.uniform(-0.05, 0.05, 3))
        else:
            name = str(rng.choice(bodies))
            feature = F.FramePose(robot, name) if kind == "pose" else F.Position(robot, name)
            task = Task(feature, weight=float(rng.uniform(0.1, 2)), gain=float(rng.uniform(0.2, 1)))
            M = state.frame_placement(robot.frame_id(name))
            shift = pin.exp6(rng.uniform(-0.2, 0.2, 6))
            task.set_target(M * shift if kind == "pose" else (M * shift).translation)
        tasks.append(task)
    tasks.append(Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3))
    return tasks


@pytest.mark.parametrize("name", ["panda", "g1"])
def test_advance_matches_quadprog_integrate_and_pinocchio(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(7)
    constrained = 0
    for _ in range(3):
        tasks = _random_stack(robot, rng)
        limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
        ik = DifferentialIK(robot, tasks, limits)
        assert ik.native and ik._fused
        # a random configuration inside the limits (G1: a free flyer, its quaternion moved)
        q = pin.integrate(robot.model, robot.q_default, 0.4 * rng.standard_normal(robot.nv))
        idx = robot.limited_joints_q
        q[idx] = np.clip(q[idx], robot.lower_limits[idx] + 0.01, robot.upper_limits[idx] - 0.01)
        state = robot.state(q)
        for _ in range(6):
            q_before = state.q
            dq = _quadprog_step(ik, state, DT)  # at the state before the step
            result = ik.advance(state, DT)
            assert result.success and result.qp.backend == "native"
            constrained += result.qp.status.name != "UNCONSTRAINED"
            np.testing.assert_allclose(result.dq, dq, atol=1e-8, rtol=0)
            expected = pin.integrate(robot.model, q_before, result.dq)
            np.testing.assert_allclose(state.q, expected, atol=1e-14, rtol=0)
            assert not state.has_velocity and not state.v.any()
            _assert_kinematics(robot, state)
    assert constrained > 0  # the limits were active in some steps


def test_state_after_advance_is_a_fresh_state() -> None:
    """Every derived quantity is recomputed: caches taken before the step are not reused."""
    robot = load_robot("panda")
    fid = robot.frame_id("panda_hand_tcp")
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"), gain=0.8)
    start = robot.state(robot.q_default)
    tcp.set_target(start.frame_placement(fid) * pin.SE3(np.eye(3), np.array([0.2, 0.1, -0.1])))
    ik = DifferentialIK(
        robot,
        [tcp, Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
    )
    v0 = np.linspace(-0.2, 0.2, robot.nv)
    state = robot.state(robot.q_default, v0)
    placement = state.frame_placement(fid)  # a reference into the data: follows the state
    before = {
        "J": state.frame_jacobian(fid).copy(),
        "J_local": state.frame_jacobian_local(fid).copy(),
        "com": state.com().copy(),
        "Jcom": state.com_jacobian().copy(),
        "drift": state.frame_drift(fid).copy(),
    }
    q0 = state.q
    result = ik.advance(state, DT)
    assert result.qp.backend == "native"
    assert state.has_velocity
    np.testing.assert_array_equal(state.v, result.dq / DT)
    np.testing.assert_array_equal(state.q, pin.integrate(robot.model, q0, result.dq))
    np.testing.assert_array_equal(q0, robot.q_default)  # the previous q was not written
    _assert_kinematics(robot, state)
    fresh = robot.state(state.q, state.v)
    np.testing.assert_allclose(state.frame_jacobian(fid), fresh.frame_jacobian(fid), atol=1e-12)
    np.testing.assert_allclose(
        state.frame_jacobian_local(fid), fresh.frame_jacobian_local(fid), atol=1e-12
    )
    np.testing.assert_allclose(state.com(), fresh.com(), atol=1e-12)
    np.testing.assert_allclose(state.com_jacobian(), fresh.com_jacobian(), atol=1e-12)
    np.testing.assert_allclose(state.frame_drift(fid), fresh.frame_drift(fid), atol=1e-12)
    np.testing.assert_allclose(
        placement.homogeneous, fresh.frame_placement(fid).homogeneous, atol=1e-12
    )
    assert np.abs(state.frame_jacobian(fid) - before["J"]).max() > 1e-4  # it did move
    assert np.abs(state.com() - before["com"]).max() > 1e-6
    # q and v stay read-only for good
    for array in (state.q, state.v):
        assert not array.flags.writeable
        with pytest.raises(ValueError):
            array.setflags(write=True)


def _panda_ik(robot: Robot, **options: Any) -> tuple[DifferentialIK, Task]:
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"))
    s = robot.state(robot.q_default)
    tcp.set_target(
        s.frame_placement(robot.frame_id("panda_hand_tcp"))
        * pin.SE3(np.eye(3), np.array([0.1, 0.1, 0.1]))
    )
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    return DifferentialIK(
        robot, [tcp, posture], limits, options=DifferentialIKOptions(**options)
    ), tcp


@pytest.mark.parametrize(
    "options", [{"native": False}, {"native_residuals": True}, {"unfused": True}]
)
def test_other_paths_move_the_state_the_same(options: dict[str, Any]) -> None:
    """The Python path, native residuals, and a kernel without ``advance``: same end state."""
    robot = load_robot("panda")
    fused, _ = _panda_ik(robot)
    unfused = options.pop("unfused", False)
    other, _ = _panda_ik(robot, **options)
    if unfused:
        assert other.native
        other._fused = False  # as with a kernel built before advance existed
    a = robot.state(robot.q_default, np.zeros(robot.nv))
    b = robot.state(robot.q_default, np.zeros(robot.nv))
    for _ in range(15):
        ra = fused.advance(a, DT)
        rb = other.advance(b, DT)
        np.testing.assert_allclose(rb.dq, ra.dq, atol=1e-7, rtol=0)
        np.testing.assert_allclose(b.q, a.q, atol=1e-7, rtol=0)
        np.testing.assert_allclose(b.v, a.v, atol=1e-5, rtol=0)
        b.update(a.q, a.v)  # both continue from the same state
        _assert_kinematics(robot, b)
        if options.get("native_residuals"):  # checked at the QP before the step: small
            assert rb.qp.kkt.primal < 1e-9 and rb.qp.kkt.dual < 1e-7


def test_refused_steps_leave_the_state_unchanged() -> None:
    robot = load_robot("panda")
    ik, tcp = _panda_ik(robot)
    state = robot.state(robot.q_default)
    ik.advance(state, DT)
    q, oMf, J = state.q, [M.copy() for M in state.data.oMf], state.data.J.copy()
    target = tcp.target
    bad = pin.SE3(np.eye(3), np.zeros(3))
    bad.translation = np.array([np.nan, 0.0, 0.0])
    object.__setattr__(tcp, "_target", bad)  # past set_target's check: the kernel refuses it
    with pytest.raises(InvalidInputError):
        ik.advance(state, DT)
    tcp.set_target(target)
    with pytest.raises(InvalidInputError):
        ik.advance(state, -DT)
    with pytest.raises(InvalidInputError):
        ik.advance(load_robot("g1").state(load_robot("g1").q_default), DT)
    assert state.q is q
    np.testing.assert_array_equal(state.data.J, J)
    for M, M0 in zip(state.data.oMf, oMf):
        np.testing.assert_array_equal(M.homogeneous, M0.homogeneous)


def test_advance_with_collision_dampers_equals_solve_then_update() -> None:
    """The 11-argument path (collision model and data): same step and state as two calls."""
    robot = Robot.load("panda", convex_collision=True)  # a private copy: an obstacle is added
    fid = robot.frame_id("panda_hand_tcp")
    start = robot.state(robot.q_default).frame_placement(fid).copy()
    robot.add_obstacle(
        Obstacle.sphere("ball", 0.07, start.translation + np.array([0.0, 0.22, -0.03]))
    )

    def make() -> DifferentialIK:
        tcp = Task(F.FramePose(robot, "panda_hand_tcp"), gain=0.5)
        tcp.set_target(pin.SE3(start.rotation, start.translation + np.array([0.0, 0.45, -0.03])))
        posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-5)
        avoid = CollisionAvoidance(robot, safety_distance=0.02, influence_distance=0.12)
        limits = [JointPositionLimits(robot), JointVelocityLimits(robot), avoid]
        return DifferentialIK(robot, [tcp, posture], limits)

    fused, two_calls = make(), make()
    a, b = robot.state(robot.q_default), robot.state(robot.q_default)
    rows = 0
    for _ in range(40):
        ra = fused.advance(a, DT)
        rb = two_calls.solve(b, DT)
        assert ra.qp.backend == "native" and ra.success
        np.testing.assert_array_equal(ra.dq, rb.dq)
        assert ra.qp.kkt.primal <= 1e-9
        b.update(pin.integrate(robot.model, b.q, rb.dq))
        np.testing.assert_array_equal(a.q, b.q)
        rows += len(fused._native.damper_rows()[3])  # type: ignore[union-attr]
    assert rows > 0  # the dampers were in the QP
    _assert_kinematics(robot, a)


def test_reassigned_weights_gains_and_lm_damping_are_seen() -> None:
    """The kernel re-reads its tasks after any task assignment (``tasks.ASSIGNMENTS``)."""
    robot = load_robot("panda")
    ik, tcp = _panda_ik(robot)
    posture = ik.tasks[1]
    state = robot.state(robot.q_default)
    changes = [
        ("weight", posture, 0.5, "native"),
        ("gain", tcp, 0.3, "native"),
        ("weight", tcp, np.array([1.0, 2.0, 0.5, 1.0, 1.0, 3.0]), "native"),
        ("lm_damping", tcp, 1e-2, "python"),  # the kernel's damping is fixed: Python path
        ("lm_damping", tcp, 0.0, "native"),
    ]
    for name, task, value, backend in changes:
        setattr(task, name, value)
        for _ in range(2):
            dq = _quadprog_step(ik, state, DT)
            result = ik.advance(state, DT)
            assert (result.qp.backend == "native") is (backend == "native")
            np.testing.assert_allclose(result.dq, dq, atol=1e-7, rtol=0)


def test_options_are_read_only() -> None:
    """The damping and residual settings are read once: replacing the options is refused."""
    robot = load_robot("panda")
    ik, _ = _panda_ik(robot)
    with pytest.raises(InvalidInputError, match="read-only"):
        ik.options = DifferentialIKOptions(damping=1.0)
    assert ik.options.damping == 1e-6
