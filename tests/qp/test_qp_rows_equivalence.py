"""Every consumer's QP equals a straightforward construction of it (builder equivalence).

The references below stack task rows, boxes and inequality rows by hand, one task, one
joint and one constraint at a time, with the rules written out (slide 2:39 for the weighted
IK step, slides 5:31-5:35 for the acceleration level); they share no code with the stacking
layer (``taskspace.qp.rows``). Each consumer (``DifferentialIK``, ``HierarchicalIK``,
``InverseDynamicsQP``, operational-space control, path optimization) must build the same
QP on random stacks of several real robots, and its solution must equal quadprog's on that
QP (an exact dual active-set method: an independent reference for the solve).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import quadprog

from taskspace import features as F
from taskspace.constraints import (
    CollisionAvoidance,
    Constraint,
    Contact6D,
    FeatureBounds,
    JointAccelerationLimits,
    JointPositionLimits,
    JointVelocityLimits,
    PointContact,
)
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.control.operational_space import operational_space_control
from taskspace.ik import DifferentialIK, DifferentialIKOptions, HierarchicalIK
from taskspace.model import Robot, State
from taskspace.tasks import Task
from tests.conftest import load_robot

BIG = 1e20  # the QP layer's stand-in for an infinite bound
RTOL = 1e-10
ROBOTS = ["panda", "ur5", "g1"]


# ---------------------------------------------------------------------- random stacks
def _random_q(robot: Robot, rng: np.random.Generator, outside: bool = False) -> np.ndarray:
    """A configuration near the default one (``outside``: some joints beyond their limits)."""
    v = 0.4 * rng.standard_normal(robot.nv)
    q = pin.integrate(robot.model, robot.q_default, v)
    lo, hi = robot.lower_limits, robot.upper_limits
    iq = robot.limited_joints_q
    q[iq] = np.clip(q[iq], lo[iq], hi[iq])
    if outside and iq.size:
        k = rng.choice(iq, size=min(2, iq.size), replace=False)
        q[k[0]] = hi[k[0]] + 0.05
        if k.size > 1:
            q[k[1]] = lo[k[1]] - 0.05
    return np.asarray(q)


def _weight(rng: np.random.Generator, dim: int) -> Any:
    return float(rng.uniform(0.1, 3.0)) if rng.random() < 0.5 else rng.uniform(0.1, 3.0, dim)


def _frames(robot: Robot) -> list[str]:
    return list(robot.end_effectors)


def _random_tasks(robot: Robot, rng: np.random.Generator, n: int) -> list[Task]:
    """``n`` tasks on random features, each with a target near the current value."""
    frames = _frames(robot)
    makers = [
        lambda: F.FramePose(robot, str(rng.choice(frames))),
        lambda: F.Position(robot, str(rng.choice(frames))),
        lambda: F.Position(robot, str(rng.choice(frames)), offset=rng.normal(scale=0.05, size=3)),
        lambda: F.Orientation(robot, str(rng.choice(frames))),
        lambda: F.CenterOfMass(robot),
        lambda: F.JointConfiguration(robot),
    ]
    q_target = _random_q(robot, rng)
    target_state = robot.state(q_target, np.zeros(robot.nv))
    tasks = []
    for _ in range(n):
        feature = makers[int(rng.integers(len(makers)))]()
        task = Task(
            feature,
            weight=_weight(rng, feature.dim),
            gain=float(rng.uniform(0.2, 1.0)),
            kp=float(rng.uniform(5.0, 100.0)),
            kd=float(rng.uniform(1.0, 20.0)),
        )
        task.set_target_from_state(target_state)
        if rng.random() < 0.3:
            task.set_reference(rng.normal(size=feature.dim), rng.normal(size=feature.dim))
        tasks.append(task)
    return tasks


def _random_constraints(robot: Robot, rng: np.random.Generator) -> list[Constraint]:
    out: list[Constraint] = [JointPositionLimits(robot, margin=float(rng.uniform(0.0, 0.05)))]
    if rng.random() < 0.8:
        out.append(JointVelocityLimits(robot, scale=float(rng.uniform(0.2, 1.0))))
    if rng.random() < 0.5:
        out.append(JointAccelerationLimits(robot, rng.uniform(5.0, 50.0, robot.nv)))
    com = F.CenterOfMass(robot)
    y = com.value(robot.state(robot.q_default))
    out.append(FeatureBounds(com, y - 0.02, y + np.array([0.02, 0.02, np.inf]), gain=0.5))
    pos = F.Position(robot, _frames(robot)[0])
    p = pos.value(robot.state(robot.q_default))
    out.append(FeatureBounds(pos, p - 0.05, p + 0.05, gain=float(rng.uniform(0.3, 1.0))))
    return out


# ---------------------------------------------------------------------- references
def _task_rows_velocity(tasks: list[Task], state: State, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """``sqrt(rho) J`` and ``-gain sqrt(rho) e`` of every task, one after the other."""
    rows_J, rows_r = [np.zeros((0, nv))], [np.zeros(0)]
    for t in tasks:
        e = t.feature.residual(state, t.target)
        J = t.feature.residual_jacobian(state, t.target)
        w = np.broadcast_to(np.sqrt(np.asarray(t.weight, dtype=float)), (t.dim,))
        rows_J.append(w[:, None] * J)
        rows_r.append(-t.gain * w * e)
    return np.vstack(rows_J), np.concatenate(rows_r)


def _task_rows_acceleration(
    tasks: list[Task], state: State, nv: int
) -> tuple[np.ndarray, np.ndarray]:
    """``sqrt(rho) J`` and ``sqrt(rho)(y''* - Jdot v)`` with ``y''* = a_ref - kp e - kd e'``."""
    rows_J, rows_r = [], []
    v = state.v
    for t in tasks:
        e = t.feature.residual(state, t.target)
        J = t.feature.residual_jacobian(state, t.target)
        e_dot = J @ v - (0.0 if t.reference_velocity is None else t.reference_velocity)
        a_ref = 0.0 if t.reference_acceleration is None else t.reference_acceleration
        desired = a_ref - t.kp * e - t.kd * e_dot
        w = np.broadcast_to(np.sqrt(np.asarray(t.weight, dtype=float)), (t.dim,))
        rows_J.append(w[:, None] * J)
        rows_r.append(w * (desired - t.feature.drift(state)))
    return np.vstack(rows_J), np.concatenate(rows_r)


def _combine_joint(hard: list[tuple[float, float]], soft: list[tuple[float, float]]) -> tuple:
    """The box of one joint (rules of the IK step, written per joint).

    Hard boxes (velocity, acceleration) intersect; an empty intersection becomes the
    midpoint of the gap. Soft boxes (position limits) intersect likewise. Where both exist,
    the soft box is cut by the hard one; a soft box entirely above (below) the hard one
    gives the hard upper (lower) bound; an empty soft box gives its midpoint clipped to
    the hard box.
    """

    def meet(boxes: list[tuple[float, float]]) -> tuple[float, float]:
        lo = max([b[0] for b in boxes], default=-BIG)
        hi = min([b[1] for b in boxes], default=BIG)
        return lo, hi

    hlo, hhi = meet(hard)
    if hlo > hhi:
        hlo = hhi = 0.5 * (hlo + hhi)
    if not soft:
        return hlo, hhi
    slo, shi = meet(soft)
    if not hard:
        if slo > shi:
            slo = shi = 0.5 * (slo + shi)
        return slo, shi
    lo, hi = max(hlo, slo), min(hhi, shi)
    if lo <= hi:
        return lo, hi
    if slo > hhi:
        return hhi, hhi
    if shi < hlo:
        return hlo, hlo
    mid = min(max(0.5 * (slo + shi), hlo), hhi)
    return mid, mid


def _boxes(constraints: list[Constraint], state: State, dt: float, nv: int) -> tuple:
    hard, soft = [], []
    for c in constraints:
        box = c.bounds(state, dt)
        if box is not None:
            (hard if c.hard_bounds else soft).append((np.asarray(box[0]), np.asarray(box[1])))
    lb, ub = np.empty(nv), np.empty(nv)
    for j in range(nv):
        lb[j], ub[j] = _combine_joint(
            [(b[0][j], b[1][j]) for b in hard], [(b[0][j], b[1][j]) for b in soft]
        )
    return lb, ub


def _inequalities(constraints: list[Constraint], state: State, dt: float, nv: int) -> tuple:
    Cs, ls, us = [np.zeros((0, nv))], [np.zeros(0)], [np.zeros(0)]
    for c in constraints:
        rows = c.inequalities(state, dt)
        if rows is not None:
            Cs.append(np.asarray(rows[0]).reshape(-1, nv))
            ls.append(np.asarray(rows[1]))
            us.append(np.asarray(rows[2]))
    return np.vstack(Cs), np.concatenate(ls), np.concatenate(us)


def reference_ik_qp(
    tasks: list[Task],
    constraints: list[Constraint],
    equality_tasks: list[Task],
    state: State,
    dt: float,
    damping: float,
) -> dict[str, np.ndarray]:
    """The weighted IK step's QP (module docstring of ``ik.differential_ik``), by hand."""
    nv = state.robot.nv
    M, r = _task_rows_velocity(tasks, state, nv)
    A, b = _task_rows_velocity(equality_tasks, state, nv)
    lb, ub = _boxes(constraints, state, dt, nv)
    C, l, u = _inequalities(constraints, state, dt, nv)
    return {
        "H": M.T @ M + damping * np.eye(nv),
        "g": -M.T @ r,
        "A": A,
        "b": b,
        "C": C,
        "l": l,
        "u": u,
        "lb": lb,
        "ub": ub,
    }


def reference_id_qp(ctrl: InverseDynamicsQP, state: State) -> dict[str, np.ndarray]:
    """The inverse-dynamics QP (module docstring of ``control.inverse_dynamics_qp``), by hand."""
    robot, opts = ctrl.robot, ctrl.options
    nv, nf = robot.nv, ctrl.nf
    n = nv + nf
    q, v = state.q, state.v
    data = robot.model.createData()
    M = pin.crba(robot.model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(robot.model, data, q, v)
    Jc = np.vstack([c.jacobian(state) for c in ctrl.contacts] or [np.zeros((0, nv))])
    Jt, rt = _task_rows_acceleration(ctrl.tasks, state, nv)
    weight = pin.computeTotalMass(robot.model) * np.linalg.norm(robot.model.gravity.linear)
    H = np.zeros((n, n))
    H[:nv, :nv] = Jt.T @ Jt + opts.acceleration_regularization * np.eye(nv)
    for k, w in enumerate(
        np.concatenate([c.regularization_weights() for c in ctrl.contacts] or [np.zeros(0)])
    ):
        H[nv + k, nv + k] = opts.force_regularization * w / weight**2
    g = np.zeros(n)
    g[:nv] = -Jt.T @ rt
    effort = robot.effort_limits
    unact, act = np.flatnonzero(effort <= 0), np.flatnonzero(effort > 0)
    # equalities: unactuated rows of the dynamics, then rigid contacts
    A_rows, b_rows = [], []
    for i in unact:
        A_rows.append(np.concatenate([M[i], -Jc[:, i]]))
        b_rows.append(-h[i])
    for c in ctrl.contacts:
        Ji = c.jacobian(state)
        rhs = -c.drift(state) - c.kd * Ji @ v
        if c.kp and c.reference is not None:
            rhs = rhs - c.kp * c.position_error(state)
        for k in range(c.force_dim):
            A_rows.append(np.concatenate([Ji[k], np.zeros(nf)]))
            b_rows.append(rhs[k])
    # inequalities: friction cones, then torque limits
    C_rows, l_rows, u_rows = [], [], []
    col = nv
    for c in ctrl.contacts:
        K, kk = c.cone()
        for i in range(K.shape[0]):
            row = np.zeros(n)
            row[col : col + c.force_dim] = K[i]
            C_rows.append(row)
            l_rows.append(kk[i])
            u_rows.append(BIG)
        col += c.force_dim
    if opts.torque_limits:
        for i in act:
            C_rows.append(np.concatenate([M[i], -Jc[:, i]]))
            l_rows.append(-effort[i] - h[i])
            u_rows.append(effort[i] - h[i])
    # box: stop within the horizon at the position limits, within the velocity limits
    lb, ub = np.full(n, -BIG), np.full(n, BIG)
    if opts.joint_limits:
        T = opts.limits_horizon
        c2 = 2.0 / T**2
        for iq, iv in zip(robot.limited_joints_q, robot.limited_joints_v):
            vmax = robot.velocity_limits[iv]
            lo = max(c2 * (robot.lower_limits[iq] - q[iq]) - 2 * v[iv] / T, (-vmax - v[iv]) / T)
            hi = min(c2 * (robot.upper_limits[iq] - q[iq]) - 2 * v[iv] / T, (vmax - v[iv]) / T)
            if lo > hi:
                lo = hi = 0.5 * (lo + hi)
            lb[iv], ub[iv] = lo, hi
    return {
        "H": H,
        "g": g,
        "A": np.array(A_rows).reshape(-1, n),
        "b": np.array(b_rows),
        "C": np.array(C_rows).reshape(-1, n),
        "l": np.array(l_rows),
        "u": np.array(u_rows),
        "lb": lb,
        "ub": ub,
    }


def quadprog_solve(qp: dict[str, np.ndarray]) -> np.ndarray:
    """``argmin 1/2 x^T H x + g^T x`` under the QP's constraints, by quadprog."""
    n = qp["g"].shape[0]
    cols, rhs = [qp["A"].T], [qp["b"]]
    for M, lo, hi in ((qp["C"], qp["l"], qp["u"]), (np.eye(n), qp["lb"], qp["ub"])):
        fin_lo, fin_hi = lo > -BIG / 2, hi < BIG / 2
        cols += [M[fin_lo].T, -M[fin_hi].T]
        rhs += [lo[fin_lo], -hi[fin_hi]]
    H = 0.5 * (qp["H"] + qp["H"].T)
    x = quadprog.solve_qp(H, -qp["g"], np.hstack(cols), np.concatenate(rhs), qp["A"].shape[0])[0]
    return np.asarray(x)


def assert_same_qp(problem: Any, reference: dict[str, np.ndarray]) -> None:
    for name, expected in reference.items():
        actual = np.asarray(getattr(problem, name))
        assert actual.shape == expected.shape, (name, actual.shape, expected.shape)
        scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
        np.testing.assert_allclose(actual, expected, rtol=0, atol=RTOL * scale, err_msg=name)


# ---------------------------------------------------------------------- velocity level
@pytest.mark.parametrize("name", ROBOTS)
def test_differential_ik_builds_the_reference_qp_and_solves_it(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(sum(name.encode()))
    dt = 0.02
    for trial in range(4):
        tasks = _random_tasks(robot, rng, int(rng.integers(1, 5)))
        eq = _random_tasks(robot, rng, 1) if trial % 2 else []
        eq = [t for t in eq if t.dim <= 6]
        constraints = _random_constraints(robot, rng)
        options = DifferentialIKOptions(damping=float(rng.uniform(1e-6, 1e-2)))
        ik = DifferentialIK(robot, tasks, constraints, eq, options)
        state = robot.state(_random_q(robot, rng, outside=trial >= 2), rng.normal(size=robot.nv))
        reference = reference_ik_qp(tasks, constraints, eq, state, dt, options.damping)
        assert_same_qp(ik.build(state, dt), reference)
        result = ik.solve(state, dt)
        if result.success:
            x = quadprog_solve(reference)
            np.testing.assert_allclose(result.dq, x, atol=1e-6 * max(1.0, np.abs(x).max()))


def test_differential_ik_collision_rows_are_the_reference_rows() -> None:
    robot = load_robot("panda", convex=True)
    rng = np.random.default_rng(3)
    avoid = CollisionAvoidance(robot, safety_distance=0.01, influence_distance=0.3)
    tasks = _random_tasks(robot, rng, 2)
    constraints: list[Constraint] = [JointPositionLimits(robot), avoid]
    ik = DifferentialIK(robot, tasks, constraints)
    dt = 0.01
    for _ in range(3):
        state = robot.state(_random_q(robot, rng))
        reference = reference_ik_qp(tasks, constraints, [], state, dt, ik.options.damping)
        assert reference["C"].shape[0] > 0
        assert_same_qp(ik.build(state, dt), reference)
        result = ik.solve(state, dt)
        assert result.success
        x = quadprog_solve(reference)
        np.testing.assert_allclose(result.dq, x, atol=1e-6 * max(1.0, np.abs(x).max()))


@pytest.mark.parametrize("name", ["panda", "g1"])
def test_hierarchical_ik_builds_the_reference_levels(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(7)
    dt = 0.02
    for _ in range(3):
        tasks = _random_tasks(robot, rng, 4)
        constraints = _random_constraints(robot, rng)
        boxes = [c for c in constraints if type(c).bounds is not Constraint.bounds]
        rows = [c for c in constraints if c not in boxes]
        levels: list[list[Any]] = [[tasks[0], rows[0]], tasks[1:3], [tasks[3], *rows[1:]]]
        # the Python cascade (the compiled step would answer active boxes itself now)
        ik = HierarchicalIK(robot, levels, boxes, native=False)
        state = robot.state(_random_q(robot, rng, outside=True), rng.normal(size=robot.nv))
        built = ik.build(state, dt)
        for level, items in zip(built, levels):
            J, r = _task_rows_velocity([t for t in items if isinstance(t, Task)], state, robot.nv)
            C, l, u = _inequalities(
                [c for c in items if isinstance(c, Constraint)], state, dt, robot.nv
            )
            got = {"J": level.J, "r": level.r}
            if level.C is not None:
                got.update(C=level.C, l=level.l, u=level.u)
            else:
                assert C.shape[0] == 0
            expected = {"J": J, "r": r, "C": C, "l": l, "u": u}
            for key, value in got.items():
                np.testing.assert_allclose(value, expected[key], rtol=0, atol=1e-10, err_msg=key)
        # the hard constraints handed to the cascade: the combined boxes (spy on the call)
        seen: dict[str, Any] = {}
        solve = ik.solver.solve

        def spy(*args: Any, _seen: dict = seen, _solve: Any = solve, **kwargs: Any) -> Any:
            _seen.update(kwargs)
            return _solve(*args, **kwargs)

        ik.solver.solve = spy  # type: ignore[method-assign]
        ik.solve(state, dt)
        lb, ub = _boxes(boxes, state, dt, robot.nv)
        np.testing.assert_allclose(seen["lb"], lb, rtol=0, atol=1e-12)
        np.testing.assert_allclose(seen["ub"], ub, rtol=0, atol=1e-12)
        assert seen.get("C") is None or np.asarray(seen["C"]).shape[0] == 0


# ---------------------------------------------------------------------- acceleration level
def _id_controller(robot: Robot, rng: np.random.Generator) -> InverseDynamicsQP:
    tasks = _random_tasks(robot, rng, int(rng.integers(2, 5)))
    contacts: list[Any] = []
    if robot.is_floating:
        feet = _frames(robot)[:2]
        contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in feet]
        if rng.random() < 0.5:
            contacts[1] = PointContact(robot, feet[1])
        contacts[0].kp = 10.0
        contacts[0].set_reference(robot.state(robot.q_default))
    options = InverseDynamicsOptions(
        torque_limits=bool(rng.random() < 0.8),
        joint_limits=bool(rng.random() < 0.8),
        limits_horizon=float(rng.uniform(0.02, 0.2)),
        force_regularization=float(rng.uniform(1e-3, 1e-1)),
    )
    return InverseDynamicsQP(robot, tasks, contacts, options)


@pytest.mark.parametrize("name", ROBOTS)
def test_inverse_dynamics_qp_builds_the_reference_qp_and_solves_it(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(11 + len(name))
    for trial in range(3):
        ctrl = _id_controller(robot, rng)
        q = _random_q(robot, rng, outside=trial == 2)
        state = robot.state(q, 0.3 * rng.normal(size=robot.nv))
        reference = reference_id_qp(ctrl, state)
        assert_same_qp(ctrl.build(state), reference)
        result = ctrl.solve(state)
        if result.success:
            x = quadprog_solve(reference)
            scale = max(1.0, float(np.abs(x).max()))
            np.testing.assert_allclose(result.a, x[: robot.nv], atol=1e-5 * scale)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_operational_space_torques_are_the_closed_form(name: str) -> None:
    robot = load_robot(name)
    rng = np.random.default_rng(5)
    for _ in range(3):
        tasks = _random_tasks(robot, rng, int(rng.integers(1, 4)))
        state = robot.state(_random_q(robot, rng), rng.normal(size=robot.nv))
        data = robot.model.createData()
        M = pin.crba(robot.model, data, state.q)
        M = np.triu(M) + np.triu(M, 1).T
        Fv = pin.nonLinearEffects(robot.model, data, state.q, state.v)
        A, b = _task_rows_acceleration(tasks, state, robot.nv)
        T = A @ np.linalg.inv(M)
        h = 1e-6
        tau = np.linalg.solve(T.T @ T + h * np.eye(robot.nv), T.T @ (b + T @ Fv))
        out = operational_space_control(state, tasks)
        np.testing.assert_allclose(out.tau, tau, rtol=1e-7, atol=1e-7 * np.abs(tau).max())


# ---------------------------------------------------------------------- path optimization
def test_path_problem_residual_is_the_stacked_task_rows() -> None:
    from taskspace.trajopt.path_optimization import PathCost, PathEquality, PathProblem

    robot = load_robot("panda")
    rng = np.random.default_rng(2)
    tasks = _random_tasks(robot, rng, 3)
    final = Task(F.FramePose(robot, "panda_hand_tcp"))
    final.set_target_from_state(robot.state(_random_q(robot, rng)))
    T = 6
    problem = PathProblem(
        robot,
        robot.q_default,
        T,
        costs=[PathCost(t, times=[2, T]) for t in tasks],
        equalities=[PathEquality(final, times=T)],
        joint_limits=False,
    )
    path = problem.initial_path(np.array([robot.q_default, _random_q(robot, rng)]))
    r = problem.residual(path, penalty=4.0)
    # control rows first (velocity order by default), then per slice: costs, equalities
    tail = []
    for t in range(1, T + 1):
        state = robot.state(path[t])
        for task in tasks:
            if t in (2, T):
                w = np.broadcast_to(np.sqrt(np.asarray(task.weight, dtype=float)), (task.dim,))
                tail.append(w * task.feature.residual(state, task.target))
        if t == T:
            tail.append(2.0 * final.feature.residual(state, final.target))
    expected = np.concatenate(tail)
    np.testing.assert_allclose(r[r.size - expected.size :], expected, rtol=0, atol=1e-12)


def test_path_problem_normal_equations_are_the_stacked_task_rows() -> None:
    """``J^T J`` and ``J^T r`` of the task rows per slice, by hand (no control cost)."""
    from taskspace.trajopt.path_optimization import PathCost, PathEquality, PathProblem

    robot = load_robot("ur5")
    rng = np.random.default_rng(8)
    T = 5
    tasks = _random_tasks(robot, rng, 3)
    final = _random_tasks(robot, rng, 1)[0]
    times = [[1, 3, T], [2, T], None]
    problem = PathProblem(
        robot,
        robot.q_default,
        T,
        costs=[PathCost(t, times=s) for t, s in zip(tasks, times)],
        equalities=[PathEquality(final, times=[4, T])],
        acceleration_weight=0.0,
        joint_limits=False,
    )
    path = problem.initial_path(np.array([robot.q_default, _random_q(robot, rng)]))
    rho = 3.0
    H, g = problem.normal_equations(path, penalty=rho)
    nv = robot.nv
    H_ref, g_ref = np.zeros((T * nv, T * nv)), np.zeros(T * nv)
    for t in range(1, T + 1):
        state = robot.state(path[t])
        block = slice((t - 1) * nv, t * nv)
        for task, s in [*zip(tasks, times), (final, [4, T])]:
            if s is not None and t not in s:
                continue
            w = np.broadcast_to(np.sqrt(np.asarray(task.weight, dtype=float)), (task.dim,))
            if task is final:
                w = np.sqrt(rho) * w
            J = w[:, None] * task.feature.residual_jacobian(state, task.target)
            e = w * task.feature.residual(state, task.target)
            H_ref[block, block] += J.T @ J
            g_ref[block] += J.T @ e
    scale = np.abs(H_ref).max()
    np.testing.assert_allclose(H.to_dense(), H_ref, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(g, g_ref, rtol=0, atol=1e-10 * max(1.0, np.abs(g_ref).max()))
