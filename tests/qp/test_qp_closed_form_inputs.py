"""The closed forms of taskspace.qp check their inputs (they took anything before).

Before: ``pseudo_inverse`` of a NaN or 1-D matrix raised numpy's LinAlgError ("SVD did not
converge", "1-dimensional array given"), ``damped_pseudo_inverse`` accepted a NaN damping
(a NaN matrix), ``weighted_pseudo_inverse`` an indefinite or non-symmetric metric (a wrong
answer), mismatched task lists were cut to the shortest by ``zip``, a singular system was a
bare "Singular matrix". Valid inputs: the answers against the textbook formulas in NumPy.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
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

RNG = np.random.default_rng(11)
J = RNG.normal(size=(2, 4))
W = np.diag([1.0, 2.0, 0.5, 3.0])
C = np.array([[2.0, 0.3], [0.3, 1.0]])


def test_valid_inputs_match_the_formulas() -> None:
    lam = 0.2
    np.testing.assert_allclose(
        damped_pseudo_inverse(J, lam), J.T @ np.linalg.inv(J @ J.T + lam**2 * np.eye(2)), atol=1e-12
    )
    np.testing.assert_allclose(pseudo_inverse(J), np.linalg.pinv(J), atol=1e-12)
    ref = np.linalg.inv(J.T @ C @ J + W) @ J.T @ C
    np.testing.assert_allclose(weighted_pseudo_inverse(J, W, C), ref, atol=1e-12)
    np.testing.assert_allclose(weighted_pseudo_inverse_woodbury(J, W, C), ref, atol=1e-12)
    np.testing.assert_allclose(nullspace_projector(J, ref), np.eye(4) - ref @ J, atol=1e-12)
    y, h = np.array([0.1, -0.2]), np.arange(4.0)
    np.testing.assert_allclose(ik_step(J, y, W, C, h), ref @ y + (np.eye(4) - ref @ J) @ h)
    # a list of lists works as an array
    np.testing.assert_allclose(pseudo_inverse(J.tolist()), np.linalg.pinv(J), atol=1e-12)


def test_hierarchies_valid() -> None:
    J1, J2 = np.array([[1.0, 0.0, 0.0]]), np.array([[1.0, 1.0, 0.0]])
    q = hierarchical_step_exact([J1, J2], [np.array([1.0]), np.array([3.0])])
    np.testing.assert_allclose(q, [1.0, 2.0, 0.0], atol=1e-12)
    q = hierarchical_step_regularized(
        [J1, J2], [np.array([1.0]), np.array([3.0])], [1e8, 1.0], 1e-8 * np.eye(3), np.zeros(3)
    )
    np.testing.assert_allclose(q, [1.0, 2.0, 0.0], atol=1e-6)
    dq = stacked_step([J1, J2], [np.array([-1.0]), np.array([-3.0])], [1.0, 1.0], np.eye(3))
    A = J1.T @ J1 + J2.T @ J2 + np.eye(3)
    np.testing.assert_allclose(dq, np.linalg.solve(A, J1.T @ [1.0] + J2.T @ [3.0]), atol=1e-12)


@pytest.mark.parametrize(
    ("call", "error", "pattern"),
    [
        (lambda: pseudo_inverse(np.array([[np.nan, 1.0]])), NotFiniteError, "J"),
        (lambda: pseudo_inverse(np.array([1.0, 2.0])), ShapeError, "J"),
        (lambda: pseudo_inverse(J, rcond=-1.0), InvalidInputError, "rcond"),
        (lambda: damped_pseudo_inverse(J, float("nan")), InvalidInputError, "damping"),
        (lambda: damped_pseudo_inverse(J, -0.1), InvalidInputError, "damping"),
        (lambda: damped_pseudo_inverse(np.ones((2, 3)), 0.0), InvalidInputError, "singular"),
        (
            lambda: weighted_pseudo_inverse(J, np.diag([1.0, -1, 1, 1]), C),
            InvalidInputError,
            r"W must be positive definite.*-1",
        ),
        (
            lambda: weighted_pseudo_inverse(J, W + np.triu(np.ones((4, 4)), 1), C),
            InvalidInputError,
            "W must be symmetric",
        ),
        (lambda: weighted_pseudo_inverse(J, W, np.eye(3)), ShapeError, "C"),
        (
            lambda: weighted_pseudo_inverse_woodbury(J, W, np.zeros((2, 2))),
            InvalidInputError,
            "C must be positive definite",
        ),
        (lambda: nullspace_projector(J, np.zeros((2, 4))), ShapeError, "J_sharp"),
        (lambda: ik_step(J, np.zeros(3), W, C), ShapeError, "y_error"),
        (lambda: ik_step(J, np.zeros(2), W, C, np.zeros(2)), ShapeError, "h"),
        (
            lambda: stacked_step([J, J], [np.zeros(2)], [1.0, 1.0], W),
            InvalidInputError,
            "one entry per task",
        ),
        (lambda: stacked_step([J], [np.zeros(2)], [0.0], W), InvalidInputError, "precisions"),
        (
            lambda: stacked_step([J, np.ones((1, 3))], [np.zeros(2), np.zeros(1)], [1, 1], W),
            ShapeError,
            r"jacobians\[1\]",
        ),
        (
            lambda: stacked_step([np.ones((1, 2))], [np.zeros(1)], [1.0], np.zeros((2, 2))),
            InvalidInputError,
            "singular",
        ),
        (lambda: stacked_step(J, [np.zeros(2)], [1.0], W), InvalidInputError, "sequence"),
        (lambda: hierarchical_step_exact([], []), InvalidInputError, "at least one task"),
        (
            lambda: hierarchical_step_exact([J], [np.zeros(2)], tolerance=-1),
            InvalidInputError,
            "tolerance",
        ),
        (lambda: hierarchical_step_exact([J], [np.zeros(3)]), ShapeError, r"targets\[0\]"),
        (
            lambda: hierarchical_step_regularized([J], [np.zeros(2)], [1.0], W, np.zeros(3)),
            ShapeError,
            "a",
        ),
    ],
)
def test_bad_inputs_are_named(call, error: type[Exception], pattern: str) -> None:
    with pytest.raises(error, match=pattern):
        call()
