"""Finite Markov decision processes with sparse transition matrices.

An MDP has ``S`` states, ``A`` actions, transition matrices ``P_a[s, s'] = P(s' | s, a)``
(one ``scipy.sparse`` matrix per action, rows summing to 1), expected rewards ``R[s, a]`` and
a discount ``gamma``. The agent maximizes ``E[sum_t gamma^t R(s_t, a_t)]``; costs are negative
rewards.

Thread safety: an :class:`MDP` is an immutable value (frozen dataclass; ``stacked`` is computed on
first use, two threads racing on it compute equal matrices), so it may be shared by threads as long
as nobody modifies its arrays in place.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse as sp

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    check_count,
    check_positive,
)
from taskspace.errors import InvalidInputError


@dataclass(frozen=True)
class MDP:
    """A finite MDP ``(P, R, gamma)``; build it with :func:`make_mdp` (validated).

    Attributes:
        transitions: one ``S x S`` CSR matrix per action, ``P_a[s, s'] = P(s' | s, a)``.
        rewards: expected immediate reward ``R[s, a]`` (S x A).
        gamma: discount factor in ``[0, 1]`` (1 only with absorbing zero-reward states).
        state_names: optional labels of the states.
        action_names: optional labels of the actions.
    """

    transitions: tuple[sp.csr_matrix, ...]
    rewards: FloatArray
    gamma: float
    state_names: tuple[str, ...] = ()
    action_names: tuple[str, ...] = ()

    @property
    def num_states(self) -> int:
        """``S``."""
        return int(self.rewards.shape[0])

    @property
    def num_actions(self) -> int:
        """``A``."""
        return int(self.rewards.shape[1])

    @cached_property
    def stacked(self) -> sp.csr_matrix:
        """``[P_0; P_1; ...]`` interleaved so that row ``s A + a`` is ``P_a[s]`` ((S A) x S)."""
        S, A = self.num_states, self.num_actions
        M = sp.vstack(self.transitions, format="csr")
        order = (np.arange(A)[None, :] * S + np.arange(S)[:, None]).ravel()
        return sp.csr_matrix(M[order])

    def q_values(self, V: FloatArray) -> FloatArray:
        """Bellman backup ``Q[s, a] = R[s, a] + gamma sum_s' P_a[s, s'] V[s']`` (S x A)."""
        PV = (self.stacked @ V).reshape(self.num_states, self.num_actions)
        return self.rewards + self.gamma * PV

    def policy_matrix(self, policy: Any) -> tuple[sp.csr_matrix, FloatArray]:
        """Transition matrix ``P_pi`` (S x S) and rewards ``R_pi`` of a deterministic policy."""
        pi = integer_array(policy, "policy")
        if (
            pi.shape != (self.num_states,)
            or pi.min(initial=0) < 0
            or (pi.max(initial=0) >= self.num_actions)
        ):
            raise InvalidInputError(
                f"policy must hold {self.num_states} action indices in [0, {self.num_actions})"
            )
        S = self.num_states
        rows = sp.csr_matrix((S, S))
        for a, P in enumerate(self.transitions):
            mask = sp.diags((pi == a).astype(float))
            rows = rows + mask @ P
        return sp.csr_matrix(rows), self.rewards[np.arange(S), pi]


EPS64 = float(np.finfo(np.float64).eps)
"""Machine epsilon of float64, the precision of the stored transition matrices."""


def _transition_matrix(P: Any, a: int) -> tuple[sp.csr_matrix, np.dtype[Any]]:
    """One action's transition matrix as float64 CSR and the dtype it was given in.

    Text, ragged, complex and 3-D inputs are refused. The dtype is float64 unless the input
    held lower-precision floats (float32, float16), whose rounding widens the row-sum check.
    """
    name = f"transition matrix of action {a}"
    if sp.issparse(P):
        if P.dtype.kind not in "biuf":
            raise InvalidInputError(f"{name} must hold real numbers, got dtype {P.dtype}")
        return sp.csr_matrix(P, dtype=float), _given_dtype(P.dtype)
    arr = as_float_array(P, name)
    if arr.ndim != 2:
        raise InvalidInputError(f"{name} must be a 2-D S x S matrix, got shape {arr.shape}")
    return sp.csr_matrix(arr), _given_dtype(getattr(np.asarray(P), "dtype", None))


def _given_dtype(dtype: Any) -> np.dtype[Any]:
    """``dtype`` if a float type coarser than float64, else float64 (exact ints, bools)."""
    if isinstance(dtype, np.dtype) and dtype.kind == "f" and np.finfo(dtype).eps > EPS64:
        return dtype
    return np.dtype(np.float64)


def integer_array(x: Any, name: str) -> np.ndarray:
    """An integer array; floats only when integral (``1.7`` was truncated to 1), no bools."""
    raw = np.asarray(x) if not isinstance(x, (str, bytes)) else np.asarray(None)
    if raw.dtype.kind in "iu":
        return raw.astype(np.intp)
    if raw.dtype.kind == "b":
        raise InvalidInputError(f"{name} must hold integers, got booleans")
    arr = as_float_array(x, name)
    if not (np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))):
        raise InvalidInputError(f"{name} must hold integers, got {arr.ravel()[:10].tolist()}")
    return arr.astype(np.intp)


def make_mdp(
    transitions: Sequence[Any],
    rewards: Any,
    gamma: float,
    *,
    state_names: Sequence[str] = (),
    action_names: Sequence[str] = (),
    tolerance: float = 1e-9,
) -> MDP:
    """Validate and build an :class:`MDP`.

    Args:
        transitions: ``A`` matrices ``S x S`` (dense or sparse), or a dense ``A x S x S`` array.
        rewards: ``R[s, a]`` (S x A), or (S,) for a reward that does not depend on the action.
        gamma: discount factor in ``[0, 1]``.
        state_names, action_names: optional labels.
        tolerance: allowed deviation of the row sums from 1. A row given in floats of machine
            epsilon ``eps`` with ``k`` nonzeros may deviate by ``max(tolerance, k eps)``: the
            rounding of its ``k`` entries (float32 rows normalised in float32 deviate by up to
            ~1e-7, float16 rows by ~1e-3; float64 rows by ``k 2.2e-16``, below the default
            up to 4.5 million nonzeros). Such rows are stored in float64 as given, not
            renormalised.

    Raises:
        InvalidInputError: shapes, negative probabilities, rows not summing to 1, gamma out of
            ``[0, 1]``, or non-finite rewards.
    """
    if isinstance(transitions, (str, bytes)) or not hasattr(transitions, "__iter__"):
        raise InvalidInputError(
            "transitions must be a sequence of S x S matrices (one per action) or an A x S x S "
            f"array, got {type(transitions).__name__}"
        )
    tolerance = check_positive(tolerance, "tolerance", strict=False)  # NaN passed every row
    given = [_transition_matrix(P, a) for a, P in enumerate(transitions)]
    mats = [P for P, _ in given]
    if not mats:
        raise InvalidInputError("an MDP needs at least one action (one transition matrix)")
    S = mats[0].shape[0]
    if S == 0:
        raise InvalidInputError(
            "an MDP needs at least one state (the transition matrices are 0 x 0)"
        )
    for a, P in enumerate(mats):
        if P.shape != (S, S):
            raise InvalidInputError(
                f"transition matrix of action {a} must be {S} x {S}, got {P.shape}"
            )
        if P.nnz and not np.all(np.isfinite(P.data)):  # NaN passed both checks below
            raise InvalidInputError(f"transition matrix of action {a} has non-finite probabilities")
        if P.nnz and P.data.min() < 0:
            raise InvalidInputError(f"transition matrix of action {a} has negative probabilities")
        sums = np.asarray(P.sum(axis=1)).ravel()
        dtype = given[a][1]
        allowed = np.maximum(tolerance, np.diff(P.indptr) * float(np.finfo(dtype).eps))
        bad = np.flatnonzero(np.abs(sums - 1.0) > allowed)
        if bad.size:
            raise InvalidInputError(
                f"rows {bad[:10].tolist()} of the transition matrix of action {a} sum to "
                f"{sums[bad[:10]].tolist()}, not 1 within the tolerance "
                f"{allowed[bad[:10]].tolist()} (max(tolerance={tolerance:g}, nonzeros x eps "
                f"of {dtype})); every state needs a successor distribution; make terminal "
                "states absorbing with P[s, s] = 1 and zero reward"
            )
    R = as_float_array(rewards, "rewards")
    if R.ndim == 1:
        R = np.repeat(R[:, None], len(mats), axis=1)
    if R.shape != (S, len(mats)):
        raise InvalidInputError(f"rewards must have shape ({S}, {len(mats)}), got {R.shape}")
    if not np.all(np.isfinite(R)):
        raise InvalidInputError("rewards must be finite")
    gamma = as_scalar(gamma, "gamma")
    if not 0.0 <= gamma <= 1.0:
        raise InvalidInputError(f"gamma must be in [0, 1], got {gamma}")
    if state_names and len(state_names) != S:
        raise InvalidInputError(f"need {S} state names, got {len(state_names)}")
    if action_names and len(action_names) != len(mats):
        raise InvalidInputError(f"need {len(mats)} action names, got {len(action_names)}")
    return MDP(
        transitions=tuple(mats),
        rewards=R,
        gamma=float(gamma),
        state_names=tuple(state_names),
        action_names=tuple(action_names),
    )


def deterministic_mdp(
    successors: Any,
    rewards: Any,
    gamma: float,
    *,
    state_names: Sequence[str] = (),
    action_names: Sequence[str] = (),
) -> MDP:
    """MDP from a successor table ``next[s, a]`` (deterministic transitions).

    Args:
        successors: integer array (S x A), the state reached from ``s`` with action ``a``.
        rewards: ``R[s, a]`` (S x A) or (S,).
        gamma: discount factor.
        state_names, action_names: optional labels.
    """
    nxt = integer_array(successors, "successors")
    if nxt.ndim != 2:
        raise InvalidInputError(f"successors must be an S x A integer table, got shape {nxt.shape}")
    S, A = nxt.shape
    if nxt.min(initial=0) < 0 or nxt.max(initial=0) >= S:
        raise InvalidInputError(f"successor indices must be in [0, {S})")
    mats = [sp.csr_matrix((np.ones(S), (np.arange(S), nxt[:, a])), shape=(S, S)) for a in range(A)]
    return make_mdp(mats, rewards, gamma, state_names=state_names, action_names=action_names)


def grid_world(
    layout: Sequence[str],
    *,
    gamma: float,
    step_reward: float = 0.0,
    slip: float = 0.0,
) -> tuple[MDP, dict[tuple[int, int], int]]:
    """A grid world from a text layout (4 actions up, down, left, right).

    Characters: ``.`` free cell, ``#`` wall, ``S`` start (free), ``G`` terminal goal (reward
    +1), ``X`` terminal trap (reward -1). Entering a
    terminal cell pays its reward once; terminal cells are absorbing with zero reward. Moving
    into a wall or off the grid stays in place. With ``slip > 0`` the move goes to one of the two
    perpendicular directions with probability ``slip / 2`` each.

    ``layout``: the rows, top first (a list of strings), or one string whose lines are the
    rows (``"S.G"`` is one row of three cells; two lines make two rows).

    Returns:
        The MDP and the map ``(row, col) -> state index``.
    """
    if not 0.0 <= slip <= 1.0:
        raise InvalidInputError(f"slip must be in [0, 1], got {slip}")
    if isinstance(layout, str):  # iterating it would make each character a row
        layout = layout.splitlines()
    cells: dict[tuple[int, int], int] = {}
    for r, line in enumerate(layout):
        for c, ch in enumerate(line):
            if ch not in ".#SGX":
                raise InvalidInputError(f"unknown grid character {ch!r}; valid ones are: . # S G X")
            if ch != "#":
                cells[(r, c)] = len(cells)
    S = len(cells)
    moves = [(-1, 0), (1, 0), (0, -1), (0, 1)]
    perpendicular = {0: (2, 3), 1: (2, 3), 2: (0, 1), 3: (0, 1)}
    terminal_reward = {"G": 1.0, "X": -1.0}
    mats = []
    R = np.zeros((S, 4))
    for a in range(4):
        P = sp.lil_matrix((S, S))
        for (r, c), s in cells.items():
            ch = layout[r][c]
            if ch in terminal_reward:
                P[s, s] = 1.0
                continue
            outcomes = [(a, 1.0 - slip)] + [(b, slip / 2) for b in perpendicular[a]]
            for b, prob in outcomes:
                if prob == 0.0:
                    continue
                dr, dc = moves[b]
                target = (r + dr, c + dc)
                s2 = cells.get(target, s)
                P[s, s2] += prob
                tch = layout[target[0]][target[1]] if target in cells else "."
                R[s, a] += prob * (terminal_reward.get(tch, 0.0) + step_reward)
        mats.append(P.tocsr())
    return make_mdp(mats, R, gamma, action_names=("up", "down", "left", "right")), cells


def t_maze(
    *,
    gamma: float = 0.5,
    stem: int = 3,
    left: tuple[int, float] = (1, 1.0),
    right: tuple[int, float] = (2, 3.0),
) -> MDP:
    """A deterministic T-maze: a stem from the start to the junction, then two rewarded arms.

    States: ``stem0`` (start) ... ``stem{stem-1}`` (the junction), ``left1`` ... ``left{k}``,
    ``right1`` ... ``right{k}`` (the last cell of each arm is terminal and absorbing). Actions
    ``forward``, ``left``, ``right``: in the stem ``forward`` moves towards the junction,
    ``left``/``right`` at the junction enter the arms and move along them; an impossible move
    stays in place. Entering an arm's terminal cell pays its reward.

    A reconstruction: the lecture notes' T-maze exercise (Toussaint, Introduction to Robotics,
    2013/14, chapter 10 and the exercises) is not in the project's copy of the notes, which
    ends in chapter 7. Only ``gamma = 0.5`` comes from issue #18; the layout, the arm lengths
    and the rewards are our choice (their exact values are in the tests).

    Args:
        gamma: discount (0.5 in issue #18).
        stem: number of stem cells (>= 1).
        left: (length, reward) of the left arm.
        right: (length, reward) of the right arm.
    """
    # 2.5 or NaN cells were bare TypeErrors from range(), True a one-cell stem
    stem = check_count(stem, "stem", minimum=1)
    arms: list[tuple[int, float]] = []
    for side, pair in (("left", left), ("right", right)):
        if isinstance(pair, (str, bytes)) or not hasattr(pair, "__len__") or len(pair) != 2:
            raise InvalidInputError(f"{side} must be a (length, reward) pair, got {pair!r}")
        arms.append((check_count(pair[0], f"{side} arm length", minimum=1), pair[1]))
    left, right = arms[0], arms[1]
    names = [f"stem{i}" for i in range(stem)]
    names += [f"left{i + 1}" for i in range(left[0])] + [f"right{i + 1}" for i in range(right[0])]
    index = {n: i for i, n in enumerate(names)}
    S, A = len(names), 3
    nxt = np.tile(np.arange(S)[:, None], (1, A))
    R = np.zeros((S, A))
    for i in range(stem - 1):
        nxt[index[f"stem{i}"], 0] = index[f"stem{i + 1}"]
    junction = index[f"stem{stem - 1}"]
    for a, (arm, (length, reward)) in enumerate((("left", left), ("right", right)), start=1):
        prev = junction
        for k in range(1, length + 1):
            cell = index[f"{arm}{k}"]
            nxt[prev, a] = cell
            if k == length:
                R[prev, a] = reward
            prev = cell
    return deterministic_mdp(
        nxt, R, gamma, state_names=names, action_names=("forward", "left", "right")
    )
