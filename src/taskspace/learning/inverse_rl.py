"""Apprenticeship learning via inverse reinforcement learning (Abbeel and Ng 2004).

The unknown reward is linear in state features, ``R(s) = w^T phi(s)`` with ``|w|_2 <= 1``; a
policy's discounted feature expectations are ``mu(pi) = d0^T (I - gamma P_pi)^-1 Phi`` so its
value is ``w^T mu(pi)``. Matching the expert's ``mu_E`` therefore matches its value for every
such reward: ``|w^T mu_E - w^T mu| <= |mu_E - mu|``.

Projection algorithm: keep ``mu_bar`` (the projection of ``mu_E`` on the convex hull of the
policies found so far); set ``w = mu_E - mu_bar`` (the max-margin direction), compute an optimal
policy for ``R = Phi w`` by value iteration, add its ``mu``, project again; stop when
``t = |mu_E - mu_bar| <= tolerance`` (or when one policy alone matches ``mu_E`` within it).
A mixture of the policies found attains ``mu_bar``.

Thread safety: the functions keep their state local to the call and may run from several
threads; :class:`ApprenticeshipResult` is plain result data, not locked.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    check_count,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError
from taskspace.optimal_control.dynamic_programming import evaluate_policy, value_iteration
from taskspace.optimal_control.mdp import MDP, make_mdp


def feature_expectations(mdp: MDP, policy: Any, features: Any, start: Any) -> FloatArray:
    """``mu = d0^T (I - gamma P_pi)^-1 Phi`` (k,) of a deterministic policy.

    Args:
        mdp: the MDP (its rewards are ignored).
        policy: action per state (S,).
        features: ``Phi`` (S x k).
        start: initial state distribution ``d0`` (S,).
    """
    Phi = as_float_array(features, "features")
    d0 = as_float_array(start, "start")
    S = mdp.num_states
    if Phi.ndim != 2 or Phi.shape[0] != S or Phi.shape[1] < 1 or d0.shape != (S,):
        raise InvalidInputError(
            f"features must be ({S} x k) with k >= 1 and start ({S},), got {Phi.shape} and "
            f"{d0.shape}"
        )
    check_finite(Phi, "features")
    # a NaN start gave NaN expectations, an unnormalized one scaled them
    if not (np.all(np.isfinite(d0)) and d0.min() >= 0 and abs(d0.sum() - 1.0) <= 1e-9):
        raise InvalidInputError(
            f"start must be a probability distribution over the {S} states (finite, >= 0, "
            f"summing to 1), got {d0[:10].tolist()}"
        )
    cols = [evaluate_policy(_with_rewards(mdp, Phi[:, j]), policy) for j in range(Phi.shape[1])]
    return np.asarray(d0 @ np.stack(cols, axis=1), dtype=float)


def _with_rewards(mdp: MDP, r: FloatArray) -> MDP:
    return make_mdp(mdp.transitions, r, mdp.gamma)


@dataclass
class ApprenticeshipResult:
    """Result of :func:`apprenticeship_learning`.

    Attributes:
        success: ``margin <= tolerance``.
        weights: the last reward direction ``w = mu_E - mu_bar`` (normalized; zero if exact).
        margin: ``t = |mu_E - mu_bar|``.
        policies: the policies found (each (S,)).
        feature_expectations: their ``mu`` (one per policy).
        mixture_point: ``mu_bar``.
        margins: ``t`` per iteration.
    """

    success: bool
    weights: FloatArray
    margin: float
    policies: list[np.ndarray] = field(default_factory=list)
    feature_expectations: list[FloatArray] = field(default_factory=list)
    mixture_point: FloatArray = field(default_factory=lambda: np.zeros(0))
    margins: list[float] = field(default_factory=list)


def apprenticeship_learning(
    mdp: MDP,
    features: Any,
    expert_feature_expectations: Any,
    start: Any,
    *,
    tolerance: float = 1e-3,
    max_iterations: int = 50,
) -> ApprenticeshipResult:
    """Projection algorithm of apprenticeship learning (see the module docstring).

    Args:
        mdp: transitions and discount (rewards ignored).
        features: ``Phi`` (S x k).
        expert_feature_expectations: ``mu_E`` (k,), e.g. from demonstrations.
        start: initial state distribution (S,).
        tolerance: stop when ``|mu_E - mu_bar| <= tolerance`` (finite, >= 0).
        max_iterations: iteration limit (an integer >= 1: ``inf``, NaN, floats, booleans,
            text and values below 1 are refused). Each iteration runs value iteration with
            its own cap; Ctrl-C stops the run and leaves nothing behind.
    """
    cap = check_count(max_iterations, "max_iterations", minimum=1)
    tol = check_positive(tolerance, "tolerance", strict=False)
    Phi = as_float_array(features, "features")
    muE = as_float_array(expert_feature_expectations, "expert_feature_expectations")
    if Phi.ndim != 2:
        raise InvalidInputError(f"features must be ({mdp.num_states} x k), got {Phi.shape}")
    if muE.shape != (Phi.shape[1],):
        raise InvalidInputError(f"expert feature expectations must have {Phi.shape[1]} entries")
    check_finite(Phi, "features")
    check_finite(muE, "expert_feature_expectations")
    policy = np.zeros(mdp.num_states, dtype=int)
    mu = feature_expectations(mdp, policy, Phi, start)
    res = ApprenticeshipResult(success=False, weights=np.zeros_like(muE), margin=np.inf)
    res.policies.append(policy)
    res.feature_expectations.append(mu)
    mu_bar = mu.copy()
    for _ in range(cap):
        w = muE - mu_bar
        t = float(np.linalg.norm(w))
        res.margins.append(t)
        res.margin = t
        res.weights = w / t if t > 0 else w
        if t <= tol:
            res.success = True
            break
        policy = value_iteration(_with_rewards(mdp, Phi @ res.weights)).policy
        mu = feature_expectations(mdp, policy, Phi, start)
        res.policies.append(policy)
        res.feature_expectations.append(mu)
        if np.linalg.norm(muE - mu) <= tol:
            # A single policy matches the expert: the mixture is that policy alone.
            mu_bar = mu
            res.margin = float(np.linalg.norm(muE - mu))
            res.margins.append(res.margin)
            res.success = True
            break
        d = mu - mu_bar
        dd = float(d @ d)
        if dd <= 1e-300:
            break  # no new policy direction: mu_E is outside the reachable set
        mu_bar = mu_bar + float(d @ (muE - mu_bar)) / dd * d
    res.mixture_point = mu_bar
    return res
