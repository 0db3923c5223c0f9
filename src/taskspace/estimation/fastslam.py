"""FastSLAM 1.0: particles over robot paths, one small EKF per landmark and particle.

Each particle ``m`` carries a pose ``x^m`` and independent Gaussians ``N(l_k^m, Sigma_k^m)``
(the map factorizes given the path). With known correspondences, one step is:

1. sample ``x^m ~ P(x | u, x^m)`` (motion model);
2. for each measurement ``z`` of landmark ``k``: if new, ``l = g(x^m, z)``,
   ``Sigma = G_z R G_z^T``; otherwise the EKF update with ``H = dh/dl``,
   ``S = H Sigma H^T + R``, ``K = Sigma H^T S^-1`` and importance weight ``w^m *= N(r | 0, S)``;
3. resample when the effective sample size is low.

All operations are vectorized over particles (2 x 2 algebra in closed form).

Thread safety: :class:`FastSLAM` serializes its calls with a lock (see there);
:class:`FastSLAMOptions` is immutable.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_vector, check_count
from taskspace.errors import InvalidInputError
from taskspace.estimation._serialized import serialized
from taskspace.estimation.motion_models import wrap_angle
from taskspace.estimation.observation_models import (
    LandmarkObservation,
    RangeBearingModel,
    checked_observation,
)
from taskspace.estimation.resampling import get_resampler
from taskspace.estimation.slam_result import SLAMResult, SLAMStatus


@dataclass(frozen=True, kw_only=True)
class FastSLAMOptions:
    """Settings of :class:`FastSLAM`.

    Attributes:
        num_particles: number of particles.
        resampling: resampling scheme name.
        ess_threshold: resample when ``N_eff < ess_threshold * N``.
    """

    num_particles: int = 100
    resampling: str = "systematic"
    ess_threshold: float = 0.5


MAX_PARTICLE_BYTES = 4 * 2**30
"""Largest particle set of :class:`FastSLAM` (poses, landmark means and covariances)."""


def _inv2(S: FloatArray) -> tuple[FloatArray, FloatArray]:
    a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
    det = a * d - b * c
    inv = np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2) / det[..., None, None]
    return inv, det


class FastSLAM:
    """FastSLAM 1.0 with known correspondences.

    Args:
        motion: motion model with ``sample(x, u, rng)`` over ``(N, 3)``.
        sensor: range-bearing sensor.
        x0: ``(3,)`` initial pose (all particles start there).
        num_landmarks: number of landmark ids that may be observed.
        rng: random generator.
        options: settings.

    Thread safety: calls are serialized by the estimator's lock; each of ``predict``,
    ``update``, ``run`` is atomic, so threads sharing one estimator (a sensor callback updating
    while a timer predicts) lose no update; they do not run in parallel (use one estimator per
    thread for that). Read the belief between calls, not during another thread's update.
    """

    def __init__(
        self,
        motion: Any,
        sensor: RangeBearingModel,
        x0: Any,
        num_landmarks: int,
        rng: np.random.Generator,
        options: FastSLAMOptions | None = None,
    ) -> None:
        self._lock = threading.RLock()
        self.options = options or FastSLAMOptions()
        M = check_count(self.options.num_particles, "FastSLAMOptions.num_particles", minimum=1)
        num_landmarks = check_count(num_landmarks, "num_landmarks")
        needed = 8 * M * (3 + 6 * num_landmarks)  # poses, landmark means and covariances
        if needed > MAX_PARTICLE_BYTES:
            raise InvalidInputError(
                f"{M:,} particles x {num_landmarks:,} landmarks would need {needed / 1e9:.3g} GB "
                f"(at most {MAX_PARTICLE_BYTES / 2**30:g} GiB): use fewer particles"
            )
        ess = self.options.ess_threshold
        if (
            isinstance(ess, bool)
            or not isinstance(ess, (int, float, np.number))
            or not (0.0 <= ess <= 1.0)
        ):  # NaN or negative never resampled, silently
            raise InvalidInputError(f"FastSLAMOptions.ess_threshold must be in [0, 1], got {ess!r}")
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {rng!r}"
            )
        if not isinstance(sensor, RangeBearingModel):
            raise InvalidInputError(
                f"sensor must be a RangeBearingModel, got {type(sensor).__name__}"
            )
        self._resample = get_resampler(self.options.resampling)
        self.motion = motion
        self.sensor = sensor
        self.rng = rng
        self.poses = np.tile(as_vector(x0, 3, "x0"), (M, 1))
        self.means = np.zeros((M, num_landmarks, 2))
        self.covs = np.tile(np.eye(2), (M, num_landmarks, 1, 1))
        self.seen = np.zeros(num_landmarks, dtype=bool)
        self.log_w = np.zeros(M)

    @serialized
    def predict(self, u: Any) -> None:
        """Sample the motion model for every particle."""
        self.poses = self.motion.sample(self.poses, u, self.rng)

    @serialized
    def update(self, obs: LandmarkObservation) -> None:
        """Landmark EKF updates and importance weights, then resampling if needed."""
        R = self.sensor.R
        x = self.poses
        ids, zs = checked_observation(obs)
        for k, z in zip(ids, zs):
            k = int(k)
            if not 0 <= k < self.seen.shape[0]:
                raise InvalidInputError(f"landmark id {k} is outside [0, {self.seen.shape[0]})")
            if not self.seen[k]:
                a = x[:, 2] + z[1]
                c, s = np.cos(a), np.sin(a)
                self.means[:, k] = RangeBearingModel.inverse(x, z[None, :])
                Gz = np.stack([np.stack([c, -z[0] * s], -1), np.stack([s, z[0] * c], -1)], -2)
                self.covs[:, k] = Gz @ R @ Gz.transpose(0, 2, 1)
                self.seen[k] = True
                continue
            lm = self.means[:, k]
            d = lm - x[:, :2]
            q = np.maximum(np.sum(d * d, axis=1), 1e-12)
            rq = np.sqrt(q)
            H = np.stack(
                [
                    np.stack([d[:, 0] / rq, d[:, 1] / rq], -1),
                    np.stack([-d[:, 1] / q, d[:, 0] / q], -1),
                ],
                -2,
            )
            zhat = RangeBearingModel.predict(x, lm)
            r = self.sensor.residual(np.broadcast_to(z, zhat.shape).copy(), zhat)
            Sig = self.covs[:, k]
            SHt = Sig @ H.transpose(0, 2, 1)
            S = H @ SHt + R
            Sinv, det = _inv2(S)
            K = SHt @ Sinv
            self.means[:, k] = lm + np.einsum("mij,mj->mi", K, r)
            C = Sig - K @ H @ Sig
            self.covs[:, k] = 0.5 * (C + C.transpose(0, 2, 1))
            self.log_w += -0.5 * np.einsum("mi,mij,mj->m", r, Sinv, r) - 0.5 * np.log(det)
        self.log_w -= self.log_w.max()
        w = np.exp(self.log_w)
        w /= w.sum()
        M = w.shape[0]
        if 1.0 / np.dot(w, w) < self.options.ess_threshold * M:
            idx = self._resample(w, self.rng)
            self.poses = self.poses[idx]
            self.means = self.means[idx]
            self.covs = self.covs[idx]
            self.log_w = np.zeros(M)

    @serialized
    def best_particle(self) -> int:
        """Index of the highest-weight particle."""
        return int(np.argmax(self.log_w))

    @serialized
    def run(
        self, controls: Sequence[Any], observations: Sequence[LandmarkObservation]
    ) -> SLAMResult:
        """Run over a sequence; poses are weighted means, the map is the best particle's."""
        if len(controls) != len(observations):
            raise InvalidInputError("controls and observations must have the same length")
        t0 = time.perf_counter()
        poses = np.empty((len(controls), 3))
        for t, (u, obs) in enumerate(zip(controls, observations)):
            self.predict(u)
            self.update(obs)
            w = np.exp(self.log_w - self.log_w.max())
            w /= w.sum()
            poses[t, :2] = w @ self.poses[:, :2]
            poses[t, 2] = np.arctan2(w @ np.sin(self.poses[:, 2]), w @ np.cos(self.poses[:, 2]))
        b = self.best_particle()
        ids = np.flatnonzero(self.seen)
        ok = bool(np.isfinite(poses).all())
        return SLAMResult(
            success=ok,
            status=SLAMStatus.SUCCESS if ok else SLAMStatus.NUMERICAL_FAILURE,
            poses=poses,
            landmarks=self.means[b, ids].copy(),
            landmark_covs=self.covs[b, ids].copy(),
            landmark_ids=ids.astype(np.float64),
            num_associated=0,
            num_new=int(ids.size),
            num_rejected=0,
            time_s=time.perf_counter() - t0,
            message="" if ok else "non-finite estimate",
        )


def wrap_heading(poses: FloatArray) -> FloatArray:
    """Return poses with headings wrapped to ``[-pi, pi)``."""
    out = np.array(as_float_array(poses, "poses"))
    out[..., 2] = wrap_angle(out[..., 2])
    return out
