"""EKF-SLAM: joint Gaussian over the robot pose and the landmark map (slide 7:1 outline).

State ``mu = (x, y, theta, l_1x, l_1y, ..., l_Lx, l_Ly)``, covariance ``Sigma``. Prediction
touches only the pose rows: ``Sigma_xx = F Sigma_xx F^T + Q``, ``Sigma_xm = F Sigma_xm``.
Each range-bearing measurement ``z`` of landmark ``k`` is a Kalman update with
``H = [dh/dx, 0, ..., dh/dl_k, ..., 0]`` (Joseph form). Landmarks are initialized when first
seen with the inverse model ``l = g(x, z) = p + r (cos(theta + b), sin(theta + b))``:
``Sigma_ll = G_x Sigma_xx G_x^T + G_z R G_z^T``, ``Sigma_l* = G_x Sigma_x*``.

Data association is either known (measurement ids) or nearest neighbour on the Mahalanobis
distance ``d^2 = r^T S^-1 r``: accepted when ``d^2 < chi2_2(gate)``, new landmark when the
smallest ``d^2`` exceeds ``chi2_2(new_landmark)``, dropped in between.

Thread safety: :class:`EKFSLAM` serializes its calls with a lock (see there);
:class:`EKFSLAMOptions` is immutable.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.stats

from taskspace._validation import FloatArray, as_vector, check_positive
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.estimation._serialized import serialized
from taskspace.estimation.covariance import as_covariance
from taskspace.estimation.motion_models import VelocityMotionModel, wrap_angle
from taskspace.estimation.observation_models import (
    LandmarkObservation,
    RangeBearingModel,
    checked_observation,
)
from taskspace.estimation.slam_result import SLAMResult, SLAMStatus


@dataclass(frozen=True, kw_only=True)
class EKFSLAMOptions:
    """Settings of :class:`EKFSLAM`.

    Attributes:
        association: ``"known"`` (use measurement ids) or ``"nearest_neighbor"``.
        gate: chi-square probability of the association gate.
        new_landmark: chi-square probability beyond which a new landmark is created.
    """

    association: str = "known"
    gate: float = 0.99
    new_landmark: float = 0.9999


class EKFSLAM:
    """EKF-SLAM with a velocity (or any Jacobian-providing) motion model.

    Args:
        motion: motion model with ``mean``, ``jacobians`` and ``state_covariance``.
        sensor: range-bearing sensor (its ``R`` is the measurement covariance).
        x0: ``(3,)`` initial pose.
        P0: ``(3, 3)`` initial pose covariance.
        options: settings.

    Thread safety: calls are serialized by the estimator's lock; each of ``predict``,
    ``update``, ``run`` is atomic, so threads sharing one estimator (a sensor callback updating
    while a timer predicts) lose no update; they do not run in parallel (use one estimator per
    thread for that). Read the belief between calls, not during another thread's update.
    """

    def __init__(
        self,
        motion: VelocityMotionModel | Any,
        sensor: RangeBearingModel,
        x0: Any,
        P0: Any,
        options: EKFSLAMOptions | None = None,
    ) -> None:
        self._lock = threading.RLock()
        self.options = options or EKFSLAMOptions()
        if self.options.association not in ("known", "nearest_neighbor"):
            raise UnknownNameError(
                "association", self.options.association, ["known", "nearest_neighbor"]
            )
        for name, value in (
            ("gate", self.options.gate),
            ("new_landmark", self.options.new_landmark),
        ):
            v = check_positive(value, f"EKFSLAMOptions.{name}")
            if not v < 1.0:  # NaN or >= 1: chi2.ppf NaN/inf gated every measurement out/in
                raise InvalidInputError(
                    f"EKFSLAMOptions.{name} is a chi-square probability in (0, 1), got {value!r}"
                )
        if self.options.new_landmark < self.options.gate:
            raise InvalidInputError(
                f"EKFSLAMOptions.new_landmark ({self.options.new_landmark}) must be >= gate "
                f"({self.options.gate}): a measurement cannot both match and be new"
            )
        if not isinstance(sensor, RangeBearingModel):
            raise InvalidInputError(
                f"sensor must be a RangeBearingModel, got {type(sensor).__name__}"
            )
        for method in ("mean", "jacobians", "state_covariance"):
            if not callable(getattr(motion, method, None)):
                raise InvalidInputError(
                    f"motion must provide mean, jacobians and state_covariance (e.g. "
                    f"VelocityMotionModel), {type(motion).__name__} has no {method}"
                )
        self.motion = motion
        self.sensor = sensor
        self.mu = as_vector(x0, 3, "x0").copy()
        self.Sigma = as_covariance(P0, 3, "P0").copy()
        self.ids: list[int] = []
        self._gate = float(scipy.stats.chi2.ppf(self.options.gate, 2))
        self._new = float(scipy.stats.chi2.ppf(self.options.new_landmark, 2))
        self.num_associated = self.num_new = self.num_rejected = 0

    @property
    def num_landmarks(self) -> int:
        """Number of landmarks in the map."""
        return (self.mu.shape[0] - 3) // 2

    @serialized
    def predict(self, u: Any) -> None:
        """Pose prediction; the map is static."""
        x = self.mu[:3]
        F, _ = self.motion.jacobians(x, u)
        Q = self.motion.state_covariance(x, u)
        self.mu[:3] = self.motion.mean(x, u)
        S = self.Sigma
        S[:3, :] = F @ S[:3, :]
        S[:, :3] = S[:, :3] @ F.T
        S[:3, :3] += Q

    def _add_landmark(self, z: FloatArray, true_id: int) -> int:
        x = self.mu[:3]
        r, b = z
        a = x[2] + b
        Gx = np.array([[1.0, 0.0, -r * np.sin(a)], [0.0, 1.0, r * np.cos(a)]])
        Gz = np.array([[np.cos(a), -r * np.sin(a)], [np.sin(a), r * np.cos(a)]])
        n = self.mu.shape[0]
        S = np.zeros((n + 2, n + 2))
        S[:n, :n] = self.Sigma
        cross = Gx @ self.Sigma[:3, :]
        S[n:, :n] = cross
        S[:n, n:] = cross.T
        S[n:, n:] = Gx @ self.Sigma[:3, :3] @ Gx.T + Gz @ self.sensor.R @ Gz.T
        self.Sigma = S
        self.mu = np.concatenate([self.mu, RangeBearingModel.inverse(x, z)])
        self.ids.append(true_id)
        self.num_new += 1
        return self.num_landmarks - 1

    def _innovation(self, z: FloatArray, k: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Residual, full-state H and S for landmark ``k``."""
        x = self.mu[:3]
        lm = self.mu[3 + 2 * k : 5 + 2 * k]
        Hx, Hl = RangeBearingModel.jacobians(x, lm)
        r = self.sensor.residual(z, RangeBearingModel.predict(x, lm))
        idx = np.r_[0:3, 3 + 2 * k : 5 + 2 * k]
        Hs = np.hstack([Hx, Hl])
        S = Hs @ self.Sigma[np.ix_(idx, idx)] @ Hs.T + self.sensor.R
        return r, Hs, S

    @serialized
    def mahalanobis_all(self, z: FloatArray) -> FloatArray:
        """``d_k^2 = r_k^T S_k^-1 r_k`` of measurement ``z`` against every landmark (vectorized)."""
        L = self.num_landmarks
        if L == 0:
            return np.zeros(0)
        x = self.mu[:3]
        lms = self.mu[3:].reshape(L, 2)
        d = lms - x[:2]
        q = np.maximum(np.sum(d * d, axis=1), 1e-12)
        rq = np.sqrt(q)
        Hl = np.stack(
            [np.stack([d[:, 0] / rq, d[:, 1] / rq], -1), np.stack([-d[:, 1] / q, d[:, 0] / q], -1)],
            -2,
        )
        Hx = np.concatenate([-Hl, np.broadcast_to([[0.0], [-1.0]], (L, 2, 1))], axis=2)
        Sxx = self.Sigma[:3, :3]
        Sxl = self.Sigma[:3, 3:].reshape(3, L, 2).transpose(1, 0, 2)  # (L, 3, 2)
        idx = 3 + 2 * np.arange(L)
        Sll = np.stack(
            [
                np.stack([self.Sigma[idx, idx], self.Sigma[idx, idx + 1]], -1),
                np.stack([self.Sigma[idx + 1, idx], self.Sigma[idx + 1, idx + 1]], -1),
            ],
            -2,
        )
        cross = Hx @ Sxl @ Hl.transpose(0, 2, 1)
        S = Hx @ Sxx @ Hx.transpose(0, 2, 1) + cross + cross.transpose(0, 2, 1)
        S = S + Hl @ Sll @ Hl.transpose(0, 2, 1) + self.sensor.R
        r = self.sensor.residual(
            np.broadcast_to(z, (L, 2)).copy(), RangeBearingModel.predict(x, lms)
        )
        return np.einsum("li,li->l", r, np.linalg.solve(S, r[..., None])[..., 0])

    def _update_landmark(self, z: FloatArray, k: int) -> None:
        r, Hs, S = self._innovation(z, k)
        idx = np.r_[0:3, 3 + 2 * k : 5 + 2 * k]
        PHt = self.Sigma[:, idx] @ Hs.T
        K = np.linalg.solve(S, PHt.T).T
        self.mu = self.mu + K @ r
        self.mu[2] = wrap_angle(self.mu[2])
        # Joseph form with sparse H: (I - K H) Sigma (I - K H)^T + K R K^T.
        n = self.mu.shape[0]
        IKH = np.eye(n)
        IKH[:, idx] -= K @ Hs
        Sg = IKH @ self.Sigma @ IKH.T + K @ self.sensor.R @ K.T
        self.Sigma = 0.5 * (Sg + Sg.T)

    @serialized
    def update(self, obs: LandmarkObservation) -> None:
        """Process every measurement of one time step (association, init, update)."""
        ids, zs = checked_observation(obs)
        if self.options.association == "known" and np.any(ids < 0):
            raise InvalidInputError(
                f"association='known' needs landmark ids >= 0, got {ids.tolist()} (-1 marks an "
                "unknown correspondence: use association='nearest_neighbor')"
            )
        for zid, z in zip(ids, zs):
            if self.options.association == "known":
                if int(zid) in self.ids:
                    self._update_landmark(z, self.ids.index(int(zid)))
                    self.num_associated += 1
                else:
                    self._add_landmark(z, int(zid))
                continue
            d2all = self.mahalanobis_all(z)
            best = int(np.argmin(d2all)) if d2all.size else -1
            d2 = float(d2all[best]) if d2all.size else np.inf
            if d2 < self._gate:
                self._update_landmark(z, best)
                self.num_associated += 1
            elif d2 > self._new:
                self._add_landmark(z, int(zid))
            else:
                self.num_rejected += 1

    @serialized
    def run(
        self, controls: Sequence[Any], observations: Sequence[LandmarkObservation]
    ) -> SLAMResult:
        """Predict with ``controls[t]`` then update with ``observations[t]`` for every step."""
        if len(controls) != len(observations):
            raise InvalidInputError("controls and observations must have the same length")
        t0 = time.perf_counter()
        poses = np.empty((len(controls), 3))
        for t, (u, obs) in enumerate(zip(controls, observations)):
            self.predict(u)
            self.update(obs)
            poses[t] = self.mu[:3]
        L = self.num_landmarks
        lms = self.mu[3:].reshape(L, 2)
        covs = np.array(
            [self.Sigma[3 + 2 * k : 5 + 2 * k, 3 + 2 * k : 5 + 2 * k] for k in range(L)]
        ).reshape(L, 2, 2)
        ok = bool(np.isfinite(self.mu).all() and np.isfinite(self.Sigma).all())
        return SLAMResult(
            success=ok,
            status=SLAMStatus.SUCCESS if ok else SLAMStatus.NUMERICAL_FAILURE,
            poses=poses,
            landmarks=lms.copy(),
            landmark_covs=covs,
            landmark_ids=np.array(self.ids, dtype=np.float64),
            num_associated=self.num_associated,
            num_new=self.num_new,
            num_rejected=self.num_rejected,
            time_s=time.perf_counter() - t0,
            message="" if ok else "non-finite state",
        )
