"""Continuous-state optimal control problems for fitted value iteration (vectorized).

Each problem gives the dynamics ``f(X, U)`` and running cost ``l(X, U)`` of
:mod:`taskspace.optimal_control.fitted_value_iteration` for batches of states (K x d) and
actions (K x m).

Thread safety: the problems are immutable values (frozen dataclasses) whose methods are functions
of their arguments, so they may be shared by threads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskspace._validation import FloatArray, check_positive
from taskspace.dynamics.pendulum import STANDARD_GRAVITY, pendulum_acceleration


def wrap_angle(x: FloatArray) -> FloatArray:
    """Angles wrapped to ``[-pi, pi)`` [rad]."""
    return np.asarray(np.mod(np.asarray(x) + np.pi, 2 * np.pi) - np.pi, dtype=float)


@dataclass(frozen=True, kw_only=True)
class DoubleIntegrator:
    """Double integrator ``x1' = x2``, ``x2' = u`` (a unit point mass).

    Quadratic cost ``l = q1 x1^2 + q2 x2^2 + r u^2``.

    Attributes:
        q: state weights ``(q1, q2)``.
        r: input weight.
    """

    q: tuple[float, float] = (1.0, 1.0)
    r: float = 1.0

    def dynamics(self, X: FloatArray, U: FloatArray) -> FloatArray:
        """``[x2, u]`` (K x 2)."""
        return np.stack([X[:, 1], U[:, 0]], axis=1)

    def cost(self, X: FloatArray, U: FloatArray) -> FloatArray:
        """``q1 x1^2 + q2 x2^2 + r u^2`` [1/s] (K,)."""
        return self.q[0] * X[:, 0] ** 2 + self.q[1] * X[:, 1] ** 2 + self.r * U[:, 0] ** 2

    @staticmethod
    def unit_cost(X: FloatArray, U: FloatArray) -> FloatArray:
        """Cost 1 per second: minimum time."""
        return np.ones(X.shape[0])

    @property
    def A(self) -> FloatArray:
        """Linear system matrix."""
        return np.array([[0.0, 1.0], [0.0, 0.0]])

    @property
    def B(self) -> FloatArray:
        """Linear input matrix."""
        return np.array([[0.0], [1.0]])


def min_time_switching_curve(velocity: FloatArray) -> FloatArray:
    """Switching curve ``x1 = -x2 |x2| / 2`` of the minimum-time double integrator.

    With ``|u| <= 1``: above the curve ``u = -1``, below it ``u = +1``.
    """
    v = np.asarray(velocity, dtype=float)
    return -0.5 * v * np.abs(v)


def min_time(X: FloatArray) -> FloatArray:
    """Analytic minimum time to the origin of ``x'' = u``, ``|u| <= 1`` [s] (K,).

    Above the switching curve (``s = x1 + x2 |x2| / 2 > 0``): ``T = x2 + 2 sqrt(x1 + x2^2/2)``;
    below: ``T = -x2 + 2 sqrt(-x1 + x2^2/2)``.
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    x1, x2 = X[:, 0], X[:, 1]
    s = x1 + 0.5 * x2 * np.abs(x2)
    up = x2 + 2.0 * np.sqrt(np.maximum(x1 + 0.5 * x2**2, 0.0))
    down = -x2 + 2.0 * np.sqrt(np.maximum(-x1 + 0.5 * x2**2, 0.0))
    return np.asarray(np.where(s > 0, up, down), dtype=float)


@dataclass(frozen=True, kw_only=True)
class PendulumSwingUp:
    """Pendulum swing-up: ``(m l^2) theta'' = u - m g l sin theta``.

    ``theta = 0`` hanging, ``pi`` upright; state ``(theta, theta')``; cost
    ``q1 wrap(theta - pi)^2 + q2 theta'^2 + r u^2``.

    The dynamics are :func:`taskspace.dynamics.pendulum.pendulum_acceleration` (the registry's
    ``pendulum`` robot: 1 kg at 1 m).

    Attributes:
        mass: [kg]; length: [m]; gravity: [m/s^2].
        q: state weights; r: input weight.
    """

    mass: float = 1.0
    length: float = 1.0
    gravity: float = STANDARD_GRAVITY
    q: tuple[float, float] = (1.0, 0.1)
    r: float = 0.01

    def __post_init__(self) -> None:
        check_positive(self.mass, "mass [kg]")
        check_positive(self.length, "length [m]")

    def dynamics(self, X: FloatArray, U: FloatArray) -> FloatArray:
        """``[theta', theta'']`` (K x 2)."""
        acc = pendulum_acceleration(
            X[:, 0], U[:, 0], mass=self.mass, length=self.length, gravity=self.gravity
        )
        return np.stack([X[:, 1], acc], axis=1)

    def cost(self, X: FloatArray, U: FloatArray) -> FloatArray:
        """Quadratic cost about the upright [1/s] (K,)."""
        d = wrap_angle(X[:, 0] - np.pi)
        return self.q[0] * d**2 + self.q[1] * X[:, 1] ** 2 + self.r * U[:, 0] ** 2

    def linearization(self) -> tuple[FloatArray, FloatArray]:
        """``(A, B)`` about the upright in ``(theta - pi, theta')``."""
        inertia = self.mass * self.length**2
        A = np.array([[0.0, 1.0], [self.gravity / self.length, 0.0]])
        B = np.array([[0.0], [1.0 / inertia]])
        return A, B


def cartpole_acceleration(
    q: FloatArray,
    v: FloatArray,
    force: FloatArray,
    *,
    cart_mass: float = 1.0,
    pole_mass: float = 0.1,
    length: float = 0.5,
    gravity: float = STANDARD_GRAVITY,
) -> FloatArray:
    """Closed-form accelerations (N x 2) of the registry's cart-pole for batches of q, v (N x 2).

    ``q = (x, theta)``, ``theta`` about +y with 0 upright, a point-mass pole:
    ``M(q) a = [F, 0] - h`` with ``M = [[M + m, m l cos th], [m l cos th, m l^2]]`` and
    ``h = [-m l sin(th) th'^2, -m g l sin th]`` (the URDF's ABA gives the same, see the tests).
    """
    th, w = q[:, 1], v[:, 1]
    c, s = np.cos(th), np.sin(th)
    m, M, l = pole_mass, cart_mass, length
    m11, m22 = M + m, m * l * l  # constant entries of the mass matrix
    m12 = (m * l) * c
    b1 = force + (m * l) * s * w * w
    b2 = (m * gravity * l) * s
    inv_det = 1.0 / (m11 * m22 - m12 * m12)
    return np.stack([(m22 * b1 - m12 * b2) * inv_det, (m11 * b2 - m12 * b1) * inv_det], axis=1)


@dataclass(frozen=True, kw_only=True)
class CartPoleBalance:
    """Cart-pole balancing: state ``(x, theta, x', theta')`` (0 upright), input the force [N].

    Cost ``x^T diag(q) x + r F^2``.

    Attributes:
        q: state weights (4,); r: input weight.
    """

    q: tuple[float, float, float, float] = (1.0, 10.0, 0.1, 0.1)
    r: float = 0.01

    def dynamics(self, X: FloatArray, U: FloatArray) -> FloatArray:
        """``[x', theta', x'', theta'']`` (K x 4)."""
        acc = cartpole_acceleration(X[:, :2], X[:, 2:], U[:, 0])
        return np.concatenate([X[:, 2:], acc], axis=1)

    def cost(self, X: FloatArray, U: FloatArray) -> FloatArray:
        """Quadratic cost [1/s] (K,)."""
        return np.asarray(X**2 @ np.asarray(self.q) + self.r * U[:, 0] ** 2, dtype=float)
