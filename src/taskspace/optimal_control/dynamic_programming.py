"""Dynamic programming on finite MDPs: value iteration and policy iteration.

Bellman's principle of optimality gives the optimal value as the fixed point of

``V(s) = max_a [R(s, a) + gamma sum_s' P(s' | s, a) V(s')]``   (Bellman optimality equation).

* Finite horizon ``T``: ``V_T = V_terminal``, ``V_t = max_a Q_t(., a)`` backwards, with a
  time-varying policy ``pi_t(s) = argmax_a Q_t(s, a)``.
* Value iteration: apply the backup until ``|V_{k+1} - V_k|_inf <= tolerance``; for
  ``gamma < 1`` the backup contracts with rate ``gamma`` and the greedy policy's value is within
  ``2 gamma tolerance / (1 - gamma)`` of optimal.
* Policy iteration: evaluate the policy exactly, ``(I - gamma P_pi) V = R_pi`` (sparse LU),
  improve greedily, stop when the policy is stable (finitely many steps).

Thread safety: the solvers keep their state local to the call (the
:class:`~taskspace.optimal_control.MDP` is only read); :class:`ValueIterationOptions` and
:class:`DPStatus` are immutable; :class:`DPResult` and :class:`FiniteHorizonResult` are plain
result data (arrays), not locked: do not modify them while another thread reads them.
"""

from __future__ import annotations

import enum
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from taskspace._validation import FloatArray, as_float_array, check_count, check_positive
from taskspace.dynamics.simulation import memory_budget
from taskspace.errors import InvalidInputError, SolverError
from taskspace.optimal_control.mdp import MDP

MAX_TABLE_BYTES = 2 * 2**30
"""Largest value/policy table of :func:`finite_horizon_value_iteration` (2 GiB, or half the
available memory if less)."""


class DPStatus(enum.Enum):
    """Outcome of a dynamic-programming solve."""

    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"


@dataclass(frozen=True, kw_only=True)
class ValueIterationOptions:
    """Settings of :func:`value_iteration` and :func:`policy_iteration`.

    Attributes:
        tolerance: stop when ``max_s |V_{k+1}(s) - V_k(s)| <= tolerance``.
        max_iterations: iteration limit (backups, or policy improvements).
        initial_value: start ``V_0`` (S,); ``None`` is zero.
    """

    tolerance: float = 1e-10
    max_iterations: int = 100_000
    initial_value: Any = None


@dataclass
class DPResult:
    """An (approximately) optimal value function and greedy policy.

    Attributes:
        success: converged within ``max_iterations``.
        status: see :class:`DPStatus`.
        V: optimal state values (S,).
        Q: action values ``Q[s, a]`` of ``V`` (S x A).
        policy: greedy action per state (S,), ties broken towards the lowest index.
        iterations: backups (value iteration) or improvement steps (policy iteration).
        residual: Bellman residual ``max_s |max_a Q(s, a) - V(s)|`` at return.
        history: ``|V_{k+1} - V_k|_inf`` of each iteration.
        solve_time: wall time [s].
    """

    success: bool
    status: DPStatus
    V: FloatArray
    Q: FloatArray
    policy: np.ndarray
    iterations: int
    residual: float
    history: list[float] = field(default_factory=list)
    solve_time: float = 0.0


@dataclass
class FiniteHorizonResult:
    """Result of :func:`finite_horizon_value_iteration` (horizon ``T``).

    Attributes:
        V: values ``V[t, s]`` for ``t = 0..T`` ((T+1) x S), ``V[T]`` the terminal value.
        policy: ``policy[t, s]`` for ``t = 0..T-1`` (T x S).
    """

    V: FloatArray
    policy: np.ndarray


def _tolerance(options: ValueIterationOptions) -> float:
    """``options.tolerance`` finite and >= 0 (NaN ran every iteration and never converged)."""
    return check_positive(options.tolerance, "ValueIterationOptions.tolerance", strict=False)


def _initial(mdp: MDP, value: Any) -> FloatArray:
    if value is None:
        return np.zeros(mdp.num_states)
    V = as_float_array(value, "initial value").copy()
    if V.shape != (mdp.num_states,) or not np.all(np.isfinite(V)):
        raise InvalidInputError(f"initial value must be a finite vector of size {mdp.num_states}")
    return V


def greedy_policy(mdp: MDP, V: Any) -> np.ndarray:
    """``pi(s) = argmax_a [R(s, a) + gamma P_a V](s)`` (lowest index on ties)."""
    return np.asarray(np.argmax(mdp.q_values(_initial(mdp, V)), axis=1), dtype=int)


def finite_horizon_value_iteration(
    mdp: MDP, horizon: int, terminal_value: Any = None
) -> FiniteHorizonResult:
    """Backward induction over ``horizon`` steps: ``V_t = max_a [R + gamma P_a V_{t+1}]``.

    Args:
        mdp: the MDP (``gamma`` may be 1).
        horizon: number of decisions ``T`` (>= 1).
        terminal_value: ``V_T`` (S,); ``None`` is zero.
    """
    horizon = check_count(horizon, "horizon", minimum=1)  # 2.5, NaN, "3" were bare errors
    needed = 16 * (horizon + 1) * max(1, mdp.num_states)  # V (float) and policy (intp)
    budget = memory_budget(MAX_TABLE_BYTES)
    if needed > budget:
        raise InvalidInputError(
            f"horizon = {horizon:,} would store {needed / 1e9:.3g} GB of values and policies but "
            f"the budget is {budget / 1e9:.3g} GB (half the available memory, at most "
            f"{MAX_TABLE_BYTES / 2**30:g} GiB); use a shorter horizon or value_iteration"
        )
    V = np.empty((horizon + 1, mdp.num_states))
    V[horizon] = _initial(mdp, terminal_value)
    pi = np.empty((horizon, mdp.num_states), dtype=int)
    for t in range(horizon - 1, -1, -1):
        Q = mdp.q_values(V[t + 1])
        pi[t] = np.argmax(Q, axis=1)
        V[t] = Q[np.arange(mdp.num_states), pi[t]]
    return FiniteHorizonResult(V=V, policy=pi)


def value_iteration(mdp: MDP, options: ValueIterationOptions | None = None) -> DPResult:
    """Infinite-horizon value iteration ``V_{k+1} = max_a [R + gamma P_a V_k]``.

    Raises:
        InvalidInputError: bad initial value.
    """
    options = options or ValueIterationOptions()
    t0 = time.perf_counter()
    max_iterations = check_count(options.max_iterations, "max_iterations")
    tolerance = _tolerance(options)
    V = _initial(mdp, options.initial_value)
    history: list[float] = []
    status = DPStatus.MAX_ITERATIONS
    k = 0
    for k in range(1, max_iterations + 1):  # noqa: B007
        V_new = np.max(mdp.q_values(V), axis=1)
        delta = float(np.max(np.abs(V_new - V))) if V.size else 0.0
        history.append(delta)
        V = V_new
        if delta <= tolerance:
            status = DPStatus.CONVERGED
            break
    Q = mdp.q_values(V)
    return DPResult(
        success=status is DPStatus.CONVERGED,
        status=status,
        V=V,
        Q=Q,
        policy=np.argmax(Q, axis=1),
        iterations=k,
        residual=float(np.max(np.abs(np.max(Q, axis=1) - V))) if V.size else 0.0,
        history=history,
        solve_time=time.perf_counter() - t0,
    )


def evaluate_policy(mdp: MDP, policy: Any) -> FloatArray:
    """Exact value of a deterministic policy: solve ``(I - gamma P_pi) V = R_pi``.

    Raises:
        SolverError: singular system (``gamma = 1`` and the policy never reaches an absorbing
            zero-reward state).
    """
    P, r = mdp.policy_matrix(policy)
    M = sp.identity(mdp.num_states, format="csc") - mdp.gamma * P.tocsc()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", spla.MatrixRankWarning)
            V = spla.spsolve(M, r)
    except RuntimeError as exc:
        raise SolverError(f"policy evaluation failed: {exc}") from exc
    V = np.atleast_1d(np.asarray(V, dtype=float))
    if not np.all(np.isfinite(V)):
        raise SolverError(
            "policy evaluation: I - gamma P_pi is singular (gamma = 1 and the policy cycles "
            "without reaching an absorbing state); use gamma < 1"
        )
    return V


def policy_iteration(mdp: MDP, options: ValueIterationOptions | None = None) -> DPResult:
    """Howard's policy iteration: exact evaluation, greedy improvement, until stable.

    The initial policy is greedy for ``options.initial_value`` (zero by default). An action
    is only switched when it improves ``Q`` by more than ``options.tolerance`` (no cycling
    between tied actions).
    """
    options = options or ValueIterationOptions()
    t0 = time.perf_counter()
    max_iterations = check_count(options.max_iterations, "max_iterations")
    tolerance = _tolerance(options)
    pi = greedy_policy(mdp, _initial(mdp, options.initial_value))
    history: list[float] = []
    V = evaluate_policy(mdp, pi)
    status = DPStatus.MAX_ITERATIONS
    k = 0
    rows = np.arange(mdp.num_states)
    for k in range(1, max_iterations + 1):  # noqa: B007
        Q = mdp.q_values(V)
        best = np.argmax(Q, axis=1)
        improve = Q[rows, best] > Q[rows, pi] + tolerance
        if not np.any(improve):
            status = DPStatus.CONVERGED
            break
        pi = np.where(improve, best, pi)
        V_new = evaluate_policy(mdp, pi)
        history.append(float(np.max(np.abs(V_new - V))))
        V = V_new
    Q = mdp.q_values(V)
    return DPResult(
        success=status is DPStatus.CONVERGED,
        status=status,
        V=V,
        Q=Q,
        policy=pi,
        iterations=k,
        residual=float(np.max(np.abs(np.max(Q, axis=1) - V))) if V.size else 0.0,
        history=history,
        solve_time=time.perf_counter() - t0,
    )
