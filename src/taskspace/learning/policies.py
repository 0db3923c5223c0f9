"""Parametric policies ``a = Phi(s) theta`` (linear in the parameters) with Gaussian exploration.

One interface for every policy-search method: ``features(s)`` gives the (m x p) matrix
``Phi(s)`` with ``a = Phi(s) theta``; the stochastic policy adds action noise,
``a ~ N(Phi(s) theta, sigma^2 I)``, whose log-likelihood gradient is

``d/dtheta log pi(a | s) = Phi(s)^T (a - Phi(s) theta) / sigma^2``.

* :class:`LinearPolicy`: ``Phi(s) = kron(I_m, [s, 1])`` (a gain matrix and optional bias).
* :class:`RBFPolicy`: normalized Gaussian radial basis functions of the state,
  ``phi_j(s) = exp(-|s - c_j|^2 / (2 w^2)) / sum_k exp(...)``, ``Phi(s) = kron(I_m, phi(s)^T)``.

Thread safety: a policy is a description (dimensions, centres, widths) that its methods do not
change (the parameters ``theta`` are an argument), so one policy may be evaluated from several
threads; do not assign its fields while other threads use it.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    check_count,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError, ShapeError


class Policy(abc.ABC):
    """A policy linear in its parameters, ``a = Phi(s) theta``."""

    state_dim: int
    action_dim: int

    @property
    @abc.abstractmethod
    def num_parameters(self) -> int:
        """``p``."""

    @abc.abstractmethod
    def basis(self, state: FloatArray) -> FloatArray:
        """State features ``phi(s)`` (k,), with ``Phi(s) = kron(I_m, phi(s)^T)`` and p = m k."""

    def features(self, state: FloatArray) -> FloatArray:
        """``Phi(s)`` (m x p)."""
        return np.asarray(np.kron(np.eye(self.action_dim), self.basis(state)[None, :]), float)

    def mean_action(self, theta: FloatArray, state: FloatArray) -> FloatArray:
        """``Phi(s) theta`` (m,).

        Raises:
            InvalidInputError: ``theta`` or ``state`` of the wrong size, not finite real numbers.
        """
        th = as_float_array(theta, "theta")
        if th.size != self.num_parameters:
            raise InvalidInputError(
                f"policy parameters must be {self.num_parameters} finite numbers, got {th.size}"
            )
        return self._mean_action(th, state)

    def _mean_action(self, th: FloatArray, state: FloatArray) -> FloatArray:
        """``Phi(s) theta`` for ``th`` of the right size; a non-finite action raises.

        One check of the (small) action instead of checks of every input: a NaN or inf in
        ``theta`` or ``state`` (or an overflow) makes the action non-finite; then the culprit
        is named.
        """
        phi = self.basis(state)
        action = th.reshape(self.action_dim, -1) @ phi
        if not all(map(math.isfinite, action.tolist())):  # 0.3 us (a NumPy sum: 3 us)
            check_finite(np.ravel(th), "theta")
            check_finite(np.ravel(state), "state")
            raise InvalidInputError(
                f"the action overflowed ({action}); scale the parameters or the state down"
            )
        return np.asarray(action, dtype=float)

    def _state(self, state: FloatArray) -> FloatArray:
        """``state`` as a (state_dim,) vector (a wrong size was a bare matmul error)."""
        s = as_float_array(state, "state").ravel()
        if s.size != self.state_dim:
            raise ShapeError("state", (self.state_dim,), s.shape)
        return s

    def log_likelihood_gradient(
        self, theta: FloatArray, state: FloatArray, action: FloatArray, sigma: float
    ) -> FloatArray:
        """``Phi(s)^T (a - Phi(s) theta) / sigma^2`` (p,)."""
        phi = self.basis(state)
        sigma = check_positive(sigma, "sigma")  # 0 gave NaN gradients
        a = as_float_array(action, "action").ravel()
        if a.size != self.action_dim:
            raise ShapeError("action", (self.action_dim,), a.shape)
        err = (a - self.mean_action(theta, state)) / sigma**2
        return np.asarray(np.kron(err, phi), dtype=float)

    def check(self, theta: FloatArray) -> FloatArray:
        """``theta`` as a float vector of the right size, or :class:`InvalidInputError`."""
        th = np.asarray(theta, dtype=float).ravel()
        if th.size != self.num_parameters or not np.all(np.isfinite(th)):
            raise InvalidInputError(
                f"policy parameters must be {self.num_parameters} finite numbers, got {th.size}"
            )
        return th


@dataclass
class LinearPolicy(Policy):
    """``a = K s (+ b)``; parameters ``theta = vec([K, b])`` row by row (m x (n + bias)).

    Attributes:
        state_dim: ``n``; action_dim: ``m``; bias: add a constant feature.
    """

    state_dim: int
    action_dim: int
    bias: bool = False

    def __post_init__(self) -> None:
        # 2.5 or 0 dimensions were accepted and failed later in a reshape
        if not isinstance(self.bias, (bool, np.bool_)):
            raise InvalidInputError(f"bias must be True or False, got {self.bias!r}")
        check_count(self.state_dim, "state_dim", minimum=0 if self.bias else 1)
        check_count(self.action_dim, "action_dim", minimum=1)

    @property
    def num_parameters(self) -> int:
        """``m (n + bias)``."""
        return self.action_dim * (self.state_dim + int(self.bias))

    def basis(self, state: FloatArray) -> FloatArray:
        """``[s, 1]`` or ``s``."""
        s = self._state(state)
        return np.append(s, 1.0) if self.bias else s


@dataclass
class RBFPolicy(Policy):
    """Normalized Gaussian RBF features of the state.

    Attributes:
        centers: RBF centers (k x n).
        width: common width ``w`` (state units).
        action_dim: ``m``.
    """

    centers: FloatArray
    width: float
    action_dim: int = 1

    def __post_init__(self) -> None:
        self.centers = np.atleast_2d(as_float_array(self.centers, "centers"))
        if self.centers.ndim != 2 or self.centers.size == 0:
            raise InvalidInputError(f"centers must be (k x n), k, n >= 1, got {self.centers.shape}")
        check_finite(self.centers, "centers")  # NaN centers gave NaN features
        check_positive(self.width, "width")
        check_count(self.action_dim, "action_dim", minimum=1)
        self.state_dim = int(self.centers.shape[1])

    @property
    def num_parameters(self) -> int:
        """``m k``."""
        return self.action_dim * int(self.centers.shape[0])

    def basis(self, state: FloatArray) -> FloatArray:
        """Normalized RBF activations (k,)."""
        d2 = np.sum((self.centers - self._state(state)) ** 2, axis=1)
        g = np.exp(-0.5 * (d2 - d2.min()) / self.width**2)
        return np.asarray(g / g.sum(), dtype=float)
