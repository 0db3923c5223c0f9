"""Probabilistic motion models of a planar mobile robot (slides 7:5-7:7, 7:16-7:17).

The pose is ``x = (p_x, p_y, theta)`` [m, m, rad]. Each model gives the transition density
``P(x_{t+1} | u_t, x_t)`` of slide 7:7 in three forms: the noise-free mean ``f(x, u)``, its
Jacobians (for the EKF), and samples (for the particle filter). Noise enters through the
controls, ``u_hat ~ N(u, M(u))``, so the state-space covariance is ``Q = V M V^T`` with
``V = df/du``. All functions accept one pose ``(3,)`` or a batch ``(N, 3)``.

Thread safety: the models are immutable values (frozen dataclasses) and their methods are functions
of their arguments, so they may be shared by threads; ``sample`` draws from the generator it is
given (one generator per thread: a numpy ``Generator`` is not thread-safe).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_vector,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError, ShapeError


def wrap_angle(a: Any) -> Any:
    """Wrap angles to ``[-pi, pi)`` [rad]."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


def _poses(x: Any) -> FloatArray:
    arr = as_float_array(x, "x")
    if arr.shape[-1:] != (3,) or arr.ndim > 2:
        raise ShapeError("x", (-1, 3), tuple(arr.shape))
    check_finite(arr, "x")  # a NaN pose or control gave a NaN successor silently
    return arr


def _controls(u: Any, k: int) -> FloatArray:
    arr = as_float_array(u, "u")
    if arr.shape[-1:] != (k,) or arr.ndim > 2:
        raise ShapeError("u", (-1, k), tuple(arr.shape))
    check_finite(arr, "u")
    return arr


def _check_fields(model: Any, positive: tuple[str, ...], non_negative: tuple[str, ...]) -> None:
    """Validate a frozen model's numeric fields at construction (stored back as floats).

    Before, nothing was checked: ``dt=NaN`` gave NaN poses, ``dt="x"`` or ``alphas=(1, 2)``
    a bare TypeError/ValueError at the first use, a negative ``dt`` ran the model backward
    and negative noise coefficients or stds were accepted.
    """
    for name in positive:
        object.__setattr__(model, name, check_positive(getattr(model, name), name))
    for name in non_negative:
        object.__setattr__(model, name, check_positive(getattr(model, name), name, strict=False))
    if hasattr(model, "alphas"):
        alphas = model.alphas
        values = as_float_array(alphas, "alphas")
        if values.shape != (4,) or not np.all(np.isfinite(values)) or np.any(values < 0):
            raise InvalidInputError(
                f"alphas must be four finite noise coefficients >= 0, got {alphas!r}"
            )
        object.__setattr__(model, "alphas", tuple(float(a) for a in values))


@dataclass(frozen=True, kw_only=True)
class VelocityMotionModel:
    """Velocity motion model: the robot follows an arc with speed ``v`` and turn rate ``w``.

    ``u = (v, w)`` [m/s, rad/s]. Mean (exact arc; straight line when ``|w|`` is tiny):
    ``p' = p + (v/w) (sin(theta + w dt) - sin theta, cos theta - cos(theta + w dt))``,
    ``theta' = theta + w dt``. Control noise ``M = diag(a1 v^2 + a2 w^2, a3 v^2 + a4 w^2)
    + diag(sigma_v^2, sigma_w^2)``.

    Attributes:
        dt: time step [s].
        alphas: ``(a1, a2, a3, a4)`` control-dependent noise coefficients.
        sigma_v: constant speed noise std [m/s].
        sigma_w: constant turn-rate noise std [rad/s].
    """

    dt: float = 0.1
    alphas: tuple[float, float, float, float] = (0.01, 0.001, 0.001, 0.01)
    sigma_v: float = 0.02
    sigma_w: float = 0.01

    def __post_init__(self) -> None:
        _check_fields(self, ("dt",), ("sigma_v", "sigma_w"))

    def control_covariance(self, u: Any) -> FloatArray:
        """``M(u)``: ``(2, 2)`` covariance of the executed control."""
        v, w = as_vector(u, 2, "u")
        a1, a2, a3, a4 = self.alphas
        return np.diag(
            [a1 * v * v + a2 * w * w + self.sigma_v**2, a3 * v * v + a4 * w * w + self.sigma_w**2]
        )

    def mean(self, x: Any, u: Any) -> FloatArray:
        """Noise-free successor pose(s) ``f(x, u)``; ``u`` is ``(2,)`` or ``(N, 2)``."""
        X = _poses(x)
        U = _controls(u, 2)
        v, w = U[..., 0], U[..., 1]
        th = X[..., 2]
        dt = self.dt
        # For |w dt| < 1e-5 the arc formula cancels badly; its 2nd-order expansion
        # p' = p + v dt (cos th - w dt/2 sin th, sin th + w dt/2 cos th) is exact to 1e-10.
        small = np.abs(w * dt) < 1e-5
        ws = np.where(small, 1.0, w)
        th2 = th + w * dt
        c, s = np.cos(th), np.sin(th)
        h = 0.5 * w * dt
        dx = np.where(small, v * dt * (c - h * s), v / ws * (np.sin(th2) - s))
        dy = np.where(small, v * dt * (s + h * c), v / ws * (c - np.cos(th2)))
        return np.stack([X[..., 0] + dx, X[..., 1] + dy, wrap_angle(th2)], axis=-1)

    def jacobians(self, x: Any, u: Any) -> tuple[FloatArray, FloatArray]:
        """``F = df/dx`` ``(3, 3)`` and ``V = df/du`` ``(3, 2)`` at one pose."""
        _, _, th = as_vector(x, 3, "x")
        v, w = as_vector(u, 2, "u")
        dt = self.dt
        F = np.eye(3)
        V = np.zeros((3, 2))
        if abs(w * dt) < 1e-5:
            c, s = np.cos(th), np.sin(th)
            h = 0.5 * w * dt
            F[0, 2], F[1, 2] = -v * dt * (s + h * c), v * dt * (c - h * s)
            V[0] = [dt * (c - h * s), -0.5 * v * dt * dt * s]
            V[1] = [dt * (s + h * c), 0.5 * v * dt * dt * c]
        else:
            th2 = th + w * dt
            s1, c1, s2, c2 = np.sin(th), np.cos(th), np.sin(th2), np.cos(th2)
            F[0, 2] = v / w * (c2 - c1)
            F[1, 2] = v / w * (s2 - s1)
            V[0] = [(s2 - s1) / w, -v * (s2 - s1) / w**2 + v * c2 * dt / w]
            V[1] = [(c1 - c2) / w, v * (c2 - c1) / w**2 + v * s2 * dt / w]
        V[2, 1] = dt
        return F, V

    def state_covariance(self, x: Any, u: Any) -> FloatArray:
        """Process noise in state space ``Q = V M V^T`` (for the EKF)."""
        _, V = self.jacobians(x, u)
        return V @ self.control_covariance(u) @ V.T + 1e-12 * np.eye(3)

    def sample(self, x: Any, u: Any, rng: np.random.Generator) -> FloatArray:
        """Samples ``x' ~ P(x' | u, x)`` for every pose in ``x`` (vectorized)."""
        X = _poses(x)
        uv = as_vector(u, 2, "u")
        std = np.sqrt(np.diag(self.control_covariance(uv)))
        shape = (*X.shape[:-1], 2)
        return self.mean(X, uv + rng.standard_normal(shape) * std)


@dataclass(frozen=True, kw_only=True)
class OdometryMotionModel:
    """Odometry motion model: relative motion measured by wheel encoders (slide 7:17).

    ``u = (rot1, trans, rot2)`` [rad, m, rad]: turn, drive straight, turn. Mean
    ``p' = p + trans (cos(theta + rot1), sin(theta + rot1))``, ``theta' = theta + rot1 + rot2``.
    Noise (Thrun et al.): ``rot1 ~ N(rot1, a1 rot1^2 + a2 trans^2)``,
    ``trans ~ N(trans, a3 trans^2 + a4 (rot1^2 + rot2^2))``,
    ``rot2 ~ N(rot2, a1 rot2^2 + a2 trans^2)``.

    Attributes:
        alphas: ``(a1, a2, a3, a4)`` noise coefficients.
        min_std: floor on each standard deviation [rad or m].
    """

    alphas: tuple[float, float, float, float] = (0.01, 0.001, 0.01, 0.001)
    min_std: float = 1e-4

    def __post_init__(self) -> None:
        _check_fields(self, (), ("min_std",))

    @staticmethod
    def odometry_from_poses(x_prev: Any, x_next: Any) -> FloatArray:
        """Control ``u = (rot1, trans, rot2)`` that moves ``x_prev`` to ``x_next``."""
        a = as_vector(x_prev, 3, "x_prev")
        b = as_vector(x_next, 3, "x_next")
        d = b[:2] - a[:2]
        trans = float(np.hypot(*d))
        rot1 = float(wrap_angle(np.arctan2(d[1], d[0]) - a[2])) if trans > 1e-12 else 0.0
        rot2 = float(wrap_angle(b[2] - a[2] - rot1))
        return np.array([rot1, trans, rot2])

    def control_covariance(self, u: Any) -> FloatArray:
        """``(3, 3)`` diagonal covariance of ``(rot1, trans, rot2)``."""
        r1, t, r2 = as_vector(u, 3, "u")
        a1, a2, a3, a4 = self.alphas
        var = np.array(
            [
                a1 * r1 * r1 + a2 * t * t,
                a3 * t * t + a4 * (r1 * r1 + r2 * r2),
                a1 * r2 * r2 + a2 * t * t,
            ]
        )
        return np.diag(np.maximum(var, self.min_std**2))

    def mean(self, x: Any, u: Any) -> FloatArray:
        """Noise-free successor pose(s); ``u`` is ``(3,)`` or ``(N, 3)``."""
        X = _poses(x)
        U = _controls(u, 3)
        r1, t, r2 = U[..., 0], U[..., 1], U[..., 2]
        h = X[..., 2] + r1
        return np.stack(
            [X[..., 0] + t * np.cos(h), X[..., 1] + t * np.sin(h), wrap_angle(h + r2)], axis=-1
        )

    def jacobians(self, x: Any, u: Any) -> tuple[FloatArray, FloatArray]:
        """``F = df/dx`` ``(3, 3)`` and ``V = df/du`` ``(3, 3)``."""
        _, _, th = as_vector(x, 3, "x")
        r1, t, _ = as_vector(u, 3, "u")
        c, s = np.cos(th + r1), np.sin(th + r1)
        F = np.array([[1.0, 0.0, -t * s], [0.0, 1.0, t * c], [0.0, 0.0, 1.0]])
        V = np.array([[-t * s, c, 0.0], [t * c, s, 0.0], [1.0, 0.0, 1.0]])
        return F, V

    def state_covariance(self, x: Any, u: Any) -> FloatArray:
        """``Q = V M V^T``."""
        _, V = self.jacobians(x, u)
        return V @ self.control_covariance(u) @ V.T + 1e-12 * np.eye(3)

    def sample(self, x: Any, u: Any, rng: np.random.Generator) -> FloatArray:
        """Samples ``x' ~ P(x' | u, x)`` (vectorized over poses)."""
        X = _poses(x)
        uv = as_vector(u, 3, "u")
        std = np.sqrt(np.diag(self.control_covariance(uv)))
        return self.mean(X, uv + rng.standard_normal((*X.shape[:-1], 3)) * std)


@dataclass(frozen=True, kw_only=True)
class KinematicCarModel:
    """Kinematic car (bicycle) with speed and steering angle (slide 7:6).

    ``u = (v, delta)`` [m/s, rad]; ``x_{t+1} = x_t + dt f(x_t, u_t)`` with
    ``f = (v cos theta, v sin theta, v tan(delta) / L)`` (explicit Euler, slide 7:7).
    Noise ``N(0, diag(sigma_v^2, sigma_delta^2))`` on the controls.

    Attributes:
        dt: time step [s].
        wheelbase: distance ``L`` between the axles [m].
        sigma_v: speed noise std [m/s].
        sigma_delta: steering noise std [rad].
        max_steering: steering limit [rad] (controls are clipped).
    """

    dt: float = 0.1
    wheelbase: float = 2.5
    sigma_v: float = 0.1
    sigma_delta: float = 0.02
    max_steering: float = 0.6

    def __post_init__(self) -> None:
        # types were not checked ("x" gave a bare TypeError), nor the stds and the steering
        # limit (NaN gave NaN headings)
        _check_fields(self, ("dt", "wheelbase", "max_steering"), ("sigma_v", "sigma_delta"))

    def control_covariance(self, u: Any) -> FloatArray:
        """``(2, 2)`` control noise covariance."""
        return np.diag([self.sigma_v**2, self.sigma_delta**2])

    def mean(self, x: Any, u: Any) -> FloatArray:
        """Noise-free successor pose(s)."""
        X = _poses(x)
        U = _controls(u, 2)
        v = U[..., 0]
        d = np.clip(U[..., 1], -self.max_steering, self.max_steering)
        th = X[..., 2]
        return np.stack(
            [
                X[..., 0] + self.dt * v * np.cos(th),
                X[..., 1] + self.dt * v * np.sin(th),
                wrap_angle(th + self.dt * v * np.tan(d) / self.wheelbase),
            ],
            axis=-1,
        )

    def jacobians(self, x: Any, u: Any) -> tuple[FloatArray, FloatArray]:
        """``F = df/dx`` ``(3, 3)`` and ``V = df/du`` ``(3, 2)``.

        Of the mean, which clips the steering: beyond ``max_steering`` the heading does not
        depend on ``delta`` (its column is 0 there) and the speed acts through the clipped
        angle (the unclipped one gave a wrong ``V``, and a wrong EKF process noise, whenever
        the command saturated).
        """
        _, _, th = as_vector(x, 3, "x")
        v, d = as_vector(u, 2, "u")
        dt, L = self.dt, self.wheelbase
        c, s = np.cos(th), np.sin(th)
        dc = float(np.clip(d, -self.max_steering, self.max_steering))
        d_heading_d_delta = dt * v / (L * np.cos(dc) ** 2) if abs(d) <= self.max_steering else 0.0
        F = np.array([[1.0, 0.0, -dt * v * s], [0.0, 1.0, dt * v * c], [0.0, 0.0, 1.0]])
        V = np.array([[dt * c, 0.0], [dt * s, 0.0], [dt * np.tan(dc) / L, d_heading_d_delta]])
        return F, V

    def state_covariance(self, x: Any, u: Any) -> FloatArray:
        """``Q = V M V^T``."""
        _, V = self.jacobians(x, u)
        return V @ self.control_covariance(u) @ V.T + 1e-12 * np.eye(3)

    def sample(self, x: Any, u: Any, rng: np.random.Generator) -> FloatArray:
        """Samples ``x' ~ P(x' | u, x)`` (vectorized over poses)."""
        X = _poses(x)
        uv = as_vector(u, 2, "u")
        std = np.array([self.sigma_v, self.sigma_delta])
        return self.mean(X, uv + rng.standard_normal((*X.shape[:-1], 2)) * std)
