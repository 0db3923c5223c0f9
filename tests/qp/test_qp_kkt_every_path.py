"""KKT residuals on the paths that solve without a QP backend (issue #16, item 3).

The closed-form levels of a hierarchy and the compiled kernel's steps report residuals that
equal an independent numpy evaluation of the same QP, are below the tolerances, and become
large when the solution is mutated.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import Contact6D, JointPositionLimits, JointVelocityLimits
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.ik import DifferentialIK, DifferentialIKOptions, HierarchicalIK
from taskspace.model import Robot
from taskspace.qp import QPStatus
from taskspace.qp.hierarchy import HierarchyLevel, HierarchySolver
from taskspace.qp.kkt import box_kkt_residuals, least_squares_kkt_residuals
from taskspace.qp.problem import INF, QPProblem
from taskspace.tasks import Task
from tests.conftest import load_robot

EPS_ABS, EPS_REL = 1e-9, 1e-6  # the hierarchy's level tolerances


def _numpy_ls_stationarity(JZ: np.ndarray, res: np.ndarray, z: np.ndarray, mu: float) -> float:
    H = JZ.T @ JZ + mu * np.eye(JZ.shape[1])
    g = -JZ.T @ res
    return float(np.max(np.abs(H @ z + g)))


@pytest.mark.parametrize("seed", range(5))
def test_least_squares_residuals_equal_numpy_and_detect_mutation(seed: int) -> None:
    rng = np.random.default_rng(seed)
    m, r = rng.integers(2, 9), rng.integers(2, 9)
    JZ, res, mu = rng.normal(size=(m, r)), rng.normal(size=m), 1e-6
    z = np.linalg.solve(JZ.T @ JZ + mu * np.eye(r), JZ.T @ res)
    kkt = least_squares_kkt_residuals(JZ, res, z, mu, 0.0)
    assert kkt.dual == pytest.approx(_numpy_ls_stationarity(JZ, res, z, mu), rel=1e-6, abs=1e-12)
    assert kkt.within(1e-12, 1e-9)
    bad = z + 1e-3 * rng.normal(size=r)
    mutated = least_squares_kkt_residuals(JZ, res, bad, mu, 0.0)
    assert mutated.dual == pytest.approx(_numpy_ls_stationarity(JZ, res, bad, mu), rel=1e-12)
    assert not mutated.within(1e-9, 1e-6)


def _random_levels(rng: np.random.Generator, n: int) -> list[HierarchyLevel]:
    levels = []
    for k, rows in enumerate((3, 4, n)):
        J = rng.normal(size=(rows, n))
        if k == 1:  # a rank-deficient level
            J[-1] = J[0] + J[1]
        C = rng.normal(size=(2, n)) if k == 0 else None
        levels.append(
            HierarchyLevel(
                f"level {k}",
                J,
                0.01 * rng.normal(size=rows),
                C,
                None if C is None else np.full(2, -10.0),
                None if C is None else np.full(2, 10.0),
            )
        )
    return levels


@pytest.mark.parametrize("seed", range(6))
def test_closed_form_hierarchy_levels_carry_residuals(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 9
    levels = _random_levels(rng, n)
    result = HierarchySolver().solve(levels, n, lb=np.full(n, -1.0), ub=np.full(n, 1.0))
    assert result.status is QPStatus.UNCONSTRAINED  # the closed-form path
    assert len(result.level_results) == len(levels)
    for lr in result.level_results:
        assert lr.status is QPStatus.UNCONSTRAINED
        assert np.isfinite(lr.kkt.primal) and np.isfinite(lr.kkt.dual)
        assert lr.kkt.within(EPS_ABS, EPS_REL), lr.kkt
    # level 0 has Z = I and starts at x = 0: its QP is H = J'J + mu I, g = -J'r, with mu = 0:
    # a well-conditioned level is solved by QR, the least-norm minimizer of the undamped
    # problem, and its residuals are that problem's (see test_qp_hierarchy_closed_form_kkt.py)
    first = result.level_results[0]
    expected = _numpy_ls_stationarity(levels[0].J, levels[0].r, first.x, 0.0)
    assert first.kkt.dual == pytest.approx(expected, rel=1e-6, abs=1e-12)
    assert first.x.shape == (n,)
    # the primal residual is the violation of the level's inequalities and bounds at x
    C, lo, hi = levels[0].C, levels[0].l, levels[0].u
    assert C is not None and lo is not None and hi is not None
    viol = max(0.0, float(np.max(np.maximum(lo - C @ result.x, C @ result.x - hi))))
    assert first.kkt.primal == pytest.approx(viol, abs=1e-15)


def test_levels_without_freedom_report_zero_residuals() -> None:
    rng = np.random.default_rng(7)
    n = 4
    levels = [
        HierarchyLevel("full", rng.normal(size=(n, n)), rng.normal(size=n)),
        HierarchyLevel(
            "ineq",
            np.zeros((0, n)),
            np.zeros(0),
            rng.normal(size=(1, n)),
            np.array([50.0]),  # infeasible: goes to the QP path, no freedom left
            np.array([60.0]),
        ),
    ]
    result = HierarchySolver().solve(levels, n)
    for lr in result.level_results:
        assert np.isfinite(lr.kkt.dual), lr


def _g1_hierarchy(robot: Robot) -> tuple[HierarchicalIK, list[tuple[Task, pin.SE3]]]:
    s = robot.state(robot.q_default)
    feet = [Task(F.FramePose(robot, f)) for f in ("left_ankle_roll_link", "right_ankle_roll_link")]
    hands = [Task(F.FramePose(robot, h)) for h in ("left_rubber_hand", "right_rubber_hand")]
    com = Task(F.CenterOfMass(robot))
    for t in (*feet, *hands, com):
        t.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default)
    ik = HierarchicalIK(
        robot,
        [feet, [com], hands, [posture]],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
    )
    return ik, [(t, t.target.copy()) for t in hands]


def test_g1_hierarchical_ik_levels_carry_residuals() -> None:
    robot = load_robot("g1")
    ik, moving = _g1_hierarchy(robot)
    q = robot.q_default.copy()
    state = robot.state(q)
    for k in range(8):
        for task, T0 in moving:
            T = T0.copy()
            T.translation = T0.translation + np.array([0.02 * k, 0.0, 0.01 * k])
            task.set_target(T)
        state.update(q)
        result = ik.solve(state, 0.01)
        assert result.success
        for lr in result.hierarchy.level_results:
            assert lr.status in (QPStatus.UNCONSTRAINED, QPStatus.SOLVED)
            assert np.isfinite(lr.kkt.dual) and np.isfinite(lr.kkt.primal), lr
            assert lr.kkt.within(EPS_ABS, EPS_REL), lr.kkt
        q = pin.integrate(robot.model, q, result.dq)


def test_g1_hierarchical_inverse_dynamics_levels_carry_residuals() -> None:
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03)
        for f in ("left_ankle_roll_link", "right_ankle_roll_link")
    ]
    com = Task(F.CenterOfMass(robot), kp=50.0, priority=0)
    com.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=1)
    ctrl = InverseDynamicsQP(
        robot, [com, posture], contacts, InverseDynamicsOptions(hierarchical=True)
    )
    rng = np.random.default_rng(1)
    for _ in range(3):
        q = robot.q_default.copy()
        q[7:] += rng.normal(scale=0.05, size=robot.nq - 7)
        s.update(q, rng.normal(scale=0.2, size=robot.nv))
        res = ctrl.solve(s)
        assert res.success and res.level_results
        for lr in res.level_results:
            assert np.isfinite(lr.kkt.dual) and np.isfinite(lr.kkt.primal), lr
            assert lr.kkt.within(EPS_ABS, EPS_REL), lr.kkt


def test_box_residuals_equal_numpy_and_detect_mutation() -> None:
    """A box QP solved by enumerating its active sets (exact reference)."""
    rng = np.random.default_rng(3)
    n = 4
    M = rng.normal(size=(6, n))
    H, g = M.T @ M + 1e-3 * np.eye(n), 3.0 * rng.normal(size=n)
    lb, ub = np.full(n, -0.2), np.full(n, 0.2)
    lb[0] = -INF
    best, best_x = np.inf, np.zeros(n)
    import itertools

    for pattern in itertools.product((0, 1, 2), repeat=n):  # free, lower, upper
        x = np.where(np.array(pattern) == 1, lb, np.where(np.array(pattern) == 2, ub, 0.0))
        if np.any(np.abs(x) >= INF):
            continue
        free = np.array(pattern) == 0
        if free.any():
            x[free] = np.linalg.solve(
                H[np.ix_(free, free)], -(g[free] + H[np.ix_(free, ~free)] @ x[~free])
            )
        if np.all(x >= lb - 1e-12) and np.all(x <= ub + 1e-12):
            f = 0.5 * x @ H @ x + g @ x
            if f < best:
                best, best_x = f, x
    p = QPProblem.unconstrained(H, g)
    p.lb, p.ub = lb, ub
    kkt = box_kkt_residuals(p, best_x)
    assert kkt.within(1e-12, 1e-9), kkt
    active = (best_x == lb) | (best_x == ub)
    assert active.any()
    # independent: the free components' gradient is the dual residual
    grad = H @ best_x + g
    assert kkt.dual == pytest.approx(float(np.max(np.abs(grad[~active]), initial=0.0)), abs=1e-15)
    # mutations: a free component moved; a component pushed off its bound into the box
    bad = best_x.copy()
    bad[~active] += 1e-2
    assert not box_kkt_residuals(p, bad).within(1e-9, 1e-6)
    bad = best_x.copy()
    i = int(np.flatnonzero(active)[0])
    bad[i] = 0.5 * (lb[i] + ub[i]) if lb[i] > -INF else ub[i] - 0.1
    assert not box_kkt_residuals(p, bad).within(1e-9, 1e-6)
    # a wrong active bound (the other one): wrong-signed multiplier
    bad = best_x.copy()
    bad[i] = ub[i] if best_x[i] == lb[i] else lb[i]
    if abs(bad[i]) < INF:
        assert not box_kkt_residuals(p, bad).within(1e-9, 1e-6)


@pytest.mark.skipif(ik_kernel() is None, reason="native kernel not built")
def test_compiled_kernel_steps_carry_residuals_when_asked() -> None:
    robot = load_robot("panda")
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"), [1.5, 0.8, 1.2])
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    ik = DifferentialIK(
        robot, [tcp, posture], limits, options=DifferentialIKOptions(native_residuals=True)
    )
    plain = DifferentialIK(robot, [tcp, posture], limits)
    assert ik.native
    q = robot.q_default.copy()
    state = robot.state(q)
    active = 0
    for _ in range(120):
        state.update(q)
        r = ik.solve(state, 0.02)
        assert r.qp.backend == "native"
        assert r.qp.kkt.within(1e-9, 1e-9), r.qp.kkt
        problem = ik.build(state, 0.02)
        at = (r.dq <= problem.lb + 1e-9) | (r.dq >= problem.ub - 1e-9)
        grad = problem.H @ r.dq + problem.g
        assert r.qp.kkt.dual == pytest.approx(
            float(np.max(np.abs(grad[~at]), initial=0.0)), abs=1e-11
        )
        active += r.qp.status is QPStatus.SOLVED
        # mutated step: large residuals
        bad = r.dq + 1e-3
        assert not box_kkt_residuals(problem, bad).within(1e-9, 1e-6)
        assert np.isnan(plain.solve(state, 0.02).qp.kkt.dual)  # off by default
        q = pin.integrate(robot.model, q, r.dq)
    assert active > 20
