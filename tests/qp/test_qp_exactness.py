"""Exactness contract: a ``SOLVED`` QP result meets its KKT tolerances and is the optimum.

References: the optimum found by enumerating active sets (small problems: every assignment of
each inequality and bound row to inactive / at its lower bound / at its upper bound, the KKT
system of each, kept when primal feasible with multipliers of the right signs), and quadprog
(an exact dual active-set method) on the IK QPs of real robots built by ``DifferentialIK``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from taskspace import features as F
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.qp import INF, QPProblem, QPSolver, QPSolverOptions, QPStatus, available_backends
from taskspace.qp.hierarchy import HierarchyLevel, HierarchySolver
from taskspace.qp.kkt import kkt_residuals
from taskspace.tasks import Task
from tests.conftest import load_robot

BACKENDS = available_backends()
EPS_ABS = EPS_REL = 1e-9  # QPSolverOptions defaults: the stated tolerances


def bare_solver(backend: str) -> QPSolver:
    """One backend alone: no shortcut, no fallback, no relaxation."""
    return QPSolver(
        QPSolverOptions(
            backend=backend, fallbacks=(), relax_on_failure=False, try_unconstrained=False
        )
    )


def enumerate_optimum(p: QPProblem) -> np.ndarray:
    """Optimum of a small strictly convex QP by enumeration of active sets."""
    n = p.n
    G = np.vstack([p.C, np.eye(n)])
    lo = np.concatenate([p.l, p.lb])
    hi = np.concatenate([p.u, p.ub])
    rows = [i for i in range(G.shape[0]) if lo[i] > -INF or hi[i] < INF]
    choices = [[0] + ([-1] if lo[i] > -INF else []) + ([1] if hi[i] < INF else []) for i in rows]
    best, best_f = None, np.inf
    for assign in itertools.product(*choices):
        act = [(i, s) for i, s in zip(rows, assign) if s]
        Ga = np.vstack([p.A, *[G[i] for i, _ in act]]) if act or p.n_eq else np.zeros((0, n))
        ha = np.concatenate([p.b, [hi[i] if s > 0 else lo[i] for i, s in act]])
        m = Ga.shape[0]
        K = np.block([[p.H, Ga.T], [Ga, np.zeros((m, m))]])
        sol = np.linalg.lstsq(K, np.concatenate([-p.g, ha]), rcond=1e-12)[0]
        if np.abs(K @ sol - np.concatenate([-p.g, ha])).max() > 1e-9:
            continue  # inconsistent active set
        x, w = sol[:n], sol[n + p.n_eq :]
        if any(s * wi < -1e-9 for (_, s), wi in zip(act, w)):
            continue  # a multiplier of the wrong sign
        Gx = G @ x
        if (Gx < lo - 1e-9).any() or (Gx > hi + 1e-9).any():
            continue
        if p.n_eq and np.abs(p.A @ x - p.b).max() > 1e-9:
            continue
        f = 0.5 * x @ p.H @ x + p.g @ x
        if f < best_f - 1e-12:
            best, best_f = x, f
    assert best is not None, "enumeration found no KKT point"
    return best


def random_problem(rng: np.random.Generator, kind: str) -> QPProblem:
    """Small QP (n = 5, at most 8 bounded rows) of one of several degenerate kinds."""
    n = 5
    J = rng.normal(size=(3 if kind == "rank_deficient" else 6, n))
    H = J.T @ J + (1e-6 if kind == "rank_deficient" else 1e-2) * np.eye(n)
    g = rng.normal(size=n) * 3.0
    x_free = np.linalg.solve(H, -g)
    x0 = rng.normal(size=n)  # a strictly feasible point: every problem has a solution
    n_eq = int(rng.integers(0, 3))
    A = rng.normal(size=(n_eq, n))
    b = A @ x0
    C = rng.normal(size=(3, n))
    Cx, Cx0 = C @ x_free, C @ x0
    u = np.maximum(Cx - 0.5 * rng.random(3), Cx0 + 0.05)  # cuts the free optimum
    l = np.where(rng.random(3) < 0.5, np.minimum(u, Cx0) - 0.05 - rng.random(3), -INF)
    if kind == "redundant":
        C = np.vstack([C, C[:1], 2.0 * C[:1]])  # the same half-space three times
        l = np.concatenate([l, l[:1], 2.0 * l[:1] if l[0] > -INF else [-INF]])
        u = np.concatenate([u, u[:1], 2.0 * u[:1]])
    if kind == "weakly_active" and not n_eq:
        u[0] = max(Cx[0], Cx0[0] + 0.05)  # through the free optimum: zero multiplier
    lb = np.full(n, -INF)
    ub = np.full(n, INF)
    ub[:2] = np.maximum(x_free[:2] - 0.3, x0[:2] + 0.05)
    if kind == "box_pushes":
        lb[2] = min(x_free[2] + 0.1, x0[2] - 0.05)
    return QPProblem(H, g, A, b, C, l, u, lb, ub)


KINDS = ["plain", "redundant", "weakly_active", "rank_deficient", "box_pushes"]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("backend", BACKENDS)
def test_solved_results_are_the_enumerated_optimum(backend: str, kind: str) -> None:
    rng = np.random.default_rng(KINDS.index(kind))
    solver = bare_solver(backend)
    default = QPSolver()
    solved = 0
    for _ in range(6):
        p = random_problem(rng, kind)
        ref = enumerate_optimum(p)
        scale = max(1.0, float(np.abs(ref).max()))
        for s in (solver, default):
            r = s.solve(p)
            if s is default:
                assert r.success, f"the default solver failed: {r.status} {r.kkt}"
            if not r.success:
                assert r.status is not QPStatus.SOLVED
                continue
            solved += s is solver
            assert r.kkt.within(EPS_ABS, EPS_REL), r.kkt
            # the reported residuals are those of the returned point and multipliers
            again = kkt_residuals(p, r.x, r.y, r.z, r.z_box)
            assert again.dual == pytest.approx(r.kkt.dual, abs=1e-12)
            # H may be ill-conditioned (1e-6): the error in x is bounded by residual / 1e-6
            tol = 1e-6 if kind == "rank_deficient" else 1e-7
            np.testing.assert_allclose(r.x, ref, atol=tol * scale)
    if backend != "osqp":  # osqp (first order) may honestly report INACCURATE instead
        assert solved >= 5


def test_inaccurate_solution_is_not_solved() -> None:
    """The bug of issue 16: a point with nonzero multipliers on inactive rows."""
    rng = np.random.default_rng(3)
    p = random_problem(rng, "plain")
    ref = enumerate_optimum(p)
    r = bare_solver("quadprog").solve(p)
    assert r.status is QPStatus.SOLVED
    z = r.z.copy()
    inactive = np.flatnonzero(np.abs(p.C @ ref - p.u) > 1e-3)
    z[inactive[0]] = 1e-3  # a multiplier on an inactive row: complementarity fails
    assert not kkt_residuals(p, r.x, r.y, z, r.z_box).within(EPS_ABS, EPS_REL)
    x = r.x + 1e-5  # a shifted point fails stationarity or feasibility
    assert not kkt_residuals(p, x, r.y, r.z, r.z_box).within(EPS_ABS, EPS_REL)


IK_ROBOTS = {
    "panda": "panda_hand_tcp",
    "ur5": "tool0",
    "g1": "left_rubber_hand",
    "talos": "gripper_left_base_link",
    "solo12": "FL_FOOT",
}


@pytest.mark.parametrize("name", list(IK_ROBOTS))
def test_ik_qps_of_real_robots(name: str) -> None:
    """DifferentialIK's own QPs (far targets: limits active), every backend vs quadprog."""
    robot = load_robot(name)
    frame = IK_ROBOTS[name]
    rng = np.random.default_rng(0)
    task = Task(F.Position(robot, frame), np.zeros(3), gain=1.0)
    posture = Task(F.JointConfiguration(robot, floating_base=True), robot.q_default, weight=1e-3)
    ik = DifferentialIK(
        robot,
        [task, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=False),
    )
    solvers = {b: bare_solver(b) for b in BACKENDS if b != "quadprog"}
    solvers["default"] = QPSolver()
    reference = bare_solver("quadprog")
    for _ in range(3):
        state = robot.state(robot.random_configuration(rng))
        task.set_target(robot.frame_placement(robot.random_configuration(rng), frame).translation)
        p = ik.build(state, 0.02)
        ref = reference.solve(p)
        assert ref.status is QPStatus.SOLVED, ref.kkt
        for label, solver in solvers.items():
            r = solver.solve(p)
            if label in ("default", "proxsuite", "daqp"):
                assert r.success, f"{label}: {r.status} {r.kkt}"
            if r.success:
                assert r.kkt.within(EPS_ABS, EPS_REL), (label, r.kkt)
                np.testing.assert_allclose(r.x, ref.x, atol=1e-6, err_msg=label)
                assert r.objective <= ref.objective + 1e-8 * max(1.0, abs(ref.objective)), label


def test_persistent_proxsuite_stays_exact_across_steps() -> None:
    """Warm start and kept preconditioner over a sequence of different QPs (issue 16)."""
    robot = load_robot("panda")
    rng = np.random.default_rng(1)
    task = Task(F.Position(robot, "panda_hand_tcp"), np.zeros(3), gain=1.0)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    ik = DifferentialIK(
        robot,
        [task, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=False),
    )
    solver = bare_solver("proxsuite")
    reference = bare_solver("quadprog")
    for _ in range(30):
        state = robot.state(robot.random_configuration(rng))
        target = robot.frame_placement(robot.random_configuration(rng), "panda_hand_tcp")
        task.set_target(target.translation)
        p = ik.build(state, 0.01)
        r = solver.solve(p)
        assert r.status is QPStatus.SOLVED, r.kkt
        np.testing.assert_allclose(r.x, reference.solve(p).x, atol=1e-7)


def test_hierarchy_levels_are_exact() -> None:
    """Each level of a cascade against quadprog with earlier levels' optima as equalities."""
    rng = np.random.default_rng(2)
    n = 8
    for _ in range(4):
        J1, J2 = rng.normal(size=(2, n)), rng.normal(size=(3, n))
        r1, r2 = rng.normal(size=2) * 2, rng.normal(size=3) * 2
        J3, r3 = np.eye(n), np.zeros(n)
        lb, ub = np.full(n, -0.4), np.full(n, 0.4)
        levels = [HierarchyLevel("a", J1, r1), HierarchyLevel("b", J2, r2)]
        levels.append(HierarchyLevel("posture", J3, r3))
        result = HierarchySolver().solve(levels, n, lb=lb, ub=ub)
        assert result.success
        for level in result.level_results:
            if level.status is QPStatus.SOLVED:
                assert level.kkt.within(1e-9, 1e-6), level.kkt
        # reference: level k minimizes its residual with the earlier J_i x held at their
        # optima (unique for least squares), to 1e-9 (as inequalities: no degenerate equalities)
        x, held, at = None, np.zeros((0, n)), np.zeros(0)
        ref_solver = QPSolver(
            QPSolverOptions(
                backend="quadprog",
                fallbacks=(),
                relax_on_failure=False,
                try_unconstrained=False,
                eps_rel=1e-6,  # H = J'J + 1e-10 I: multipliers of order 1e2
            )
        )
        for J, r in ((J1, r1), (J2, r2), (J3, r3)):
            H = J.T @ J + 1e-10 * np.eye(n)
            p = QPProblem(
                H, -J.T @ r, np.zeros((0, n)), np.zeros(0), held, at - 1e-9, at + 1e-9, lb, ub
            )
            ref = ref_solver.solve(p)
            assert ref.success, ref.status
            x = ref.x
            held = np.vstack([held, J])
            at = held @ x
        assert x is not None
        np.testing.assert_allclose(result.x, x, atol=1e-6)


def test_inverse_dynamics_cascade_levels_are_exact() -> None:
    """G1 hierarchical inverse dynamics with the hands out of reach: inequalities active."""
    import pinocchio as pin

    from tests.control.test_control_inverse_dynamics_qp import g1_controller

    robot = load_robot("g1")
    ctrl, _, hands, s = g1_controller(robot, hierarchical=True)
    for h in hands:
        h.set_target(h.target * pin.SE3(np.eye(3), np.array([0.6, 0.0, 0.5])))
    res = ctrl.solve(s)
    assert res.success
    solved = [r for r in res.level_results if r.status is QPStatus.SOLVED]
    assert solved  # the cascade needed QPs here
    for r in solved:
        assert r.kkt.within(1e-9, 1e-6), r.kkt
