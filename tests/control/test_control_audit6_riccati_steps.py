"""Riccati differential equation integrated with too few RK4 steps, new-user sweep audit6.

Before: ``solve_riccati_differential`` on ``A = diag(10, -3)`` over 1 s returned, with
``steps=2``, a finite P(0) of entries -4.5e39 (negative definite: no cost-to-go is), with
``steps=4`` a P(0) 38% off (and an indefinite P(0.5)), with ``steps=8`` 0.8% off, all
silently. Now a P that leaves the positive semidefinite cone is a SolverError naming the
number of steps needed, and a step longer than 1 / (fastest rate of the Hamiltonian) warns.
Reference: scipy solve_ivp (rtol 1e-12) on the same ODE.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from taskspace.control.finite_horizon import solve_riccati_differential
from taskspace.errors import SolverError, TaskspaceWarning

A = np.array([[10.0, 0.0], [0.0, -3.0]])
B = np.array([[1.0], [1.0]])
Q, R, QF = np.eye(2), np.eye(1), np.eye(2)


def _reference() -> np.ndarray:
    G = B @ B.T

    def rhs(_s: float, p: np.ndarray) -> np.ndarray:
        P = p.reshape(2, 2)
        return (A.T @ P + P @ A - P @ G @ P + Q).ravel()

    sol = solve_ivp(rhs, (0.0, 1.0), QF.ravel(), rtol=1e-12, atol=1e-12)
    return sol.y[:, -1].reshape(2, 2)


@pytest.mark.parametrize("steps", [2, 4])
def test_a_diverged_cost_to_go_is_an_error(steps: int) -> None:
    with pytest.raises(SolverError, match="steps >= 11"):
        solve_riccati_differential(A, B, Q, R, QF, 1.0, steps=steps)


def test_too_long_steps_warn() -> None:
    # h * rate = 1.26: P stays semidefinite but P(0) is 0.8% off
    with pytest.warns(TaskspaceWarning, match="steps >= 11"):
        res = solve_riccati_differential(A, B, Q, R, QF, 1.0, steps=8)
    assert abs(res.P[0, 0, 0] - _reference()[0, 0]) > 1e-3 * _reference()[0, 0]


def test_enough_steps_are_silent_and_right() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", TaskspaceWarning)
        res = solve_riccati_differential(A, B, Q, R, QF, 1.0, steps=200)
    np.testing.assert_allclose(res.P[0], _reference(), rtol=1e-9, atol=1e-12)
