"""The compiled closed-form step of HierarchicalIK (``_native/hier_kernel.hpp``).

Where the kernel answers (``result.native``), its step is checked against references that do
not use the cascade: the level-by-level quadprog reference in the original variables of
``test_ik_hierarchical_priority`` (each level's optimal value, earlier levels held at the
reference's own point) and, without inequalities and boxes, the recursive nullspace formula
``hierarchical_step_exact`` (SVD pseudo-inverses). The scenes are G1 and Talos (feet; a CoM
box; CoM; hands; posture) and Panda (tcp pose with a height cap; elbow; posture), with the
robots' joint position and velocity limits. Where it must decline (a level close to
rank-deficient, an inequality or a bound active at the closed-form point), the step must come
from the Python cascade (``result.native`` false, ``native_declined`` saying why) and still
match the reference. Mutation check: the kernel without ``r_k - J_k x`` (every level solved as
if the higher levels had not moved) fails the reference and nullspace-formula tests.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace._native import ik_kernel
from taskspace.constraints import (
    Constraint,
    FeatureBounds,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.features import CenterOfMass, FramePose, JointConfiguration, Position
from taskspace.ik import HierarchicalIK
from taskspace.ik._native_hierarchy import DECLINED
from taskspace.model import Robot
from taskspace.qp import INF, HierarchyLevel, QPStatus, hierarchical_step_exact
from taskspace.tasks import Task
from tests.ik.test_ik_hierarchical_priority import _copy, _level_value, _reference

DT = 0.005

pytestmark = pytest.mark.skipif(
    ik_kernel() is None or not hasattr(ik_kernel(), "HierarchicalIKKernel"),
    reason="the compiled IK kernel is not built",
)

FRAMES = {
    "g1": (
        ("left_ankle_roll_link", "right_ankle_roll_link"),
        ("left_rubber_hand", "right_rubber_hand"),
    ),
    "talos": (
        ("left_sole_link", "right_sole_link"),
        ("gripper_left_base_link", "gripper_right_base_link"),
    ),
}


def _humanoid(
    robot: Robot, com_shift: float, box_ahead: float, hand_shift: float, inequality: bool = True
) -> list[list[Task | Constraint]]:
    """Feet (+ a CoM box ``box_ahead`` ahead of the CoM); CoM moved ``com_shift`` forward;
    hands moved; posture (weight 1e-2 on all rows)."""
    feet, hands = FRAMES[robot.name]
    s = robot.state(robot.q_default)
    foot_tasks = [Task(FramePose(robot, f), name=f) for f in feet]
    com = Task(CenterOfMass(robot), name="com")
    hand_tasks = [Task(Position(robot, h), name=h) for h in hands]
    for t in (*foot_tasks, com, *hand_tasks):
        t.set_target_from_state(s)
    c = com.target.copy()
    support = FeatureBounds(
        CenterOfMass(robot),
        [c[0] - 0.02, c[1] - 0.02, -INF],
        [c[0] + box_ahead, c[1] + 0.02, INF],
        name="CoM box",
    )
    com.set_target(c + np.array([com_shift, 0.0, -0.002]))
    for sign, h in zip((1.0, -1.0), hand_tasks, strict=True):
        h.set_target(h.target + hand_shift * np.array([1.0, sign * 0.5, 0.6]))
    posture = Task(JointConfiguration(robot), robot.q_default, weight=1e-2, name="posture")
    first: list[Task | Constraint] = [*foot_tasks, support] if inequality else [*foot_tasks]
    return [first, [com], list(hand_tasks), [posture]]


def _panda(
    robot: Robot, cap_above: float, inequality: bool = True, pose: bool = False
) -> list[list[Task | Constraint]]:
    """tcp pose (+ a height cap ``cap_above`` above its target); elbow position (its 1-d
    self-motion); posture. With ``pose``: tcp position (+ cap); tcp pose (its position rows
    repeat level 1's: a rank-deficient level); posture."""
    s = robot.state(robot.q_default)
    tcp = "panda_hand_tcp"
    first_task = Task(Position(robot, tcp) if pose else FramePose(robot, tcp), name="tcp")
    first_task.set_target_from_state(s)
    z = float(s.frame_placement(robot.frame_id(tcp)).translation[2]) + 0.002  # the target's height
    if pose:
        first_task.set_target(first_task.target + np.array([0.002, 0.001, 0.002]))
        second = Task(FramePose(robot, tcp), name="tcp pose")
    else:
        second = Task(Position(robot, "panda_link4"), name="elbow")
    second.set_target_from_state(s)
    for task in (first_task, second):
        if task.feature.dim == 6:
            T = task.target.copy()
            T.translation = T.translation + np.array([0.002, 0.001, 0.002])
            task.set_target(T)
        elif task is second:
            task.set_target(task.target + np.array([0.0, 0.002, 0.0]))
    cap = FeatureBounds(Position(robot, tcp), [-INF, -INF, -INF], [INF, INF, z + cap_above])
    posture = Task(JointConfiguration(robot), robot.q_default, name="posture")
    first: list[Task | Constraint] = [first_task, cap] if inequality else [first_task]
    return [first, [second], [posture]]


def _limits(robot: Robot) -> list[Constraint]:
    if robot.name == "talos":  # at q_default a joint sits at its limit and a few mm of hand
        return []  # motion exceed the arms' velocity limits: every box is active
    return [JointPositionLimits(robot), JointVelocityLimits(robot)]


def _levels_and_box(
    ik: HierarchicalIK, robot: Robot, state: object
) -> tuple[list[HierarchyLevel], np.ndarray, np.ndarray]:
    """The Python path's rows of the step (copies) and the combined joint box."""
    levels = [_copy(level) for level in ik.build(state, DT)]  # type: ignore[arg-type]
    lb, ub, _ = ik._boxes.fill(state, DT)  # type: ignore[arg-type]
    return levels, np.array(lb), np.array(ub)


def _check_against_reference(
    levels: list[HierarchyLevel], x: np.ndarray, lb: np.ndarray, ub: np.ndarray
) -> None:
    reference = _reference(levels, x.shape[0], lb, ub)
    values = [_level_value(level, x) for level in levels]
    for k, (value, ref) in enumerate(zip(values, reference, strict=True)):
        # the reference is approximate too (a 1e-10 regularization, 1e-12 bands on the held
        # rows): it may be off either way by ~1e-6 relative
        assert ref <= value * (1.0 + 5e-5) + 1e-12, (k, values, reference)
        assert value == pytest.approx(ref, rel=5e-5, abs=1e-12), (k, values, reference)
    assert np.all(x >= lb - 1e-10) and np.all(x <= ub + 1e-10)


def _inequalities_hold(levels: list[HierarchyLevel], x: np.ndarray) -> None:
    for level in levels:
        if level.C is not None:
            assert level.l is not None and level.u is not None
            v = level.C @ x
            assert np.all(v >= level.l - 1e-10) and np.all(v <= level.u + 1e-10)


def _scene(name: str, robot: Robot, active: bool) -> list[list[Task | Constraint]]:
    if name == "panda":
        return _panda(robot, cap_above=-0.001 if active else 0.05)
    # active: the CoM box 0.2 mm ahead of the CoM, the CoM sent 1 cm forward
    return _humanoid(robot, 0.002, 2e-4 if active else 0.05, 0.002)


@pytest.mark.parametrize("name", ["g1", "talos", "panda"])
def test_native_step_answers_and_matches_the_level_by_level_reference(
    name: str, robot_loader: object
) -> None:
    robot = robot_loader(name)  # type: ignore[operator]
    ik = HierarchicalIK(robot, _scene(name, robot, active=False), _limits(robot))
    python = HierarchicalIK(robot, _scene(name, robot, active=False), _limits(robot), native=False)
    state = robot.state(robot.q_default)
    result = ik.solve(state, DT)
    assert result.native, result.native_declined  # the compiled step answered
    assert not python.solve(state, DT).native
    assert result.success
    assert [lr.backend for lr in result.hierarchy.level_results] == ["native closed form"] * len(
        ik.levels
    )
    levels, lb, ub = _levels_and_box(ik, robot, state)
    _check_against_reference(levels, result.dq, lb, ub)
    _inequalities_hold(levels, result.dq)  # what the kernel's check certified
    # what the result reports, against the rows: residuals, KKT of each level
    for level, residual, lr in zip(
        levels, result.residuals, result.hierarchy.level_results, strict=True
    ):
        assert residual == pytest.approx(np.linalg.norm(level.J @ result.dq - level.r), abs=1e-12)
        assert lr.status is QPStatus.UNCONSTRAINED
        assert lr.kkt.within(1e-9, 1e-6), lr.kkt  # (the undamped QR step: dual ~ mu |z|)
    dims = result.hierarchy.nullspace_dims
    assert dims == sorted(dims, reverse=True) and dims[0] < robot.nv


@pytest.mark.parametrize("name", ["g1", "talos", "panda"])
def test_native_step_equals_the_recursive_nullspace_formula(
    name: str, robot_loader: object
) -> None:
    # no inequality and no box: the step is the recursive pseudo-inverse projection
    robot = robot_loader(name)  # type: ignore[operator]
    if name == "panda":
        task_levels = _panda(robot, 0.05, inequality=False)
    else:
        task_levels = _humanoid(robot, 0.01, 0.05, 0.02, inequality=False)
    ik = HierarchicalIK(robot, task_levels)
    state = robot.state(robot.q_default)
    result = ik.solve(state, DT)
    assert result.native, result.native_declined
    jacobians, targets = [], []
    for level in task_levels:
        rows = [t.rows(state) for t in level if isinstance(t, Task)]
        jacobians.append(np.vstack([r[0] for r in rows]))
        targets.append(np.concatenate([r[1] for r in rows]))
    reference = hierarchical_step_exact(jacobians, targets)
    np.testing.assert_allclose(
        result.dq, reference, rtol=0, atol=1e-9 * max(1.0, np.abs(reference).max())
    )


def _check_level_qps(result: object, python: object) -> None:
    """The kernel's level QPs answered: certified, and the Python cascade's step."""
    assert result.native, result.native_declined  # type: ignore[attr-defined]
    hierarchy = result.hierarchy  # type: ignore[attr-defined]
    assert result.success and hierarchy.status is QPStatus.SOLVED  # type: ignore[attr-defined]
    for lr in hierarchy.level_results:
        if lr.backend == "native active set":
            assert lr.status is QPStatus.SOLVED
            assert lr.kkt.within(1e-9, 1e-9), lr.kkt
        else:  # a level without freedom
            assert lr.x.size == 0
    assert any(lr.backend == "native active set" for lr in hierarchy.level_results)
    assert not python.native  # type: ignore[attr-defined]
    # the Python cascade's level QPs (daqp / proxsuite, certified to 1e-9 / 1e-6): the same
    # step up to the levels' conditioning (|J|^2 / damping ~ 1e9)
    scale = max(1.0, float(np.abs(python.dq).max()))  # type: ignore[attr-defined]
    np.testing.assert_allclose(
        result.dq,  # type: ignore[attr-defined]
        python.dq,  # type: ignore[attr-defined]
        rtol=0,
        atol=1e-6 * scale,
    )


@pytest.mark.parametrize("name", ["g1", "panda"])
def test_native_level_qps_on_an_active_inequality(name: str, robot_loader: object) -> None:
    robot = robot_loader(name)  # type: ignore[operator]
    ik = HierarchicalIK(robot, _scene(name, robot, active=True), _limits(robot))
    python = HierarchicalIK(robot, _scene(name, robot, active=True), _limits(robot), native=False)
    state = robot.state(robot.q_default)
    result = ik.solve(state, DT)
    _check_level_qps(result, python.solve(state, DT))
    levels, lb, ub = _levels_and_box(ik, robot, state)
    _check_against_reference(levels, result.dq, lb, ub)
    for level, residual, violation in zip(levels, result.residuals, result.violations, strict=True):
        assert residual == pytest.approx(np.linalg.norm(level.J @ result.dq - level.r), abs=1e-12)
        if level.C is not None:
            assert level.l is not None and level.u is not None
            v = level.C @ result.dq
            assert violation == pytest.approx(
                max(0.0, float(np.max(np.maximum(level.l - v, v - level.u)))), abs=1e-12
            )
    # the level QPs turned off: the kernel declines, the Python cascade answers
    assert ik._native is not None
    ik._native.kernel.set_level_qps(False)
    result = ik.solve(state, DT)
    assert not result.native and result.native_declined == DECLINED[3]
    _check_against_reference(levels, result.dq, lb, ub)


def test_native_level_qps_follow_the_active_scene_over_steps(g1: Robot) -> None:
    # the CoM box active on every step while the hands move: every step by the kernel's
    # level QPs, each the Python cascade's step; the last against the reference
    task_levels = _scene("g1", g1, active=True)
    ik = HierarchicalIK(g1, task_levels, _limits(g1))
    python = HierarchicalIK(g1, task_levels, _limits(g1), native=False)
    hands = task_levels[2]
    state = g1.state(g1.q_default)
    for k in range(12):
        for sign, h in zip((1.0, -1.0), hands, strict=True):
            assert isinstance(h, Task)
            h.set_target(h.target + 0.003 * np.array([np.cos(k), sign, 0.5]))
        a = ik.solve(state, DT)
        _check_level_qps(a, python.solve(state, DT))
        state.update(g1.integrate(state.q, a.dq))
    levels, lb, ub = _levels_and_box(ik, g1, state)
    result = ik.solve(state, DT)
    assert result.native
    _check_against_reference(levels, result.dq, lb, ub)


def test_native_step_declines_on_an_active_bound_and_a_hard_inequality(panda: Robot) -> None:
    state = panda.state(panda.q_default)
    # a joint step box tighter than the closed-form step
    tight = JointVelocityLimits(panda, scale=0.05)
    ik = HierarchicalIK(panda, _panda(panda, 0.05), [JointPositionLimits(panda), tight])
    python = HierarchicalIK(
        panda, _panda(panda, 0.05), [JointPositionLimits(panda), tight], native=False
    )
    result = ik.solve(state, DT)
    _check_level_qps(result, python.solve(state, DT))
    levels, lb, ub = _levels_and_box(ik, panda, state)
    assert np.any(np.isclose(result.dq, lb) | np.isclose(result.dq, ub))  # the box is active
    _check_against_reference(levels, result.dq, lb, ub)
    # the height cap as a hard constraint (every level): inactive, then active
    for above, qp in ((0.05, False), (-0.001, True)):
        task_levels = _panda(panda, above)
        cap = task_levels[0].pop()
        assert isinstance(cap, FeatureBounds)
        ik = HierarchicalIK(panda, task_levels, [*_limits(panda), cap])
        result = ik.solve(state, DT)
        if qp:
            python = HierarchicalIK(panda, task_levels, [*_limits(panda), cap], native=False)
            _check_level_qps(result, python.solve(state, DT))
        else:
            assert result.native and result.hierarchy.status is QPStatus.UNCONSTRAINED
        C, _, u = cap.inequalities(state, DT)
        assert np.all(C @ result.dq <= u + 1e-9)  # a hard row: held


def test_native_step_declines_on_a_rank_deficient_level_panda(panda: Robot) -> None:
    # the tcp pose below the tcp position: its position rows vanish in level 1's nullspace
    ik = HierarchicalIK(panda, _panda(panda, 0.05, pose=True), _limits(panda))
    state = panda.state(panda.q_default)
    result = ik.solve(state, DT)
    assert not result.native
    assert result.native_declined == DECLINED[1]
    assert result.success
    levels, lb, ub = _levels_and_box(ik, panda, state)
    _check_against_reference(levels, result.dq, lb, ub)


def test_native_step_declines_on_a_rank_deficient_level(g1: Robot) -> None:
    # the hands' level holds each hand position twice: 12 rows of rank 6
    task_levels = _humanoid(g1, 0.01, 0.05, 0.01)
    hands = task_levels[2]
    twins = []
    for h in hands:
        assert isinstance(h, Task)
        twin = Task(Position(g1, h.feature.frame), name=f"{h.name} twice")  # type: ignore[attr-defined]
        twin.set_target(h.target)
        twins.append(twin)
    task_levels[2] = [*hands, *twins]
    ik = HierarchicalIK(g1, task_levels, _limits(g1))
    state = g1.state(g1.q_default)
    result = ik.solve(state, DT)
    assert not result.native
    assert result.native_declined == DECLINED[1]
    assert result.success
    levels, lb, ub = _levels_and_box(ik, g1, state)
    _check_against_reference(levels, result.dq, lb, ub)


def test_native_step_follows_reassigned_weights_targets_and_bounds(g1: Robot) -> None:
    task_levels = _humanoid(g1, 0.01, 0.05, 0.01)
    ik = HierarchicalIK(g1, task_levels, _limits(g1))
    python = HierarchicalIK(g1, task_levels, _limits(g1), native=False)
    state = g1.state(g1.q_default)
    assert ik.solve(state, DT).native
    posture = task_levels[3][0]
    support = task_levels[0][-1]
    assert isinstance(posture, Task) and isinstance(support, FeatureBounds)
    posture.weight = 0.5  # reassigned: the kernel's scaling is sent again
    hand = task_levels[2][0]
    assert isinstance(hand, Task)
    hand.set_target(hand.target + np.array([0.0, 0.0, 0.01]))
    support.upper[0] = support.upper[0] - 0.049  # changed in place: sent again, now active
    a, b = ik.solve(state, DT), python.solve(state, DT)
    _check_level_qps(a, b)  # the level QPs
    support.upper[0] += 0.049
    a, b = ik.solve(state, DT), python.solve(state, DT)
    assert a.native and a.hierarchy.status is QPStatus.UNCONSTRAINED  # closed form again
    levels, lb, ub = _levels_and_box(ik, g1, state)
    _check_against_reference(levels, a.dq, lb, ub)


def test_native_step_declines_with_levenberg_marquardt_damping(panda: Robot) -> None:
    task_levels = _panda(panda, 0.05)
    pose = task_levels[1][0]
    assert isinstance(pose, Task)
    pose.lm_damping = 1.0
    ik = HierarchicalIK(panda, task_levels, _limits(panda))
    result = ik.solve(panda.state(panda.q_default), DT)
    assert not result.native and result.native_declined == DECLINED[-1]


def test_native_step_with_two_posture_tasks_equals_the_nullspace_formula(g1: Robot) -> None:
    # posture rows of a joint subset on level 2 and of every joint, the free flyer included
    # (its Lie-group dDifference block), on level 3; the state away from the targets
    q = g1.q_default.copy()
    q[:3] += np.array([0.01, -0.02, 0.0])
    q[7:] += 0.03
    state = g1.state(q)
    feet = [Task(FramePose(g1, f)) for f in FRAMES["g1"][0]]
    for t in feet:
        t.set_target_from_state(state)
    waist = Task(
        JointConfiguration(g1, ["waist_yaw_joint", "left_elbow_joint", "right_elbow_joint"]),
        g1.q_default,
        weight=4.0,
        name="waist and elbows",
    )
    everything = Task(
        JointConfiguration(g1, floating_base=True), g1.q_default, weight=0.3, name="posture"
    )
    task_levels: list[list[Task | Constraint]] = [[*feet], [waist], [everything]]
    ik = HierarchicalIK(g1, task_levels)
    result = ik.solve(state, DT)
    assert result.native, result.native_declined
    jacobians, targets = [], []
    for level in task_levels:
        rows = [t.rows(state) for t in level if isinstance(t, Task)]
        jacobians.append(np.vstack([r[0] for r in rows]))
        targets.append(np.concatenate([r[1] for r in rows]))
    reference = hierarchical_step_exact(jacobians, targets)
    scale = max(1.0, float(np.abs(reference).max()))
    np.testing.assert_allclose(result.dq, reference, rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("hard", [False, True])
def test_native_step_checks_inequality_rows_evaluated_in_python(panda: Robot, hard: bool) -> None:
    # a cap on a point 1 cm off the tcp frame: no compiled term, its rows are evaluated in
    # Python and passed to the kernel's check (on level 1, or binding every level)
    state = panda.state(panda.q_default)
    tcp = "panda_hand_tcp"
    offset = np.array([0.0, 0.0, 0.01])
    point = Position(panda, tcp, offset)
    z = float(point.value(state)[2]) + 0.002  # where level 1 sends it (about)
    for above, qp in ((0.05, False), (-0.001, True)):
        task_levels = _panda(panda, 0.05, inequality=False)
        cap = FeatureBounds(point, [-INF, -INF, -INF], [INF, INF, z + above], name="point cap")
        constraints = _limits(panda)
        if hard:
            constraints.append(cap)
        else:
            task_levels[0].append(cap)
        ik = HierarchicalIK(panda, task_levels, constraints)
        result = ik.solve(state, DT)
        assert result.native, result.native_declined
        if qp:  # the level QPs, the Python cascade's step
            python = HierarchicalIK(panda, task_levels, constraints, native=False)
            _check_level_qps(result, python.solve(state, DT))
        else:
            assert result.hierarchy.status is QPStatus.UNCONSTRAINED
        levels, lb, ub = _levels_and_box(ik, panda, state)
        if not qp or hard:  # held: satisfied (level 1 cannot reach its target under it)
            C, _, u = cap.inequalities(state, DT)
            assert np.all(C @ result.dq <= u + 1e-9)
        if not hard:
            _check_against_reference(levels, result.dq, lb, ub)


def test_native_step_with_one_level_is_the_damped_least_squares_step(panda: Robot) -> None:
    # one level (the kernel's per-level data has one row): its damped normal equations
    state = panda.state(panda.q_default)
    task_levels = _panda(panda, 0.05, inequality=False)
    tasks = [t for level in task_levels for t in level if isinstance(t, Task)]
    ik = HierarchicalIK(panda, [tasks])
    result = ik.solve(state, DT)
    assert result.native, result.native_declined
    rows = [t.rows(state) for t in tasks]
    J = np.vstack([r[0] for r in rows])
    r = np.concatenate([r[1] for r in rows])
    mu = ik.solver.options.damping
    reference = np.linalg.solve(J.T @ J + mu * np.eye(panda.nv), J.T @ r)
    np.testing.assert_allclose(result.dq, reference, rtol=0, atol=1e-9)
    assert len(result.hierarchy.level_results) == 1
    assert result.hierarchy.nullspace_dims == [panda.nv]


def test_after_an_active_step_the_python_cascade_answers_directly(g1: Robot) -> None:
    # the CoM box active on every step, the kernel's level QPs off: the first step's kernel
    # call declines, the next steps skip it (the Python cascade answers directly, the same
    # steps as without the kernel)
    task_levels = _scene("g1", g1, active=True)
    ik = HierarchicalIK(g1, task_levels, _limits(g1))
    assert ik.native and ik._native is not None
    ik._native.kernel.set_level_qps(False)
    python = HierarchicalIK(g1, task_levels, _limits(g1), native=False)
    state = g1.state(g1.q_default)
    reasons = []
    for _ in range(3):
        a, b = ik.solve(state, DT), python.solve(state, DT)
        assert not a.native and a.success
        reasons.append(a.native_declined)
        np.testing.assert_array_equal(a.dq, b.dq)
        state.update(g1.integrate(state.q, a.dq))
    assert reasons == [DECLINED[3], DECLINED[-2], DECLINED[-2]]
    levels, lb, ub = _levels_and_box(ik, g1, state)
    _check_against_reference(levels, ik.solve(state, DT).dq, lb, ub)


@pytest.mark.parametrize("velocity", [False, True])
def test_advance_solves_integrates_and_moves_the_state(g1: Robot, velocity: bool) -> None:
    # the active scene (kernel level QPs): advance = solve at the state, then the state at
    # q (+) dq (Pinocchio's integrate and forward kinematics as the reference)
    import pinocchio as pin

    task_levels = _scene("g1", g1, active=True)
    ik = HierarchicalIK(g1, task_levels, _limits(g1))
    twin = HierarchicalIK(g1, task_levels, _limits(g1))
    q0 = g1.q_default.copy()
    state = g1.state(q0, np.zeros(g1.nv) if velocity else None)
    reference_state = g1.state(q0)
    for _ in range(3):
        expected = twin.solve(reference_state, DT)
        result = ik.advance(state, DT)
        assert result.native and expected.native
        np.testing.assert_array_equal(result.dq, expected.dq)
        q1 = pin.integrate(g1.model, reference_state.q, expected.dq)
        np.testing.assert_allclose(state.q, q1, rtol=0, atol=1e-15)
        if velocity:
            np.testing.assert_allclose(state.v, expected.dq / DT, rtol=0, atol=1e-12)
        data = g1.model.createData()
        pin.framesForwardKinematics(g1.model, data, q1)
        frame = g1.frame_id(FRAMES["g1"][1][0])
        np.testing.assert_allclose(
            state.frame_placement(frame).homogeneous, data.oMf[frame].homogeneous, atol=1e-12
        )
        reference_state.update(q1)
    assert not np.shares_memory(state.q, q0) and np.array_equal(q0, g1.q_default)


def test_native_level_qps_on_degenerate_levels_answer_or_decline(g1: Robot) -> None:
    # random configurations and tight joint velocity boxes: the boxes and held rows block
    # most of the lower levels' freedom (degenerate vertices: more rows tight than freedoms).
    # Each step is either the kernel's certified level QPs, equal to the Python cascade's
    # step, or declined (DECLINED[4]) and answered by the Python cascade
    rng = np.random.default_rng(0)
    idx = g1.limited_joints_q
    lo, hi = g1.lower_limits[idx], g1.upper_limits[idx]
    answered = 0
    for _ in range(6):
        q = g1.q_default.copy()
        q[idx] = np.clip(q[idx] + 0.15 * rng.standard_normal(idx.size), lo, hi)
        state = g1.state(q)
        limits = [JointPositionLimits(g1), JointVelocityLimits(g1, scale=0.05)]
        task_levels = _humanoid(
            g1, float(rng.uniform(0, 0.02)), float(rng.uniform(-0.005, 0.01)), 0.01
        )
        ik = HierarchicalIK(g1, task_levels, limits)
        result = ik.solve(state, DT)
        python = HierarchicalIK(g1, task_levels, limits, native=False).solve(state, DT)
        if result.native and python.success:
            _check_level_qps(result, python)
            answered += 1
        elif result.native:
            # the Python cascade relaxed a level (RELAXED: its QP solvers did not certify it
            # and the polished answer violates a box): the kernel's step holds every box and
            # equals it on the levels above
            levels, lb, ub = _levels_and_box(ik, g1, state)
            assert result.success and np.all(result.dq >= lb - 1e-10)
            assert np.all(result.dq <= ub + 1e-10)
            statuses = [lr.status for lr in python.hierarchy.level_results]
            assert QPStatus.RELAXED in statuses, statuses
            for level, lr in zip(levels, python.hierarchy.level_results, strict=True):
                if lr.status is QPStatus.RELAXED:
                    break
                assert _level_value(level, result.dq) == pytest.approx(
                    _level_value(level, python.dq), rel=1e-8, abs=1e-12
                )
            answered += 1
        else:
            assert result.native_declined == DECLINED[4], result.native_declined
            np.testing.assert_array_equal(result.dq, python.dq)
    assert answered >= 3
