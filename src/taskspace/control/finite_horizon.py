"""Finite-horizon linear-quadratic control: Riccati differential equation and recursion.

Continuous time, cost ``x(T)^T Q_f x(T) + int_0^T x^T Q x + u^T R u dt``: the value is
``x^T P(t) x`` with the Riccati differential equation, integrated backward from ``P(T) = Q_f``,

``-P' = A^T P + P A - P B R^-1 B^T P + Q``,   ``u = -K(t) x``, ``K(t) = R^-1 B^T P(t)``.

Discrete time, cost ``x_N^T Q_f x_N + sum_{k<N} x_k^T Q x_k + u_k^T R u_k``: the backward
recursion from ``P_N = Q_f``,

``K_k = (R + B^T P_{k+1} B)^-1 B^T P_{k+1} A``,  ``P_k = Q + A^T P_{k+1} (A - B K_k)``,
``u_k = -K_k x_k``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, check_positive
from taskspace.control._linear import symmetric_psd, system
from taskspace.errors import InvalidInputError


@dataclass
class FiniteHorizonLQR:
    """Time-varying Riccati solution and gains.

    Attributes:
        times: sample times (N+1,) [s] (continuous) or stage indices (discrete).
        P: cost-to-go matrices (N+1, n, n); ``P[0]`` is the cost at the start.
        K: feedback gains ``u = -K x``: (N+1, m, n) continuous, (N, m, n) discrete.
        discrete: discrete-time problem.
    """

    times: FloatArray
    P: FloatArray
    K: FloatArray
    discrete: bool

    def cost(self, x0: Any) -> float:
        """Optimal cost ``x0^T P_0 x0`` from ``x0``."""
        x = np.asarray(x0, dtype=float)
        return float(x @ self.P[0] @ x)


def _inputs(
    A: Any, B: Any, Q: Any, R: Any, Qf: Any
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    A, B = system(A, B)
    n, m = B.shape
    return (
        A,
        B,
        symmetric_psd(Q, "Q", n, definite=False),
        symmetric_psd(R, "R", m, definite=True),
        symmetric_psd(Qf, "Qf", n, definite=False),
    )


def solve_riccati_differential(
    A: Any, B: Any, Q: Any, R: Any, Qf: Any, horizon: float, steps: int = 1000
) -> FiniteHorizonLQR:
    """Integrate ``-P' = A^T P + P A - P B R^-1 B^T P + Q`` backward from ``P(T) = Q_f``.

    Classical RK4 with ``steps`` equal steps in reversed time ``s = T - t``.

    Args:
        A, B, Q, R, Qf: the problem (see the module docstring).
        horizon: ``T`` [s] (> 0).
        steps: number of RK4 steps (>= 1).
    """
    A, B, Q, R, Qf = _inputs(A, B, Q, R, Qf)
    T = check_positive(horizon, "horizon [s]")
    if int(steps) < 1:
        raise InvalidInputError(f"steps must be >= 1, got {steps}")
    steps = int(steps)
    G = B @ np.linalg.solve(R, B.T)
    At = A.T

    def rhs(P: FloatArray) -> FloatArray:  # dP/ds, s = T - t
        return At @ P + P @ A - P @ G @ P + Q

    h = T / steps
    n = A.shape[0]
    Ps = np.empty((steps + 1, n, n))
    P = Qf.copy()
    Ps[steps] = P
    for k in range(steps, 0, -1):
        k1 = rhs(P)
        k2 = rhs(P + 0.5 * h * k1)
        k3 = rhs(P + 0.5 * h * k2)
        k4 = rhs(P + h * k3)
        P = P + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        P = 0.5 * (P + P.T)
        Ps[k - 1] = P
    K = np.linalg.solve(R, B.T @ Ps)  # R^-1 B^T P(t) for every sample
    return FiniteHorizonLQR(times=np.linspace(0.0, T, steps + 1), P=Ps, K=K, discrete=False)


def solve_riccati_recursion(A: Any, B: Any, Q: Any, R: Any, Qf: Any, N: int) -> FiniteHorizonLQR:
    """Discrete backward Riccati recursion over ``N`` stages (see the module docstring).

    Args:
        A, B, Q, R, Qf: the problem.
        N: number of stages (>= 1).
    """
    A, B, Q, R, Qf = _inputs(A, B, Q, R, Qf)
    if int(N) < 1:
        raise InvalidInputError(f"N must be >= 1, got {N}")
    N = int(N)
    n, m = B.shape
    Ps = np.empty((N + 1, n, n))
    Ks = np.empty((N, m, n))
    P = Qf.copy()
    Ps[N] = P
    for k in range(N - 1, -1, -1):
        PB = P @ B
        K = np.linalg.solve(R + B.T @ PB, PB.T @ A)
        P = Q + A.T @ P @ (A - B @ K)
        P = 0.5 * (P + P.T)
        Ps[k], Ks[k] = P, K
    return FiniteHorizonLQR(times=np.arange(N + 1, dtype=float), P=Ps, K=Ks, discrete=True)
