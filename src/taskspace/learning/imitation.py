"""Imitation learning by behaviour cloning: regress the demonstrator's actions on the states.

For a policy linear in its parameters, ``a = Phi(s) theta`` (:class:`~taskspace.learning.
policies.Policy`), behaviour cloning is the (ridge) least-squares problem

``min_theta sum_k |Phi(s_k) theta - a_k|^2 + lambda |theta|^2``,

solved from the stacked features. Demonstrations from a linear controller ``a = K s`` are
reproduced exactly by a :class:`LinearPolicy` when the states span the state space.

Thread safety: the functions keep their state local to the call and may run from several
threads; :class:`BehaviourCloningResult` is plain result data, not locked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array
from taskspace.errors import InvalidInputError
from taskspace.learning.policies import Policy


@dataclass
class BehaviourCloningResult:
    """Result of :func:`behaviour_cloning`.

    Attributes:
        parameters: fitted ``theta`` (p,).
        residual_rms: root-mean-square action error on the demonstrations.
        rank: rank of the stacked feature matrix (< p: the demonstrations do not determine
            ``theta``; the ridge term picks the minimum-norm solution).
    """

    parameters: FloatArray
    residual_rms: float
    rank: int


def behaviour_cloning(
    policy: Policy, states: Any, actions: Any, *, regularization: float = 0.0
) -> BehaviourCloningResult:
    """Fit ``theta`` so that ``policy.mean_action(theta, s_k) ~ a_k``.

    Args:
        policy: a policy linear in its parameters.
        states: demonstrated states (K x n).
        actions: demonstrated actions (K x m) (or (K,) for one input).
        regularization: ridge weight ``lambda`` (>= 0).

    Raises:
        InvalidInputError: shapes or non-finite data.
    """
    if not isinstance(policy, Policy):  # a str was a bare AttributeError
        raise InvalidInputError(
            f"policy must be a Policy (LinearPolicy, RBFPolicy...), got {type(policy).__name__}"
        )
    S = np.atleast_2d(as_float_array(states, "states"))  # complex: refused, not truncated
    A = as_float_array(actions, "actions")
    if A.ndim == 1:
        A = A[:, None]
    if S.shape[0] != A.shape[0] or A.shape[1] != policy.action_dim or S.shape[0] == 0:
        raise InvalidInputError(
            f"need as many states as actions with {policy.action_dim} action columns; got "
            f"states {S.shape} and actions {A.shape}"
        )
    if not (np.all(np.isfinite(S)) and np.all(np.isfinite(A))) or regularization < 0:
        raise InvalidInputError("demonstrations must be finite and regularization >= 0")
    Phi = np.vstack([policy.features(s) for s in S])
    y = A.reshape(-1)
    rank = int(np.linalg.matrix_rank(Phi))
    p = Phi.shape[1]
    if regularization > 0:
        theta = np.linalg.solve(Phi.T @ Phi + regularization * np.eye(p), Phi.T @ y)
    else:
        theta = np.linalg.lstsq(Phi, y, rcond=None)[0]
    res = Phi @ theta - y
    return BehaviourCloningResult(
        parameters=np.asarray(theta, dtype=float),
        residual_rms=float(np.sqrt(np.mean(res**2))),
        rank=rank,
    )
