"""Dynamic movement primitives (Ijspeert, Nakanishi, Hoffmann, Pastor, Schaal 2013).

Discrete DMP, per dimension, with phase ``x`` (1 -> 0), goal ``g`` and temporal scale
``tau`` [s]:

``tau z' = alpha_z (beta_z (g - y) - z) + f(x)``,  ``tau y' = z``,  ``tau x' = -alpha_x x``,

``f(x) = sum_i psi_i(x) w_i / sum_i psi_i(x) * x (g - y_0)``,
``psi_i(x) = exp(-h_i (x - c_i)^2)``.

With ``beta_z = alpha_z / 4`` the transformation system is a critically damped spring to
``g``, and ``f`` vanishes with ``x``: the motion converges to ``g`` from any start. Learning
from a demonstration ``y(t)`` (sampled at ``t_k``): the target forcing term
``f_k = tau^2 y''_k - alpha_z (beta_z (g - y_k) - tau y'_k)`` is fitted by (ridge) least
squares on the features ``x_k (g - y_0) psi(x_k) / sum psi(x_k)``.

Goal changes are filtered, ``g' = alpha_g (g_target - g)`` (the goal is a state of the DMP),
so a goal jump gives no discontinuous acceleration.

Rhythmic DMP: phase ``phi' = 1 / tau`` (2 pi periodic), ``psi_i = exp(h (cos(phi - c_i) - 1))``,
``f = sum psi_i w_i / sum psi_i * r`` with amplitude ``r``; the same spring towards the
anchor ``g`` (the centre of the oscillation).

Thread safety: a fitted :class:`DiscreteDMP` / :class:`RhythmicDMP` is not changed by its
methods (fitting returns a new one; a rollout integrates in local arrays), so one DMP may be
rolled out from several threads. :class:`DMPOptions` is immutable; a :class:`DMPTrajectory` is
plain result data, not locked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    as_vector,
    check_count,
    check_positive,
)
from taskspace.errors import InvalidInputError

MAX_BASIS = 10_000
"""Largest ``num_basis`` (10**9 tried to allocate the basis of every sample)."""
MAX_ROLLOUT_SAMPLES = 10_000_000
"""Largest number of samples of a rollout (``duration / dt``); more was a bare MemoryError
(745 GiB for ``duration=1e9``) or ran for hours (``dt=1e-9``)."""


@dataclass(frozen=True, kw_only=True)
class DMPOptions:
    """Gains and basis of the DMPs.

    Attributes:
        num_basis: number of basis functions per dimension.
        alpha_z: spring gain [1]; ``beta_z = alpha_z / 4`` (critical damping).
        alpha_x: phase decay; ``x(tau) = exp(-alpha_x)`` at the demonstration's end.
        alpha_g: goal filter gain [1] (``tau g' = alpha_g (g_target - g)``).
        regularization: ridge weight of the least-squares fit.
    """

    num_basis: int = 30
    alpha_z: float = 25.0
    alpha_x: float = 4.0
    alpha_g: float = 12.5
    regularization: float = 1e-8

    def __post_init__(self) -> None:
        # 0 or 2.5 basis functions, NaN or negative gains gave NaN or diverging rollouts
        n = check_count(self.num_basis, "num_basis", minimum=1)
        if n > MAX_BASIS:
            raise InvalidInputError(f"num_basis must be at most {MAX_BASIS}, got {n}")
        for name in ("alpha_z", "alpha_x", "alpha_g"):
            check_positive(getattr(self, name), name)
        check_positive(self.regularization, "regularization", strict=False)


def _check_weights(weights: Any, options: Any) -> FloatArray:
    """``weights`` (d x num_basis) finite, for ``options`` a :class:`DMPOptions`."""
    if not isinstance(options, DMPOptions):
        raise InvalidInputError(f"options must be DMPOptions, got {type(options).__name__}")
    W = as_float_array(weights, "weights")
    if W.ndim != 2 or W.shape[1] != options.num_basis or W.shape[0] < 1:
        raise InvalidInputError(
            f"weights must be (d x num_basis = {options.num_basis}) with d >= 1, got {W.shape}"
        )
    if not np.all(np.isfinite(W)):
        raise InvalidInputError("weights must be finite")
    return W.copy()


def _vector(x: Any, d: int, name: str) -> FloatArray:
    """``x`` as a finite (d,) vector; any shape with d entries (a scalar for d = 1) is taken."""
    return as_vector(np.ravel(as_float_array(x, name)), d, name)


def _rollout_steps(dt: Any, duration: Any) -> tuple[float, int]:
    """``(dt, number of samples)`` of a rollout over ``duration`` [s] (finite, >= 0)."""
    step = check_positive(dt, "dt [s]")
    span = check_positive(duration, "duration [s]", strict=False)
    samples = span / step + 1
    if samples > MAX_ROLLOUT_SAMPLES:
        raise InvalidInputError(
            f"duration {span:g} s with dt {step:g} s gives {samples:.3g} samples (at most "
            f"{MAX_ROLLOUT_SAMPLES}): use a larger dt or a shorter duration"
        )
    return step, round(span / step) + 1


def _largest_step(options: DMPOptions, *, phase: bool = True, goal_filter: bool = True) -> float:
    """Largest stable ``dt / tau`` of the semi-implicit Euler steps of a DMP.

    With ``a = dt / tau``, ``c = alpha_z`` and ``k = alpha_z beta_z`` the error ``(y - g, z)`` of
    the transformation system evolves by a matrix of determinant ``1 - a c`` and trace
    ``2 - a c - a^2 k``; it decays iff ``a c < 2`` and ``4 - 2 a c - a^2 k > 0`` (Jury), i.e.
    ``a < 4 (sqrt 2 - 1) / alpha_z`` for ``beta_z = alpha_z / 4``. The phase
    ``x_{k+1} = (1 - a alpha_x) x_k`` must not change sign (``a <= 1 / alpha_x``) and the goal
    filter must not overshoot (``a alpha_g < 2``).
    """
    c, k = options.alpha_z, options.alpha_z**2 / 4.0
    limit = min(2.0 / c, (-c + np.sqrt(c * c + 4.0 * k)) / k)
    if phase:
        limit = min(limit, 1.0 / options.alpha_x)
    if goal_filter:
        limit = min(limit, 2.0 / options.alpha_g)
    return float(limit)


def _check_step(
    dt: float, tau: float, options: DMPOptions, *, phase: bool = True, goal_filter: bool = True
) -> None:
    """Refuse a ``dt`` for which the Euler steps of a DMP diverge.

    A silently wrong rollout otherwise: dt = 0.1 s with tau = 1 s ended at -8788 for a goal of 1.
    """
    limit = _largest_step(options, phase=phase, goal_filter=goal_filter)
    if not dt < limit * tau:
        raise InvalidInputError(
            f"dt = {dt:g} s is too large for tau = {tau:g} s with alpha_z = {options.alpha_z:g}"
            f", alpha_x = {options.alpha_x:g}, alpha_g = {options.alpha_g:g}: the Euler steps "
            f"of the DMP diverge for dt >= {limit * tau:.4g} s; use a smaller dt (resample "
            "the rollout afterwards if fewer samples are wanted)"
        )


@dataclass
class DMPTrajectory:
    """A DMP rollout sampled every ``dt``.

    Attributes:
        time: [s] (K,); y: positions (K x d); yd: velocities (K x d); ydd: accelerations
            (K x d); phase: (K,).
    """

    time: FloatArray
    y: FloatArray
    yd: FloatArray
    ydd: FloatArray
    phase: FloatArray


def _demo(times: Any, Y: Any) -> tuple[FloatArray, FloatArray]:
    t = np.asarray(times, dtype=float).ravel()
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        Y = Y[:, None]
    if Y.shape[0] != t.size or t.size < 3:
        raise InvalidInputError(
            f"need at least 3 samples with one time each; got {t.size} times and Y {Y.shape}"
        )
    if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(Y)):
        raise InvalidInputError("demonstration times must increase and positions be finite")
    return t, Y


class DiscreteDMP:
    """A discrete (point-to-point) DMP in ``d`` dimensions; build it with :meth:`fit`.

    Attributes:
        weights: forcing-term weights (d x num_basis).
        y0: demonstrated start (d,); goal: demonstrated goal (d,); tau: duration [s].
        initial_velocity: demonstrated start velocity (d,).
    """

    def __init__(
        self, weights: FloatArray, y0: FloatArray, goal: FloatArray, tau: float, options: DMPOptions
    ) -> None:
        self.weights = _check_weights(weights, options)
        d = self.weights.shape[0]
        self.y0 = _vector(y0, d, "y0")
        self.goal = _vector(goal, d, "goal")
        self.tau = check_positive(tau, "tau [s]")
        self.options = options
        self.initial_velocity = np.zeros_like(self.y0)
        n = options.num_basis
        self.centers = np.exp(-options.alpha_x * np.linspace(0.0, 1.0, n))
        diffs = np.diff(self.centers)
        widths = np.append(diffs, diffs[-1]) if n > 1 else np.array([1.0])
        self.widths = 1.0 / (0.65 * widths) ** 2

    @property
    def beta_z(self) -> float:
        """``alpha_z / 4``."""
        return self.options.alpha_z / 4.0

    def basis(self, x: Any) -> FloatArray:
        """Normalized basis ``x psi(x) / sum psi(x)`` (K x num_basis) at phases ``x``."""
        x = np.atleast_1d(as_float_array(x, "x"))
        if not np.all(np.isfinite(x)):
            raise InvalidInputError("phases x must be finite")
        psi = np.exp(-self.widths * (x[:, None] - self.centers) ** 2)
        return np.asarray(psi * x[:, None] / (psi.sum(axis=1, keepdims=True) + 1e-300), float)

    @classmethod
    def fit(cls, times: Any, Y: Any, options: DMPOptions | None = None) -> DiscreteDMP:
        """Learn the weights from a demonstration (least squares on the forcing term).

        Velocities and accelerations come from finite differences (``np.gradient``).

        Args:
            times: sample times [s] (K,), increasing.
            Y: positions (K x d) (or (K,) for one dimension).
            options: see :class:`DMPOptions`.

        Raises:
            InvalidInputError: bad demonstration or options.
        """
        options = options or DMPOptions()
        if options.num_basis < 1:
            raise InvalidInputError("num_basis must be >= 1")
        t, Y = _demo(times, Y)
        tau = float(t[-1] - t[0])
        yd = np.gradient(Y, t, axis=0)
        ydd = np.gradient(yd, t, axis=0)
        y0, g = Y[0], Y[-1]
        dmp = cls(np.zeros((Y.shape[1], options.num_basis)), y0, g, tau, options)
        dmp.initial_velocity = yd[0].copy()
        x = np.exp(-options.alpha_x * (t - t[0]) / tau)
        Phi = dmp.basis(x)
        A = Phi.T @ Phi + options.regularization * np.eye(options.num_basis)
        for j in range(Y.shape[1]):
            f = tau**2 * ydd[:, j] - options.alpha_z * (
                dmp.beta_z * (g[j] - Y[:, j]) - tau * yd[:, j]
            )
            scale = g[j] - y0[j]
            if abs(scale) < 1e-10:
                # No displacement: the forcing term is not scaled (avoid dividing by zero).
                scale = 1.0
            dmp.weights[j] = np.linalg.solve(A, Phi.T @ (f / scale))
        return dmp

    def forcing(self, x: float, goal: FloatArray, y0: FloatArray) -> FloatArray:
        """``f(x)`` (d,) for the current goal and start."""
        scale = goal - y0
        scale = np.where(np.abs(self.goal - self.y0) < 1e-10, 1.0, scale)
        return np.asarray((self.weights @ self.basis(x)[0]) * scale, dtype=float)

    def rollout(
        self,
        dt: float,
        *,
        duration: float | None = None,
        y0: Any = None,
        goal: Any = None,
        tau: float | None = None,
        goal_changes: tuple[tuple[float, Any], ...] = (),
        yd0: Any = None,
    ) -> DMPTrajectory:
        """Integrate the DMP (semi-implicit Euler with ``dt`` [s]).

        Args:
            dt: time step [s].
            duration: simulated time [s] (default ``1.5 tau``).
            y0: start (default: demonstrated start); goal: goal (default: demonstrated goal).
            tau: temporal scale [s] (default: the demonstration's duration).
            goal_changes: ``(time [s], new goal)`` events; the goal is filtered toward them.
            yd0: initial velocity (default: the demonstration's; zero for a start at rest).
        """
        tau = self.tau if tau is None else check_positive(tau, "tau [s]")
        dt, steps = _rollout_steps(dt, 1.5 * tau if duration is None else duration)
        _check_step(dt, tau, self.options)
        d = self.weights.shape[0]
        start = self.y0.copy() if y0 is None else _vector(y0, d, "y0")
        g_target = self.goal.copy() if goal is None else _vector(goal, d, "goal")
        g = g_target.copy()
        events = sorted(_goal_events(goal_changes, d), key=lambda e: e[0])
        Y = np.empty((steps, d))
        Yd = np.empty((steps, d))
        Ydd = np.empty((steps, d))
        X = np.empty(steps)
        v0 = self.initial_velocity if yd0 is None else _vector(yd0, d, "yd0")
        y, z = start.copy(), tau * v0
        o = self.options
        # The phase does not depend on the state: its samples and the weighted basis come first.
        X[:] = (1.0 - dt * o.alpha_x / tau) ** np.arange(steps)
        shape = self.weights @ self.basis(X).T  # (d x K): sum psi w / sum psi * x
        unscaled = np.abs(self.goal - self.y0) < 1e-10
        for k in range(steps):
            t = k * dt
            while events and events[0][0] <= t + 1e-12:
                g_target = events.pop(0)[1]
            f = shape[:, k] * np.where(unscaled, 1.0, g - start)
            zd = (o.alpha_z * (self.beta_z * (g - y) - z) + f) / tau
            Y[k], Yd[k], Ydd[k] = y, z / tau, zd / tau
            z = z + dt * zd
            y = y + dt * z / tau
            g = g + dt * o.alpha_g * (g_target - g) / tau
        return DMPTrajectory(
            time=np.arange(steps, dtype=np.float64) * float(dt), y=Y, yd=Yd, ydd=Ydd, phase=X
        )


def _goal_events(goal_changes: Any, d: int) -> list[tuple[float, FloatArray]]:
    """``goal_changes`` as ``(time >= 0 [s], goal (d,))`` pairs, each finite."""
    if isinstance(goal_changes, (str, bytes)) or not hasattr(goal_changes, "__iter__"):
        raise InvalidInputError(f"goal_changes must be (time, goal) pairs, got {goal_changes!r}")
    events = []
    for i, event in enumerate(goal_changes):
        if isinstance(event, (str, bytes)) or not hasattr(event, "__len__") or len(event) != 2:
            raise InvalidInputError(f"goal_changes[{i}] must be a (time, goal) pair, got {event!r}")
        time, new_goal = event
        events.append(
            (
                check_positive(time, f"goal_changes[{i}] time [s]", strict=False),
                _vector(new_goal, d, f"goal_changes[{i}] goal"),
            )
        )
    return events


class RhythmicDMP:
    """A rhythmic (periodic) DMP; build it with :meth:`fit` from one period of a demonstration.

    Attributes:
        weights: (d x num_basis); anchor: centre of oscillation (d,); tau: period / (2 pi) [s].
    """

    def __init__(
        self, weights: FloatArray, anchor: FloatArray, tau: float, options: DMPOptions
    ) -> None:
        self.weights = _check_weights(weights, options)
        self.anchor = _vector(anchor, self.weights.shape[0], "anchor")
        self.tau = check_positive(tau, "tau [s]")
        self.options = options
        self.centers = np.linspace(0, 2 * np.pi, options.num_basis, endpoint=False)
        self.h = 2.5 * options.num_basis

    def basis(self, phi: Any) -> FloatArray:
        """Normalized von Mises basis (K x num_basis) at phases ``phi`` [rad]."""
        phi = np.atleast_1d(as_float_array(phi, "phi"))
        if not np.all(np.isfinite(phi)):
            raise InvalidInputError("phases phi must be finite")
        psi = np.exp(self.h * (np.cos(phi[:, None] - self.centers) - 1.0))
        return np.asarray(psi / psi.sum(axis=1, keepdims=True), dtype=float)

    @classmethod
    def fit(cls, times: Any, Y: Any, options: DMPOptions | None = None) -> RhythmicDMP:
        """Learn from exactly one period (``times[0]`` to ``times[-1]``) of a periodic motion.

        Derivatives are periodic central differences; the anchor is the mean position.
        """
        options = options or DMPOptions()
        t, Y = _demo(times, Y)
        period = float(t[-1] - t[0])
        tau = period / (2 * np.pi)
        Yp = Y[:-1]
        h = np.diff(t)[:-1] if t.size > 2 else np.diff(t)
        dtm = float(np.mean(np.diff(t)))
        if np.max(np.abs(np.diff(t) - dtm)) > 1e-9 * max(1.0, period):
            raise InvalidInputError("the rhythmic DMP needs uniformly sampled demonstrations")
        del h
        yd = (np.roll(Yp, -1, axis=0) - np.roll(Yp, 1, axis=0)) / (2 * dtm)
        ydd = (np.roll(Yp, -1, axis=0) - 2 * Yp + np.roll(Yp, 1, axis=0)) / dtm**2
        anchor = Yp.mean(axis=0)
        dmp = cls(np.zeros((Y.shape[1], options.num_basis)), anchor, tau, options)
        phi = (t[:-1] - t[0]) / tau
        Phi = dmp.basis(phi)
        A = Phi.T @ Phi + options.regularization * np.eye(options.num_basis)
        beta = options.alpha_z / 4.0
        for j in range(Y.shape[1]):
            f = tau**2 * ydd[:, j] - options.alpha_z * (
                beta * (anchor[j] - Yp[:, j]) - tau * yd[:, j]
            )
            dmp.weights[j] = np.linalg.solve(A, Phi.T @ f)
        return dmp

    def rollout(
        self,
        dt: float,
        *,
        duration: float,
        y0: Any = None,
        amplitude: float = 1.0,
        tau: float | None = None,
    ) -> DMPTrajectory:
        """Integrate (semi-implicit Euler); ``amplitude`` scales the forcing term (``r``).

        Args:
            dt: time step [s]; duration: simulated time [s].
            y0: start (default: the demonstration's start is unknown here, so the anchor).
            amplitude: ``r``; tau: temporal scale [s] (default: learned).
        """
        tau = self.tau if tau is None else check_positive(tau, "tau [s]")
        dt, steps = _rollout_steps(dt, duration)
        _check_step(dt, tau, self.options, phase=False, goal_filter=False)
        amplitude = as_scalar(amplitude, "amplitude")
        d = self.weights.shape[0]
        y = self.anchor.copy() if y0 is None else _vector(y0, d, "y0")
        z = np.zeros(d)
        phi = 0.0
        Y, Yd, Ydd, P = (
            np.empty((steps, d)),
            np.empty((steps, d)),
            np.empty((steps, d)),
            np.empty(steps),
        )
        o = self.options
        P[:] = phi + np.arange(steps) * dt / tau
        forcing = amplitude * (self.weights @ self.basis(P).T)  # (d x K)
        for k in range(steps):
            zd = (o.alpha_z * (o.alpha_z / 4.0 * (self.anchor - y) - z) + forcing[:, k]) / tau
            Y[k], Yd[k], Ydd[k] = y, z / tau, zd / tau
            z = z + dt * zd
            y = y + dt * z / tau
        return DMPTrajectory(
            time=np.arange(steps, dtype=np.float64) * float(dt), y=Y, yd=Yd, ydd=Ydd, phase=P
        )
