"""Differential IK on real robots (slides 2:25-2:29, 2:39-2:41, 2:58): limits, tracking,
singularities, collision avoidance, relaxation, and the closed form of slide 2:41."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest

from taskspace.constraints import (
    CollisionAvoidance,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.features import CenterOfMass, FramePose, JointConfiguration, Position
from taskspace.ik import DifferentialIK, DifferentialIKOptions, IKStatus
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.qp import QPStatus, stacked_step
from taskspace.tasks import Task
from tests.ik.ik_scenarios import DT, benchmark_offset

LIMIT_TOL = 1e-9


def _limit_violation(robot: Robot, q: np.ndarray) -> float:
    idx = robot.limited_joints_q
    lo, hi = robot.lower_limits[idx], robot.upper_limits[idx]
    return float(max(np.max(lo - q[idx]), np.max(q[idx] - hi)))


def test_panda_tracks_benchmark_trajectory_within_limits(panda: Robot) -> None:
    state = panda.state()
    tcp = Task(FramePose(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(state)
    start = tcp.target.copy()
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-3)
    velocity = JointVelocityLimits(panda)
    ik = DifferentialIK(panda, [tcp, posture], [JointPositionLimits(panda), velocity])
    failed = 0
    worst_tracking = 0.0
    for k in range(1500):
        target = start.copy()
        target.translation = start.translation + benchmark_offset(k)
        tcp.set_target(target)
        q, result = ik.step(state, DT)
        failed += not result.success
        assert _limit_violation(panda, q) <= LIMIT_TOL
        assert np.all(np.abs(result.dq) <= velocity.limits * DT + LIMIT_TOL)
        np.testing.assert_allclose(result.velocity, result.dq / DT)
        state.update(q)
        # the target moves at most ~0.6 mm per step: the tcp stays within a few mm
        worst_tracking = max(worst_tracking, float(np.linalg.norm(tcp.error(state))))
    assert failed == 0
    assert worst_tracking < 1e-2


def test_panda_position_and_velocity_limits_active_never_violated(panda: Robot) -> None:
    # a heavy joint-4 task pulls the elbow beyond its upper limit (-0.0698 rad) and the
    # velocity limits are scaled down: both boxes are active for hundreds of steps
    state = panda.state()
    tcp = Task(FramePose(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(state)
    start = tcp.target.copy()
    elbow_target = panda.q_default.copy()
    elbow_target[3] = 0.3
    elbow = Task(JointConfiguration(panda, ["panda_joint4"]), elbow_target, gain=0.2)
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-3)
    velocity = JointVelocityLimits(panda, scale=0.2)
    ik = DifferentialIK(panda, [tcp, posture, elbow], [JointPositionLimits(panda), velocity])
    failed = at_position_limit = at_velocity_limit = 0
    for k in range(1500):
        target = start.copy()
        target.translation = start.translation + benchmark_offset(k)
        tcp.set_target(target)
        q, result = ik.step(state, DT)
        failed += not result.success
        assert _limit_violation(panda, q) <= LIMIT_TOL, f"step {k}"
        excess = np.abs(result.dq) - velocity.limits * DT
        assert np.all(excess <= LIMIT_TOL), f"step {k}"
        at_position_limit += _limit_violation(panda, q) > -1e-6
        at_velocity_limit += excess.max() > -1e-6
        state.update(q)
    assert failed == 0
    assert at_position_limit > 300
    assert at_velocity_limit > 20


@pytest.mark.slow
def test_g1_hands_move_feet_fixed(g1: Robot) -> None:
    state = g1.state()
    feet = [
        Task(FramePose(g1, f), weight=100.0)
        for f in ("left_ankle_roll_link", "right_ankle_roll_link")
    ]
    hands = [Task(Position(g1, f)) for f in ("left_rubber_hand", "right_rubber_hand")]
    com = Task(CenterOfMass(g1), weight=10.0)
    for task in [*feet, *hands, com]:
        task.set_target_from_state(state)
    posture = Task(JointConfiguration(g1), g1.q_default, weight=1e-3)
    velocity = JointVelocityLimits(g1)
    ik = DifferentialIK(g1, [*feet, *hands, com, posture], [JointPositionLimits(g1), velocity])
    hand_start = [h.target.copy() for h in hands]
    mirror = np.array([1.0, -1.0, 1.0])
    failed = 0
    for k in range(300):
        hands[0].set_target(hand_start[0] + benchmark_offset(k))
        hands[1].set_target(hand_start[1] + mirror * benchmark_offset(k))
        q, result = ik.step(state, DT)
        failed += not result.success
        assert _limit_violation(g1, q) <= LIMIT_TOL
        finite = np.isfinite(velocity.limits)
        assert np.all(np.abs(result.dq[finite]) <= velocity.limits[finite] * DT + LIMIT_TOL)
        state.update(q)
        for foot in feet:
            assert np.linalg.norm(foot.error(state)) < 1e-3
        for hand in hands:
            assert np.linalg.norm(hand.error(state)) < 1e-2
    assert failed == 0
    assert np.linalg.norm(hands[0].target - hand_start[0]) > 0.1  # the hands did move
    assert np.linalg.norm(com.error(state)) < 1e-2


def test_start_outside_joint_limit_is_pulled_back_at_velocity_limit(panda: Robot) -> None:
    q0 = panda.q_default.copy()
    upper = panda.upper_limits[0]
    q0[0] = upper + 0.2  # 0.2 rad beyond the limit
    state = panda.state(q0)
    tcp = Task(FramePose(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(state)
    velocity = JointVelocityLimits(panda)
    ik = DifferentialIK(panda, [tcp], [JointPositionLimits(panda), velocity])
    max_step = velocity.limits[0] * DT
    bound = int(np.ceil(0.2 / max_step))  # steps needed at full speed: 19
    inside_at = None
    for k in range(bound + 5):
        q, result = ik.step(state, DT)
        assert result.success, f"step {k} rejected: {result.status}"
        moved = q[0] - state.q[0]
        assert abs(moved) <= max_step + LIMIT_TOL
        if state.q[0] > upper:  # back as fast as allowed (the last step lands on the limit)
            assert moved <= -min(max_step, state.q[0] - upper) + 1e-9
        state.update(q)
        if inside_at is None and q[0] <= upper + LIMIT_TOL:
            inside_at = k + 1
        if inside_at is not None:
            assert q[0] <= upper + LIMIT_TOL  # and stays inside
    assert inside_at is not None and inside_at <= bound


def test_singular_stretched_arm_damped_steps_bounded_error_decreasing(
    robot_loader: Callable[..., Robot],
) -> None:
    # planar 2-link arm (1 m + 1 m) fully stretched, target beyond reach: the Jacobian is
    # singular at the start and again at the optimum (stretched toward the target)
    robot = robot_loader("planar_2link")
    target = np.array([2.2, 1.0, 0.0])
    best = np.linalg.norm(target) - 2.0  # distance from the reachable disk
    damping = 0.1  # slide 2:58: J^T (J J^T + eps I)^-1 with eps = 0.1
    gain = 0.5
    state = robot.state(np.zeros(2))
    np.testing.assert_allclose(state.frame_placement(robot.frame_id("ee")).translation, [2, 0, 0])
    task = Task(Position(robot, "ee"), target, gain=gain)
    ik = DifferentialIK(
        robot, [task], [JointPositionLimits(robot)], options=DifferentialIKOptions(damping=damping)
    )
    errors = [float(np.linalg.norm(task.error(state)))]
    for _ in range(300):
        q, result = ik.step(state, 0.01)
        # |J^T (J J^T + eps)^-1 r| <= |r| / (2 sqrt(eps)) with r = gain e
        assert np.linalg.norm(result.dq) <= gain * errors[-1] / (2 * np.sqrt(damping)) + 1e-12
        state.update(q)
        errors.append(float(np.linalg.norm(task.error(state))))
    assert np.all(np.diff(errors) <= 1e-12)
    assert errors[-1] == pytest.approx(best, abs=1e-6)


@pytest.mark.parametrize("native", [True, False])
def test_singular_stretched_arm_with_velocity_limits(
    robot_loader: Callable[..., Robot], native: bool
) -> None:
    robot = robot_loader("planar_2link")
    target = np.array([2.2, 1.0, 0.0])
    best = np.linalg.norm(target) - 2.0
    state = robot.state(np.zeros(2))
    task = Task(Position(robot, "ee"), target, gain=0.5)
    velocity = JointVelocityLimits(robot)
    options = DifferentialIKOptions(native=native)
    ik = DifferentialIK(robot, [task], [JointPositionLimits(robot), velocity], options=options)
    errors = [float(np.linalg.norm(task.error(state)))]
    for _ in range(300):
        q, result = ik.step(state, 0.01)
        assert np.all(np.abs(result.dq) <= velocity.limits * 0.01 + LIMIT_TOL)
        state.update(q)
        errors.append(float(np.linalg.norm(task.error(state))))
    # small chattering near the singular optimum (< 1 mm), otherwise decreasing
    assert np.max(np.diff(errors)) < 1e-3
    assert errors[-1] < 0.5 * errors[0]
    assert min(errors[-50:]) == pytest.approx(best, abs=2e-4)
    assert max(errors[-50:]) < best + 1e-3


@pytest.mark.parametrize("damping", [1e-6, 1e-2])
def test_weighted_step_equals_closed_form_stacked_step(panda: Robot, damping: float) -> None:
    rng = np.random.default_rng(3)
    q = panda.q_default + rng.uniform(-0.2, 0.2, panda.nv)
    state = panda.state(q)
    tcp = Task(FramePose(panda, "panda_hand_tcp"), weight=4.0, gain=0.3)
    target = state.frame_placement(panda.frame_id("panda_hand_tcp")).copy()
    target.translation += np.array([0.01, -0.02, 0.005])
    tcp.set_target(target)
    com = Task(CenterOfMass(panda), state.com() + np.array([0.0, 0.003, 0.0]), weight=0.5, gain=0.8)
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-2, gain=0.5)
    tasks = [tcp, com, posture]
    ik = DifferentialIK(panda, tasks, options=DifferentialIKOptions(damping=damping))
    result = ik.solve(state, DT)
    assert result.qp.status is QPStatus.UNCONSTRAINED
    jacobians, errors, precisions = [], [], []
    for t in tasks:
        e, J = t.feature.residual_and_jacobian(state, t.target)
        jacobians.append(J)
        errors.append(t.gain * e)
        precisions.append(float(t.sqrt_weight) ** 2)
    reference = stacked_step(jacobians, errors, precisions, damping * np.eye(panda.nv))
    np.testing.assert_allclose(result.dq, reference, atol=1e-10, rtol=1e-8)


def test_collision_avoidance_keeps_safety_distance() -> None:
    robot = Robot.load("panda", convex_collision=True)  # private copy: obstacles are added
    state = robot.state()
    tcp_id = robot.frame_id("panda_hand_tcp")
    start = state.frame_placement(tcp_id).translation.copy()
    goal = start + np.array([0.0, 0.4, 0.0])
    robot.add_obstacle(Obstacle.sphere("ball", 0.06, start + np.array([0.0, 0.2, 0.0])))
    pairs = [p for p in robot.collision_pairs if "ball" in p]
    safety = 0.02
    tolerance = 1e-3  # linearization error of the damper over one step [m]

    def run(with_avoidance: bool) -> tuple[float, float]:
        state = robot.state()
        tcp = Task(Position(robot, "panda_hand_tcp"), goal, gain=0.05)
        posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-3)
        constraints = [JointPositionLimits(robot), JointVelocityLimits(robot)]
        if with_avoidance:
            constraints.append(
                CollisionAvoidance(robot, safety, influence_distance=0.1, gain=0.5, pairs=pairs)
            )
        ik = DifferentialIK(robot, [tcp, posture], constraints)
        model, geom = robot.model, robot.collision_model
        data, geom_data = model.createData(), geom.createData()
        index = [k for k, p in enumerate(robot.collision_pairs) if "ball" in p]
        closest = np.inf
        for k in range(400):
            q, result = ik.step(state, 0.01)
            assert result.success, f"step {k}: {result.status}"
            state.update(q)
            # independent distance: Pinocchio/coal directly
            pin.computeDistances(model, data, geom, geom_data, q)
            d = min(geom_data.distanceResults[i].min_distance for i in index)
            closest = min(closest, d)
        return closest, float(np.linalg.norm(tcp.error(state)))

    closest, final_error = run(True)
    assert closest >= safety - tolerance
    assert final_error < 0.25 * np.linalg.norm(goal - start)  # went around the ball
    closest_free, _ = run(False)
    assert closest_free < 0.0  # without the dampers the straight line goes through it


def test_hard_task_conflicting_with_bounds_is_relaxed_with_culprits(panda: Robot) -> None:
    state = panda.state()
    target = panda.q_default.copy()
    target[0] += 1.0  # 1 rad in one step of 5 ms: impossible within the velocity limits
    hard = Task(JointConfiguration(panda, ["panda_joint1"]), target, name="joint1 home")
    tcp = Task(Position(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(state)
    velocity = JointVelocityLimits(panda)
    ik = DifferentialIK(panda, [tcp], [JointPositionLimits(panda), velocity], equality_tasks=[hard])
    result = ik.solve(state, DT)
    assert result.status is IKStatus.RELAXED
    assert not result.success
    assert "task 'joint1 home'" in result.culprits
    assert "joint velocity limits" in result.culprits
    # the position limits are satisfied by the relaxed step and are not at fault
    assert "joint position limits" not in result.culprits
    # relaxed step: the joint moves between the velocity bound and the hard target
    assert velocity.limits[0] * DT - 1e-6 <= result.dq[0] <= 1.0


def test_hard_task_feasible_is_met_exactly(panda: Robot) -> None:
    state = panda.state()
    target = panda.q_default.copy()
    target[0] += 0.005
    hard = Task(JointConfiguration(panda, ["panda_joint1"]), target, name="joint1")
    tcp = Task(Position(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(state)
    ik = DifferentialIK(
        panda,
        [tcp],
        [JointPositionLimits(panda), JointVelocityLimits(panda)],
        equality_tasks=[hard],
    )
    result = ik.solve(state, DT)
    assert result.success and result.status is IKStatus.SOLVED
    assert result.dq[0] == pytest.approx(0.005, abs=1e-9)
