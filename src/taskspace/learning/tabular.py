"""Tabular reinforcement learning on finite MDPs: Q-learning, SARSA and TD(lambda).

The agent only samples transitions ``s' ~ P(. | s, a)`` and rewards; the MDP's matrices are
used by the simulator, never by the learner.

* Q-learning (off-policy): ``Q(s, a) += alpha [r + gamma max_a' Q(s', a') - Q(s, a)]``.
* SARSA (on-policy): ``Q(s, a) += alpha [r + gamma Q(s', a') - Q(s, a)]`` with ``a'`` the
  action actually taken next (epsilon-greedy).
* TD(lambda) policy evaluation with accumulating eligibility traces:
  ``delta = r + gamma V(s') - V(s)``, ``e(s) += 1``, ``V += alpha delta e``, ``e *= gamma lambda``.

With every state-action pair visited infinitely often and step sizes with
``sum alpha = inf``, ``sum alpha^2 < inf`` (``alpha = 1 / n(s, a)^omega``, ``1/2 < omega <= 1``)
Q-learning converges to ``Q*`` and TD(lambda) to ``V^pi``; SARSA converges to ``Q*`` when the
exploration decays (GLIE).

Thread safety: the algorithms keep their tables local to the call. An :class:`MDPSimulator`
draws from the generator it was given: numpy serializes the draws, so a simulator shared by
threads gives valid but not reproducible episodes; use one simulator (and generator) per
thread. :class:`TabularOptions` is immutable and :class:`TabularResult` plain result data.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, check_count, check_positive
from taskspace.errors import InvalidInputError
from taskspace.optimal_control.mdp import MDP


@dataclass(frozen=True, kw_only=True)
class TabularOptions:
    """Settings of :func:`q_learning`, :func:`sarsa` and :func:`td_lambda`.

    Attributes:
        episodes: number of episodes (an integer >= 1).
        max_steps: steps per episode (an integer >= 1; an episode also ends in an absorbing
            state).
        learning_rate: ``alpha_0``; the step size of the n-th update of a pair is
            ``alpha_0 / n^decay``.
        learning_rate_decay: ``omega`` in ``[0, 1]`` (0: constant step size).
        epsilon: exploration probability of the epsilon-greedy behaviour.
        epsilon_decay: ``epsilon_k = epsilon / (1 + epsilon_decay k)`` in episode ``k``.
        trace_decay: ``lambda`` of TD(lambda) in ``[0, 1]``.
        start_states: states an episode may start from (uniformly); ``None``: every
            non-absorbing state (exploring starts).
    """

    episodes: int = 2000
    max_steps: int = 100
    learning_rate: float = 1.0
    learning_rate_decay: float = 0.8
    epsilon: float = 0.3
    epsilon_decay: float = 0.0
    trace_decay: float = 0.0
    start_states: tuple[int, ...] | None = None


@dataclass
class TabularResult:
    """A learned value table.

    Attributes:
        Q: action values (S x A) (zeros for TD(lambda)).
        V: state values (S,) (``max_a Q`` for the control methods).
        policy: greedy policy (S,).
        episode_returns: undiscounted return of each episode.
        visits: number of updates of each pair (S x A) (for TD(lambda): of each state, column 0).
    """

    Q: FloatArray
    V: FloatArray
    policy: np.ndarray
    episode_returns: FloatArray
    visits: np.ndarray = field(repr=False)


class MDPSimulator:
    """Samples transitions of an MDP: ``s' ~ P_a[s, .]``, reward ``R[s, a]``.

    Args:
        mdp: the MDP.
        rng: random generator.
    """

    def __init__(self, mdp: MDP, rng: np.random.Generator) -> None:
        _check_mdp(mdp)
        _check_rng(rng)
        self.mdp = mdp
        self.rng = rng
        self._rows = [(P.indptr, P.indices, P.data) for P in mdp.transitions]
        self.absorbing = self._absorbing()

    def _absorbing(self) -> np.ndarray:
        out = np.ones(self.mdp.num_states, dtype=bool)
        for a, P in enumerate(self.mdp.transitions):
            diag = P.diagonal()
            out &= (diag >= 1.0 - 1e-12) & (self.mdp.rewards[:, a] == 0.0)
        return out

    def step(self, s: int, a: int) -> tuple[int, float]:
        """Sample ``(s', r)``.

        Raises:
            InvalidInputError: ``s`` or ``a`` not an index of the MDP (was a bare IndexError;
                -1 silently meant the last state).
        """
        for name, value, size in (("s", s, self.mdp.num_states), ("a", a, self.mdp.num_actions)):
            if (
                isinstance(value, (bool, np.bool_))
                or not isinstance(value, (int, np.integer))
                or not 0 <= value < size
            ):
                raise InvalidInputError(f"{name} must be an integer in [0, {size}), got {value!r}")
        return self._step(int(s), int(a))

    def _step(self, s: int, a: int) -> tuple[int, float]:
        """:meth:`step` without the checks (the learners pass valid indices)."""
        indptr, indices, data = self._rows[a]
        lo, hi = indptr[s], indptr[s + 1]
        if hi - lo == 1:
            nxt = int(indices[lo])
        else:
            nxt = int(indices[lo + np.searchsorted(np.cumsum(data[lo:hi]), self.rng.random())])
        return nxt, float(self.mdp.rewards[s, a])


def _starts(sim: MDPSimulator, options: TabularOptions) -> np.ndarray:
    if options.start_states is not None:
        raw = np.asarray(options.start_states)
        if raw.dtype.kind not in "iu" or raw.ndim != 1:
            raise InvalidInputError(
                f"start_states must be a sequence of integer state indices, got "
                f"{options.start_states!r}"
            )
        starts = raw.astype(int)
        if starts.size == 0 or starts.min() < 0 or starts.max() >= sim.mdp.num_states:
            raise InvalidInputError(f"start_states must be indices in [0, {sim.mdp.num_states})")
        return starts
    starts = np.flatnonzero(~sim.absorbing)
    if starts.size == 0:
        raise InvalidInputError("every state is absorbing: nothing to learn")
    return starts


def _fraction(value: object, name: str, *, open_low: bool = False) -> float:
    """A number in ``[0, 1]`` (``(0, 1]`` with ``open_low``), else InvalidInputError."""
    v = check_positive(value, name, strict=open_low)
    if v > 1.0:
        interval = "(0, 1]" if open_low else "[0, 1]"
        raise InvalidInputError(f"{name} must be in {interval}, got {value!r}")
    return v


def _check(options: TabularOptions) -> tuple[int, int]:
    """Validate the options; return the caps ``(episodes, max_steps)``.

    Every loop is bounded by these integer caps (``inf``, NaN, floats, booleans, text and
    values below 1 are refused), so a run always ends; Ctrl-C stops it between two steps and
    leaves nothing behind (the tables are local until returned).
    """
    if not isinstance(options, TabularOptions):
        raise InvalidInputError(f"options must be a TabularOptions, got {type(options).__name__}")
    episodes = check_count(options.episodes, "episodes", minimum=1)
    max_steps = check_count(options.max_steps, "max_steps", minimum=1)
    _fraction(options.learning_rate, "learning_rate", open_low=True)
    _fraction(options.learning_rate_decay, "learning_rate_decay")
    _fraction(options.epsilon, "epsilon")
    check_positive(options.epsilon_decay, "epsilon_decay", strict=False)
    _fraction(options.trace_decay, "trace_decay (lambda)")
    return episodes, max_steps


def _check_mdp(mdp: object) -> None:
    if not isinstance(mdp, MDP):  # a str was a bare AttributeError
        raise InvalidInputError(
            f"mdp must be an MDP (taskspace.optimal_control.make_mdp, grid_world...), got "
            f"{type(mdp).__name__}"
        )


def _check_rng(rng: object) -> None:
    if not isinstance(rng, np.random.Generator):
        raise InvalidInputError(
            f"rng must be a numpy Generator (np.random.default_rng(seed)), got {type(rng).__name__}"
        )


def _epsilon_greedy(Q: FloatArray, s: int, eps: float, rng: np.random.Generator) -> int:
    if rng.random() < eps:
        return int(rng.integers(Q.shape[1]))
    row = Q[s]
    best = np.flatnonzero(row == row.max())
    return int(best[rng.integers(best.size)])


def _control(
    mdp: MDP, options: TabularOptions, rng: np.random.Generator, on_policy: bool
) -> TabularResult:
    episodes, max_steps = _check(options)
    _check_rng(rng)
    sim = MDPSimulator(mdp, rng)
    starts = _starts(sim, options)
    S, A = mdp.num_states, mdp.num_actions
    Q = np.zeros((S, A))
    n = np.zeros((S, A), dtype=np.int64)
    returns: list[float] = []  # not preallocated: a cap of 10**18 episodes is a valid cap
    for k in range(episodes):
        eps = options.epsilon / (1.0 + options.epsilon_decay * k)
        s = int(starts[rng.integers(starts.size)])
        a = _epsilon_greedy(Q, s, eps, rng)
        total = 0.0
        for _ in range(max_steps):
            s2, r = sim._step(s, a)
            total += r
            a2 = _epsilon_greedy(Q, s2, eps, rng)
            n[s, a] += 1
            alpha = options.learning_rate / n[s, a] ** options.learning_rate_decay
            target = Q[s2, a2] if on_policy else Q[s2].max()
            if sim.absorbing[s2]:
                target = 0.0
            Q[s, a] += alpha * (r + mdp.gamma * target - Q[s, a])
            s, a = s2, a2
            if sim.absorbing[s]:
                break
        returns.append(total)
    return TabularResult(
        Q=Q,
        V=Q.max(axis=1),
        policy=np.argmax(Q, axis=1),
        episode_returns=np.asarray(returns, dtype=float),
        visits=n,
    )


def q_learning(
    mdp: MDP, options: TabularOptions | None = None, *, rng: np.random.Generator
) -> TabularResult:
    """Watkins' Q-learning with an epsilon-greedy behaviour policy (off-policy).

    Args:
        mdp: the MDP, only sampled.
        options: see :class:`TabularOptions`.
        rng: random generator.
    """
    return _control(mdp, TabularOptions() if options is None else options, rng, on_policy=False)


def sarsa(
    mdp: MDP, options: TabularOptions | None = None, *, rng: np.random.Generator
) -> TabularResult:
    """SARSA with an epsilon-greedy policy (on-policy); decay ``epsilon`` for the optimum."""
    return _control(mdp, TabularOptions() if options is None else options, rng, on_policy=True)


def td_lambda(
    mdp: MDP,
    policy: Any,
    options: TabularOptions | None = None,
    *,
    rng: np.random.Generator,
) -> TabularResult:
    """TD(lambda) evaluation of a policy with accumulating eligibility traces.

    Args:
        mdp: the MDP, only sampled.
        policy: deterministic policy (S,) of action indices, or a stochastic one (S x A) of
            action probabilities.
        options: see :class:`TabularOptions` (``trace_decay`` is lambda; ``epsilon`` unused).
        rng: random generator.
    """
    options = TabularOptions() if options is None else options
    episodes, max_steps = _check(options)
    _check_rng(rng)
    S, A = mdp.num_states, mdp.num_actions
    pi = np.asarray(policy)
    if pi.shape == (S,):
        if pi.min() < 0 or pi.max() >= A:
            raise InvalidInputError(f"policy actions must be in [0, {A})")
        probs = np.eye(A)[pi.astype(int)]
    elif pi.shape == (S, A):
        probs = np.asarray(pi, dtype=float)
        if np.any(probs < 0) or not np.allclose(probs.sum(axis=1), 1.0):
            raise InvalidInputError("a stochastic policy's rows must be probabilities summing to 1")
    else:
        raise InvalidInputError(f"policy must have shape ({S},) or ({S}, {A}), got {pi.shape}")
    sim = MDPSimulator(mdp, rng)
    starts = _starts(sim, options)
    V = np.zeros(S)
    n = np.zeros(S, dtype=np.int64)
    cum = np.cumsum(probs, axis=1)
    returns: list[float] = []
    lam_gamma = mdp.gamma * options.trace_decay
    for _ in range(episodes):
        e = np.zeros(S)
        s = int(starts[rng.integers(starts.size)])
        total = 0.0
        for _ in range(max_steps):
            a = min(int(np.searchsorted(cum[s], rng.random(), side="right")), A - 1)
            s2, r = sim._step(s, a)
            total += r
            v2 = 0.0 if sim.absorbing[s2] else V[s2]
            delta = r + mdp.gamma * v2 - V[s]
            n[s] += 1
            e[s] += 1.0
            alpha = options.learning_rate / n[s] ** options.learning_rate_decay
            V += alpha * delta * e
            e *= lam_gamma
            s = s2
            if sim.absorbing[s]:
                break
        returns.append(total)
    return TabularResult(
        Q=np.zeros((S, A)),
        V=V,
        policy=np.argmax(probs, axis=1),
        episode_returns=np.asarray(returns, dtype=float),
        visits=n[:, None],
    )
