"""Non-convex, non-symmetric and impossible-bound QPs are refused, on every backend.

Before: ``H = -I`` in a box came back ``SOLVED`` at ``x = 0`` (the maximum; the minimizers are
the box's corners), a non-symmetric ``H`` was ``SOLVED`` by whatever triangle the backend
reads, ``l = +inf`` ended ``FAILED`` with ``x = NaN``; the duality gap of a box with infinite
bounds and zero multipliers was NaN (``inf * 0``) with a numpy RuntimeWarning.
References: enumeration of the box's vertices (an LP's optimum is at a vertex), hand-solved
problems, the KKT conditions.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.qp import QPProblem, QPSolver, QPSolverOptions, QPStatus, available_backends

BACKENDS = available_backends()


def _qp(H, g, *, A=None, b=None, C=None, l=None, u=None, lb=None, ub=None) -> QPProblem:
    n = len(g)
    empty = np.empty((0, n))
    return QPProblem(
        np.asarray(H, dtype=float),
        np.asarray(g, dtype=float),
        empty if A is None else np.asarray(A, dtype=float),
        np.empty(0) if b is None else np.asarray(b, dtype=float),
        empty if C is None else np.asarray(C, dtype=float),
        np.empty(0) if l is None else np.asarray(l, dtype=float),
        np.empty(0) if u is None else np.asarray(u, dtype=float),
        np.full(n, -np.inf) if lb is None else np.asarray(lb, dtype=float),
        np.full(n, np.inf) if ub is None else np.asarray(ub, dtype=float),
    )


def _solver(backend: str) -> QPSolver:
    return QPSolver(QPSolverOptions(backend=backend))


@pytest.mark.parametrize("backend", BACKENDS)
def test_concave_box_qp_refused(backend: str) -> None:
    p = _qp(-np.eye(2), [0.0, 0.0], lb=[-1, -1], ub=[1, 1])
    with pytest.raises(
        InvalidInputError, match=r"positive semi-definite.*smallest eigenvalue is -1"
    ):
        _solver(backend).solve(p)


@pytest.mark.parametrize("backend", BACKENDS)
def test_indefinite_with_equalities_refused(backend: str) -> None:
    """The equality path (one KKT solve, no backend) also checked: a saddle otherwise."""
    H = np.diag([1.0, -2.0, 1.0])
    p = _qp(H, [0.0, 0.0, 0.0], A=[[1.0, 0.0, 1.0]], b=[1.0])
    with pytest.raises(InvalidInputError, match=r"smallest eigenvalue is -2"):
        _solver(backend).solve(p)


@pytest.mark.parametrize("backend", BACKENDS)
def test_non_symmetric_refused(backend: str) -> None:
    p = _qp([[1.0, 5.0], [0.0, 1.0]], [1.0, 0.0], lb=[-1, -1], ub=[1, 1])
    with pytest.raises(InvalidInputError, match=r"symmetric.*\(H \+ H\.T\) / 2"):
        _solver(backend).solve(p)


@pytest.mark.parametrize("backend", [b for b in BACKENDS if b != "quadprog"])
def test_linear_program_in_a_box_solved_at_its_vertex(backend: str) -> None:
    """H = 0 is PSD (an LP): accepted, answer = the best vertex (enumerated)."""
    g = np.array([1.0, -2.0, 0.5])
    lo, hi = np.array([-1.0, -2.0, 0.0]), np.array([1.0, 3.0, 4.0])
    p = _qp(np.zeros((3, 3)), g, lb=lo, ub=hi)
    result = _solver(backend).solve(p)
    vertices = np.array(list(itertools.product(*zip(lo, hi))))
    best = vertices[np.argmin(vertices @ g)]
    assert result.status is QPStatus.SOLVED
    np.testing.assert_allclose(result.x, best, atol=1e-6)


@pytest.mark.parametrize("backend", BACKENDS)
def test_built_hessian_with_rounding_asymmetry_accepted(backend: str) -> None:
    """J^T (W J) is symmetric only to rounding and singular (rank 2 of 4): accepted."""
    rng = np.random.default_rng(5)
    J = rng.normal(size=(2, 4))
    W = np.diag([3.0, 0.7])
    H = J.T @ (W @ J) + 1e-6 * np.eye(4)
    H[0, 1] += 1e-15  # rounding-size asymmetry
    g = rng.normal(size=4)
    lb, ub = -0.1 * np.ones(4), 0.1 * np.ones(4)
    result = _solver(backend).solve(_qp(H, g, lb=lb, ub=ub))
    assert result.status in (QPStatus.SOLVED, QPStatus.UNCONSTRAINED)
    assert result.kkt.within(1e-6, 1e-6)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"C": [[1.0, 1.0]], "l": [np.inf], "u": [np.inf]}, r"QP l entries \[0\] are \+inf"),
        ({"C": [[1.0, 1.0]], "l": [-np.inf], "u": [-np.inf]}, r"QP u entries \[0\] are -inf"),
        ({"lb": [0.0, np.inf], "ub": [1.0, np.inf]}, r"QP lb entries \[1\] are \+inf"),
        ({"lb": [-np.inf, 0.0], "ub": [-np.inf, 1.0]}, r"QP ub entries \[0\] are -inf"),
    ],
)
def test_impossible_infinite_bounds_refused(backend: str, kwargs: dict, pattern: str) -> None:
    p = _qp(np.eye(2), [1.0, 1.0], **kwargs)
    with pytest.raises(InvalidInputError, match=pattern):
        _solver(backend).solve(p)


@pytest.mark.parametrize("backend", BACKENDS)
def test_gap_finite_without_warning_for_infinite_bounds(backend: str) -> None:
    """One active bound, the other rows with infinite bounds and zero multipliers."""
    p = _qp(np.eye(2), [-5.0, 0.3], lb=[-np.inf, -np.inf], ub=[1.0, np.inf])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = _solver(backend).solve(p)
    assert result.status is QPStatus.SOLVED
    np.testing.assert_allclose(result.x, [1.0, -0.3], atol=1e-7)
    assert result.kkt.duality_gap < 1e-6  # was NaN (inf * 0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_solve_relaxed_checks_too(backend: str) -> None:
    """solve_relaxed is public: its relaxation diag(H, I) is convex only if H is."""
    p = _qp(-np.eye(2), [0.0, 0.0], lb=[1, 1], ub=[0, 0])
    with pytest.raises(InvalidInputError, match=r"positive semi-definite"):
        _solver(backend).solve_relaxed(p)
