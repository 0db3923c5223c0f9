"""The compiled general IK step: equality tasks and inequality rows beside the box (and dampers).

References are independent of the kernel: the Python path's QP (``DifferentialIK.build``)
solved by quadprog (Goldfarb-Idnani, called here), the optimum found by enumerating the
active sets of small problems (each KKT system solved with NumPy), and the KKT conditions of
the Python path's QP checked with :func:`taskspace.qp.kkt.kkt_residuals` at the kernel's
step and multipliers.
"""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import (
    CollisionAvoidance,
    Constraint,
    FeatureBounds,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.errors import InvalidInputError
from taskspace.features.compiled import CompiledConstraint, compiled_term
from taskspace.features.rows import INF, Box, InequalityRows
from taskspace.ik import DifferentialIK, DifferentialIKOptions, HierarchicalIK
from taskspace.model import Obstacle, Robot
from taskspace.qp.kkt import kkt_residuals
from taskspace.qp.problem import QPProblem
from taskspace.tasks import Task

pytestmark = pytest.mark.skipif(
    ik_kernel() is None or not hasattr(ik_kernel(), "GeneralIKStep"),
    reason="compiled IK kernel with the general step not built",
)

DT = 0.05
STEP_TOL = 1e-8  # |dq - reference| [rad]
KKT_TOL = 1e-9


def quadprog_step(p: QPProblem) -> np.ndarray:
    """The exact optimum of ``p`` by quadprog (equalities first, each finite side a row)."""
    import quadprog

    n = p.H.shape[0]
    G, h = [p.A], [p.b]
    for M, lo, hi in ((p.C, p.l, p.u), (np.eye(n), p.lb, p.ub)):
        for i in range(M.shape[0]):
            if lo[i] > -1e19:
                G.append(M[i : i + 1])
                h.append(lo[i : i + 1])
            if hi[i] < 1e19:
                G.append(-M[i : i + 1])
                h.append(-hi[i : i + 1])
    x = quadprog.solve_qp(
        np.array(p.H), -np.array(p.g), np.vstack(G).T, np.concatenate(h), p.A.shape[0]
    )[0]
    return np.asarray(x)


def enumerated_step(p: QPProblem) -> np.ndarray:
    """The optimum of a small ``p`` by enumerating every active set (lower / upper / free).

    For each choice of active sides the KKT system ``[H W'; W 0] [x; lam] = [-g; w]`` is
    solved; the optimum is the candidate that is primal feasible with multipliers of the
    right signs (unique: H is positive definite).
    """
    n = p.H.shape[0]
    rows = [(p.C[i], p.l[i], p.u[i]) for i in range(p.C.shape[0])]
    rows += [
        (np.eye(n)[i], p.lb[i], p.ub[i]) for i in range(n) if p.lb[i] > -1e19 or p.ub[i] < 1e19
    ]
    found = []
    for sides in itertools.product((0, -1, 1), repeat=len(rows)):
        W = [p.A[i] for i in range(p.A.shape[0])]
        w = list(p.b)
        for (c, lo, hi), s in zip(rows, sides):
            if s == -1:
                if lo < -1e19:
                    break
                W.append(c)
                w.append(lo)
            elif s == 1:
                if hi > 1e19:
                    break
                W.append(c)
                w.append(hi)
        else:
            m = len(W)
            K = np.zeros((n + m, n + m))
            K[:n, :n] = p.H
            if m:
                K[:n, n:] = np.array(W).T
                K[n:, :n] = np.array(W)
            rhs = np.concatenate((-p.g, w))
            try:
                sol = np.linalg.solve(K, rhs)
            except np.linalg.LinAlgError:
                continue
            if np.linalg.cond(K) > 1e12:
                continue
            x, lam = sol[:n], sol[n:]
            ok = all(lo - 1e-9 <= c @ x <= hi + 1e-9 for c, lo, hi in rows)
            active = [s for s in sides if s != 0]
            # H x + g + W' lam = 0: lam <= 0 on a lower side, >= 0 on an upper side
            lam_in = lam[p.A.shape[0] :]
            ok = ok and all(lv * s >= -1e-9 for lv, s in zip(lam_in, active))
            if ok:
                found.append(x)
    assert found, "no KKT point: the problem is infeasible"
    return found[0]


class HalfSpaces(Constraint):
    """A user's joint-space half-spaces ``A q <= b`` (revolute joints): rows ``A dq <= b - A q``."""

    def __init__(self, robot: Robot, A: np.ndarray, b: np.ndarray, lower: bool = False) -> None:
        super().__init__(robot, "half spaces")
        self.A, self.b, self.lower = A, b, lower

    def inequalities(self, state, dt: float) -> InequalityRows:  # type: ignore[no-untyped-def]
        slack = self.b - self.A @ state.q
        lo = -slack if self.lower else np.full(len(slack), -INF)
        return InequalityRows(self.A, lo, slack)


class FixedRows(Constraint):
    """A user's constant rows ``l <= C dq <= u``."""

    def __init__(self, robot: Robot, C: np.ndarray, l: np.ndarray, u: np.ndarray) -> None:
        super().__init__(robot, "fixed rows")
        self.rows = InequalityRows(C, l, u)

    def inequalities(self, state, dt: float) -> InequalityRows:  # type: ignore[no-untyped-def]
        return self.rows


class PartialBox(Constraint):
    """A box on a few joints only (the others unbounded)."""

    def __init__(self, robot: Robot, joints: list[int], width: float) -> None:
        super().__init__(robot, "partial box")
        self.joints, self.width = joints, width

    def bounds(self, state, dt: float) -> Box:  # type: ignore[no-untyped-def]
        lb = np.full(self.robot.nv, -INF)
        ub = np.full(self.robot.nv, INF)
        lb[self.joints] = -self.width
        ub[self.joints] = self.width
        return Box(lb, ub)


def _pair(robot: Robot, tasks, constraints, equality_tasks=()):  # type: ignore[no-untyped-def]
    native = DifferentialIK(robot, tasks, constraints, equality_tasks)
    python = DifferentialIK(
        robot, tasks, constraints, equality_tasks, options=DifferentialIKOptions(native=False)
    )
    return native, python


def _panda_stack(robot: Robot, state, rng: np.random.Generator):  # type: ignore[no-untyped-def]
    """Position task, posture, limits; equality: link 7's position; rows: tcp axis and CoM
    bounds near their values, and a user's joint-space half-space."""
    tcp = robot.end_effectors[0]
    pos = F.Position(robot, tcp)
    tasks = [
        Task(pos, pos.value(state) + 0.3 * rng.standard_normal(3)),
        Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2),
    ]
    link7 = F.Position(robot, "panda_link7")
    joint1 = F.JointConfiguration(robot, ["panda_joint1"])
    equality = [  # a row evaluated in Python (posture kind) before one the kernel evaluates
        Task(joint1, state.q + 0.01, gain=0.5),
        Task(link7, link7.value(state) + 0.002 * rng.standard_normal(3), gain=0.5),
    ]
    axis = F.Vector(robot, tcp, [0.0, 0.0, 1.0])
    a0 = axis.value(state)
    com = F.CenterOfMass(robot)
    c0 = com.value(state)
    A = rng.standard_normal((2, robot.nv))
    rows = [
        FeatureBounds(axis, a0 - 0.02, a0 + 0.02, name="axis"),
        FeatureBounds(
            com, c0 - np.array([0.003, 1.0, 1.0]), c0 + np.array([1.0, 0.003, 1.0]), name="com"
        ),
        HalfSpaces(robot, A, A @ state.q + 0.01),
    ]
    return tasks, [JointPositionLimits(robot), JointVelocityLimits(robot), *rows], equality


def _random_state(robot: Robot, rng: np.random.Generator):  # type: ignore[no-untyped-def]
    q = robot.q_default + 0.3 * rng.standard_normal(robot.nq)
    return robot.state(np.clip(q, robot.lower_limits, robot.upper_limits))


def test_panda_general_steps_are_quadprogs_optimum_with_their_kkt_certificate(
    panda: Robot,
) -> None:
    """Equality task + feature bounds + a user's rows + limits: the kernel answers every step,
    at quadprog's optimum of the Python path's QP, with multipliers that satisfy that QP's
    KKT conditions (checked here); some rows are active."""
    rng = np.random.default_rng(3)
    active_rows = 0
    for _ in range(12):
        state = _random_state(panda, rng)
        tasks, constraints, equality = _panda_stack(panda, state, rng)
        native, python = _pair(panda, tasks, constraints, equality)
        assert native.native
        r = native.solve(state, DT)
        assert r.native_declined == "" and r.qp.backend == "native general", r.native_declined
        assert r.success and r.qp.kkt.within(KKT_TOL, KKT_TOL)
        p = python.build(state, DT)
        np.testing.assert_allclose(r.dq, quadprog_step(p), atol=STEP_TOL, rtol=0)
        k = kkt_residuals(p, r.dq, r.qp.y, r.qp.z, r.qp.z_box)
        assert k.within(KKT_TOL, KKT_TOL), k
        active_rows += int(np.count_nonzero(r.qp.z))
        # the Python path agrees where it solves the QP (it may relax a feasible one: seed 3's
        # first problem, proxsuite then daqp, RELAXED 3.4e-6 rad from quadprog's optimum)
        rp = python.solve(state, DT)
        if rp.success:
            np.testing.assert_allclose(r.dq, rp.dq, atol=1e-6, rtol=0)
    assert active_rows >= 5  # the rows decide the steps


def test_g1_general_steps_are_quadprogs_optimum(g1: Robot) -> None:
    """G1 (free flyer): hands weighted, feet as equality tasks, CoM bounds, a user's rows."""
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(4):
        q = g1.q_default.copy()
        q[7:] += 0.1 * rng.standard_normal(g1.nv - 6)
        q[7:] = np.clip(q[7:], g1.lower_limits[7:], g1.upper_limits[7:])
        state = g1.state(q)
        hands = [F.FramePose(g1, h) for h in ("left_rubber_hand", "right_rubber_hand")]
        tasks = [Task(h, h.value(state) * pin.exp6(0.2 * rng.standard_normal(6))) for h in hands]
        tasks.append(Task(F.JointConfiguration(g1), g1.q_default, weight=1e-3))
        feet = [F.FramePose(g1, f) for f in ("left_ankle_roll_link", "right_ankle_roll_link")]
        equality = [Task(f, f.value(state)) for f in feet]
        com = F.CenterOfMass(g1)
        c0 = com.value(state)
        C = np.zeros((1, g1.nv))
        C[0, 6 + rng.integers(0, g1.nv - 6)] = 1.0
        constraints = [
            JointPositionLimits(g1),
            JointVelocityLimits(g1),
            FeatureBounds(com, c0 - 0.002, c0 + 0.002),
            FixedRows(g1, C, np.array([-0.001]), np.array([0.001])),
        ]
        native, python = _pair(g1, tasks, constraints, equality)
        r = native.solve(state, DT)
        assert r.qp.backend == "native general", r.native_declined
        assert r.qp.kkt.within(KKT_TOL, KKT_TOL)
        p = python.build(state, DT)
        np.testing.assert_allclose(r.dq, quadprog_step(p), atol=STEP_TOL, rtol=0)
        assert kkt_residuals(p, r.dq, r.qp.y, r.qp.z, r.qp.z_box).within(KKT_TOL, KKT_TOL)
        hits += int(np.count_nonzero(r.qp.z))
    assert hits >= 2


def test_small_problems_match_the_enumerated_optimum(panda: Robot) -> None:
    """Panda, one equality row, three two-sided rows and a box on two joints: the kernel's
    step is the optimum found by enumerating all 3^5 active sets."""
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(6):
        state = _random_state(panda, rng)
        tcp = F.Position(panda, panda.end_effectors[0])
        tasks = [
            Task(tcp, tcp.value(state) + 0.2 * rng.standard_normal(3)),
            Task(F.JointConfiguration(panda), panda.q_default, weight=1e-2),
        ]
        joint = F.JointConfiguration(panda, ["panda_joint4"])
        equality = [Task(joint, state.q + 0.02 * rng.standard_normal(panda.nq), gain=1.0)]
        A = rng.standard_normal((3, panda.nv))
        rows = HalfSpaces(panda, A, A @ state.q + 0.02 * rng.random(3), lower=True)
        constraints = [PartialBox(panda, [1, 5], 0.03), rows]
        native, python = _pair(panda, tasks, constraints, equality)
        r = native.solve(state, DT)
        assert r.qp.backend == "native general", r.native_declined
        p = python.build(state, DT)
        assert p.A.shape[0] == 1 and p.C.shape[0] == 3
        np.testing.assert_allclose(r.dq, enumerated_step(p), atol=STEP_TOL, rtol=0)
        checked += int(np.count_nonzero(r.qp.z) + np.count_nonzero(r.qp.z_box))
    assert checked >= 3  # rows or the box are active in some problems


def test_dampers_with_equality_and_rows(panda: Robot) -> None:
    """Collision dampers (coal distances in the kernel) together with an equality task and
    a user's rows: quadprog's optimum of the Python path's QP (dampers evaluated in Python)."""
    robot = Robot.load("panda", convex_collision=True)
    tcp = robot.end_effectors[0]
    state = robot.state(robot.q_default)
    start = state.frame_placement(robot.frame_id(tcp)).copy()
    robot.add_obstacle(
        Obstacle.sphere("ball", 0.07, start.translation + np.array([0.0, 0.12, -0.03]))
    )
    pos = F.Position(robot, tcp)
    tasks = [
        Task(pos, start.translation + np.array([0.0, 0.3, 0.0]), gain=0.5),
        Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3),
    ]
    orient = F.Orientation(robot, tcp)
    equality = [Task(orient, orient.value(state))]
    A = np.eye(1, robot.nv)
    constraints = [
        JointPositionLimits(robot),
        JointVelocityLimits(robot),
        CollisionAvoidance(robot, safety_distance=0.02, influence_distance=0.12, gain=0.5),
        HalfSpaces(robot, A, A @ state.q + 0.01, lower=True),
    ]
    native, python = _pair(robot, tasks, constraints, equality)
    q = state.q.copy()
    damped = 0
    for _ in range(15):
        state.update(q)
        r = native.solve(state, 0.01)
        assert r.qp.backend == "native general", r.native_declined
        assert r.qp.kkt.within(KKT_TOL, KKT_TOL)
        np.testing.assert_allclose(
            r.dq, quadprog_step(python.build(state, 0.01)), atol=STEP_TOL, rtol=0
        )
        assert native._native is not None
        damped += len(native._native.damper_rows()[3])
        q = pin.integrate(robot.model, q, r.dq)
    assert damped > 0  # damper rows took part


def test_advance_moves_the_state_as_solve_and_update(panda: Robot) -> None:
    rng = np.random.default_rng(2)
    state = _random_state(panda, rng)
    tasks, constraints, equality = _panda_stack(panda, state, rng)
    ik = DifferentialIK(panda, tasks, constraints, equality)
    other = panda.state(state.q)
    r = ik.solve(other, DT)
    a = ik.advance(state, DT)
    assert a.qp.backend == "native general"
    np.testing.assert_allclose(a.dq, r.dq, atol=1e-12, rtol=0)
    np.testing.assert_allclose(state.q, pin.integrate(panda.model, other.q, r.dq), atol=1e-12)


def test_reassigned_equality_gain_is_followed(panda: Robot) -> None:
    """The kernel-evaluated equality rows use the task's gain as assigned now."""
    rng = np.random.default_rng(8)
    state = _random_state(panda, rng)
    tasks, constraints, equality = _panda_stack(panda, state, rng)
    native, python = _pair(panda, tasks, constraints, equality)
    first = native.solve(state, DT).dq
    equality[1].gain = 0.1
    r = native.solve(state, DT)
    assert r.qp.backend == "native general"
    np.testing.assert_allclose(r.dq, quadprog_step(python.build(state, DT)), atol=STEP_TOL, rtol=0)
    assert np.abs(r.dq - first).max() > 1e-5


def test_redundant_equalities_decline_with_the_reason(panda: Robot) -> None:
    """The same equality task twice: linearly dependent rows; the kernel declines, says
    why, and the Python path answers."""
    state = panda.state(panda.q_default)
    tcp = F.Position(panda, panda.end_effectors[0])
    target = tcp.value(state) + np.array([0.01, 0.0, 0.0])
    tasks = [Task(F.JointConfiguration(panda), panda.q_default, weight=1e-2)]
    equality = [Task(tcp, target, name="a"), Task(tcp, target, name="b")]
    ik = DifferentialIK(panda, tasks, [JointVelocityLimits(panda)], equality)
    assert ik.native
    r = ik.solve(state, DT)
    assert "linearly dependent" in r.native_declined
    assert r.qp.backend != "native general"


def test_infeasible_equality_and_box_decline_and_the_python_path_reports(
    panda: Robot,
) -> None:
    """An equality step the velocity box cannot reach: declined (no feasible point); the
    Python path relaxes and names the culprits."""
    state = panda.state(panda.q_default)
    tcp = F.Position(panda, panda.end_effectors[0])
    tasks = [Task(F.JointConfiguration(panda), panda.q_default, weight=1e-2)]
    equality = [Task(tcp, tcp.value(state) + np.array([0.5, 0.0, 0.0]), name="far")]
    ik = DifferentialIK(panda, tasks, [JointVelocityLimits(panda)], equality)
    r = ik.solve(state, 0.001)
    assert "no point satisfying" in r.native_declined
    assert not r.success and r.culprits


def test_nan_rows_are_refused(panda: Robot) -> None:
    state = panda.state(panda.q_default)
    tcp = F.Position(panda, panda.end_effectors[0])
    A = np.full((1, panda.nv), np.nan)
    ik = DifferentialIK(panda, [Task(tcp, tcp.value(state))], [HalfSpaces(panda, A, np.zeros(1))])
    assert ik.native
    with pytest.raises(InvalidInputError, match="inequality rows"):
        ik.solve(state, DT)


def test_user_rows_of_any_array_layout(panda: Robot) -> None:
    """A user's rows as lists, integer or Fortran-ordered arrays: the same step."""
    state = panda.state(panda.q_default)
    tcp = F.Position(panda, panda.end_effectors[0])
    task = Task(tcp, tcp.value(state) + np.array([0.05, 0.05, 0.05]))
    C = np.zeros((2, panda.nv))
    C[0, 0] = C[1, 1] = 1
    steps = []
    for rows in (
        (C, np.array([-0.001, -INF]), np.array([0.001, 0.002])),
        (C.astype(int).tolist(), [-0.001, -INF], [0.001, 0.002]),
        (np.asfortranarray(C), np.array([-0.001, -INF]), np.array([0.001, 0.002])),
    ):
        ik = DifferentialIK(panda, [task], [FixedRows(panda, *rows)])  # type: ignore[arg-type]
        r = ik.solve(state, DT)
        assert r.qp.backend == "native general"
        steps.append(r.dq)
        active = np.count_nonzero(r.qp.z)
    python = DifferentialIK(
        panda,
        [task],
        [FixedRows(panda, C, np.array([-0.001, -INF]), np.array([0.001, 0.002]))],
        options=DifferentialIKOptions(native=False),
    )
    reference = quadprog_step(python.build(state, DT))
    for dq in steps:
        np.testing.assert_allclose(dq, reference, atol=STEP_TOL, rtol=0)
    assert active  # a row is active


def test_hierarchy_serves_bounds_by_declaration_not_by_type(panda: Robot) -> None:
    """The hierarchical kernel evaluates the bounds a constraint class declares itself: a
    FeatureBounds subclass that does not declare them has its rows evaluated in Python; a
    class of another hierarchy that declares ``bounds`` has them evaluated by the kernel."""

    class Undeclared(FeatureBounds):
        pass

    class Declared(Constraint):
        def __init__(self, robot: Robot, lower: np.ndarray, upper: np.ndarray) -> None:
            super().__init__(robot, "declared")
            self.feature = F.CenterOfMass(robot)
            self.lower, self.upper = lower, upper

        def inequalities(self, state, dt):  # type: ignore[no-untyped-def]
            return FeatureBounds(self.feature, self.lower, self.upper).inequalities(state, dt)

        def compiled_constraint(self) -> CompiledConstraint:
            term = compiled_term(self.feature)
            return CompiledConstraint(
                "bounds", gain=1.0, term=term, lower=self.lower, upper=self.upper
            )

    state = panda.state(panda.q_default)
    tcp = Task(F.FramePose(panda, panda.end_effectors[0]))
    tcp.set_target_from_state(state)
    c0 = F.CenterOfMass(panda).value(state)
    for constraint, in_kernel in (
        (FeatureBounds(F.CenterOfMass(panda), c0 - 0.1, c0 + 0.1), True),
        (Undeclared(F.CenterOfMass(panda), c0 - 0.1, c0 + 0.1), False),
        (Declared(panda, c0 - 0.1, c0 + 0.1), True),
        (FeatureBounds(F.Vector(panda, panda.end_effectors[0], [0, 0, 1]), -1, 1), False),
    ):
        ik = HierarchicalIK(panda, [[tcp, constraint]])
        ik.solve(state, DT)
        native = ik._native
        assert native is not None
        assert (constraint in native._bounds) is in_kernel, type(constraint).__name__
