"""Maximum (causal) entropy inverse reinforcement learning (Ziebart et al. 2008, 2010).

The expert is modelled as soft-optimal for an unknown reward that is linear in state features,
``r(s) = w^T phi(s)``: over a horizon of ``T`` decisions it picks actions with the stochastic
policy of the soft Bellman equation

``Q_t(s, a) = sum_s' P_a(s, s') [w^T phi(s') + V_{t+1}(s')]``,
``V_t(s) = log sum_a exp Q_t(s, a)``,   ``V_T = 0``,   ``pi_t(a | s) = exp(Q_t(s, a) - V_t(s))``.

With deterministic transitions this is the maximum-entropy distribution over action sequences,
``P(a_0..a_{T-1} | s_0) = exp(w^T f(tau) - V_0(s_0))`` with the feature counts
``f(tau) = sum_{t=1..T} phi(s_t)``. The weights maximize the likelihood of the demonstrations,
equivalently minimize the convex dual

``L(w) = sum_s d0(s) V_0(s) - w^T mu_E``,   ``grad L = mu(w) - mu_E``,

where ``mu(w)`` are the expected feature counts of the soft-optimal policy (forward pass of the
state visitation frequencies) and ``mu_E`` the expert's. At the optimum the learned policy
matches the expert's feature counts. The weights are recovered up to the expert's temperature:
an expert that is soft-optimal for ``beta w`` gives ``beta w``.

Thread safety: the functions keep their state local to the call and may run from several
threads; options and statuses are immutable, :class:`SoftPolicy` and :class:`MaxEntIRLResult`
are plain result data, not locked.
"""

from __future__ import annotations

import enum
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.optimize
import scipy.special

from taskspace._validation import FloatArray, as_float_array, check_count, check_positive
from taskspace.errors import InvalidInputError
from taskspace.optimal_control.mdp import MDP

NEWTON_POLISH_STEPS = 5
"""Newton steps on the dual's gradient after L-BFGS (see :func:`max_entropy_irl`)."""


class MaxEntIRLStatus(enum.Enum):
    """Outcome of :func:`max_entropy_irl`."""

    CONVERGED = "converged"
    MAX_ITERATIONS = "max_iterations"
    FAILED = "failed"


@dataclass(frozen=True, kw_only=True)
class MaxEntIRLOptions:
    """Settings of :func:`max_entropy_irl`.

    Attributes:
        tolerance: stop when the gradient ``|mu(w) - mu_E + l2 w|_inf <= tolerance`` (the
            feature-count mismatch without ridge).
        max_iterations: L-BFGS iterations.
        l2: ridge weight ``lambda`` of ``lambda/2 |w|^2`` added to ``L`` (0: none); needed when
            a feature combination is constant along every trajectory (then ``w`` is not
            identifiable in that direction).
        initial_weights: start ``w`` (k,); ``None`` is zero.
    """

    tolerance: float = 1e-8
    max_iterations: int = 500
    l2: float = 0.0
    initial_weights: Any = None


@dataclass
class SoftPolicy:
    """Finite-horizon soft-optimal policy of :func:`soft_value_iteration`.

    Attributes:
        V: soft values ``V[t, s]`` for ``t = 0..T`` ((T+1) x S), ``V[T] = 0``.
        policy: ``policy[t, s, a] = pi_t(a | s)`` (T x S x A).
    """

    V: FloatArray
    policy: FloatArray


@dataclass
class MaxEntIRLResult:
    """Result of :func:`max_entropy_irl`.

    Attributes:
        success: converged to the tolerance.
        status: see :class:`MaxEntIRLStatus`.
        weights: learned reward weights ``w`` (k,).
        feature_counts: expected feature counts ``mu(w)`` of the learned soft policy (k,).
        mismatch: ``|mu(w) - mu_E + l2 w|_inf`` (the gradient of the dual).
        dual: ``L(w)`` at return (the mean negative log-likelihood of the demonstrations for
            deterministic transitions).
        policy: the soft-optimal policy of the learned reward.
        iterations: L-BFGS iterations.
        message: the optimizer's message.
        solve_time: wall time [s].
        history: ``L(w)`` at every evaluation.
    """

    success: bool
    status: MaxEntIRLStatus
    weights: FloatArray
    feature_counts: FloatArray
    mismatch: float
    dual: float
    policy: SoftPolicy
    iterations: int
    message: str = ""
    solve_time: float = 0.0
    history: list[float] = field(default_factory=list)


MAX_POLICY_ENTRIES = 10**8
"""Cap on ``horizon x states x actions`` of a soft policy (0.8 GB)."""


def _check(mdp: MDP, features: Any, start: Any, horizon: int) -> tuple[FloatArray, FloatArray]:
    if not isinstance(mdp, MDP):
        raise InvalidInputError(
            f"mdp must be a taskspace.optimal_control.MDP, got {type(mdp).__name__}"
        )
    if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 1:
        raise InvalidInputError(f"horizon must be an integer >= 1, got {horizon!r}")
    S = mdp.num_states
    if horizon * S * mdp.num_actions > MAX_POLICY_ENTRIES:
        # horizon=10**9 was a bare MemoryError (44.7 GiB for the values alone)
        raise InvalidInputError(
            f"horizon x states x actions = {horizon} x {S} x {mdp.num_actions} exceeds "
            f"{MAX_POLICY_ENTRIES:.0e} (the time-varying policy is stored): use a shorter horizon"
        )
    Phi = np.asarray(features, dtype=float)
    if Phi.ndim != 2 or Phi.shape[0] != S or not np.all(np.isfinite(Phi)):
        raise InvalidInputError(f"features must be a finite ({S} x k) array, got {Phi.shape}")
    d0 = np.asarray(start, dtype=float)
    if d0.shape != (S,) or not np.all(np.isfinite(d0)) or d0.min() < 0 or abs(d0.sum() - 1) > 1e-9:
        raise InvalidInputError(f"start must be a probability distribution over the {S} states")
    return Phi, d0


def soft_value_iteration(mdp: MDP, state_rewards: Any, horizon: int) -> SoftPolicy:
    """Backward soft Bellman recursion over ``horizon`` decisions (see the module docstring).

    Args:
        mdp: transitions (its rewards and discount are not used).
        state_rewards: ``r(s')`` (S,) received on entering ``s'``.
        horizon: number of decisions ``T`` (>= 1).
    """
    S = mdp.num_states
    r = as_float_array(state_rewards, "state rewards")  # complex was cut to its real part
    if r.shape != (S,) or not np.all(np.isfinite(r)):
        raise InvalidInputError(f"state rewards must be a finite vector of size {S}")
    _check(mdp, np.zeros((S, 1)), np.full(S, 1.0 / S), horizon)
    V = np.zeros((horizon + 1, S))
    pi = np.empty((horizon, S, mdp.num_actions))
    for t in range(horizon - 1, -1, -1):
        nxt = r + V[t + 1]
        Q = np.stack([P @ nxt for P in mdp.transitions], axis=1)
        V[t] = scipy.special.logsumexp(Q, axis=1)
        pi[t] = np.exp(Q - V[t][:, None])
    if not np.all(np.isfinite(V[0])):
        # rewards near 1e308 summed over the horizon gave inf values and a NaN policy
        raise InvalidInputError(
            f"the soft values overflowed over {horizon} steps (largest |reward| "
            f"{float(np.max(np.abs(r))):.3g}): scale the rewards down"
        )
    return SoftPolicy(V=V, policy=pi)


def expected_feature_counts(mdp: MDP, policy: SoftPolicy, features: Any, start: Any) -> FloatArray:
    """``mu = sum_{t=1..T} D_t^T Phi`` with the state distributions ``D_t`` of the policy.

    Forward pass ``D_{t+1} = sum_a (D_t * pi_t(a | .)) P_a``, ``D_0 = d0``.
    """
    if not isinstance(policy, SoftPolicy):
        raise InvalidInputError(
            f"policy must be a SoftPolicy (from soft_value_iteration), got {type(policy).__name__}"
        )
    pi = np.asarray(policy.policy)
    shape = (mdp.num_states, mdp.num_actions)
    if pi.ndim != 3 or pi.shape[1:] != shape or pi.shape[0] < 1:
        # a policy of a 3-action MDP on a 2-action one dropped the third action's probability
        raise InvalidInputError(
            f"policy.policy must be T x {shape[0]} x {shape[1]} (horizon x states x actions of "
            f"this MDP), got shape {pi.shape}: was the policy computed for another MDP?"
        )
    if not (np.all(np.isfinite(pi)) and np.allclose(pi.sum(axis=2), 1.0, atol=1e-9)):
        raise InvalidInputError(
            "policy.policy must hold finite action probabilities summing to 1 in every state"
        )
    T = pi.shape[0]
    Phi, D = _check(mdp, features, start, T)
    mu = np.zeros(Phi.shape[1])
    for t in range(T):
        D = sum(
            (P.T @ (D * pi[t, :, a]) for a, P in enumerate(mdp.transitions)),
            np.zeros(mdp.num_states),
        )
        mu += D @ Phi
    return mu


def demonstration_feature_counts(demonstrations: Sequence[Any], features: Any) -> FloatArray:
    """Mean feature counts ``(1/N) sum_i sum_{t=1..T} phi(s_t^i)`` of state sequences.

    Args:
        demonstrations: state index sequences ``[s_0, s_1, ..., s_T]`` (the start state's
            features are not counted, as in :func:`expected_feature_counts`).
        features: ``Phi`` (S x k).
    """
    Phi = as_float_array(features, "features")
    if Phi.ndim != 2 or not np.all(np.isfinite(Phi)):  # NaN features gave NaN counts
        raise InvalidInputError(f"features must be a finite (S x k) array, got shape {Phi.shape}")
    if len(demonstrations) == 0:
        raise InvalidInputError("need at least one demonstration")
    total = np.zeros(Phi.shape[1])
    for i, demo in enumerate(demonstrations):
        s = np.asarray(demo)
        if s.ndim != 1 or s.size < 2 or not np.issubdtype(s.dtype, np.integer):
            raise InvalidInputError(
                f"demonstration {i} must be a sequence of >= 2 integer state indices"
            )
        if s.min() < 0 or s.max() >= Phi.shape[0]:
            raise InvalidInputError(f"demonstration {i} has states outside [0, {Phi.shape[0]})")
        total += Phi[s[1:]].sum(axis=0)
    return total / len(demonstrations)


def max_entropy_irl(
    mdp: MDP,
    features: Any,
    expert_feature_counts: Any,
    start: Any,
    horizon: int,
    options: MaxEntIRLOptions | None = None,
) -> MaxEntIRLResult:
    """Reward weights whose soft-optimal policy matches the expert's feature counts.

    Minimizes the convex dual ``L(w) (+ l2/2 |w|^2)`` with L-BFGS and its exact gradient
    ``mu(w) - mu_E (+ l2 w)`` (see the module docstring).

    Args:
        mdp: transitions (rewards and discount not used).
        features: ``Phi`` (S x k).
        expert_feature_counts: ``mu_E`` (k,), e.g. from
            :func:`demonstration_feature_counts`.
        start: initial state distribution ``d0`` (S,) (the demonstrations' start states).
        horizon: number of decisions ``T`` of a demonstration.
        options: see :class:`MaxEntIRLOptions`.

    Raises:
        InvalidInputError: shapes, a start that is not a distribution, bad options.
    """
    options = options or MaxEntIRLOptions()
    t0 = time.perf_counter()
    Phi, d0 = _check(mdp, features, start, horizon)
    k = Phi.shape[1]
    muE = np.asarray(expert_feature_counts, dtype=float)
    if muE.shape != (k,) or not np.all(np.isfinite(muE)):
        raise InvalidInputError(f"expert feature counts must be a finite vector of {k} entries")
    check_positive(options.tolerance, "tolerance")
    check_positive(options.l2, "l2", strict=False)
    max_iterations = check_count(options.max_iterations, "max_iterations", minimum=1)
    w0 = np.zeros(k) if options.initial_weights is None else options.initial_weights
    w0 = np.asarray(w0, dtype=float)
    if w0.shape != (k,) or not np.all(np.isfinite(w0)):
        raise InvalidInputError(f"initial_weights must be a finite vector of {k} entries")
    history: list[float] = []

    def dual(w: FloatArray) -> tuple[float, FloatArray]:
        soft = soft_value_iteration(mdp, Phi @ w, horizon)
        mu = expected_feature_counts(mdp, soft, Phi, d0)
        value = float(d0 @ soft.V[0] - w @ muE + 0.5 * options.l2 * (w @ w))
        history.append(value)
        return value, mu - muE + options.l2 * w

    opt = scipy.optimize.minimize(
        dual,
        w0,
        jac=True,
        method="L-BFGS-B",
        options={"maxiter": max_iterations, "gtol": options.tolerance, "ftol": 0.0},
    )
    w = np.asarray(opt.x, dtype=float)

    def gradient(w: FloatArray) -> FloatArray:
        soft = soft_value_iteration(mdp, Phi @ w, horizon)
        return expected_feature_counts(mdp, soft, Phi, d0) - muE + options.l2 * w

    # L-BFGS stops once the dual stops decreasing in floating point, which can leave the
    # gradient (the feature-count mismatch) above a tight tolerance; Newton steps on the
    # gradient, with its Jacobian (the feature covariance) by central differences, finish it.
    g = gradient(w)
    for _ in range(NEWTON_POLISH_STEPS):
        if float(np.max(np.abs(g))) <= options.tolerance:
            break
        h = 1e-5 * max(1.0, float(np.max(np.abs(w))))
        J = np.column_stack(
            [(gradient(w + h * e) - gradient(w - h * e)) / (2 * h) for e in np.eye(k)]
        )
        try:
            step = np.linalg.lstsq(0.5 * (J + J.T), -g, rcond=1e-10)[0]
        except np.linalg.LinAlgError:
            break
        g_new = gradient(w + step)
        if not np.max(np.abs(g_new)) < np.max(np.abs(g)):
            break
        w, g = w + step, g_new
    soft = soft_value_iteration(mdp, Phi @ w, horizon)
    mu = expected_feature_counts(mdp, soft, Phi, d0)
    mismatch = float(np.max(np.abs(mu - muE + options.l2 * w)))
    if mismatch <= options.tolerance:
        status = MaxEntIRLStatus.CONVERGED
    elif opt.nit >= max_iterations:
        status = MaxEntIRLStatus.MAX_ITERATIONS
    else:
        status = MaxEntIRLStatus.FAILED
    return MaxEntIRLResult(
        success=status is MaxEntIRLStatus.CONVERGED,
        status=status,
        weights=w,
        feature_counts=mu,
        mismatch=mismatch,
        dual=float(d0 @ soft.V[0] - w @ muE + 0.5 * options.l2 * (w @ w)),
        policy=soft,
        iterations=int(opt.nit),
        message=str(opt.message),
        solve_time=time.perf_counter() - t0,
        history=history,
    )
