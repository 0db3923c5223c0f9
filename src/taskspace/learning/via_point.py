"""A via-point task on DMP parameters: the policy-search benchmark of PoWER and PI^2.

The policy parameters are the forcing-term weights of a :class:`DiscreteDMP` (d x num_basis,
flattened); a rollout integrates the DMP and returns
``-(w_via |y(t_via) - p_via|^2 + w_acc sum_k |y''_k|^2 dt)``. The rollout is deterministic
(the seed is unused): exploration comes from the parameter perturbations of the method.

Thread safety: a :class:`ViaPointTask` is not changed by its methods (each rollout builds its
DMP from ``theta``) and may be rolled out from several threads; do not assign its fields while
other threads use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskspace._validation import FloatArray, check_positive
from taskspace.errors import InvalidInputError
from taskspace.learning.dmp import DiscreteDMP, _vector
from taskspace.learning.rollout import Episode


@dataclass
class ViaPointTask:
    """Pass through ``via_point`` at ``via_time`` with a DMP.

    Attributes:
        dmp: the primitive whose weights are the parameters (its start, goal, tau are kept).
        via_time: [s]; via_point: (d,); dt: integration step [s].
        via_weight: weight of the squared via-point error [1/m^2].
        acceleration_weight: weight of the integrated squared acceleration [s^3/m^2].
    """

    dmp: DiscreteDMP
    via_time: float
    via_point: FloatArray
    dt: float = 0.01
    via_weight: float = 1e3
    acceleration_weight: float = 1e-4

    def __post_init__(self) -> None:
        # a via time after the rollout was a bare IndexError, NaN a bare ValueError, a NaN via
        # point a NaN return
        if not isinstance(self.dmp, DiscreteDMP):
            raise InvalidInputError(f"dmp must be a DiscreteDMP, got {type(self.dmp).__name__}")
        dt = check_positive(self.dt, "dt [s]")
        t = check_positive(self.via_time, "via_time [s]", strict=False)
        steps = round(self.dmp.tau / dt)
        if round(t / dt) > steps:
            raise InvalidInputError(
                f"via_time {t:g} s is after the rollout's end (tau = {self.dmp.tau:g} s)"
            )
        self.via_point = _vector(self.via_point, self.dmp.weights.shape[0], "via_point")
        check_positive(self.via_weight, "via_weight", strict=False)
        check_positive(self.acceleration_weight, "acceleration_weight", strict=False)

    @property
    def num_parameters(self) -> int:
        """``d num_basis``."""
        return int(self.dmp.weights.size)

    def _dmp(self, theta: FloatArray) -> DiscreteDMP:
        th = np.asarray(theta, dtype=float).ravel()
        if th.size != self.num_parameters or not np.all(np.isfinite(th)):
            raise InvalidInputError(f"need {self.num_parameters} finite DMP weights, got {th.size}")
        base = self.dmp
        dmp = DiscreteDMP(
            th.reshape(base.weights.shape), base.y0, base.goal, base.tau, base.options
        )
        dmp.initial_velocity = base.initial_velocity
        return dmp

    def trajectory(self, theta: FloatArray) -> FloatArray:
        """Positions (K x d) of the DMP with weights ``theta``."""
        return self._dmp(theta).rollout(self.dt, duration=self.dmp.tau).y

    def via_error(self, theta: FloatArray) -> float:
        """``|y(t_via) - p_via|`` [m]."""
        y = self.trajectory(theta)
        return float(np.linalg.norm(y[round(self.via_time / self.dt)] - self.via_point))

    def activations(self) -> FloatArray:
        """Basis activation of each weight at each rollout step (K x d num_basis).

        Column ``j = dim * num_basis + b`` (the flattened weights) holds the DMP's normalized
        basis ``x psi_b(x) / sum psi(x)`` at the phases of the rollout steps: the
        ``w_{j,t_i}`` of per-time-step PI^2 (``pi2(..., activations=task.activations())``).
        """
        steps = round(self.dmp.tau / self.dt) + 1
        o = self.dmp.options
        x = (1.0 - self.dt * o.alpha_x / self.dmp.tau) ** np.arange(steps)
        return np.tile(self.dmp.basis(x), (1, self.dmp.weights.shape[0]))

    def rollout(self, theta: FloatArray, seed: int) -> Episode:
        """Deterministic rollout (``seed`` unused).

        ``rewards`` holds the per-step rewards: ``-w_acc |y''_k|^2 dt`` at every step k, plus
        ``-w_via |y(t_via) - p_via|^2`` at the via step; they sum to ``total_return``.
        """
        traj = self._dmp(theta).rollout(self.dt, duration=self.dmp.tau)
        k_via = round(self.via_time / self.dt)
        err = traj.y[k_via] - np.asarray(self.via_point, dtype=float)
        rewards = -self.acceleration_weight * np.sum(traj.ydd**2, axis=1) * self.dt
        rewards[k_via] -= self.via_weight * float(err @ err)
        if not np.all(np.isfinite(rewards)):
            raise InvalidInputError(
                "the DMP rollout overflowed with these weights (non-finite rewards); use "
                "smaller weights"
            )
        return Episode(
            total_return=float(rewards.sum()),
            log_likelihood_gradient=np.zeros(self.num_parameters),
            rewards=rewards,
            steps=traj.time.size,
        )
