"""Parametric policies ``a = Phi(s) theta`` (linear in the parameters) with Gaussian exploration.

One interface for every policy-search method: ``features(s)`` gives the (m x p) matrix
``Phi(s)`` with ``a = Phi(s) theta``; the stochastic policy adds action noise,
``a ~ N(Phi(s) theta, sigma^2 I)``, whose log-likelihood gradient is

``d/dtheta log pi(a | s) = Phi(s)^T (a - Phi(s) theta) / sigma^2``.

* :class:`LinearPolicy`: ``Phi(s) = kron(I_m, [s, 1])`` (a gain matrix and optional bias).
* :class:`RBFPolicy`: normalized Gaussian radial basis functions of the state,
  ``phi_j(s) = exp(-|s - c_j|^2 / (2 w^2)) / sum_k exp(...)``, ``Phi(s) = kron(I_m, phi(s)^T)``.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from taskspace._validation import FloatArray, check_positive
from taskspace.errors import InvalidInputError


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
        """``Phi(s) theta`` (m,)."""
        return np.asarray(theta, dtype=float).reshape(self.action_dim, -1) @ self.basis(state)

    def log_likelihood_gradient(
        self, theta: FloatArray, state: FloatArray, action: FloatArray, sigma: float
    ) -> FloatArray:
        """``Phi(s)^T (a - Phi(s) theta) / sigma^2`` (p,)."""
        phi = self.basis(state)
        err = (np.asarray(action, dtype=float) - self.mean_action(theta, state)) / sigma**2
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

    @property
    def num_parameters(self) -> int:
        """``m (n + bias)``."""
        return self.action_dim * (self.state_dim + int(self.bias))

    def basis(self, state: FloatArray) -> FloatArray:
        """``[s, 1]`` or ``s``."""
        s = np.asarray(state, dtype=float).ravel()
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
        self.centers = np.atleast_2d(np.asarray(self.centers, dtype=float))
        check_positive(self.width, "width")
        self.state_dim = int(self.centers.shape[1])

    @property
    def num_parameters(self) -> int:
        """``m k``."""
        return self.action_dim * int(self.centers.shape[0])

    def basis(self, state: FloatArray) -> FloatArray:
        """Normalized RBF activations (k,)."""
        d2 = np.sum((self.centers - np.asarray(state, dtype=float).ravel()) ** 2, axis=1)
        g = np.exp(-0.5 * (d2 - d2.min()) / self.width**2)
        return np.asarray(g / g.sum(), dtype=float)
