"""Policy search: policy gradients (REINFORCE, eNAC), PoWER, PI^2, (mu, lambda)-ES, CMA-ES.

All methods maximize the expected return ``J(theta) = E[R]`` of a :data:`Rollout` (a pure
function of the parameters and a seed), evaluating each population with
:func:`taskspace.learning.rollout.evaluate_population`.

Action exploration (likelihood ratio), from episodes with ``g_i = sum_t grad log pi``:

* REINFORCE with the optimal baseline: ``grad J ~ <g_i (R_i - b)>``,
  ``b_h = <g_ih^2 R_i> / <g_ih^2>`` per component (Peters and Schaal 2008).
* Episodic natural actor-critic (eNAC): regress ``R_i ~ g_i^T w + J`` by least squares; ``w``
  is the natural gradient ``F^-1 grad J`` (``F`` the Fisher information of the trajectory
  distribution); update ``theta += alpha w``.

Parameter exploration, ``theta_i = theta + eps_i``, ``eps_i ~ N(0, sigma^2 I)``:

* PoWER (Kober and Peters 2009, episodic form):
  ``theta_{k+1} = theta_k + sum_i w(tau_i) eps_i / sum_i w(tau_i)``, ``eps_i = theta_i -
  theta_k``, importance sampling over the ``elite`` best rollouts of ALL iterations so far
  (kept in memory), with the positive, sharply peaked reward transformation
  ``w = exp(-beta S)``, cost ``S = -R``, ``beta = h / (max S - min S)`` over that set
  (``h`` = ``temperature``). A linear reward ``R - min R`` (used before) weighs the elite
  almost uniformly: on the DMP via-point task the mean then moved too little per update and
  the decaying exploration ran out before the via point (0 of 5 seeds within 2 cm).
* PI^2 (Theodorou, Buchli and Schaal 2010), two forms:

  - episodic: ``theta += sum_k P_k eps_k``, ``P_k ∝ exp(-h (S_k - min S) / (max S - min S))``
    with the cost ``S = -R`` (one cost per rollout);
  - per time step (the paper's Table 2), when ``activations`` (N x p: the basis activation
    ``w_{j,t_i}`` of parameter j at step i, e.g. :meth:`ViaPointTask.activations`) are given
    and each episode's ``rewards`` has N entries (cost ``r = -reward``, terminal cost in the
    last step): cost-to-go ``S(tau_{i,k}) = sum_{j >= i} r_{j,k}``; probabilities per step
    ``P(tau_{i,k}) ∝ exp(-h (S_{i,k} - min_k S_{i,k}) / (max_k S_{i,k} - min_k S_{i,k}))``;
    update per step ``dtheta_{t_i} = sum_k P(tau_{i,k}) eps_k``; time average
    ``[dtheta]_j = sum_i (N - i) w_{j,t_i} [dtheta_{t_i}]_j / sum_i (N - i) w_{j,t_i}``
    (i = 0 .. N-1); ``theta += dtheta``. The exploration ``eps_k`` is constant over a rollout
    (parameter exploration). The paper's projection ``M_{t_i} eps = g g^T eps / (g^T g)``
    of the noise onto the basis ``g`` at ``t_i`` is optional (``projection_blocks``); without
    it the activation weighting alone carries the time locality. See :func:`pi2_update`.
* (mu, lambda)-ES: keep the ``mu`` best of ``lambda`` offspring, new mean = their average.
* CMA-ES: ``cma.CMAEvolutionStrategy`` (pycma, Hansen's reference implementation).

Thread safety: each search keeps its state (parameters, generator, history) local to the call,
so searches may run in several threads at once; the user's rollout function is called as
described in :mod:`taskspace.learning.rollout` (on the ``executor`` given, possibly from
several threads). Options and statuses are immutable and :class:`PolicySearchResult` is plain
result data.
"""

from __future__ import annotations

import enum
import time
from collections.abc import Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    check_count,
    check_positive,
    check_seed,
)
from taskspace.batch import Executor as BatchExecutor
from taskspace.errors import InvalidInputError, SolverError
from taskspace.learning.rollout import Episode, Rollout, evaluate_population

MAX_POPULATION_ENTRIES = 10**8
"""Cap on ``population x parameters`` (the noise of one update, 0.8 GB): above it
:class:`PolicySearchOptions` is refused instead of failing in a bare ``MemoryError``."""


class PolicySearchStatus(enum.Enum):
    """Outcome of a policy search."""

    TARGET_REACHED = "target_reached"
    MAX_ITERATIONS = "max_iterations"
    MAX_ROLLOUTS = "max_rollouts"


@dataclass(frozen=True, kw_only=True)
class PolicySearchOptions:
    """Settings shared by the policy-search methods.

    Attributes:
        iterations: maximum number of updates (an integer >= 1).
        population: rollouts per update (``lambda`` of the evolution strategies; >= 1).
        elite: rollouts kept by PoWER and the (mu, lambda)-ES (``mu``; 1 to population).
        learning_rate: step size of REINFORCE and eNAC.
        exploration: initial parameter noise std ``sigma`` (PoWER, PI^2, ES, CMA-ES).
        exploration_decay: ``sigma`` is multiplied by this after each update (PoWER, PI^2, ES).
        temperature: ``h`` of PI^2 and of PoWER's reward transformation.
        target_return: stop when the mean return of the current parameters reaches it
            (a finite number or ``None``).
        max_rollouts: stop after this many rollouts (an integer >= 1, ``None``: no limit
            besides ``iterations``).
        seed: base seed; rollout seeds are drawn from it.
    """

    iterations: int = 100
    population: int = 20
    elite: int = 5
    learning_rate: float = 0.1
    exploration: float = 0.5
    exploration_decay: float = 0.98
    temperature: float = 10.0
    target_return: float | None = None
    max_rollouts: int | None = None
    seed: int = 0


@dataclass
class PolicySearchResult:
    """Result of a policy search.

    Attributes:
        success: the target return was reached (or no target was set and the search ended).
        status: see :class:`PolicySearchStatus`.
        parameters: final parameters (mean of the search distribution).
        best_parameters: parameters of the best rollout seen.
        best_return: its return.
        mean_returns: mean return of each population (one per iteration).
        rollouts: total number of rollouts.
        environment_steps: total number of environment steps.
        solve_time: wall time [s].
    """

    success: bool
    status: PolicySearchStatus
    parameters: FloatArray
    best_parameters: FloatArray
    best_return: float
    mean_returns: list[float] = field(default_factory=list)
    rollouts: int = 0
    environment_steps: int = 0
    solve_time: float = 0.0


def _arrays(episodes: Sequence[Episode]) -> tuple[FloatArray, FloatArray]:
    if not episodes:
        raise InvalidInputError("need at least one episode")
    grads = [np.asarray(e.log_likelihood_gradient, dtype=float).ravel() for e in episodes]
    sizes = sorted({g.size for g in grads})
    if len(sizes) > 1:
        raise InvalidInputError(
            f"every episode's log_likelihood_gradient needs one entry per parameter; got sizes "
            f"{sizes}"
        )
    G = np.stack(grads)
    R = np.array([e.total_return for e in episodes], dtype=float)
    return G, R


def reinforce_terms(G: FloatArray, R: FloatArray) -> FloatArray:
    """Per-episode REINFORCE terms ``g_i (R_i - b)`` (N x p); their mean estimates the gradient.

    The baseline is the per-component optimum ``b_h = <g_ih^2 R_i> / <g_ih^2>``.
    """
    g2 = G**2
    denom = g2.mean(axis=0)
    safe = np.where(denom > 0, denom, 1.0)
    b = np.where(denom > 0, (g2 * R[:, None]).mean(axis=0) / safe, 0.0)
    return np.asarray(G * (R[:, None] - b[None, :]), dtype=float)


def reinforce_gradient(episodes: Sequence[Episode]) -> FloatArray:
    """REINFORCE estimate ``<g_i (R_i - b)>`` with the per-component optimal baseline."""
    G, R = _arrays(episodes)
    return np.asarray(reinforce_terms(G, R).mean(axis=0), dtype=float)


def enac_regression(G: FloatArray, R: FloatArray) -> tuple[FloatArray, float, FloatArray]:
    """Least squares ``R_i ~ g_i^T w + J``: ``(w, J, covariance of w)``.

    Raises:
        InvalidInputError: fewer episodes than parameters + 2.
    """
    N, p = G.shape
    if N < p + 2:
        raise InvalidInputError(f"eNAC needs at least p + 2 = {p + 2} episodes, got {N}")
    Phi = np.hstack([G, np.ones((N, 1))])
    sol, *_ = np.linalg.lstsq(Phi, R, rcond=None)
    res = R - Phi @ sol
    cov = float(res @ res) / (N - p - 1) * np.linalg.pinv(Phi.T @ Phi)
    return np.asarray(sol[:-1], dtype=float), float(sol[-1]), np.asarray(cov[:-1, :-1])


def enac_gradient(episodes: Sequence[Episode]) -> tuple[FloatArray, float]:
    """eNAC: least squares ``R_i ~ g_i^T w + J``; returns the natural gradient ``w`` and ``J``.

    Raises:
        InvalidInputError: fewer episodes than parameters + 2.
    """
    G, R = _arrays(episodes)
    w, J, _ = enac_regression(G, R)
    return w, J


def _check_options(options: PolicySearchOptions) -> int:
    """Validate the options; return the iteration cap.

    Caps (``iterations``, ``population``, ``elite``, ``max_rollouts``) are integers:
    ``inf``, NaN, floats, booleans, text and values below 1 are refused, so every search ends
    after at most ``iterations`` updates. Ctrl-C stops it between two rollouts and leaves
    nothing behind (``theta0`` is copied; the result is built locally).
    """
    if not isinstance(options, PolicySearchOptions):
        raise InvalidInputError(
            f"options must be a PolicySearchOptions, got {type(options).__name__}"
        )
    iterations = check_count(options.iterations, "iterations", minimum=1)
    population = check_count(options.population, "population", minimum=1)
    elite = check_count(options.elite, "elite", minimum=1)
    if elite > population:
        raise InvalidInputError(f"elite must be in [1, population = {population}], got {elite}")
    if options.max_rollouts is not None:
        check_count(options.max_rollouts, "max_rollouts", minimum=1)
    check_seed(options.seed)
    check_positive(options.learning_rate, "learning_rate")
    check_positive(options.exploration, "exploration")
    check_positive(options.exploration_decay, "exploration_decay")
    check_positive(options.temperature, "temperature")
    target = options.target_return
    if target is not None and not (
        isinstance(target, (int, float, np.integer, np.floating))
        and not isinstance(target, (bool, np.bool_))
        and np.isfinite(target)
    ):
        raise InvalidInputError(f"target_return must be a finite number or None, got {target!r}")
    return iterations


class _Search:
    """Book-keeping shared by the methods (seeds, counters, stopping)."""

    def __init__(
        self,
        rollout: Rollout,
        theta0: FloatArray,
        options: PolicySearchOptions,
        executor: Executor | BatchExecutor | None,
    ) -> None:
        self.iterations = _check_options(options)
        self.rollout = rollout
        self.theta = as_float_array(theta0, "initial parameters").ravel().copy()
        if self.theta.size == 0 or not np.all(np.isfinite(self.theta)):
            raise InvalidInputError("initial parameters must be finite and not empty")
        if options.population * self.theta.size > MAX_POPULATION_ENTRIES:
            raise InvalidInputError(
                f"population x parameters = {options.population} x {self.theta.size} exceeds "
                f"{MAX_POPULATION_ENTRIES:.0e} numbers per update (the noise alone would need "
                f"{options.population * self.theta.size * 8 / 2**30:.3g} GiB)"
            )
        self.options = options
        self.executor = executor
        self.seeds = np.random.SeedSequence(options.seed)
        self.rng = np.random.default_rng(self.seeds.spawn(1)[0])
        self.result = PolicySearchResult(
            success=False,
            status=PolicySearchStatus.MAX_ITERATIONS,
            parameters=self.theta,
            best_parameters=self.theta.copy(),
            best_return=-np.inf,
        )
        self.t0 = time.perf_counter()

    def evaluate(self, params: Sequence[FloatArray]) -> list[Episode]:
        seeds = self.rng.integers(0, 2**31 - 1, size=len(params))
        eps = evaluate_population(self.rollout, params, list(seeds), executor=self.executor)
        res = self.result
        for p, e in zip(params, eps):
            res.rollouts += 1
            res.environment_steps += e.steps
            if e.total_return > res.best_return:
                res.best_return = e.total_return
                res.best_parameters = np.asarray(p, dtype=float).copy()
        res.mean_returns.append(float(np.mean([e.total_return for e in eps])))
        return eps

    def set_theta(self, theta: FloatArray) -> None:
        """Take the update ``theta``; a NaN or infinite update raises (never returned)."""
        if not np.all(np.isfinite(theta)):
            raise SolverError(
                f"the update after {len(self.result.mean_returns)} populations is not finite "
                f"(returns {self.result.mean_returns[-1:]}); scale the returns down or lower "
                "learning_rate / exploration"
            )
        self.theta = theta

    def done(self) -> bool:
        o, res = self.options, self.result
        if (
            o.target_return is not None
            and res.mean_returns
            and res.mean_returns[-1] >= o.target_return
        ):
            res.status = PolicySearchStatus.TARGET_REACHED
            return True
        if o.max_rollouts is not None and res.rollouts >= o.max_rollouts:
            res.status = PolicySearchStatus.MAX_ROLLOUTS
            return True
        return False

    def finish(self) -> PolicySearchResult:
        res = self.result
        res.parameters = self.theta
        res.success = (
            res.status is PolicySearchStatus.TARGET_REACHED or self.options.target_return is None
        )
        res.solve_time = time.perf_counter() - self.t0
        return res


def _gradient_method(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None,
    executor: Executor | BatchExecutor | None,
    natural: bool,
) -> PolicySearchResult:
    s = _Search(rollout, theta0, options or PolicySearchOptions(), executor)
    for _ in range(s.iterations):
        eps = s.evaluate([s.theta] * s.options.population)
        if s.done():
            break
        step = enac_gradient(eps)[0] if natural else reinforce_gradient(eps)
        s.set_theta(s.theta + s.options.learning_rate * step)
    return s.finish()


def reinforce(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None = None,
    *,
    executor: Executor | BatchExecutor | None = None,
) -> PolicySearchResult:
    """Gradient ascent with the REINFORCE estimate (the rollout must explore in its actions)."""
    return _gradient_method(rollout, theta0, options, executor, natural=False)


def enac(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None = None,
    *,
    executor: Executor | BatchExecutor | None = None,
) -> PolicySearchResult:
    """Natural gradient ascent with the eNAC estimate (needs ``population >= p + 1``)."""
    return _gradient_method(rollout, theta0, options, executor, natural=True)


def power_update(returns: FloatArray, perturbations: FloatArray, temperature: float) -> FloatArray:
    """PoWER step ``sum_i w_i eps_i / sum_i w_i``, ``w_i = exp(-h (S_i - min S) / span S)``.

    ``S = -returns`` (the importance-sampled rollouts), ``eps_i`` their parameter offsets from
    the current mean (rows of ``perturbations``), ``h = temperature``; equal weights if all
    costs are equal.
    """
    S, eps = _checked_rollouts(returns, perturbations, "returns")
    if S.ndim != 1:
        raise InvalidInputError(f"returns must be (K,), got {S.shape}")
    w = _softmax_weights(-S, check_positive(temperature, "temperature"))
    return np.asarray(w @ eps, dtype=float)


def _checked_rollouts(
    values: FloatArray, perturbations: FloatArray, name: str
) -> tuple[FloatArray, FloatArray]:
    """``values`` (K, ...) and ``perturbations`` (K x p) as finite real arrays, K >= 1.

    ``values`` is scaled by a power of two (exact) so that its largest magnitude is below 1:
    the weights only depend on ``(S - min S) / span``, and sums and spans of costs up to
    1.8e308 then cannot overflow to inf (which made the update NaN).
    """
    C = as_float_array(values, name)
    eps = as_float_array(perturbations, "perturbations")
    if eps.ndim != 2 or C.ndim == 0 or C.shape[:1] != eps.shape[:1] or eps.shape[0] == 0:
        raise InvalidInputError(
            f"need {name} (K,) or (K x N) and perturbations (K x p) for the same K >= 1 "
            f"rollouts, got {C.shape} and {eps.shape}"
        )
    for label, a in ((name, C), ("perturbations", eps)):
        bad = ~np.isfinite(a).reshape(a.shape[0], -1).all(axis=1)
        if bad.any():
            raise InvalidInputError(
                f"{label} must be finite; NaN or inf in rollout(s) {np.flatnonzero(bad).tolist()}"
            )
    top = float(np.max(np.abs(C))) if C.size else 0.0
    if top > 0.0:
        C = C * 2.0 ** -np.frexp(top)[1]
    return C, eps


def _softmax_weights(S: FloatArray, temperature: float) -> FloatArray:
    """``exp(-h (S - min S) / (max S - min S))`` along the last axis, normalized to sum 1.

    Equal costs give equal weights.
    """
    lo = S.min(axis=-1, keepdims=True)
    span = S.max(axis=-1, keepdims=True) - lo
    safe = np.where(span > 0, span, 1.0)
    w = np.where(span > 0, np.exp(-temperature * (S - lo) / safe), 1.0)
    return np.asarray(w / w.sum(axis=-1, keepdims=True), dtype=float)


def pi2_update(
    costs: FloatArray,
    perturbations: FloatArray,
    temperature: float,
    activations: FloatArray | None = None,
    projection_blocks: int | None = None,
) -> FloatArray:
    """PI^2 parameter update ``dtheta`` from K rollouts.

    Args:
        costs: (K,) one cost per rollout (episodic form), or (K x N) per-step costs
            ``r_{t_i,k}`` (terminal cost in the last column) for the per-time-step form.
        perturbations: (K x p) exploration ``eps_k`` of each rollout (constant over it).
        temperature: ``h``.
        activations: (N x p) basis activation ``w_{j,t_i}`` of each parameter at each step;
            needed by the per-time-step form, ``None`` for the episodic one.
        projection_blocks: ``None`` (default): no projection. ``d``: the parameters are d
            contiguous blocks (e.g. the d dimensions of a DMP) and each block's noise is
            projected at each step onto that block's activations ``g = w_{.,t_i}``, the
            paper's ``M_{t_i} eps = g g^T eps / (g^T g)`` (control cost ``R = I``), before
            ``dtheta_{t_i}`` is formed.

    Per time step: ``S_{i,k} = sum_{j >= i} r_{j,k}``, ``P_{i,k}`` the softmax of
    ``-h (S_{i,k} - min_k) / (max_k - min_k)`` over k, ``dtheta_{t_i} = sum_k P_{i,k} eps_k``
    and ``[dtheta]_j = sum_i (N - i) w_{j,t_i} [dtheta_{t_i}]_j / sum_i (N - i) w_{j,t_i}``.
    A parameter that is never active (all its ``w_{j,t_i}`` zero) gets ``dtheta_j = 0``.

    Raises:
        InvalidInputError: inconsistent shapes, no rollout, non-real or non-finite costs,
            perturbations or activations, a temperature that is not finite and > 0.
    """
    C, eps = _checked_rollouts(costs, perturbations, "costs")
    temperature = check_positive(temperature, "temperature")
    if projection_blocks is not None and (
        activations is None
        or isinstance(projection_blocks, (bool, np.bool_))
        or not isinstance(projection_blocks, (int, np.integer))
    ):
        raise InvalidInputError(
            f"projection_blocks must be an integer and needs activations, got {projection_blocks!r}"
        )
    if activations is None:
        if C.ndim != 1:
            raise InvalidInputError(
                f"per-step costs {C.shape} need activations (N x p); pass (K,) costs "
                "for the episodic form"
            )
        return np.asarray(_softmax_weights(C, temperature) @ eps, dtype=float)
    W = as_float_array(activations, "activations")
    if not np.all(np.isfinite(W)) or (W.size and W.min() < 0):
        raise InvalidInputError("activations must be finite and nonnegative")
    if C.ndim != 2 or W.shape != (C.shape[1], eps.shape[1]):
        raise InvalidInputError(
            f"per-time-step PI^2 needs costs (K x N) and activations (N x p) = "
            f"({C.shape[-1]} x {eps.shape[1]}), got costs {C.shape} and activations {W.shape}"
        )
    N = C.shape[1]
    S = np.cumsum(C[:, ::-1], axis=1)[:, ::-1]  # cost-to-go S_{i,k} (K x N)
    P = _softmax_weights(S.T, temperature)  # (N x K): probabilities per step
    if projection_blocks is None:
        step = P @ eps  # (N x p): dtheta_{t_i}
    else:
        d = int(projection_blocks)
        K, p = eps.shape
        if d < 1 or p % d:
            raise InvalidInputError(
                f"projection_blocks must divide the {p} parameters, got {projection_blocks!r}"
            )
        G = W.reshape(N, d, p // d)  # g_{t_i} of each block
        E = eps.reshape(K, d, p // d)
        gg = (G * G).sum(axis=2)  # (N x d)
        coef = np.einsum("ndb,kdb->nkd", G, E) / np.where(gg > 0, gg, 1.0)[:, None, :]
        step = np.einsum("nk,nkd,ndb->ndb", P, coef, G).reshape(N, p)
    weight = (N - np.arange(N))[:, None] * W  # (N - i) w_{j,t_i}
    total = weight.sum(axis=0)
    num = (weight * step).sum(axis=0)
    return np.asarray(np.where(total > 0, num / np.where(total > 0, total, 1.0), 0.0), float)


def _parameter_exploration(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None,
    executor: Executor | BatchExecutor | None,
    method: str,
    activations: FloatArray | None = None,
    projection_blocks: int | None = None,
) -> PolicySearchResult:
    s = _Search(rollout, theta0, options or PolicySearchOptions(), executor)
    o = s.options
    sigma = o.exploration
    memory: list[tuple[float, FloatArray]] = []  # PoWER: the best rollouts of all iterations
    for _ in range(s.iterations):
        noise = sigma * s.rng.standard_normal((o.population, s.theta.size))
        if not np.all(np.isfinite(s.theta + noise)):
            raise InvalidInputError(
                f"the exploration noise overflowed (sigma = {sigma!r} after "
                f"{len(s.result.mean_returns)} updates: exploration {o.exploration!r}, "
                f"exploration_decay {o.exploration_decay!r}); use a smaller exploration or "
                "a decay <= 1"
            )
        eps = s.evaluate(list(s.theta + noise))
        R = np.array([e.total_return for e in eps])
        if method == "power":
            memory.extend((float(r), s.theta + n) for r, n in zip(R, noise))
            memory = sorted(memory, key=lambda m: -m[0])[: o.elite]
            s.set_theta(
                s.theta
                + power_update(
                    np.array([m[0] for m in memory]),
                    np.array([m[1] for m in memory]) - s.theta,
                    o.temperature,
                )
            )
        elif method == "pi2":
            if activations is None:
                s.set_theta(s.theta + pi2_update(-R, noise, o.temperature))
            else:
                costs = _step_costs(eps, activations.shape[0])
                s.set_theta(
                    s.theta
                    + pi2_update(costs, noise, o.temperature, activations, projection_blocks)
                )
        else:  # (mu, lambda)-ES
            idx = np.argsort(R)[::-1][: o.elite]
            s.set_theta(s.theta + noise[idx].mean(axis=0))
        sigma *= o.exploration_decay
        if s.done():
            break
    return s.finish()


def power(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None = None,
    *,
    executor: Executor | BatchExecutor | None = None,
) -> PolicySearchResult:
    """PoWER: ``theta += sum_i w_i eps_i / sum_i w_i`` over the best rollouts of all iterations.

    ``w = exp(-beta S)`` (see :func:`power_update`); ``elite`` rollouts are kept in memory.
    """
    return _parameter_exploration(rollout, theta0, options, executor, "power")


def _step_costs(episodes: Sequence[Episode], steps: int) -> FloatArray:
    costs = []
    for e in episodes:
        r = np.asarray(e.rewards, dtype=float).ravel()
        if r.size != steps:
            raise InvalidInputError(
                f"per-time-step PI^2 needs {steps} per-step rewards per episode (one per row "
                f"of activations), got {r.size}"
            )
        costs.append(-r)
    return np.array(costs)


def pi2(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None = None,
    *,
    executor: Executor | BatchExecutor | None = None,
    activations: FloatArray | None = None,
    projection_blocks: int | None = None,
) -> PolicySearchResult:
    """PI^2 (see :func:`pi2_update`).

    Without ``activations``: the episodic form (one cost ``-R`` per rollout). With
    ``activations`` (N x p, e.g. :meth:`ViaPointTask.activations`): the per-time-step form;
    each episode's ``rewards`` must then hold N per-step rewards. ``projection_blocks``
    (per-time-step form only): project the noise onto the activations, see
    :func:`pi2_update`.
    """
    W = None
    if activations is not None:
        W = as_float_array(activations, "activations")
        theta = np.asarray(theta0).ravel()
        if W.ndim != 2 or W.shape[1] != theta.size or not np.all(np.isfinite(W)) or W.min() < 0:
            raise InvalidInputError(
                f"activations must be finite, nonnegative, (N x {theta.size}), got {W.shape}"
            )
    elif projection_blocks is not None:
        raise InvalidInputError("projection_blocks needs activations (per-time-step PI^2)")
    return _parameter_exploration(rollout, theta0, options, executor, "pi2", W, projection_blocks)


def mu_lambda_es(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None = None,
    *,
    executor: Executor | BatchExecutor | None = None,
) -> PolicySearchResult:
    """(mu, lambda)-evolution strategy: mean of the ``elite`` best of ``population`` offspring."""
    return _parameter_exploration(rollout, theta0, options, executor, "es")


def cma_es(
    rollout: Rollout,
    theta0: FloatArray,
    options: PolicySearchOptions | None = None,
    *,
    executor: Executor | BatchExecutor | None = None,
) -> PolicySearchResult:
    """CMA-ES through pycma's ask-and-tell interface (population = ``options.population``).

    Each candidate is evaluated by one rollout (use a deterministic rollout, or average
    several inside it, for noisy returns).
    """
    import cma

    s = _Search(rollout, theta0, options or PolicySearchOptions(), executor)
    o = s.options
    if o.population < 2:
        raise InvalidInputError(f"cma_es needs population >= 2, got {o.population}")
    if o.seed >= 2**32 - 1:
        raise InvalidInputError(f"cma_es needs seed < 2**32 - 1 (pycma's limit), got {o.seed}")
    if o.exploration < 1e-300:
        raise InvalidInputError(
            f"cma_es needs exploration >= 1e-300, got {o.exploration!r} (pycma fails an "
            "internal assertion on subnormal step sizes)"
        )
    es = cma.CMAEvolutionStrategy(
        s.theta,
        o.exploration,
        {"popsize": o.population, "seed": int(o.seed) + 1, "verbose": -9},
    )
    for _ in range(s.iterations):
        candidates = [np.asarray(c, dtype=float) for c in es.ask()]
        eps = s.evaluate(candidates)
        es.tell(candidates, [-float(e.total_return) for e in eps])
        s.theta = np.asarray(es.mean, dtype=float).copy()
        if s.done() or es.stop():
            break
    return s.finish()
