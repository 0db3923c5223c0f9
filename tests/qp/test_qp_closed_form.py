"""Closed-form IK formulas of the notes (slides 2:26, 2:29, 2:41, 2:43, 2:58) vs references.

References are independent: SVD formulas, the normal equations of the weighted least-squares
problem, scipy.optimize, and a lexicographic solution built from scipy.linalg.null_space and
numpy.linalg.lstsq.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from taskspace.qp import (
    damped_pseudo_inverse,
    hierarchical_step_exact,
    hierarchical_step_regularized,
    ik_step,
    nullspace_projector,
    pseudo_inverse,
    stacked_step,
    weighted_pseudo_inverse,
    weighted_pseudo_inverse_woodbury,
)
from tests.qp.problems_qp import lexicographic_reference


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("shape", [(3, 7), (6, 7), (6, 12), (2, 2)])
def test_weighted_pseudo_inverse_equals_woodbury(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(shape[0] * 100 + shape[1])
    d, n = shape
    J = rng.normal(size=(d, n))
    W = _spd(rng, n)
    C = _spd(rng, d)
    np.testing.assert_allclose(
        weighted_pseudo_inverse(J, W, C),
        weighted_pseudo_inverse_woodbury(J, W, C),
        atol=1e-12,
        rtol=1e-9,
    )


def test_weighted_pseudo_inverse_normal_equations() -> None:
    # J# y minimizes |J dq - y|^2_C + |dq|^2_W (slide 2:26): gradient of the objective is zero
    rng = np.random.default_rng(1)
    J = rng.normal(size=(4, 6))
    W, C = _spd(rng, 6), _spd(rng, 4)
    y = rng.normal(size=4)
    dq = weighted_pseudo_inverse(J, W, C) @ y
    gradient = J.T @ C @ (J @ dq - y) + W @ dq
    np.testing.assert_allclose(gradient, 0.0, atol=1e-10)


@pytest.mark.parametrize("damping", [1e-3, 0.1, 1.0])
def test_damped_pseudo_inverse_vs_svd(damping: float) -> None:
    rng = np.random.default_rng(2)
    J = rng.normal(size=(3, 7))
    J[2] = J[0] + 1e-6 * J[1]  # nearly singular
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    reference = Vt.T @ np.diag(s / (s**2 + damping**2)) @ U.T
    np.testing.assert_allclose(damped_pseudo_inverse(J, damping), reference, atol=1e-10)
    # the singularity-robust inverse is bounded by 1 / (2 lambda) (slide 2:58)
    assert np.linalg.norm(damped_pseudo_inverse(J, damping), 2) <= 1 / (2 * damping) + 1e-12


def test_pseudo_inverse_vs_svd_and_formula() -> None:
    rng = np.random.default_rng(3)
    J = rng.normal(size=(4, 7))
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    np.testing.assert_allclose(pseudo_inverse(J), Vt.T @ np.diag(1 / s) @ U.T, atol=1e-12)
    # full row rank: J^T (J J^T)^-1 (slide 2:26, C -> inf, W = I)
    np.testing.assert_allclose(pseudo_inverse(J), J.T @ np.linalg.inv(J @ J.T), atol=1e-12)


def test_nullspace_projector_undamped_is_exact() -> None:
    rng = np.random.default_rng(4)
    for d, n in [(3, 7), (6, 7), (2, 3)]:
        J = rng.normal(size=(d, n))
        N = nullspace_projector(J, pseudo_inverse(J))
        np.testing.assert_allclose(J @ N, 0.0, atol=1e-12)
        np.testing.assert_allclose(N @ N, N, atol=1e-12)  # a projector
        np.testing.assert_allclose(N, N.T, atol=1e-12)  # orthogonal
        assert np.isclose(np.trace(N), n - d)  # onto the (n - d)-dim nullspace
        # rank-deficient Jacobian: still exact
        Jr = np.vstack([J, J[:1] + J[-1:]])
        Nr = nullspace_projector(Jr, pseudo_inverse(Jr))
        np.testing.assert_allclose(Jr @ Nr, 0.0, atol=1e-11)


def test_nullspace_projector_damped_leaks_by_known_amount() -> None:
    # J (I - J^T (J J^T + l^2)^-1 J) = l^2 (J J^T + l^2)^-1 J  (analytic)
    rng = np.random.default_rng(5)
    J = rng.normal(size=(3, 7))
    lam = 0.05
    N = nullspace_projector(J, damped_pseudo_inverse(J, lam))
    expected = lam**2 * np.linalg.solve(J @ J.T + lam**2 * np.eye(3), J)
    np.testing.assert_allclose(J @ N, expected, atol=1e-12)
    assert np.abs(J @ N).max() > 1e-5  # not zero: damping leaks into the task


def test_ik_step_with_nullspace_motion_minimizes_slide_2_29() -> None:
    # dq = J# e + (I - J# J) h minimizes |J dq - e|^2_C + |dq - h|^2_W
    rng = np.random.default_rng(6)
    J = rng.normal(size=(3, 7))
    W, C = _spd(rng, 7), _spd(rng, 3)
    e, h = rng.normal(size=3), rng.normal(size=7)
    Lc, Lw = np.linalg.cholesky(C), np.linalg.cholesky(W)
    A = np.vstack([Lc.T @ J, Lw.T])
    b = np.concatenate([Lc.T @ e, Lw.T @ h])
    reference, *_ = np.linalg.lstsq(A, b, rcond=None)
    np.testing.assert_allclose(ik_step(J, e, W, C, h), reference, atol=1e-10)
    reference0, *_ = np.linalg.lstsq(A, np.concatenate([Lc.T @ e, np.zeros(7)]), rcond=None)
    np.testing.assert_allclose(ik_step(J, e, W, C), reference0, atol=1e-10)


def test_stacked_step_equals_scipy_minimizer() -> None:
    # slide 2:41: dq = argmin |dq|^2_W + sum_i rho_i |phi_i + J_i dq|^2
    rng = np.random.default_rng(7)
    n = 7
    jacobians = [rng.normal(size=(3, n)), rng.normal(size=(3, n)), rng.normal(size=(2, n))]
    errors = [rng.normal(size=3), rng.normal(size=3), rng.normal(size=2)]
    precisions = [10.0, 1.0, 0.1]
    W = 0.01 * _spd(rng, n)

    def f(dq: np.ndarray) -> tuple[float, np.ndarray]:
        val = dq @ W @ dq
        grad = 2 * W @ dq
        for J, e, rho in zip(jacobians, errors, precisions):
            r = e + J @ dq
            val += rho * r @ r
            grad += 2 * rho * J.T @ r
        return float(val), grad

    opt = minimize(f, np.zeros(n), jac=True, method="BFGS", options={"gtol": 1e-11})
    dq = stacked_step(jacobians, errors, precisions, W)
    np.testing.assert_allclose(dq, opt.x, atol=1e-6)
    assert f(dq)[0] <= opt.fun + 1e-10


@pytest.mark.parametrize("levels", [2, 3, 4])
def test_hierarchical_step_regularized_equals_weighted_least_squares(levels: int) -> None:
    # slide 2:43 is a rewrite of min |q - a|^2_W + sum rho_i |J_i q - y_i|^2 (normal equations)
    rng = np.random.default_rng(8 + levels)
    n = 9
    dims = [3, 2, 4, 3][:levels]
    jacobians = [rng.normal(size=(d, n)) for d in dims]
    targets = [rng.normal(size=d) for d in dims]
    precisions = [1e3, 1e2, 10.0, 1.0][:levels]
    W = _spd(rng, n) / n
    a = rng.normal(size=n)
    lhs = W + sum(r * J.T @ J for J, r in zip(jacobians, precisions))
    rhs = W @ a + sum(r * J.T @ y for J, y, r in zip(jacobians, targets, precisions))
    reference = np.linalg.solve(lhs, rhs)
    q = hierarchical_step_regularized(jacobians, targets, precisions, W, a)
    np.testing.assert_allclose(q, reference, atol=1e-10, rtol=0)


@pytest.mark.parametrize("seed", range(5))
def test_hierarchical_step_exact_equals_lexicographic_reference(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(6, 15))
    K = int(rng.integers(2, 5))
    dims = [int(rng.integers(1, n // 2 + 2)) for _ in range(K)]
    jacobians = [rng.normal(size=(d, n)) for d in dims]
    if seed % 2:  # a rank-deficient level (repeated row of a higher level)
        jacobians[-1][0] = jacobians[0][0]
    targets = [rng.normal(size=d) for d in dims]
    q = hierarchical_step_exact(jacobians, targets)
    reference = lexicographic_reference(jacobians, targets)
    np.testing.assert_allclose(q, reference, atol=1e-8)


def test_hierarchical_step_exact_small_hand_example() -> None:
    # level 1: x0 = 1; level 2: x0 + x1 = 5 and x0 = 3 (conflicts with level 1); level 3: x2 = 7
    J1, y1 = np.array([[1.0, 0, 0]]), np.array([1.0])
    J2, y2 = np.array([[1.0, 1, 0], [1.0, 0, 0]]), np.array([5.0, 3.0])
    J3, y3 = np.array([[0.0, 0, 1]]), np.array([7.0])
    q = hierarchical_step_exact([J1, J2, J3], [y1, y2, y3])
    np.testing.assert_allclose(q, [1.0, 4.0, 7.0], atol=1e-12)


def test_regularized_hierarchy_approaches_exact_as_precisions_separate() -> None:
    rng = np.random.default_rng(11)
    n = 10
    dims = [4, 4, 4]  # conflicting: 12 rows for 10 variables
    jacobians = [rng.normal(size=(d, n)) for d in dims]
    targets = [rng.normal(size=d) for d in dims]
    exact = lexicographic_reference(jacobians, targets)
    W = np.eye(n)
    errors = []
    for ratio in [1e2, 1e3, 1e4]:
        precisions = [ratio**3, ratio**2, ratio]
        q = hierarchical_step_regularized(jacobians, targets, precisions, W, np.zeros(n))
        errors.append(float(np.linalg.norm(q - exact)))
    # first order in 1 / ratio: each factor 10 in the ratios divides the error by ~10
    assert errors[0] > 5 * errors[1] > 25 * errors[2]
    assert errors[2] < 2e-3
