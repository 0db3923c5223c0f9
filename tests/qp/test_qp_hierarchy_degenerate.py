"""Degenerate cascades: held inequalities in the span of higher levels' equalities,
rank-deficient levels, and the G1 inverse-dynamics cascade with its hands out of reach.

References are independent of the cascade: the lexicographic optimum by enumeration of the
active sets of each level (small problems), level by level in the original variables.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.model import Robot
from taskspace.qp import INF, HierarchyLevel, HierarchySolver, QPStatus
from taskspace.qp.hierarchy import CASCADE_SOLVER_OPTIONS, HierarchyOptions
from taskspace.tasks import Task
from tests.qp.problems_qp import vanished_hard_row


def _degenerate_scene(
    seed: int,
) -> tuple[list[HierarchyLevel], int, np.ndarray, np.ndarray, np.ndarray]:
    """Six variables in random (dense) coordinates; hard rows 0 and 1 lie in the span of
    level 1's equalities and are active at its optimum (projected onto the later levels'
    freedom they are rounding noise, 1e-17); level 2 repeats a level-1 row (rank-deficient)
    and pulls two free directions out of their hard box; level 3 fixes the rest."""
    rng = np.random.default_rng(seed)
    n = 6
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    e = np.eye(n)
    J1 = np.array([e[0] + e[1], e[2]]) @ Q.T
    r1 = np.array([1.0, 0.5])
    a, b = rng.uniform(0.5, 2.0, 2)
    C = np.vstack([a * J1[0] + b * J1[1], 2.0 * J1[1] - 0.3 * J1[0], Q[:, 3], Q[:, 4]])
    v = C[:2] @ np.linalg.pinv(J1) @ r1
    l = np.array([v[0] - 1.0, -INF, -0.2, -0.3])
    u = np.array([v[0], v[1], 0.2, 0.3])
    J2 = np.vstack([J1[0], 2.0 * J1[0], Q[:, 3], Q[:, 4], Q[:, 3] + Q[:, 4]])
    r2 = np.array([3.0, 6.0, 2.0, -3.0, -1.0])
    levels = [
        HierarchyLevel("L1", J1, r1),
        HierarchyLevel("L2", J2, r2),
        HierarchyLevel("L3", np.eye(n), rng.normal(size=n)),
    ]
    return levels, n, C, l, u


def _far_flat_scene(
    seed: int, scale: float
) -> tuple[list[HierarchyLevel], int, np.ndarray, np.ndarray, np.ndarray]:
    """Eight variables in random coordinates; level 1 pulls y0 to ``scale`` and the hard rows
    y0 <= y1 <= y2 drag y1, y2 along, directions level 1 leaves free (curvature: the damping
    only, like the G1 cascade's contact forces); the hard row y2 + y3 <= scale / 2 then holds
    level 2's pull on y3; y4 is boxed. With proxsuite's defaults (rho 1e-6) and the former
    cascade, level 3 fails (x off by 24..200 from the optimum)."""
    rng = np.random.default_rng(seed)
    n = 8
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    e = np.eye(n) @ Q.T  # rows: the coordinate directions
    C = np.vstack([e[0] - e[1], e[1] - e[2], e[2] + e[3], e[4]])
    l = np.array([-INF, -INF, -INF, -1.0])
    u = np.array([0.0, 0.0, 0.5 * scale, 1.0])
    levels = [
        HierarchyLevel("L1", e[[0]], np.array([scale])),
        HierarchyLevel("L2", e[[3, 4, 0]], np.array([2.0 * scale, 5.0, 0.0])),
        HierarchyLevel("L3", np.eye(n), rng.normal(size=n)),
    ]
    return levels, n, C, l, u


def _lexicographic_by_enumeration(
    levels: list[HierarchyLevel], n: int, C: np.ndarray, l: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """Level k: min |J_k x - r_k|^2 s.t. J_i x = J_i x_i* (i < k), l <= C x <= u, by trying
    every active set of C (inactive, at l, at u): the best feasible equality-constrained
    least-squares point (its J_k x is unique)."""
    held: list[tuple[np.ndarray, np.ndarray]] = []
    x_best = np.zeros(n)
    for lv in levels:
        best, best_x = np.inf, None
        for choice in itertools.product((0, 1, 2), repeat=C.shape[0]):
            rows = [J for J, _ in held]
            vals = [v for _, v in held]
            if any(c and abs((l, u)[c - 1][i]) >= INF for i, c in enumerate(choice)):
                continue
            for i, c in enumerate(choice):
                if c:
                    rows.append(C[i : i + 1])
                    vals.append(np.array([(l, u)[c - 1][i]]))
            if rows:
                E, e = np.vstack(rows), np.concatenate(vals)
                xp = np.linalg.lstsq(E, e, rcond=None)[0]
                if np.abs(E @ xp - e).max() > 1e-9:
                    continue
                _, s, Vt = np.linalg.svd(E)
                N = Vt[int(np.count_nonzero(s > 1e-10 * s[0])) :].T
            else:
                xp, N = np.zeros(n), np.eye(n)
            JN = lv.J @ N
            s_max = float(np.linalg.norm(JN, 2)) if N.shape[1] else 0.0
            thr = 1e-9 * max(1.0, float(np.linalg.norm(lv.J, 2)))  # round-off of used rows
            w = (
                np.linalg.lstsq(JN, lv.r - lv.J @ xp, rcond=thr / s_max)[0]
                if s_max > thr
                else np.zeros(N.shape[1])
            )
            x = xp + N @ w
            Cx = C @ x
            if np.any(Cx < l - 1e-9) or np.any(Cx > u + 1e-9):
                continue
            f = float(np.sum((lv.J @ x - lv.r) ** 2))
            if f < best - 1e-12:
                best, best_x = f, x
        assert best_x is not None
        x_best = best_x
        held.append((lv.J, lv.J @ x_best))
    return x_best


def _bare_cascade_options(**kwargs: object) -> HierarchyOptions:
    """The cascade's proxsuite settings alone: no daqp first pass, fallbacks or relaxation."""
    solver = replace(CASCADE_SOLVER_OPTIONS, fallbacks=(), relax_on_failure=False)
    return HierarchyOptions(solver=solver, exact_first=None, **kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize("seed", range(4))
def test_degenerate_cascade_matches_the_enumerated_lexicographic_optimum(seed: int) -> None:
    levels, n, C, l, u = _degenerate_scene(seed)
    result = HierarchySolver(_bare_cascade_options()).solve(levels, n, C=C, l=l, u=u)
    assert result.success
    assert not result.culprits
    for lr in result.level_results:
        assert lr.status in (QPStatus.SOLVED, QPStatus.UNCONSTRAINED)
        assert lr.backend in ("proxsuite", "proxsuite+polish", "cholesky")
    reference = _lexicographic_by_enumeration(levels, n, C, l, u)
    np.testing.assert_allclose(result.x, reference, atol=1e-7)
    Cx = C @ result.x
    assert np.all(Cx >= l - 1e-9) and np.all(Cx <= u + 1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_far_flat_directions_cascade_matches_the_enumerated_optimum(seed: int) -> None:
    scale = 300.0
    levels, n, C, l, u = _far_flat_scene(seed, scale)
    result = HierarchySolver(_bare_cascade_options()).solve(levels, n, C=C, l=l, u=u)
    assert result.success
    for lr in result.level_results:
        assert lr.status is QPStatus.SOLVED
        assert lr.backend.startswith("proxsuite")
        assert lr.kkt.within(1e-9, 1e-6)
    reference = _lexicographic_by_enumeration(levels, n, C, l, u)
    # the damping 1e-9 |z|^2 of each level moves x by ~1e-8 * scale
    np.testing.assert_allclose(result.x, reference, atol=1e-8 * scale)


def test_vanished_rows_are_left_out_of_the_level_qp() -> None:
    # the held rows 0 and 1 project to noise in level 2's freedom: zero rows, no bounds
    levels, n, C, l, u = _degenerate_scene(0)
    seen = []

    class Spy(HierarchySolver):
        def _solver(self, k: int):  # type: ignore[no-untyped-def]
            inner = super()._solver(k)
            solve = inner.solve

            def record(problem):  # type: ignore[no-untyped-def]
                seen.append(problem)
                return solve(problem)

            inner.solve = record  # type: ignore[method-assign]
            return inner

    Spy(_bare_cascade_options()).solve(levels, n, C=C, l=l, u=u)
    level2 = seen[1]
    assert np.all(level2.C[:2] == 0.0)
    assert np.all(level2.l[:2] <= -INF) and np.all(level2.u[:2] >= INF)
    assert np.all(np.linalg.norm(level2.C[2:4], axis=1) > 0.5)  # the box rows stay


def test_hard_row_in_the_span_of_the_hard_equalities_and_violated_is_reported() -> None:
    # A x = 1 fixes x0 + x1; the hard row 2 (x0 + x1) in [3, 3] cannot hold: reported, no hang
    data = vanished_hard_row()
    A, b = data["A"], data["b"]
    result = HierarchySolver(_bare_cascade_options()).solve(
        data["levels"], 3, C=data["C"], l=data["l"], u=data["u"], A=A, b=b
    )
    assert not result.success
    assert result.status is QPStatus.RELAXED
    # the violated block's name (unnamed rows: "hard inequalities"), then the diagnosis
    assert len(result.culprits) == 2 and result.culprits[0] == "hard inequalities"
    assert "hard inequalities rows [0] vanish" in result.culprits[1]
    np.testing.assert_allclose(A @ result.x, b, atol=1e-9)
    assert result.x[2] == pytest.approx(0.5, abs=1e-7)  # the satisfiable row still holds
    assert result.level_results[0].status is QPStatus.SOLVED


def test_g1_inverse_dynamics_cascade_levels_solved_by_proxsuite() -> None:
    # the qp_backends benchmark's hierarchy scene: G1 on two feet, CoM, hands sent 0.78 m away
    # (out of reach: the levels hold active torque limits and cones), posture, forces
    robot = Robot.load("g1")
    s0 = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03)
        for f in ("left_ankle_roll_link", "right_ankle_roll_link")
    ]
    com = Task(F.CenterOfMass(robot), kp=50.0, priority=0)
    com.set_target_from_state(s0)
    hands = [
        Task(F.FramePose(robot, h), kp=50.0, weight=0.1, priority=1)
        for h in ("left_rubber_hand", "right_rubber_hand")
    ]
    for t in hands:
        t.set_target_from_state(s0)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=2)
    ctrl = InverseDynamicsQP(
        robot, [com, *hands, posture], contacts, InverseDynamicsOptions(hierarchical=True)
    )
    ctrl._hierarchy = HierarchySolver(_bare_cascade_options())
    for hand in ctrl.tasks[1:3]:
        hand.set_target(hand.target * pin.SE3(np.eye(3), np.array([0.6, 0.0, 0.5])))
    c0 = com.target.copy()
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    state = robot.state(q, v)
    dt = 0.002
    qp_levels = 0
    # 30 steps (about 3 s): at steps 22 and 25 proxsuite stops at a certified point whose
    # active set does not refine; without the polish it ends at its iteration limit
    for k in range(30):
        com.set_target(c0 + np.array([0.0, 0.04 * np.sin(np.pi * k * dt), 0.0]))
        state.update(q, v)
        res = ctrl.solve(state)
        assert res.success
        for lr in res.level_results:
            assert lr.status in (QPStatus.SOLVED, QPStatus.UNCONSTRAINED), lr.status
            # proxsuite, refined or polished on its active set; the Cholesky shortcut
            assert lr.backend in ("proxsuite", "proxsuite+polish", "cholesky"), lr.backend
            assert lr.kkt.within(1e-9, 1e-6)
            qp_levels += lr.backend.startswith("proxsuite")
        v = v + dt * res.a
        q = pin.integrate(robot.model, q, dt * v)
    assert qp_levels >= 80  # the cascade's levels were constrained QPs
