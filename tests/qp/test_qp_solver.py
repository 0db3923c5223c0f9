"""QPSolver: each available backend on the named problems, workspace, shortcut, relaxation."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import UnknownNameError
from taskspace.qp import (
    BACKENDS,
    INF,
    QPProblem,
    QPSolver,
    QPSolverOptions,
    QPStatus,
    RowBlock,
    available_backends,
)
from tests.qp.problems_qp import PROBLEMS, box_qp, infeasible_qp, random_dense_qp

pytestmark = [
    pytest.mark.filterwarnings("ignore:Converted matrix:UserWarning"),
    pytest.mark.filterwarnings("ignore:OSQP exited with status:UserWarning"),
]

# osqp is a first-order method: its answers are accurate to ~1e-6 only
TOLERANCE = {"proxsuite": 1e-7, "daqp": 1e-8, "quadprog": 1e-8, "osqp": 1e-5}


def _backend_only(backend: str) -> QPSolver:
    """A solver that runs exactly this backend (no shortcut, fallback or relaxation)."""
    return QPSolver(
        QPSolverOptions(
            backend=backend, fallbacks=(), try_unconstrained=False, relax_on_failure=False
        )
    )


def test_backends_are_known() -> None:
    assert set(available_backends()) <= set(BACKENDS)
    assert "proxsuite" in available_backends()  # a core dependency


@pytest.mark.parametrize("backend", available_backends())
@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_backend_solves_named_problem(backend: str, name: str) -> None:
    named = PROBLEMS[name]()
    result = _backend_only(backend).solve(named.problem)
    assert result.success, f"{backend} on {name}: {result.status}"
    assert result.status is QPStatus.SOLVED
    assert result.backend.split("+")[0] == backend  # "osqp+polish": refined on its active set
    tol = TOLERANCE[backend]
    np.testing.assert_allclose(result.x, named.x, atol=tol * 10, err_msg=named.reference)
    assert named.problem.is_feasible(result.x, tolerance=tol)
    ref_objective = 0.5 * named.x @ named.problem.H @ named.x + named.problem.g @ named.x
    assert result.objective == pytest.approx(ref_objective, abs=tol * 100)


@pytest.mark.parametrize("backend", available_backends())
def test_backend_default_pipeline_on_named_problems(backend: str) -> None:
    # the default pipeline (shortcut + fallbacks + relaxation) must give the same answers
    solver = QPSolver(QPSolverOptions(backend=backend))
    for name, make in sorted(PROBLEMS.items()):
        named = make()
        result = solver.solve(named.problem)
        assert result.success, name
        np.testing.assert_allclose(result.x, named.x, atol=TOLERANCE[backend] * 10, err_msg=name)


def test_proxsuite_workspace_persists_and_updates() -> None:
    solver = _backend_only("proxsuite")
    first = random_dense_qp(3)
    second = random_dense_qp(1)  # same structure (n, n_eq, n_in), new data
    assert first.problem.structure() == second.problem.structure()
    r1 = solver.solve(first.problem)
    workspace = solver._proxsuite
    assert workspace is not None
    r2 = solver.solve(second.problem)
    assert solver._proxsuite is workspace, "the workspace was rebuilt instead of updated"
    np.testing.assert_allclose(r1.x, first.x, atol=1e-6)
    np.testing.assert_allclose(r2.x, second.x, atol=1e-6)
    # and back: the update path again, compared with a fresh solver
    r3 = solver.solve(first.problem)
    fresh = _backend_only("proxsuite").solve(first.problem)
    np.testing.assert_allclose(r3.x, fresh.x, atol=1e-7)
    np.testing.assert_allclose(r3.x, first.x, atol=1e-6)


def test_proxsuite_workspace_rebuilt_on_new_structure() -> None:
    solver = _backend_only("proxsuite")
    solver.solve(random_dense_qp(3).problem)
    named = box_qp()
    result = solver.solve(named.problem)
    np.testing.assert_allclose(result.x, named.x, atol=1e-7)


def test_unconstrained_shortcut_taken_only_when_bounds_inactive() -> None:
    rng = np.random.default_rng(0)
    M = rng.normal(size=(5, 5))
    H = M @ M.T + np.eye(5)
    g = rng.normal(size=5)
    x_free = np.linalg.solve(H, -g)  # reference minimizer
    empty = np.zeros((0, 5))
    loose = QPProblem(
        H, g, empty, np.zeros(0), empty, np.zeros(0), np.zeros(0), x_free - 1, x_free + 1
    )
    result = QPSolver().solve(loose)
    assert result.status is QPStatus.UNCONSTRAINED
    assert result.success and result.iterations == 0
    np.testing.assert_allclose(result.x, x_free, atol=1e-12)
    assert result.objective == pytest.approx(0.5 * x_free @ H @ x_free + g @ x_free, rel=1e-12)
    # one bound cuts the free minimizer: the QP must run
    ub = x_free + 1
    ub[2] = x_free[2] - 0.5
    tight = QPProblem(H, g, empty, np.zeros(0), empty, np.zeros(0), np.zeros(0), x_free - 1, ub)
    result = QPSolver().solve(tight)
    assert result.status is QPStatus.SOLVED
    assert result.x[2] == pytest.approx(ub[2], abs=1e-8)
    # reference: the problem with x2 fixed at its bound, solved by the normal equations
    keep = [0, 1, 3, 4]
    x_ref = np.empty(5)
    x_ref[2] = ub[2]
    x_ref[keep] = np.linalg.solve(H[np.ix_(keep, keep)], -g[keep] - H[keep, 2] * ub[2])
    np.testing.assert_allclose(result.x, x_ref, atol=1e-7)


def test_unconstrained_shortcut_with_equalities_objective() -> None:
    # equality-constrained minimizer through the KKT system, objective reported exactly
    H = np.diag([1.0, 2.0, 4.0])
    g = np.array([1.0, -1.0, 0.5])
    A = np.array([[1.0, 1.0, 1.0]])
    b = np.array([1.0])
    empty = np.zeros((0, 3))
    p = QPProblem(H, g, A, b, empty, np.zeros(0), np.zeros(0), np.full(3, -INF), np.full(3, INF))
    K = np.block([[H, A.T], [A, np.zeros((1, 1))]])
    x_ref = np.linalg.solve(K, np.concatenate([-g, b]))[:3]
    result = QPSolver().solve(p)
    assert result.status is QPStatus.UNCONSTRAINED
    np.testing.assert_allclose(result.x, x_ref, atol=1e-12)
    assert result.objective == pytest.approx(0.5 * x_ref @ H @ x_ref + g @ x_ref, rel=1e-12)


@pytest.mark.parametrize("backend", available_backends())
def test_infeasible_problem_is_relaxed_with_culprit(backend: str) -> None:
    p = infeasible_qp()
    w = 1e6
    solver = QPSolver(QPSolverOptions(backend=backend, relaxation_weight=w))
    result = solver.solve(p)
    assert result.status is QPStatus.RELAXED
    assert not result.success
    assert "sum" in result.culprits
    assert "box" in result.culprits
    t = 10 * w / (6 * w + 2)  # hand-derived least-violating point (see infeasible_qp)
    np.testing.assert_allclose(result.x, [t, t], atol=1e-6)
    assert result.violations["sum"] == pytest.approx(4 - 2 * t, abs=1e-6)
    assert result.violations["box"] == pytest.approx(t - 1, abs=1e-6)


def test_relaxation_names_only_the_violated_block() -> None:
    # x0 + x1 = 4 conflicts with the box; the inequality x0 - x1 <= 10 is never at fault
    base = infeasible_qp()
    p = QPProblem(
        base.H,
        base.g,
        base.A,
        base.b,
        np.array([[1.0, -1.0]]),
        np.array([-INF]),
        np.array([10.0]),
        base.lb,
        base.ub,
        eq_blocks=base.eq_blocks,
        in_blocks=[RowBlock("difference", 0, 1)],
        box_blocks=base.box_blocks,
    )
    result = QPSolver().solve(p)
    assert result.status is QPStatus.RELAXED
    assert "difference" not in result.culprits
    assert "sum" in result.culprits


def test_unknown_backend_lists_available() -> None:
    with pytest.raises(UnknownNameError) as info:
        QPSolver(QPSolverOptions(backend="gurobi"))
    message = str(info.value)
    assert "unknown QP backend 'gurobi'" in message
    for name in available_backends():
        assert name in message
    with pytest.raises(UnknownNameError, match="unknown QP backend 'cplex'"):
        QPSolver(QPSolverOptions(fallbacks=("cplex",)))
