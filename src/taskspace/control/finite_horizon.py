"""Finite-horizon linear-quadratic control: Riccati differential equation and recursion.

Continuous time, cost ``x(T)^T Q_f x(T) + int_0^T x^T Q x + u^T R u dt``: the value is
``x^T P(t) x`` with the Riccati differential equation, integrated backward from ``P(T) = Q_f``,

``-P' = A^T P + P A - P B R^-1 B^T P + Q``,   ``u = -K(t) x``, ``K(t) = R^-1 B^T P(t)``.

Discrete time, cost ``x_N^T Q_f x_N + sum_{k<N} x_k^T Q x_k + u_k^T R u_k``: the backward
recursion from ``P_N = Q_f``,

``K_k = (R + B^T P_{k+1} B)^-1 B^T P_{k+1} A``,  ``P_k = Q + A^T P_{k+1} (A - B K_k)``,
``u_k = -K_k x_k``.

Thread safety: the solvers keep their state local to the call; a :class:`FiniteHorizonLQR` is plain
result data (arrays) whose methods only read it, so it may be shared by threads as long as nobody
modifies its arrays.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_vector, check_count, check_positive
from taskspace.control._linear import check_overflow, symmetric_psd, system
from taskspace.dynamics.simulation import memory_budget
from taskspace.errors import InvalidInputError, SolverError, TaskspaceWarning

MAX_TABLE_BYTES = 2 * 2**30
"""Largest table of cost-to-go matrices and gains allocated (2 GiB, or half the available
memory if less)."""


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
        """Optimal cost ``x0^T P_0 x0`` from ``x0`` (n,)."""
        x = as_vector(x0, self.P.shape[1], "x0")
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


def _check_table(samples: int, n: int, m: int, name: str, what: str) -> None:
    """Refuse a table of ``samples`` (n x n) and (m x n) matrices larger than the budget."""
    needed = 8 * samples * n * (n + m)
    budget = memory_budget(MAX_TABLE_BYTES)
    if needed > budget:
        raise InvalidInputError(
            f"{name} = {samples - 1:,} {what} would store {needed / 1e9:.3g} GB of matrices but "
            f"the budget is {budget / 1e9:.3g} GB (half the available memory, at most "
            f"{MAX_TABLE_BYTES / 2**30:g} GiB); use fewer {what}"
        )


def _overflowed(P: FloatArray, where: str) -> SolverError:
    return SolverError(
        f"the cost-to-go P overflowed float64 (or became NaN) at {where}: rescale the problem "
        "(state and input units), shorten the horizon, or use more steps"
    )


def _fastest_rate(A: FloatArray, G: FloatArray, Q: FloatArray, Qf: FloatArray) -> float:
    """A bound of the Riccati flow's rates [1/s].

    The Hamiltonian's largest eigenvalue modulus, or ``2 |G| |Qf|`` (the quadratic term at
    the start) when larger.
    """
    H = np.block([[A, -G], [-Q, -A.T]])
    with np.errstate(over="ignore", invalid="ignore"):
        rho = float(np.max(np.abs(np.linalg.eigvals(H))))
        quad = 2.0 * float(np.linalg.norm(G, 2) * np.linalg.norm(Qf, 2))
    return max(rho, quad) if math.isfinite(rho) and math.isfinite(quad) else math.inf


def _steps_needed(T: float, rate: float) -> str:
    """``"steps >= N"`` with ``N = ceil(T rate)``, or advice to rescale when N is absurd."""
    n = T * rate
    if not math.isfinite(n) or n > 1e9:
        return f"more steps (T * rate = {n:.3g}) or rescale the problem (units, weights)"
    return f"steps >= {math.ceil(n):,}"


def _check_semidefinite(Ps: FloatArray, h: float, rate: float, T: float) -> None:
    """Refuse a cost-to-go table that left the positive semidefinite cone.

    With Q, Q_f >= 0 and R > 0 every exact P(t) is a cost-to-go, so >= 0; RK4 steps far too
    long for the problem gave finite negative definite P (P(0) = -4.5e39 on diag(10, -3)
    with 2 steps over 1 s), returned silently.
    """
    lam = np.linalg.eigvalsh(Ps)  # ascending per sample
    scale = np.maximum(1.0, np.abs(lam).max(axis=1))
    bad = np.flatnonzero(lam[:, 0] < -1e-8 * scale)
    if bad.size:
        k = int(bad.max())  # integrated backward: the first sample that went wrong
        need = _steps_needed(T, rate)
        raise SolverError(
            f"the cost-to-go P is not positive semidefinite at t = {k * h:.6g} s (smallest "
            f"eigenvalue {lam[k, 0]:.3g}): RK4 steps of {h:.3g} s are too long for this problem "
            f"(fastest rate {rate:.3g} 1/s); use {need}"
        )


def solve_riccati_differential(
    A: Any, B: Any, Q: Any, R: Any, Qf: Any, horizon: float, steps: int = 1000
) -> FiniteHorizonLQR:
    """Integrate ``-P' = A^T P + P A - P B R^-1 B^T P + Q`` backward from ``P(T) = Q_f``.

    Classical RK4 with ``steps`` equal steps in reversed time ``s = T - t``. Its accuracy
    needs ``h = T / steps`` below ``1 / rate``, ``rate`` the largest eigenvalue modulus of the
    Hamiltonian ``[[A, -G], [-Q, -A^T]]`` (``G = B R^-1 B^T``) or ``2 |G| |Q_f|`` if larger:
    a longer step warns (``h rate = 1.26`` left P(0) 0.8% off; at ``2.5`` P became indefinite,
    which is an error).

    Args:
        A, B, Q, R, Qf: the problem (see the module docstring).
        horizon: ``T`` [s] (> 0).
        steps: number of RK4 steps (an integer >= 1).

    Raises:
        InvalidInputError: bad inputs, a non-integer ``steps``, or a table larger than the
            memory budget (:data:`MAX_TABLE_BYTES`).
        SolverError: ``P`` overflows (too large steps on a fast system, or huge weights), or
            leaves the positive semidefinite cone (steps far too long).

    Warns:
        TaskspaceWarning: ``h rate > 1`` (see above), with the number of steps needed.
    """
    A, B, Q, R, Qf = _inputs(A, B, Q, R, Qf)
    T = check_positive(horizon, "horizon [s]")
    steps = check_count(steps, "steps", minimum=1)
    n, m = B.shape
    _check_table(steps + 1, n, m, "steps", "RK4 steps")
    with np.errstate(over="ignore", invalid="ignore"):
        G = B @ np.linalg.solve(R, B.T)
    check_overflow(G, "B R^-1 B^T", "rescale the problem (state and input units)")
    At = A.T

    def rhs(P: FloatArray) -> FloatArray:  # dP/ds, s = T - t
        return At @ P + P @ A - P @ G @ P + Q

    h = T / steps
    rate = _fastest_rate(A, G, Q, Qf)
    if h * rate > 1.0:  # P came back tens of % off (or finite and negative definite)
        warnings.warn(
            f"solve_riccati_differential: RK4 steps of {h:.3g} s are long for this problem "
            f"(fastest rate {rate:.3g} 1/s: h * rate = {h * rate:.3g} > 1), P may be far off; "
            f"use {_steps_needed(T, rate)}",
            TaskspaceWarning,
            stacklevel=2,
        )
    Ps = np.empty((steps + 1, n, n))
    P = Qf.copy()
    Ps[steps] = P
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(steps, 0, -1):
            k1 = rhs(P)
            k2 = rhs(P + 0.5 * h * k1)
            k3 = rhs(P + 0.5 * h * k2)
            k4 = rhs(P + h * k3)
            P = P + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
            P = 0.5 * (P + P.T)
            if not np.isfinite(P).all():  # a NaN P made every gain NaN, silently
                raise _overflowed(P, f"t = {(k - 1) * h:.6g} s (step {steps - k + 1} of {steps})")
            Ps[k - 1] = P
    _check_semidefinite(Ps, h, rate, T)
    K = np.linalg.solve(R, B.T @ Ps)  # R^-1 B^T P(t) for every sample
    return FiniteHorizonLQR(times=np.linspace(0.0, T, steps + 1), P=Ps, K=K, discrete=False)


def solve_riccati_recursion(A: Any, B: Any, Q: Any, R: Any, Qf: Any, N: int) -> FiniteHorizonLQR:
    """Discrete backward Riccati recursion over ``N`` stages (see the module docstring).

    Args:
        A, B, Q, R, Qf: the problem.
        N: number of stages (an integer >= 1).

    Raises:
        InvalidInputError: bad inputs, a non-integer ``N``, or a table larger than the memory
            budget (:data:`MAX_TABLE_BYTES`).
        SolverError: ``P`` overflows.
    """
    A, B, Q, R, Qf = _inputs(A, B, Q, R, Qf)
    N = check_count(N, "N", minimum=1)
    n, m = B.shape
    _check_table(N + 1, n, m, "N", "stages")
    Ps = np.empty((N + 1, n, n))
    Ks = np.empty((N, m, n))
    P = Qf.copy()
    Ps[N] = P
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(N - 1, -1, -1):
            PB = P @ B
            K = np.linalg.solve(R + B.T @ PB, PB.T @ A)
            P = Q + A.T @ P @ (A - B @ K)
            P = 0.5 * (P + P.T)
            if not (np.isfinite(P).all() and np.isfinite(K).all()):
                raise _overflowed(P, f"stage {k} (of {N})")
            Ps[k], Ks[k] = P, K
    return FiniteHorizonLQR(times=np.arange(N + 1, dtype=float), P=Ps, K=Ks, discrete=True)
