"""Orientation (quaternion) DMP of Ude, Nemec, Petric and Morimoto (2014), on SO(3).

The orientation ``q`` (unit quaternion, or rotation ``R``) follows

``tau eta' = alpha_z (beta_z e - eta) + f(x)``,  ``e = 2 log(g * conj(q))`` (= ``log3(R_g R^T)``),
``tau q' = 1/2 eta * q``,  ``tau x' = -alpha_x x``,

with ``eta = tau omega`` (scaled angular velocity, world frame) and the forcing term
``f(x) = D0 sum_i psi_i w_i / sum_i psi_i x``, ``D0 = diag(2 log(g * conj(q0)))`` scaling it with
the start-to-goal rotation. The orientation is integrated on the group,
``R_{k+1} = exp3(dt omega) R_k``, so it stays a rotation (a unit quaternion) exactly.
Learning is least squares on ``f_k = tau eta'_k - alpha_z (beta_z e_k - eta_k)``.

Thread safety: a fitted :class:`OrientationDMP` is not changed by its methods (rollouts
integrate in local arrays) and may be rolled out from several threads; an
:class:`OrientationTrajectory` is plain result data, not locked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_float_array, check_positive
from taskspace.errors import InvalidInputError
from taskspace.learning.dmp import (
    DiscreteDMP,
    DMPOptions,
    _check_step,
    _check_weights,
    _rollout_steps,
    _vector,
)


def _rotation(q: Any) -> FloatArray:
    arr = as_float_array(q, "orientation")
    if arr.shape == (3, 3):
        # a NaN or non-orthonormal matrix was integrated as given
        if not (
            np.all(np.isfinite(arr))
            and np.allclose(arr @ arr.T, np.eye(3), atol=1e-6)
            and np.linalg.det(arr) > 0
        ):
            raise InvalidInputError("a 3 x 3 orientation must be a finite rotation matrix")
        return arr.copy()
    if arr.shape == (4,):
        n = np.linalg.norm(arr)
        if not np.isfinite(n) or n < 1e-12:
            raise InvalidInputError("a quaternion must be finite and non-zero")
        x, y, z, w = arr / n
        return np.asarray(pin.Quaternion(w, x, y, z).toRotationMatrix(), dtype=float)
    raise InvalidInputError(
        f"orientations are quaternions (x, y, z, w) or 3 x 3 rotations, got shape {arr.shape}"
    )


def quaternion(R: FloatArray) -> FloatArray:
    """Unit quaternion ``(x, y, z, w)`` (Pinocchio's coefficient order) of a rotation.

    Raises:
        InvalidInputError: ``R`` is not a finite 3 x 3 rotation matrix (orthonormal to 1e-6,
            determinant +1): a NaN matrix gave a NaN quaternion, ``2 I`` one of norm 1.32 and
            a reflection the quaternion of a half turn.
    """
    if isinstance(R, (str, bytes)):
        raise InvalidInputError(f"R must be a 3 x 3 rotation matrix, got {type(R).__name__}")
    arr = as_float_array(R, "R")
    if arr.shape != (3, 3):
        raise InvalidInputError(f"R must be a 3 x 3 rotation matrix, got shape {arr.shape}")
    return _quaternion(_rotation(arr))


def _quaternion(R: FloatArray) -> FloatArray:
    """:func:`quaternion` without the checks (``R`` already a rotation)."""
    return np.asarray(pin.Quaternion(np.asarray(R)).coeffs(), dtype=float).copy()


@dataclass
class OrientationTrajectory:
    """An orientation DMP rollout.

    Attributes:
        time: [s] (K,); rotations: (K x 3 x 3); quaternions: (K x 4) (x, y, z, w);
        angular_velocity: world frame [rad/s] (K x 3).
    """

    time: FloatArray
    rotations: FloatArray
    quaternions: FloatArray
    angular_velocity: FloatArray


class OrientationDMP:
    """Orientation DMP; build it with :meth:`fit` from a demonstrated rotation sequence.

    Attributes:
        weights: (3 x num_basis); R0, goal: demonstrated start and goal rotations; tau [s].
    """

    def __init__(
        self, weights: FloatArray, R0: FloatArray, goal: FloatArray, tau: float, options: DMPOptions
    ) -> None:
        self.weights = _check_weights(weights, options)
        if self.weights.shape[0] != 3:
            raise InvalidInputError(f"weights must be (3 x num_basis), got {self.weights.shape}")
        self.R0 = _rotation(R0)
        self.goal = _rotation(goal)
        self.tau = check_positive(tau, "tau [s]")
        self.options = options
        self._phase = DiscreteDMP(
            np.zeros((1, options.num_basis)), np.zeros(1), np.ones(1), tau, options
        )
        self.initial_angular_velocity = np.zeros(3)

    @staticmethod
    def _scale(goal: FloatArray, R0: FloatArray) -> FloatArray:
        d = pin.log3(goal @ R0.T)
        return np.where(np.abs(d) < 1e-10, 1.0, d)

    @classmethod
    def fit(
        cls, times: Any, orientations: Any, options: DMPOptions | None = None
    ) -> OrientationDMP:
        """Learn from sampled orientations (K quaternions (x, y, z, w) or K x 3 x 3 rotations)."""
        options = options or DMPOptions()
        t = np.asarray(times, dtype=float).ravel()
        Rs = [_rotation(o) for o in orientations]
        if len(Rs) != t.size or t.size < 3 or np.any(np.diff(t) <= 0):
            raise InvalidInputError("need at least 3 orientations with increasing times")
        tau = float(t[-1] - t[0])
        # World-frame angular velocity between samples, then central averages.
        steps = np.array(
            [pin.log3(Rs[k + 1] @ Rs[k].T) / (t[k + 1] - t[k]) for k in range(t.size - 1)]
        )
        omega = np.empty((t.size, 3))
        omega[0], omega[-1] = steps[0], steps[-1]
        omega[1:-1] = 0.5 * (steps[:-1] + steps[1:])
        eta = tau * omega
        eta_d = np.gradient(eta, t, axis=0)
        g, R0 = Rs[-1], Rs[0]
        dmp = cls(np.zeros((3, options.num_basis)), R0, g, tau, options)
        dmp.initial_angular_velocity = omega[0].copy()
        e = np.array([pin.log3(g @ R.T) for R in Rs])
        beta = options.alpha_z / 4.0
        f = tau * eta_d - options.alpha_z * (beta * e - eta)
        x = np.exp(-options.alpha_x * (t - t[0]) / tau)
        Phi = dmp._phase.basis(x)
        A = Phi.T @ Phi + options.regularization * np.eye(options.num_basis)
        D0 = cls._scale(g, R0)
        for j in range(3):
            dmp.weights[j] = np.linalg.solve(A, Phi.T @ (f[:, j] / D0[j]))
        return dmp

    def rollout(
        self,
        dt: float,
        *,
        duration: float | None = None,
        start: Any = None,
        goal: Any = None,
        angular_velocity0: Any = None,
    ) -> OrientationTrajectory:
        """Integrate on SO(3) with step ``dt`` [s] (default duration ``1.5 tau``).

        Args:
            dt: step [s]; duration: [s].
            start, goal: quaternions (x, y, z, w) or rotations (default: demonstrated).
            angular_velocity0: initial angular velocity [rad/s] (default: demonstrated).
        """
        tau = self.tau
        dt, steps = _rollout_steps(dt, 1.5 * tau if duration is None else duration)
        _check_step(dt, tau, self.options, goal_filter=False)
        R = self.R0.copy() if start is None else _rotation(start)
        g = self.goal.copy() if goal is None else _rotation(goal)
        w0 = self.initial_angular_velocity if angular_velocity0 is None else angular_velocity0
        eta = tau * _vector(w0, 3, "angular_velocity0")
        D0 = self._scale(g, R)
        o = self.options
        beta = o.alpha_z / 4.0
        Rs = np.empty((steps, 3, 3))
        Q = np.empty((steps, 4))
        W = np.empty((steps, 3))
        X = (1.0 - dt * o.alpha_x / tau) ** np.arange(steps)
        shape = self.weights @ self._phase.basis(X).T  # (3 x K)
        for k in range(steps):
            Rs[k], Q[k], W[k] = R, _quaternion(R), eta / tau
            f = D0 * shape[:, k]
            eta_d = (o.alpha_z * (beta * pin.log3(g @ R.T) - eta) + f) / tau
            eta = eta + dt * eta_d
            R = pin.exp3(dt * eta / tau) @ R
        return OrientationTrajectory(
            time=np.arange(steps, dtype=np.float64) * float(dt),
            rotations=Rs,
            quaternions=Q,
            angular_velocity=W,
        )
