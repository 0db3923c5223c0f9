"""Fast paths of path optimization: per-term evaluation, cached collision results, the
vectorized collision Jacobian, the banded algebra and the hinge rows of the step model.

Each fast path is compared with a slow, independent reference (fresh states, per-joint
Jacobians, dense matrices, a generic minimizer).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from taskspace import features as F
from taskspace.constraints import FeatureBounds
from taskspace.errors import ShapeError
from taskspace.model import Robot
from taskspace.tasks import Task
from taskspace.trajopt.banded import SymmetricBlockBanded
from taskspace.trajopt.path_optimization import (
    PathCost,
    PathEquality,
    PathInequality,
    PathMultipliers,
    PathProblem,
    _CandidateRows,
    _damped_step,
    optimize_path,
)
from tests.trajopt._path_problems import perturbed_start, sphere_scene

TCP = "panda_hand_tcp"


@pytest.fixture(scope="module")
def scene() -> tuple[Robot, np.ndarray, np.ndarray, list[tuple[str, str]]]:
    """A Panda (own instance: an obstacle is added) with self-collision pairs and a sphere."""
    return sphere_scene()


def random_configurations(robot: Robot, n: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    lo, hi = robot.lower_limits, robot.upper_limits
    return [robot.q_default + 0.3 * rng.uniform(-1, 1, robot.nq) * (hi - lo) / 2 for _ in range(n)]


# ---------------------------------------------------------------------- collision feature
def reference_collision_jacobian(feature: F.CollisionDistance, state, robot: Robot) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Row k = [n; p_b x n]^T J_b - [n; p_a x n]^T J_a from Pinocchio's per-joint Jacobians."""
    state.compute_distances()
    results = state.collision_data.distanceResults
    J = np.zeros((feature.dim, robot.nv))
    for row, (k, (ja, jb)) in enumerate(zip(feature.pair_indices, feature._joints)):
        res = results[int(k)]
        n = np.array(res.normal)
        if jb:
            w = np.concatenate([n, np.cross(np.array(res.getNearestPoint2()), n)])
            J[row] += w @ state.joint_jacobian_world(jb)
        if ja:
            w = np.concatenate([n, np.cross(np.array(res.getNearestPoint1()), n)])
            J[row] -= w @ state.joint_jacobian_world(ja)
    return J


def test_collision_values_follow_updates_and_match_fresh_states(scene) -> None:  # type: ignore[no-untyped-def]
    robot = scene[0]
    feature = F.CollisionDistance(robot)  # self-collision and ball pairs
    state = robot.state(robot.q_default)
    for q in random_configurations(robot, 6, seed=1):
        state.update(q)
        fresh = robot.state(q)
        fresh.compute_distances()
        expected = np.array(
            [
                fresh.collision_data.distanceResults[int(k)].min_distance
                for k in feature.pair_indices
            ]
        )
        # coal's warm-started GJK leaves ~1e-6 m of history-dependent noise
        np.testing.assert_allclose(feature.value(state), expected, atol=1e-6)
    # a replaced collision data is picked up (the cached handles belong to the old one)
    q = random_configurations(robot, 1, seed=2)[0]
    state.update(q)
    before = feature.value(state).copy()
    state.collision_data = robot.collision_model.createData()
    state.update(q + 0.05)
    moved = feature.value(state)
    expected = feature.value(robot.state(q + 0.05))
    np.testing.assert_allclose(moved, expected, atol=1e-6)
    assert np.abs(moved - before).max() > 1e-3


def test_collision_jacobian_rows_match_per_joint_reference(scene) -> None:  # type: ignore[no-untyped-def]
    robot = scene[0]
    feature = F.CollisionDistance(robot)  # both geometries move in self-collision pairs
    assert any(ja and jb for ja, jb in feature._joints)
    assert any(not ja or not jb for ja, jb in feature._joints)
    state = robot.state(robot.q_default)
    for q in random_configurations(robot, 5, seed=4):
        state.update(q)
        ref = reference_collision_jacobian(feature, state, robot)
        assert np.abs(ref).max() > 0.1
        np.testing.assert_allclose(feature.jacobian(state), ref, atol=1e-12)
        mask = np.zeros(feature.dim, dtype=bool)
        mask[::3] = True
        np.testing.assert_allclose(feature.jacobian(state, rows=mask), ref[mask], atol=1e-12)
        index = np.array([feature.dim - 1, 0, 5])
        np.testing.assert_allclose(feature.jacobian(state, rows=index), ref[index], atol=1e-12)
        assert feature.jacobian(state, rows=np.zeros(feature.dim, dtype=bool)).shape == (
            0,
            robot.nv,
        )


# ---------------------------------------------------------------------- banded algebra
def random_banded(n: int, b: int, k: int, seed: int) -> tuple[SymmetricBlockBanded, np.ndarray]:
    rng = np.random.default_rng(seed)
    H = SymmetricBlockBanded(n, b, k)
    A = rng.normal(size=(n * b, n * b))
    mask = np.abs(np.subtract.outer(np.arange(n * b) // b, np.arange(n * b) // b)) <= k
    dense = (A @ A.T) * mask + n * b * np.eye(n * b)
    for o in range(H.bandwidth):
        idx = np.arange(n * b - o)
        H.ab[o, : n * b - o] = dense[idx + o, idx]
    return H, dense


def test_banded_diagonal_update_matvec_and_copy_match_dense() -> None:
    H, dense = random_banded(7, 3, 2, seed=5)
    rng = np.random.default_rng(6)
    x = rng.normal(size=21)
    np.testing.assert_allclose(H.matvec(x), dense @ x, rtol=1e-12)
    shift = rng.uniform(0.5, 1.0, size=21)
    copy = H.copy()
    copy.add_diagonal(shift)
    dense_b = dense + np.diag(shift)
    np.testing.assert_allclose(copy.to_dense(), dense_b, rtol=1e-12)
    np.testing.assert_allclose(H.to_dense(), dense, rtol=1e-12)  # the copy is independent
    np.testing.assert_allclose(copy.solve(x), np.linalg.solve(dense_b, x), rtol=1e-10)
    with pytest.raises(ShapeError):
        H.matvec(x[:-1])


# ---------------------------------------------------------------------- problem evaluation
def small_problem(scene) -> tuple[PathProblem, np.ndarray, PathMultipliers]:  # type: ignore[no-untyped-def]
    """T = 6, every kind of term, several terms per slice, random multipliers."""
    robot, q0, qg, pairs = scene
    T = 6
    goal = robot.frame_placement(qg, TCP)
    problem = PathProblem(
        robot,
        q0,
        T,
        costs=[
            PathCost(Task(F.Position(robot, "panda_link5"), [0.3, 0.1, 0.5], weight=0.5)),
            PathCost(Task(F.FramePose(robot, TCP), goal, weight=3.0), times=[2, 5]),
        ],
        equalities=[
            PathEquality(Task(F.FramePose(robot, TCP), goal), times=-1),
            PathEquality(Task(F.Position(robot, "panda_link4"), [0.2, 0.0, 0.6]), times=[3, 6]),
        ],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), 0.3, 2.0)),
            PathInequality(
                FeatureBounds(F.Position(robot, "panda_link6"), [-1, -1, 0.45], [1, 1, 2]),
                times=[2, 3, 6],
            ),
        ],
        velocity_weight=0.2,
    )
    path, mult = perturbed_start(problem, q0, qg, seed=7)
    return problem, path, mult


def test_residual_rows_match_features_on_fresh_states(scene) -> None:  # type: ignore[no-untyped-def]
    """The per-term evaluation lays the rows out per slice exactly as documented."""
    robot = scene[0]
    problem, path, mult = small_problem(scene)
    rho = 3.0
    r = problem.residual(path, penalty=rho, multipliers=mult)
    T, nv = problem.horizon, problem.nv
    row = sum(T * nv for _ in problem.control_weights)
    for t in range(1, T + 1):
        state = robot.state(path[t])
        parts = []
        for cost in problem.costs:
            if t in problem._times(cost.times, ""):
                task = cost.task
                parts.append(task.sqrt_weight * task.feature.residual(state, task.target))
        lam_h = mult.equality[t - 1]
        h = []
        for eq in problem.equalities:
            if t in problem._times(eq.times, ""):
                task = eq.task
                h.append(task.sqrt_weight * task.feature.residual(state, task.target))
        h_all = np.concatenate(h) if h else np.zeros(0)
        parts.append(np.sqrt(rho) * (h_all + lam_h / (2 * rho)))
        g = []
        for ineq in problem.inequalities:
            if t in problem._times(ineq.times, ""):
                y = np.asarray(ineq.bounds.feature.value(state))
                g += [ineq.bounds.lower - y, y - ineq.bounds.upper]
        q = path[t][robot.limited_joints_q]
        g += [
            robot.lower_limits[robot.limited_joints_q] - q,
            q - robot.upper_limits[robot.limited_joints_q],
        ]
        lam_g = mult.inequality[t - 1]
        parts.append(np.sqrt(rho) * np.maximum(np.concatenate(g) + lam_g / (2 * rho), 0.0))
        expected = np.concatenate(parts)
        np.testing.assert_allclose(r[row : row + expected.size], expected, rtol=1e-12, atol=1e-12)
        row += expected.size
    assert row == r.size


def test_multiplier_sizes_are_checked(scene) -> None:  # type: ignore[no-untyped-def]
    problem, path, mult = small_problem(scene)
    mult.inequality[2] = mult.inequality[2][:-1]
    with pytest.raises(ShapeError, match="inequality multipliers of slice 3"):
        problem.residual(path, multipliers=mult)
    short = PathMultipliers(mult.equality[:-1], mult.inequality)
    with pytest.raises(ShapeError, match="multipliers"):
        problem.residual(path, multipliers=short)


def test_candidate_rows_are_inactive_rows_of_the_residual_jacobian(scene) -> None:  # type: ignore[no-untyped-def]
    """Watched inactive rows: linearization of the same rows made active (signs, scale)."""
    problem, path, mult = small_problem(scene)
    rho = 3.0
    ev = problem._evaluate(problem.check_path(path), problem._states)
    lam = problem._term_multipliers(mult)
    problem._set_rows(ev, rho, lam)
    watch = [np.ones_like(R, dtype=bool) for R in ev.ineq_rows]
    H0, g0, none = problem._assemble(ev, rho, lam)
    H1, g1, cand = problem._assemble(ev, rho, lam, watch)
    assert none.size == 0
    # candidates do not change J^T J and J^T r
    np.testing.assert_array_equal(H0.ab, H1.ab)
    np.testing.assert_array_equal(g0, g1)
    inactive = sum(int((R <= 0).sum()) for R in ev.ineq_rows)
    assert cand.size == inactive > 10
    assert np.all(cand.residual <= 0.0)
    sqrt_rho = np.sqrt(rho)
    for c in range(cand.size):
        term = problem._ineq_terms[cand.term[c]]
        i, k = cand.index[c], cand.row[c]
        t = term.slices[i]
        assert cand.slices[c] == t
        d = term.dim
        Jy = term.feature.jacobian(problem._states[t])
        sign = -1.0 if k < d else 1.0
        np.testing.assert_allclose(cand.jacobian[c], sign * sqrt_rho * Jy[k % d], atol=1e-12)
        g = ev.ineqs[cand.term[c]][i, k]
        lam_k = lam.inequality[cand.term[c]][i, k]
        assert cand.residual[c] == pytest.approx(sqrt_rho * (g + lam_k / (2 * rho)))


def test_hinge_step_minimizes_the_piecewise_quadratic_model() -> None:
    """The active-set step equals the minimizer of 2 g.dx + dx.(H + mu).dx + sum [r + j dx]_+^2."""
    n, b, k = 5, 3, 2
    H, dense = random_banded(n, b, k, seed=8)
    rng = np.random.default_rng(9)
    grad = 5.0 * rng.normal(size=n * b)
    mu = 0.3
    m = 8
    slices = rng.integers(0, n, size=m).astype(np.intp)
    jac = 3.0 * rng.normal(size=(m, b))
    residual = -rng.uniform(0.1, 1.0, size=m)
    idx = np.zeros(m, dtype=np.intp)
    cand = _CandidateRows(slices, jac, residual, idx, idx, idx)

    def model(dx: np.ndarray) -> float:
        z = cand.linearized(dx.reshape(n, b))
        return float(
            2 * grad @ dx + dx @ (dense + mu * np.eye(n * b)) @ dx + np.sum(np.maximum(z, 0) ** 2)
        )

    def model_grad(dx: np.ndarray) -> np.ndarray:
        z = np.maximum(cand.linearized(dx.reshape(n, b)), 0.0)
        out = 2 * grad + 2 * (dense + mu * np.eye(n * b)) @ dx
        out = out.reshape(n, b)
        np.add.at(out, slices, 2 * z[:, None] * jac)
        return out.ravel()

    plain = np.linalg.solve(dense + mu * np.eye(n * b), -grad)
    assert np.any(cand.linearized(plain.reshape(n, b)) > 0)  # the plain step crosses rows
    step = _damped_step(H, grad, mu, cand, b, passes=20)
    ref = scipy.optimize.minimize(model, plain, jac=model_grad, method="BFGS", tol=1e-12).x
    assert model(step) < model(plain)
    assert model(step) == pytest.approx(model(ref), rel=1e-9, abs=1e-9)
    np.testing.assert_allclose(step, ref, atol=1e-5)
    # no candidates: the plain Levenberg-Marquardt step
    empty = _CandidateRows(
        np.zeros(0, dtype=np.intp), np.zeros((0, b)), np.zeros(0), idx[:0], idx[:0], idx[:0]
    )
    np.testing.assert_allclose(_damped_step(H, grad, mu, empty, b), plain, rtol=1e-10)


def test_reach_converges_in_few_iterations(scene) -> None:  # type: ignore[no-untyped-def]
    """Hinge rows learned at rejected steps avoid long damping recoveries (about 20
    iterations without them on this problem, 12-14 with them)."""
    robot, q0, qg, pairs = scene
    goal = robot.frame_placement(qg, TCP)
    problem = PathProblem(
        robot,
        q0,
        20,
        equalities=[PathEquality(Task(F.FramePose(robot, TCP), goal), times=-1)],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), 0.02, np.inf))
        ],
    )
    result = optimize_path(problem)
    assert result.success, (result.status, result.violations)
    assert result.iterations <= 17
    assert result.max_violation <= 1e-4


@pytest.mark.parametrize("straight", [True, False])
def test_slow_reach_converges_from_both_initial_paths(scene, straight: bool) -> None:  # type: ignore[no-untyped-def]
    """Duration 3 s (smaller control cost): rejected steps whose learned rows do not change
    the step must not be retried forever (a loop that used to exhaust the iterations)."""
    robot, q0, qg, pairs = scene
    goal = robot.frame_placement(qg, TCP)
    T = 20
    problem = PathProblem(
        robot,
        q0,
        T,
        equalities=[PathEquality(Task(F.FramePose(robot, TCP), goal))],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), 0.02, np.inf))
        ],
        duration=3.0,
    )
    result = optimize_path(problem, np.linspace(q0, qg, T + 1) if straight else None)
    assert result.success, (result.status, result.iterations, result.violations)
    assert result.iterations < 60
    d = F.CollisionDistance(robot, pairs)
    assert min(d.value(robot.state(q)).min() for q in result.path[1:]) >= 0.02 - 1e-3
