"""HierarchicalIK (slides 2:42-2:44) on the G1 humanoid: feet; CoM; hands; posture."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.constraints import FeatureBounds, JointPositionLimits, JointVelocityLimits
from taskspace.features import CenterOfMass, FramePose, JointConfiguration, Position
from taskspace.ik import HierarchicalIK
from taskspace.model import Robot
from taskspace.qp import hierarchical_step_exact
from taskspace.tasks import Task
from tests.ik.ik_scenarios import DT, benchmark_offset

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
HANDS = ("left_rubber_hand", "right_rubber_hand")


def _g1_tasks(g1: Robot) -> tuple[list[Task], Task, list[Task], Task]:
    state = g1.state()
    feet = [Task(FramePose(g1, f)) for f in FEET]
    com = Task(CenterOfMass(g1))
    hands = [Task(Position(g1, f)) for f in HANDS]
    for task in [*feet, com, *hands]:
        task.set_target_from_state(state)
    posture = Task(JointConfiguration(g1), g1.q_default, gain=0.05)
    return feet, com, hands, posture


@pytest.mark.slow
def test_g1_four_levels_feet_held_while_hands_move(g1: Robot) -> None:
    feet, com, hands, posture = _g1_tasks(g1)
    velocity = JointVelocityLimits(g1)
    ik = HierarchicalIK(g1, [feet, [com], hands, [posture]], [JointPositionLimits(g1), velocity])
    state = g1.state()
    hand_start = [h.target.copy() for h in hands]
    mirror = np.array([1.0, -1.0, 1.0])
    idx = g1.limited_joints_q
    for k in range(150):
        offset = 2.0 * benchmark_offset(3 * k)  # faster and larger than the benchmark
        hands[0].set_target(hand_start[0] + offset)
        hands[1].set_target(hand_start[1] + mirror * offset)
        q, result = ik.step(state, DT)
        assert result.success, f"step {k}"
        assert len(result.residuals) == 4
        assert result.residuals[0] < 1e-8  # level 1 (feet), linearized
        assert result.residuals[1] < 1e-8  # level 2 (CoM), feasible here
        assert np.all(q[idx] >= g1.lower_limits[idx] - 1e-9)
        assert np.all(q[idx] <= g1.upper_limits[idx] + 1e-9)
        state.update(q)
        for foot in feet:  # nonlinear error: second order in the step
            assert np.linalg.norm(foot.error(state)) < 1e-4  # [m, rad]
        for hand in hands:
            assert np.linalg.norm(hand.error(state)) < 1e-3
    assert np.linalg.norm(hands[0].target - hand_start[0]) > 0.05
    assert result.hierarchy.nullspace_dims == [g1.nv - 12, g1.nv - 15, g1.nv - 21, g1.nv - 21]


def test_g1_unconstrained_hierarchy_equals_exact_nullspace_formula(g1: Robot) -> None:
    # without limits, one step equals the recursive nullspace projection of the stacked rows
    rng = np.random.default_rng(5)
    feet, com, hands, posture = _g1_tasks(g1)
    state = g1.state()
    hands[0].set_target(hands[0].target + rng.uniform(-0.05, 0.05, 3))
    hands[1].set_target(hands[1].target + rng.uniform(-0.05, 0.05, 3))
    com.set_target(com.target + np.array([0.01, 0.0, -0.01]))
    levels = [feet, [com], hands, [posture]]
    ik = HierarchicalIK(g1, levels)
    result = ik.solve(state, DT)
    jacobians, targets = [], []
    for level in levels:
        rows = [t.rows(state) for t in level]
        jacobians.append(np.vstack([r[0] for r in rows]))
        targets.append(np.concatenate([r[1] for r in rows]))
    reference = hierarchical_step_exact(jacobians, targets)
    np.testing.assert_allclose(result.dq, reference, atol=1e-6)


def test_from_priorities_groups_levels(g1: Robot) -> None:
    feet, com, hands, posture = _g1_tasks(g1)
    for t in feet:
        t.priority = 0
    com.priority = 1
    for t in hands:
        t.priority = 2
    posture.priority = 3
    state = g1.state()
    hands[0].set_target(hands[0].target + np.array([0.02, 0.0, 0.01]))
    a = HierarchicalIK.from_priorities(g1, [posture, *hands, com, *feet]).solve(state, DT)
    b = HierarchicalIK(g1, [feet, [com], hands, [posture]]).solve(state, DT)
    np.testing.assert_allclose(a.dq, b.dq, atol=1e-10)


def test_level_inequality_in_ik_respected(panda: Robot) -> None:
    # level 1: tcp height >= current height - 1 mm; level 2: tcp pulled 5 cm down
    state = panda.state()
    tcp = Position(panda, "panda_hand_tcp")
    z0 = state.frame_placement(panda.frame_id("panda_hand_tcp")).translation[2]
    floor = FeatureBounds(tcp, [-np.inf, -np.inf, z0 - 1e-3], [np.inf, np.inf, np.inf])
    start = state.frame_placement(panda.frame_id("panda_hand_tcp")).translation
    down = Task(tcp, start - np.array([0.0, 0.0, 0.05]))
    ik = HierarchicalIK(panda, [[floor], [down]], [JointPositionLimits(panda)])
    result = ik.solve(state, DT)
    J = tcp.jacobian(state)
    assert (J @ result.dq)[2] == pytest.approx(-1e-3, abs=1e-8)  # stops on the (linear) floor
    assert result.violations[0] <= 1e-9


def test_build_refills_each_level_with_the_rows_of_its_tasks(panda: Robot) -> None:
    """The preallocated level rows equal the stacked Task.rows at every new state."""
    s0 = panda.state(panda.q_default)
    tcp = Task(FramePose(panda, "panda_hand_tcp"), weight=2.0, gain=0.5)
    tcp.set_target_from_state(s0)
    link = Task(Position(panda, "panda_link4"), [0.1, 0.0, 0.5], weight=np.array([1.0, 2.0, 3.0]))
    posture = Task(JointConfiguration(panda), panda.q_default, weight=1e-3)
    bounds = FeatureBounds(Position(panda, "panda_link6"), [-1, -1, 0.3], [1, 1, 2])
    ik = HierarchicalIK(panda, [[tcp, bounds, link], [posture]])
    rng = np.random.default_rng(8)
    for _ in range(3):
        q = panda.q_default + 0.3 * rng.uniform(-1, 1, panda.nq)
        state = panda.state(q)
        levels = ik.build(state, DT)
        for level, tasks in zip(levels, [[tcp, link], [posture]]):
            rows = [t.rows(state) for t in tasks]
            np.testing.assert_allclose(level.J, np.vstack([r[0] for r in rows]), atol=1e-14)
            np.testing.assert_allclose(level.r, np.concatenate([r[1] for r in rows]), atol=1e-14)
        assert levels[0].C is not None and levels[0].C.shape[0] == 3  # l <= C dq <= u
        assert levels[1].C is None
