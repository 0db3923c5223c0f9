"""The batched task and contact rows of the inverse-dynamics QP equal the per-object ones."""

from __future__ import annotations

import numpy as np

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import InverseDynamicsQP
from taskspace.qp.rows import TaskRowStack
from taskspace.tasks import Task
from tests.conftest import load_robot


def _random_state(robot, rng):  # type: ignore[no-untyped-def]
    q = robot.q_default.copy()
    q[7:] += rng.normal(scale=0.1, size=robot.nq - 7)
    v = rng.normal(scale=0.5, size=robot.nv)
    return robot.state(q, v)


def test_stack_equals_the_rows_of_each_task() -> None:
    robot = load_robot("g1")
    rng = np.random.default_rng(3)
    s0 = robot.state(robot.q_default, np.zeros(robot.nv))
    com = Task(F.CenterOfMass(robot), kp=50.0, weight=np.array([1.0, 4.0, 9.0]))
    com.set_target_from_state(s0)
    hand = Task(F.FramePose(robot, "left_rubber_hand"), kp=20.0, kd=3.0, weight=0.1)
    hand.set_target_from_state(s0)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0)
    tasks = [com, hand, posture]
    stack = TaskRowStack(tasks, robot.nv)
    for step in range(4):
        state = _random_state(robot, rng)
        if step == 2:  # gains and references changed between calls are picked up
            hand.kp, hand.kd = 80.0, 1.0
            com.set_reference(velocity=rng.normal(size=3), acceleration=rng.normal(size=3))
        J, rhs = stack.acceleration(state)
        rows = [t.acceleration_rows(state) for t in tasks]
        np.testing.assert_allclose(J, np.vstack([r[0] for r in rows]), rtol=0, atol=1e-12)
        np.testing.assert_allclose(rhs, np.concatenate([r[1] for r in rows]), rtol=1e-12, atol=1e-9)


def test_contact_rows_of_the_qp_equal_each_contact_rhs() -> None:
    robot = load_robot("g1")
    rng = np.random.default_rng(4)
    s0 = robot.state(robot.q_default, np.zeros(robot.nv))
    feet = ["left_ankle_roll_link", "right_ankle_roll_link"]
    contacts = [Contact6D(robot, f, kp=10.0) for f in feet]
    for c in contacts:
        c.set_reference(s0)
    posture = Task(F.JointConfiguration(robot), robot.q_default)
    ctrl = InverseDynamicsQP(robot, [posture], contacts)
    nu = len(ctrl.unactuated)
    for step in range(3):
        state = _random_state(robot, rng)
        if step == 1:
            contacts[0].kd = 5.0
        problem = ctrl.build(state)
        expected = np.concatenate([c.acceleration_rhs(state) for c in contacts])
        np.testing.assert_allclose(problem.b[nu:], expected, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(
            problem.A[nu:, : robot.nv], np.vstack([c.jacobian(state) for c in contacts])
        )


def test_hierarchy_levels_follow_priority_changes() -> None:
    """The cascade's preallocated levels are rebuilt when a task's priority changes."""
    from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions

    robot = load_robot("g1")
    rng = np.random.default_rng(5)
    s0 = robot.state(robot.q_default, np.zeros(robot.nv))
    feet = ["left_ankle_roll_link", "right_ankle_roll_link"]

    def controller() -> tuple[InverseDynamicsQP, list[Task]]:
        com = Task(F.CenterOfMass(robot), kp=50.0, priority=0)
        com.set_target_from_state(s0)
        hand = Task(F.FramePose(robot, "left_rubber_hand"), kp=50.0, priority=1)
        hand.set_target_from_state(s0)
        posture = Task(F.JointConfiguration(robot), robot.q_default, kp=30.0, priority=2)
        tasks = [com, hand, posture]
        contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in feet]
        opts = InverseDynamicsOptions(hierarchical=True)
        return InverseDynamicsQP(robot, tasks, contacts, opts), tasks

    ctrl, tasks = controller()
    state = _random_state(robot, rng)
    first = ctrl.solve(state)
    tasks[1].priority, tasks[2].priority = 2, 1  # posture above the hand now
    swapped = ctrl.solve(state)
    fresh_ctrl, fresh_tasks = controller()
    fresh_tasks[1].priority, fresh_tasks[2].priority = 2, 1
    expected = fresh_ctrl.solve(state)
    np.testing.assert_allclose(swapped.a, expected.a, atol=1e-8)
    assert np.abs(swapped.a - first.a).max() > 1e-3  # the order matters here


def test_stacked_feasibility_test_agrees_with_the_blockwise_one() -> None:
    """The QP's stacked rows (G, lo, hi) describe exactly its C, A and box constraints."""
    import dataclasses

    from taskspace.qp.solver import unconstrained_minimizer

    robot = load_robot("g1")
    rng = np.random.default_rng(6)
    s0 = robot.state(robot.q_default, np.zeros(robot.nv))
    feet = ["left_ankle_roll_link", "right_ankle_roll_link"]
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in feet]
    com = Task(F.CenterOfMass(robot), kp=50.0)
    com.set_target_from_state(s0)
    ctrl = InverseDynamicsQP(robot, [com], contacts)
    for _ in range(3):
        problem = ctrl.build(_random_state(robot, rng))
        plain = dataclasses.replace(problem, stacked=None)
        x = unconstrained_minimizer(problem)
        assert x is not None
        candidates = [x, x + 1e-3 * rng.normal(size=x.size)]
        for k in range(problem.n):  # push each variable past its bound, one at a time
            if problem.ub[k] < 1e19:
                y = x.copy()
                y[k] = problem.ub[k] + 1e-6
                candidates.append(y)
        for y in candidates:
            for tol in (1e-10, 1e-4):
                assert problem.is_feasible(y, tol) == plain.is_feasible(y, tol)
        assert any(not plain.is_feasible(y, 1e-10) for y in candidates)
