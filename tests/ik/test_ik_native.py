"""The compiled weighted-IK kernel (taskspace/_native) against the Python path it replaces.

Both solve the same QP (``DifferentialIK.build``); the kernel with an exact active-set method
on the box, the reference with the Python path and quadprog (an exact dual active-set
solver; proxsuite's default eps stops ~1e-6 short of active bounds). Every test runs both on
the same states and compares the steps.
"""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import ik_kernel, status
from taskspace.constraints import (
    CollisionAvoidance,
    FeatureBounds,
    JointAccelerationLimits,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.errors import InvalidInputError
from taskspace.features import CenterOfMass, FramePose, JointConfiguration, Orientation, Position
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.qp import QPSolverOptions, QPStatus
from taskspace.tasks import Task
from tests.ik.ik_scenarios import DT, benchmark_offset

STEP_TOL = 1e-8

if os.environ.get("TASKSPACE_REQUIRE_NATIVE"):

    def test_kernel_is_built() -> None:
        assert ik_kernel() is not None, status()


pytestmark = pytest.mark.skipif(ik_kernel() is None, reason=f"native kernel: {status()}")


def _pair(robot: Robot, tasks, constraints) -> tuple[DifferentialIK, DifferentialIK]:  # type: ignore[no-untyped-def]
    native = DifferentialIK(robot, tasks, constraints)
    reference = DifferentialIKOptions(native=False, solver=QPSolverOptions(backend="quadprog"))
    python = DifferentialIK(robot, tasks, constraints, options=reference)
    assert native.native and not python.native
    return native, python


def _g1_tasks(g1: Robot) -> tuple[list[Task], list[tuple[Task, pin.SE3]]]:
    s = g1.state(g1.q_default)
    feet = [Task(FramePose(g1, f)) for f in ("left_ankle_roll_link", "right_ankle_roll_link")]
    hands = [Task(FramePose(g1, h)) for h in ("left_rubber_hand", "right_rubber_hand")]
    com = Task(CenterOfMass(g1))
    for t in (*feet, *hands, com):
        t.set_target_from_state(s)
    posture = Task(JointConfiguration(g1), g1.q_default, weight=1e-3)
    return [*feet, *hands, com, posture], [(t, t.target.copy()) for t in hands]


def test_g1_benchmark_scene_matches_python_path(g1: Robot) -> None:
    tasks, moving = _g1_tasks(g1)
    native, python = _pair(g1, tasks, [JointPositionLimits(g1), JointVelocityLimits(g1)])
    state = g1.state(g1.q_default)
    q = g1.q_default.copy()
    statuses = set()
    for k in range(0, 1500, 5):  # the benchmark's targets, every 5th step
        for task, T0 in moving:
            T = T0.copy()
            T.translation = T0.translation + benchmark_offset(k)
            task.set_target(T)
        state.update(q)
        a, b = native.solve(state, DT), python.solve(state, DT)
        assert a.success and a.qp.backend == "native"
        statuses.add(a.qp.status)
        np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)
        np.testing.assert_allclose(a.velocity, a.dq / DT)
        q = pin.integrate(g1.model, q, a.dq)
    assert QPStatus.UNCONSTRAINED in statuses


def test_active_position_and_velocity_limits_match_python_path(panda: Robot) -> None:
    """A target far outside the workspace drives joints into their limits: the active set
    works, and its optimum equals proxsuite's."""
    tcp = Task(FramePose(panda, "panda_hand_tcp"), [1.5, 0.8, 1.2])
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-3)
    limits = [JointPositionLimits(panda), JointVelocityLimits(panda)]
    native, python = _pair(panda, [tcp, posture], limits)
    state = panda.state(panda.q_default)
    q = panda.q_default.copy()
    solved_with_active_set = 0
    for _ in range(400):
        state.update(q)
        a, b = native.solve(state, 0.02), python.solve(state, 0.02)
        np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)
        solved_with_active_set += a.qp.status is QPStatus.SOLVED and a.qp.iterations > 0
        q = pin.integrate(panda.model, q, a.dq)
        idx = panda.limited_joints_q
        assert np.all(q[idx] >= panda.lower_limits[idx] - 1e-9)
        assert np.all(q[idx] <= panda.upper_limits[idx] + 1e-9)
    assert solved_with_active_set > 50


def test_start_outside_limits_with_acceleration_limits(
    panda: Robot, rng: np.random.Generator
) -> None:
    """Boxes that conflict (outside the position limits, acceleration-bounded velocity):
    the kernel combines them by the same rules as ``combine_bounds``."""
    tcp = Task(Position(panda, "panda_hand_tcp"), [0.4, 0.2, 0.5], weight=[1.0, 2.0, 0.5])
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-2, gain=0.5)
    limits = [
        JointPositionLimits(panda, margin=0.05),
        JointVelocityLimits(panda),
        JointAccelerationLimits(panda, np.full(panda.nv, 5.0)),
    ]
    native, python = _pair(panda, [tcp, posture], limits)
    for _ in range(20):
        q = panda.q_default.copy()
        idx = panda.limited_joints_q
        q[idx] = panda.upper_limits[idx] + rng.uniform(-0.2, 0.1, idx.size)
        v = rng.uniform(-1.0, 1.0, panda.nv)
        state = panda.state(q, v)
        a, b = native.solve(state, 0.01), python.solve(state, 0.01)
        np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)


def test_position_limits_evaluated_in_the_kernel_on_a_floating_base(
    g1: Robot, rng: np.random.Generator
) -> None:
    """The kernel evaluates the first joint-position box from q (floating base: the q and v
    indices of the limited joints differ); a second, looser one comes from Python."""
    tasks, _ = _g1_tasks(g1)
    limits = [
        JointPositionLimits(g1, margin=0.02),
        JointVelocityLimits(g1),
        JointPositionLimits(g1),
    ]
    native, python = _pair(g1, tasks, limits)
    idx = g1.limited_joints_q
    assert not np.array_equal(idx, g1.limited_joints_v)
    active = 0
    for _ in range(10):
        q = g1.q_default.copy()
        near = rng.random(idx.size) < 0.5  # half the joints at or just outside a limit
        edge = np.where(rng.random(idx.size) < 0.5, g1.lower_limits[idx], g1.upper_limits[idx])
        q[idx] = np.where(near, edge + rng.uniform(-0.03, 0.03, idx.size), q[idx])
        state = g1.state(q)
        a, b = native.solve(state, DT), python.solve(state, DT)
        np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)
        active += a.qp.status is QPStatus.SOLVED
    assert active > 0


def test_posture_on_selected_joints_and_free_flyer(g1: Robot, rng: np.random.Generator) -> None:
    """Posture rows on a subset of joints and a quaternion base (dDifference blocks)."""
    s = g1.state(g1.q_default)
    hand = Task(Position(g1, "left_rubber_hand"))
    hand.set_target_from_state(s)
    hand.set_target(hand.target + np.array([0.05, 0.02, -0.03]))
    legs = [j for j in g1.model.names[2:] if "leg" in j or "knee" in j or "ankle" in j]
    legs_posture = Task(JointConfiguration(g1, legs), g1.q_default, weight=0.3)
    full = Task(JointConfiguration(g1), g1.q_default, weight=1e-3, gain=0.7)
    native, python = _pair(g1, [hand, legs_posture, full], [JointVelocityLimits(g1)])
    for _ in range(10):
        q = pin.randomConfiguration(g1.model, -np.ones(g1.nq), np.ones(g1.nq))
        q[:3] = rng.uniform(-0.5, 0.5, 3)
        state = g1.state(q)
        a, b = native.solve(state, DT), python.solve(state, DT)
        np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)


def test_weights_changed_between_steps_are_used(panda: Robot) -> None:
    tcp = Task(FramePose(panda, "panda_hand_tcp"), [0.5, 0.1, 0.4])
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-3)
    native, python = _pair(panda, [tcp, posture], [JointVelocityLimits(panda)])
    state = panda.state(panda.q_default)
    first = native.solve(state, DT).dq
    posture.sqrt_weight = 1.0  # a much stronger posture
    a, b = native.solve(state, DT), python.solve(state, DT)
    np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)
    assert np.linalg.norm(a.dq - first) > 1e-4


def test_unsupported_stacks_take_the_python_path(panda: Robot) -> None:
    s = panda.state(panda.q_default)
    tcp = Task(FramePose(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(s)
    orient = Task(Orientation(panda, "panda_hand_tcp"))
    orient.set_target_from_state(s)
    offset = Task(Position(panda, "panda_hand_tcp", offset=[0.0, 0.0, 0.1]), [0.4, 0.0, 0.5])
    # a weighted orientation: the kernel evaluates it when it has add_orientation
    weighted = hasattr(ik_kernel().WeightedIKKernel, "add_orientation")
    assert DifferentialIK(panda, [tcp, orient]).native is weighted
    assert not DifferentialIK(panda, [offset]).native
    # equality tasks and rows the kernel does not evaluate: its general step (rows from
    # Python), when the kernel has one
    general = hasattr(ik_kernel(), "GeneralIKStep")
    assert DifferentialIK(panda, [tcp], equality_tasks=[orient]).native is general
    rows = FeatureBounds(Position(panda, "panda_hand_tcp"), [-1.0, -1.0, 0.1], [1.0, 1.0, 2.0])
    assert DifferentialIK(panda, [tcp], [rows]).native is general
    assert DifferentialIK(panda, [tcp], [CollisionAvoidance(panda)]).native  # declared rows
    assert DifferentialIK(panda, [tcp], [JointPositionLimits(panda)]).native


def test_errors_on_the_native_path(panda: Robot, g1: Robot) -> None:
    tcp = Task(FramePose(panda, "panda_hand_tcp"))
    ik = DifferentialIK(panda, [tcp])
    assert ik.native
    with pytest.raises(InvalidInputError, match="no target"):
        ik.solve(panda.state(), DT)
    tcp.set_target([0.4, 0.0, 0.5])
    with pytest.raises(InvalidInputError, match="state belongs to robot"):
        ik.solve(g1.state(), DT)


@pytest.mark.parametrize("name", ["ur5", "talos", "solo12", "panda", "g1"])
def test_random_stacks_match_python_path_on_every_robot(robot_loader, name: str) -> None:  # type: ignore[no-untyped-def]
    """Random stacks (end effectors as poses or positions, CoM, posture) with random
    weights, gains and targets, at random configurations near the limits: the kernel's step
    equals the Python path's (quadprog) on fixed- and floating-base robots."""
    robot = robot_loader(name)
    rng = np.random.default_rng(sum(map(ord, name)))
    frames = list(robot.end_effectors) or [robot.model.frames[-1].name]
    compared = solved = 0
    for trial in range(6):
        q = pin.randomConfiguration(robot.model, -np.ones(robot.nq), np.ones(robot.nq))
        if robot.is_floating:
            q[:3] = rng.uniform(-0.3, 0.3, 3)
        idx = robot.limited_joints_q
        lo, hi = robot.lower_limits[idx], robot.upper_limits[idx]
        q[idx] = lo + rng.uniform(-0.02, 1.02, idx.size) * (hi - lo)  # some just outside
        state = robot.state(q)
        tasks = []
        for f in frames:
            kind = FramePose if rng.random() < 0.6 else Position
            task = Task(
                kind(robot, f), weight=float(rng.uniform(0.1, 2.0)), gain=rng.uniform(0.2, 1)
            )
            task.set_target_from_state(state)
            if kind is Position:
                task.set_target(task.target + rng.normal(0.0, 0.05, 3))
            else:
                offset = pin.SE3(pin.exp3(rng.normal(0.0, 0.2, 3)), rng.normal(0.0, 0.05, 3))
                task.set_target(task.target * offset)
            tasks.append(task)
        if robot.is_floating or trial % 2:
            com = Task(CenterOfMass(robot), weight=float(rng.uniform(0.5, 5.0)))
            com.set_target_from_state(state)
            tasks.append(com)
        posture_target = pin.randomConfiguration(robot.model, -np.ones(robot.nq), np.ones(robot.nq))
        tasks.append(
            Task(JointConfiguration(robot), posture_target, weight=float(rng.uniform(1e-4, 1e-1)))
        )
        limits = [JointPositionLimits(robot), JointVelocityLimits(robot, scale=rng.uniform(0.2, 1))]
        native, python = _pair(robot, tasks, limits)
        a, b = native.solve(state, 0.01), python.solve(state, 0.01)
        assert a.success and a.qp.backend == "native"
        np.testing.assert_allclose(a.dq, b.dq, atol=STEP_TOL, rtol=0)
        compared += 1
        solved += a.qp.status is QPStatus.SOLVED
    assert compared == 6 and solved > 0  # the active set was exercised


def test_kernel_frees_what_pinocchio_allocated(robot_loader) -> None:  # type: ignore[no-untyped-def]
    """A Data and the neutral vector made by Pinocchio's library are freed by the kernel: the
    kernel's Eigen allocator matches the wheels' (a mismatch crashes this test's process)."""
    module = ik_kernel()
    for name in ("panda", "talos"):
        robot = robot_loader(name)
        data = robot.model.createData()
        pin.forwardKinematics(robot.model, data, pin.neutral(robot.model))
        expected = np.linalg.norm(data.oMi[robot.model.njoints - 1].translation)
        for _ in range(20):
            assert module.abi_selfcheck(robot.model) == pytest.approx(expected, abs=1e-12)
