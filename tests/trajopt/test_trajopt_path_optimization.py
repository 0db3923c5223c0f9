"""Path optimization (slides 4:1-4:4) vs finite differences, dense algebra, analytic paths."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg

from taskspace import features as F
from taskspace.constraints import FeatureBounds
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, SolverError
from taskspace.model import Robot
from taskspace.tasks import Task
from taskspace.trajopt.banded import SymmetricBlockBanded
from taskspace.trajopt.path_optimization import (
    PathCost,
    PathEquality,
    PathInequality,
    PathMultipliers,
    PathOptimizationOptions,
    PathOptimizationStatus,
    PathProblem,
    optimize_path,
)
from tests.conftest import load_robot
from tests.trajopt._path_problems import perturbed_start, sphere_scene

TCP = "panda_hand_tcp"
MARGIN = 0.02


@pytest.fixture(scope="module")
def scene() -> tuple[Robot, np.ndarray, np.ndarray, list[tuple[str, str]]]:
    """A Panda (own instance: obstacles are added) reaching around a sphere."""
    return sphere_scene()


def reach_problem(scene, T: int, **kw) -> PathProblem:  # type: ignore[no-untyped-def]
    robot, q0, qg, pairs = scene
    goal = robot.frame_placement(qg, TCP)
    return PathProblem(
        robot,
        q0,
        T,
        equalities=[PathEquality(Task(F.FramePose(robot, TCP), goal), times=-1)],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), MARGIN, np.inf))
        ],
        **kw,
    )


def min_distances(robot: Robot, pairs, path: np.ndarray) -> np.ndarray:  # type: ignore[no-untyped-def]
    feature = F.CollisionDistance(robot, pairs)
    return np.array([feature.value(robot.state(q)).min() for q in path])


# ---------------------------------------------------------------------- derivatives
def small_problem(scene) -> tuple[PathProblem, np.ndarray, PathMultipliers]:  # type: ignore[no-untyped-def]
    """T = 5 with every kind of term, a margin large enough for active collision rows."""
    robot, q0, qg, pairs = scene
    T = 5
    goal = robot.frame_placement(qg, TCP)
    problem = PathProblem(
        robot,
        q0,
        T,
        costs=[
            PathCost(Task(F.FramePose(robot, TCP), goal, weight=3.0), times=[2, 4]),
            PathCost(Task(F.Position(robot, "panda_link5"), [0.3, 0.1, 0.5], weight=0.5)),
        ],
        equalities=[PathEquality(Task(F.FramePose(robot, TCP), goal), times=-1)],
        inequalities=[PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), 0.3, 2.0))],
        velocity_weight=0.3,
        acceleration_weight=1.0,
        jerk_weight=0.01,
    )
    path, mult = perturbed_start(problem, q0, qg, seed=3)
    return problem, path, mult


def test_residual_jacobian_matches_finite_differences(scene) -> None:  # type: ignore[no-untyped-def]
    problem, path, mult = small_problem(scene)
    rho = 7.0
    J = problem.residual_jacobian(path, penalty=rho, multipliers=mult).toarray()
    r0 = problem.residual(path, penalty=rho, multipliers=mult)
    nv, T = problem.nv, problem.horizon
    assert J.shape == (r0.size, T * nv)
    active = problem.residual(path, penalty=rho, multipliers=mult) != 0
    assert active.sum() > T * nv * 3  # control rows plus some constraint rows are active
    # coal's GJK distances carry ~1e-6 m of history-dependent noise (warm-started queries):
    # central differences with a larger step keep that noise below the tolerance
    eps = 1e-3
    J_fd = np.empty_like(J)
    for col in range(T * nv):
        plus, minus = path.copy(), path.copy()
        plus[1 + col // nv, col % nv] += eps
        minus[1 + col // nv, col % nv] -= eps
        J_fd[:, col] = (
            problem.residual(plus, penalty=rho, multipliers=mult)
            - problem.residual(minus, penalty=rho, multipliers=mult)
        ) / (2 * eps)
    np.testing.assert_allclose(J, J_fd, rtol=2e-3, atol=5e-3)
    assert np.abs(J).max() > 1.0  # not trivially small


def test_banded_normal_equations_equal_dense(scene) -> None:  # type: ignore[no-untyped-def]
    problem, path, mult = small_problem(scene)
    rho = 7.0
    H, g = problem.normal_equations(path, penalty=rho, multipliers=mult)
    J = problem.residual_jacobian(path, penalty=rho, multipliers=mult).toarray()
    r = problem.residual(path, penalty=rho, multipliers=mult)
    dense = J.T @ J
    np.testing.assert_allclose(H.to_dense(), dense, rtol=1e-10, atol=1e-8 * np.abs(dense).max())
    np.testing.assert_allclose(g, J.T @ r, rtol=1e-10, atol=1e-8 * np.abs(J.T @ r).max())
    # structure: band storage of (k + 1) nv rows (k = 3 here), no dense (T nv)^2 storage
    nv, k = problem.nv, 3
    assert problem.order == k
    assert H.ab.shape == ((k + 1) * nv, problem.horizon * nv)
    assert problem.bandwidth == (k + 1) * nv
    # the dense matrix really is zero beyond block distance k and nonzero at distance k
    T = problem.horizon
    blocks = dense.reshape(T, nv, T, nv)
    for s in range(T):
        for t in range(T):
            if abs(s - t) > k:
                assert np.all(blocks[s, :, t, :] == 0.0)
    assert np.abs(blocks[k, :, 0, :]).max() > 0


def test_gradient_matches_finite_differences_of_objective(scene) -> None:  # type: ignore[no-untyped-def]
    problem, path, mult = small_problem(scene)
    rho = 7.0
    _, g = problem.normal_equations(path, penalty=rho, multipliers=mult)
    rng = np.random.default_rng(11)
    for _ in range(3):
        direction = rng.normal(size=path.shape)
        direction[0] = 0.0
        eps = 1e-3

        def f(x: np.ndarray) -> float:
            r = problem.residual(x, penalty=rho, multipliers=mult)
            return float(r @ r)

        fd = (f(path + eps * direction) - f(path - eps * direction)) / (2 * eps)
        assert 2 * g @ direction[1:].ravel() == pytest.approx(fd, rel=1e-3, abs=1e-3)


def test_banded_solve_matches_dense_solve() -> None:
    rng = np.random.default_rng(0)
    n, b, k = 6, 3, 2
    H = SymmetricBlockBanded(n, b, k)
    A = rng.normal(size=(n * b, n * b))
    mask = np.abs(np.subtract.outer(np.arange(n * b) // b, np.arange(n * b) // b)) <= k
    dense = (A @ A.T) * mask + n * b * np.eye(n * b)
    for o in range(H.bandwidth):
        idx = np.arange(n * b - o)
        H.ab[o, : n * b - o] = dense[idx + o, idx]
    np.testing.assert_allclose(H.to_dense(), dense)
    rhs = rng.normal(size=n * b)
    np.testing.assert_allclose(H.solve(rhs), scipy.linalg.solve(dense, rhs), rtol=1e-10)
    np.testing.assert_allclose(H.matvec(rhs), dense @ rhs, rtol=1e-10)
    H.ab[0, 0] = -1.0
    with pytest.raises(SolverError, match="not positive definite"):
        H.solve(rhs)


# ---------------------------------------------------------------------- analytic solutions
def test_velocity_cost_gives_uniform_steps() -> None:
    """min sum |q_t - q_t-1|^2 with q_T fixed: the straight line with equal steps."""
    robot = load_robot("panda")
    q0 = robot.q_default.copy()
    qg = q0 + np.array([0.4, -0.3, 0.2, 0.5, -0.2, 0.3, 0.1])
    T = 12
    problem = PathProblem(
        robot,
        q0,
        T,
        equalities=[PathEquality(Task(F.JointConfiguration(robot), qg), times=[T])],
        velocity_weight=1.0,
        acceleration_weight=0.0,
    )
    result = optimize_path(problem, options=PathOptimizationOptions(constraint_tolerance=1e-9))
    assert result.success, result.status
    expected = q0 + np.linspace(0.0, 1.0, T + 1)[:, None] * (qg - q0)
    np.testing.assert_allclose(result.path, expected, atol=1e-6)
    steps = np.diff(result.path, axis=0)
    np.testing.assert_allclose(steps, np.tile((qg - q0) / T, (T, 1)), atol=1e-6)


def test_acceleration_cost_matches_least_squares_reference() -> None:
    """Acceleration cost, start at rest, fixed end: the discrete minimizer from numpy lstsq;
    with a prefix on the line the minimizer is exactly the linear interpolation."""
    robot = load_robot("panda")
    q0 = robot.q_default.copy()
    qg = q0 + np.array([0.3, 0.2, -0.2, 0.4, 0.1, -0.3, 0.2])
    T = 10
    end = [PathEquality(Task(F.JointConfiguration(robot), qg), times=-1)]
    opts = PathOptimizationOptions(constraint_tolerance=1e-9)
    result = optimize_path(PathProblem(robot, q0, T, equalities=end), options=opts)
    assert result.success
    # reference: variables q_1..q_T-1 per joint, residuals q_t - 2 q_t-1 + q_t-2, q_-1 = q_0
    n = T - 1
    full = np.zeros((T, n + 3))  # columns: q_-1, q_0, q_1..q_T-1, q_T
    for t in range(1, T + 1):
        full[t - 1, t + 1], full[t - 1, t], full[t - 1, t - 1] = 1.0, -2.0, 1.0
    A = full[:, 2 : 2 + n]
    for j in range(robot.nv):
        b = -(full[:, 0] + full[:, 1]) * q0[j] - full[:, -1] * qg[j]
        ref = np.linalg.lstsq(A, b, rcond=None)[0]
        np.testing.assert_allclose(result.path[1:T, j], ref, atol=1e-6)
    # prefix on the straight line: zero acceleration is reachable
    prefix = np.array([q0 - 2 * (qg - q0) / T, q0 - (qg - q0) / T])  # q_-2, q_-1
    line = optimize_path(PathProblem(robot, q0, T, equalities=end, prefix=prefix), options=opts)
    expected = q0 + np.linspace(0.0, 1.0, T + 1)[:, None] * (qg - q0)
    np.testing.assert_allclose(line.path, expected, atol=1e-6)
    assert line.cost < 1e-10


# ---------------------------------------------------------------------- constrained paths
def test_reach_around_obstacle_satisfies_constraints(scene) -> None:  # type: ignore[no-untyped-def]
    robot, q0, qg, pairs = scene
    result = optimize_path(reach_problem(scene, 20))
    assert result.success, (result.status, result.violations)
    assert result.status is PathOptimizationStatus.CONVERGED
    path = result.path
    assert path.shape == (21, robot.nq)
    np.testing.assert_array_equal(path[0], q0)
    idx = robot.limited_joints_q
    assert np.all(path[:, idx] >= robot.lower_limits[idx] - 1e-6)
    assert np.all(path[:, idx] <= robot.upper_limits[idx] + 1e-6)
    assert min_distances(robot, pairs, path[1:]).min() >= MARGIN - 1e-3
    goal = robot.frame_placement(qg, TCP)
    error = pin.log6(goal.actInv(robot.frame_placement(path[-1], TCP))).vector
    assert np.linalg.norm(error) < 1e-3
    # diagnostics are consistent with the path
    assert len(result.cost_history) == len(result.violation_history) >= 2
    assert result.violation_history[-1] == pytest.approx(result.max_violation)
    assert result.max_violation <= 1e-4
    assert result.iterations >= 1 and result.solve_time > 0
    assert result.evaluation_time + result.linear_solve_time <= result.solve_time


def test_repair_of_in_collision_initial_guess(scene) -> None:  # type: ignore[no-untyped-def]
    robot, q0, qg, pairs = scene
    T = 20
    straight = np.linspace(q0, qg, T + 1)
    assert not all(robot.is_collision_free(q) for q in straight)  # the guess is in collision
    result = optimize_path(reach_problem(scene, T), straight)
    assert result.success, (result.status, result.violations)
    assert result.repaired_slices > 0
    assert all(robot.is_collision_free(q) for q in result.path)
    assert min_distances(robot, pairs, result.path[1:]).min() >= MARGIN - 1e-3


def test_warm_start_waypoints_are_resampled(scene) -> None:  # type: ignore[no-untyped-def]
    robot, q0, qg, _ = scene
    problem = reach_problem(scene, 8)
    mid = q0.copy()
    mid[0] = 0.0
    init = problem.initial_path([q0, mid, qg])
    assert init.shape == (9, robot.nq)
    np.testing.assert_allclose(init[0], q0)
    np.testing.assert_allclose(init[-1], qg)
    np.testing.assert_allclose(np.diff(init[:, 0]), (qg[0] - q0[0]) / 8)  # equal arc length


# ---------------------------------------------------------------------- errors
def test_bad_inputs_raise_taskspace_errors(scene) -> None:  # type: ignore[no-untyped-def]
    robot, q0, qg, _ = scene
    for bad in (0, -3, 2.5, True):
        with pytest.raises(InvalidInputError, match="horizon T must be an integer >= 1"):
            PathProblem(robot, q0, bad)  # type: ignore[arg-type]
    problem = reach_problem(scene, 5)
    nan_path = np.tile(q0, (6, 1))
    nan_path[3, 2] = np.nan
    with pytest.raises(NotFiniteError, match="initial path has non-finite"):
        optimize_path(problem, nan_path)
    with pytest.raises(ShapeError, match=r"initial path must have shape \(-1, 7\)"):
        optimize_path(problem, np.zeros((6, 5)))
    with pytest.raises(ShapeError, match=r"path must have shape \(6, 7\)"):
        problem.residual(np.zeros((4, 7)))
    with pytest.raises(ShapeError, match="q_start must have shape"):
        PathProblem(robot, q0[:3], 5)
    task = Task(F.FramePose(robot, TCP), robot.frame_placement(qg, TCP))
    with pytest.raises(InvalidInputError, match=r"time slice 7 .* outside 1..T = 1..5"):
        PathProblem(robot, q0, 5, costs=[PathCost(task, times=[1, 7])])
    with pytest.raises(InvalidInputError, match="has no target"):
        PathProblem(robot, q0, 5, equalities=[PathEquality(Task(F.FramePose(robot, TCP)))])
    other = load_robot("panda")
    with pytest.raises(InvalidInputError, match="same object required"):
        PathProblem(robot, q0, 5, costs=[PathCost(Task(F.JointConfiguration(other), q0))])
    with pytest.raises(ShapeError, match=r"prefix must have shape \(2, 7\)"):
        PathProblem(robot, q0, 5, prefix=np.zeros((1, 7)))
    with pytest.raises(InvalidInputError, match="weight of the order-2 control cost"):
        PathProblem(robot, q0, 5, acceleration_weight=-1.0)
    with pytest.raises(InvalidInputError, match="penalty must be finite and > 0"):
        problem.residual(np.tile(q0, (6, 1)), penalty=0.0)


def test_floating_base_is_rejected_with_explanation() -> None:
    robot = load_robot("solo12")
    with pytest.raises(InvalidInputError, match=r"vector space \(nq == nv\).*nq=19, nv=18"):
        PathProblem(robot, robot.q_default, 5)
