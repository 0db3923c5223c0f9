"""The QP data check raises no NumPy "overflow encountered in dot" warning.

Its sums of squares overflow for entries beyond ~1.3e154: bounds of 1e200 (valid: beyond INF
they mean "no bound") warned on a solved problem, and refused data warned beside the error.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.qp import QPProblem, QPStatus
from taskspace.qp.solver import QPSolver


def _problem(H: np.ndarray, g: np.ndarray, lo: float, hi: float) -> QPProblem:
    return QPProblem(
        H,
        g,
        np.zeros((0, 2)),
        np.zeros(0),
        np.ones((1, 2)),
        np.array([lo]),
        np.array([hi]),
        np.array([-1.0, -1.0]),
        np.array([1.0, 1.0]),
    )


def test_huge_bounds_solve_without_a_warning() -> None:
    # min 1/2 |x|^2 + 5 x_0 in the unit box, -1e200 <= x_0 + x_1 <= 1e200: x = (-1, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = QPSolver().solve(_problem(np.eye(2), np.array([5.0, 0.0]), -1e200, 1e200))
    assert res.status is QPStatus.SOLVED
    np.testing.assert_allclose(res.x, [-1.0, 0.0], atol=1e-9)


def test_huge_data_is_refused_without_a_warning() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InvalidInputError, match=r"QP H rows \[0, 1\]: entries up to 1e\+200"):
            QPSolver().solve(_problem(1e200 * np.eye(2), np.array([1e201, 0.0]), -1.0, 1.0))
