"""Rollouts as pure functions of the policy parameters and a seed.

``rollout(theta, seed) -> Episode``: the same ``(theta, seed)`` always gives the same
episode, so a population can be evaluated in any order, on threads or processes, or on a Ray
cluster through :class:`taskspace.batch.Executor`, with :func:`evaluate_population`.

Thread safety: :class:`LinearQuadraticTask` is immutable and its rollouts draw from a generator
seeded per call (``seed``), so they may run from several threads; :class:`Episode` is plain
result data, not locked. :func:`evaluate_population` calls the user's rollout function in the
calling thread or on the executor given (a ``concurrent.futures`` thread pool runs it in
several threads at once, see also :mod:`taskspace.batch`): a rollout that keeps state between
calls must be safe for that.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, check_count, check_positive
from taskspace.batch import Executor as BatchExecutor
from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.learning.policies import LinearPolicy, Policy


class RolloutError(TaskspaceError):
    """A user rollout raised, or returned something that is not a valid :class:`Episode`.

    A rollout's exception (other than a :class:`TaskspaceError`, re-raised as is) is the
    ``__cause__``. A return that is NaN or infinite is refused: a search would otherwise keep
    it as the best rollout (the (mu, lambda)-ES sorted NaN first) or average it into a NaN
    step; give a failing rollout a large finite penalty instead.

    Attributes:
        index: position of the rollout in the population.
        parameters: the parameters it was given.
        seed: the seed it was given.
    """

    def __init__(self, message: str, index: int, parameters: FloatArray, seed: int) -> None:
        self.index = index
        self.parameters = parameters
        self.seed = seed
        super().__init__(
            f"rollout {index} (seed {seed}, parameters {np.array2string(parameters, threshold=8)})"
            f" {message}"
        )


@dataclass
class Episode:
    """One rollout.

    Attributes:
        total_return: ``sum_t r_t`` (undiscounted, or as the task defines it).
        log_likelihood_gradient: ``sum_t d/dtheta log pi(a_t | s_t)`` (p,) of the action
            exploration (zeros without action noise).
        rewards: per-step rewards (T,).
        steps: number of environment steps.
        states: visited states (T x n), if recorded.
    """

    total_return: float
    log_likelihood_gradient: FloatArray
    rewards: FloatArray
    steps: int
    states: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))


Rollout = Callable[[FloatArray, int], Episode]
"""``rollout(theta, seed)``: one episode, a pure function of its arguments."""


def evaluate_population(
    rollout: Rollout,
    parameters: Sequence[FloatArray] | FloatArray,
    seeds: Sequence[int],
    *,
    executor: Executor | BatchExecutor | None = None,
) -> list[Episode]:
    """Run ``rollout(parameters[i], seeds[i])`` for every i, serially or on an executor.

    ``executor`` is a ``concurrent.futures`` executor or a :class:`taskspace.batch.Executor`
    (local processes or Ray; the rollout is shipped once per worker as its context, and a
    failing rollout raises :class:`taskspace.batch.BatchError` naming its parameters).

    Every result is checked: an :class:`Episode` whose ``total_return`` is a finite real
    number, ``log_likelihood_gradient`` finite real numbers and ``steps`` an integer >= 0.

    Raises:
        InvalidInputError: different numbers of parameter vectors and seeds.
        RolloutError: a rollout raised (other than a :class:`TaskspaceError`, which passes
            through) or returned an invalid episode (e.g. a NaN or infinite return).
    """
    params = [np.asarray(p, dtype=float) for p in parameters]
    if len(params) != len(seeds):
        raise InvalidInputError(f"{len(params)} parameter vectors but {len(seeds)} seeds")
    seed_list = [int(s) for s in seeds]
    episodes: list[Any] = []
    if isinstance(executor, BatchExecutor):
        items = list(zip(params, seed_list))
        result = executor.map(
            _rollout_task, items, context=functools.partial(_same, rollout), description="rollouts"
        )
        episodes = list(result.values)
    else:
        results = (
            map(rollout, params, seed_list)
            if executor is None
            else executor.map(rollout, params, seed_list)
        )
        try:
            for episode in results:
                episodes.append(episode)
        except TaskspaceError:
            raise
        except Exception as exc:
            i = len(episodes)
            raise RolloutError(
                f"raised {type(exc).__name__}: {exc}", i, params[i], seed_list[i]
            ) from exc
    for i, episode in enumerate(episodes):
        problem = _episode_problem(episode)
        if problem:
            raise RolloutError(problem, i, params[i], seed_list[i])
    return episodes


def _episode_problem(episode: Any) -> str:
    """Why ``episode`` is not a valid :class:`Episode` ("" if it is)."""
    if not isinstance(episode, Episode):
        return f"returned a {type(episode).__name__}, not an Episode"
    ret = episode.total_return
    if isinstance(ret, np.ndarray) and ret.shape == ():
        ret = ret[()]
    if isinstance(ret, (bool, np.bool_)) or not isinstance(
        ret, (int, float, np.integer, np.floating)
    ):
        return f"returned total_return={ret!r}, not a real number"
    if not np.isfinite(ret):
        return (
            f"returned total_return={ret!r}; returns must be finite (give a failing rollout a "
            "large finite penalty instead)"
        )
    steps = episode.steps
    if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 0:
        return f"returned steps={steps!r}, not an integer >= 0"
    try:
        g = np.asarray(episode.log_likelihood_gradient)
    except ValueError:  # ragged nested sequences
        g = np.asarray(None)
    if g.dtype.kind not in "fiu" or not np.all(np.isfinite(g)):
        return "returned a log_likelihood_gradient that is not finite real numbers"
    return ""


def _same(value: Any) -> Any:
    return value


def _rollout_task(item: Any, rng: np.random.Generator, rollout: Rollout) -> Episode:
    """A batch task: the rollout's own seed decides its noise (``rng`` is unused)."""
    parameters, seed = item
    return rollout(parameters, seed)


@dataclass(frozen=True, kw_only=True)
class LinearQuadraticTask:
    """``x+ = A x + B u``, reward ``-(x^T Q x + u^T R u)`` over ``horizon`` steps, from ``x0``.

    The policy is ``u = K x + sigma eps`` (a :class:`LinearPolicy` without bias, theta =
    vec(K) row by row). The expected return has a closed form (see :meth:`expected_return`),
    which makes the task the reference for policy-gradient estimators.

    Attributes:
        A: (n x n); B: (n x m); Q: (n x n); R: (m x m).
        x0: initial state (n,); horizon: number of steps; sigma: action noise std.
        initial_std: std of a Gaussian perturbation of ``x0`` (isotropic).
    """

    A: FloatArray
    B: FloatArray
    Q: FloatArray
    R: FloatArray
    x0: FloatArray
    horizon: int = 10
    sigma: float = 0.1
    initial_std: float = 0.0

    def __post_init__(self) -> None:
        check_count(self.horizon, "horizon", minimum=1)  # an integer: inf, 2.5, True refused
        check_positive(self.sigma, "sigma", strict=False)
        check_positive(self.initial_std, "initial_std", strict=False)

    @property
    def policy(self) -> LinearPolicy:
        """The linear policy of this task."""
        return LinearPolicy(state_dim=self.A.shape[0], action_dim=self.B.shape[1])

    def rollout(self, theta: FloatArray, seed: int) -> Episode:
        """One episode with action noise (pure function of ``theta`` and ``seed``)."""
        return self.sample_episodes(theta, 1, seed)[0]

    def sample_episodes(self, theta: FloatArray, count: int, seed: int) -> list[Episode]:
        """``count`` independent episodes, simulated together (see :meth:`sample_arrays`)."""
        G, R, rewards = self.sample_arrays(theta, count, seed)
        return [
            Episode(
                total_return=float(R[k]),
                log_likelihood_gradient=G[k],
                rewards=rewards[k],
                steps=self.horizon,
            )
            for k in range(count)
        ]

    def sample_arrays(
        self, theta: FloatArray, count: int, seed: int
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Vectorized episodes ``(G, R, rewards)``.

        G (count x p): the summed log-likelihood gradients ``sum_t kron(u - K x, x) / sigma^2``;
        R (count,): the returns; rewards (count x horizon).
        """
        th = self.policy.check(theta)
        rng = np.random.default_rng(seed)
        n, m = self.B.shape
        K = th.reshape(m, n)
        x = np.asarray(self.x0, dtype=float)[None, :] + self.initial_std * rng.standard_normal(
            (count, n)
        )
        grad = np.zeros((count, m, n))
        rewards = np.empty((count, self.horizon))
        for t in range(self.horizon):
            noise = self.sigma * rng.standard_normal((count, m))
            u = x @ K.T + noise
            rewards[:, t] = -(
                np.einsum("ki,ij,kj->k", x, self.Q, x) + np.einsum("ki,ij,kj->k", u, self.R, u)
            )
            if self.sigma > 0:
                grad += noise[:, :, None] * x[:, None, :] / self.sigma**2
            x = x @ self.A.T + u @ self.B.T
        return grad.reshape(count, m * n), rewards.sum(axis=1), rewards

    def state_covariances(self, theta: FloatArray) -> list[FloatArray]:
        """``E[x_t x_t^T]`` for ``t = 0..horizon-1``."""
        n = self.A.shape[0]
        K = np.asarray(theta, dtype=float).reshape(self.B.shape[1], n)
        Acl = self.A + self.B @ K
        x0 = np.asarray(self.x0, dtype=float)
        S = np.outer(x0, x0) + self.initial_std**2 * np.eye(n)
        out = []
        for _ in range(self.horizon):
            out.append(S)
            S = Acl @ S @ Acl.T + self.sigma**2 * self.B @ self.B.T
        return out

    def expected_return(self, theta: FloatArray) -> float:
        """Closed-form expected return.

        ``E[sum_t r_t] = -sum_t [tr((Q + K^T R K) S_t) + sigma^2 tr(R)]`` with ``S_t = E[x x^T]``,
        ``S_{t+1} = (A + B K) S_t (A + B K)^T + sigma^2 B B^T``.
        """
        n = self.A.shape[0]
        K = np.asarray(theta, dtype=float).reshape(self.B.shape[1], n)
        M = self.Q + K.T @ self.R @ K
        total = 0.0
        for S in self.state_covariances(theta):
            total -= float(np.trace(M @ S)) + self.sigma**2 * float(np.trace(self.R))
        return total

    def fisher_information(self, theta: FloatArray) -> FloatArray:
        """``F = E[g g^T]`` of ``g = sum_t grad log pi`` = ``sum_t kron(I_m, S_t) / sigma^2``."""
        m = self.B.shape[1]
        F = np.zeros((m * self.A.shape[0],) * 2)
        for S in self.state_covariances(theta):
            F += np.kron(np.eye(m), S) / self.sigma**2
        return F


def policy_rollout(
    policy: Policy,
    step: Callable[[FloatArray, FloatArray], tuple[FloatArray, float, bool]],
    initial_state: Callable[[np.random.Generator], FloatArray],
    *,
    horizon: int,
    sigma: float = 0.0,
) -> Rollout:
    """A :data:`Rollout` from a step function ``step(s, a) -> (s', r, done)``.

    Args:
        policy: the policy.
        step: deterministic environment step.
        initial_state: draws the initial state from the episode's generator.
        horizon: step limit (an integer >= 1: ``inf``, NaN, floats, booleans and text are
            refused).
        sigma: action noise std (0: deterministic policy, for parameter-exploring methods).
    """
    horizon = check_count(horizon, "horizon", minimum=1)
    sigma = check_positive(sigma, "sigma", strict=False)

    def rollout(theta: FloatArray, seed: int) -> Episode:
        th = policy.check(theta)
        rng = np.random.default_rng(seed)
        s = np.asarray(initial_state(rng), dtype=float)
        grad = np.zeros(th.size)
        rewards: list[Any] = []
        for _ in range(horizon):
            a = policy._mean_action(th, s)  # th checked above; s is checked
            if sigma > 0:
                a = a + sigma * rng.standard_normal(a.shape)
                grad += policy.log_likelihood_gradient(th, s, a, sigma)
            out = step(s, a)
            if not (isinstance(out, tuple) and len(out) == 3):
                raise InvalidInputError(
                    f"step(s, a) must return (next_state, reward, done), got {out!r} at step "
                    f"{len(rewards)}"
                )
            s, r, done = out
            if not (r.__class__ is float and math.isfinite(r)) and (
                isinstance(r, (bool, np.bool_))
                or not isinstance(r, (int, float, np.integer, np.floating))
                or not np.isfinite(r)
            ):
                # a NaN reward made a NaN return, text a bare ValueError
                raise InvalidInputError(
                    f"step(s, a) returned the reward {r!r} at step {len(rewards)}; rewards must "
                    "be finite real numbers"
                )
            rewards.append(r)
            if done:
                break
        rew = np.asarray(rewards, dtype=float)
        return Episode(
            total_return=float(rew.sum()),
            log_likelihood_gradient=grad,
            rewards=rew,
            steps=rew.size,
        )

    return rollout
