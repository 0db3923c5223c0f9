"""Observation models ``P(y_t | x_t)`` of a planar robot (slides 7:14-7:19).

* :class:`RangeBearingModel`: landmark ``l`` seen at range and bearing
  ``h(x, l) = (|l - p|, atan2(l_y - p_y, l_x - p_x) - theta)`` plus ``N(0, R)``;
* :class:`PositionModel`: direct position fix ``h(x) = (p_x, p_y)`` plus ``N(0, R)`` (GPS-like).

Thread safety: the models are immutable values (frozen dataclasses) and their methods are functions
of their arguments, so they may be shared by threads (``sample`` draws from the generator it is
given: one generator per thread); do not modify :attr:`PositionModel.R` in place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_matrix,
    as_vector,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation.motion_models import wrap_angle


def _batch(x: Any, last: int, name: str) -> FloatArray:
    """A finite float array of shape ``(..., last)`` (one item or a batch)."""
    arr = as_float_array(x, name)
    if arr.ndim == 0 or arr.shape[-1] != last:
        raise ShapeError(name, (-1, last), tuple(arr.shape))
    check_finite(arr, name)
    return arr


def _check_ranges(z: FloatArray, name: str) -> None:
    """Refuse a negative measured range (column 0 of ``z`` ``(..., 2)``): a range is a distance.

    A negative range put a new landmark behind the robot (``inverse``, the first sighting in
    EKF-SLAM and FastSLAM) and was fused as if it were a distance; the message names the first
    offending row.
    """
    ranges = z[..., 0]
    if np.any(ranges < 0.0):
        index = tuple(int(i) for i in np.unravel_index(int(np.argmax(ranges < 0.0)), ranges.shape))
        where = f"{name}[{', '.join(str(i) for i in (*index, 0))}]"
        raise InvalidInputError(
            f"{where} (range) must be >= 0 [m], got {float(ranges[index])!r}: a measured range "
            "is a distance (clip simulated noisy ranges at 0)"
        )


@dataclass(frozen=True)
class LandmarkObservation:
    """Range-bearing measurements of several landmarks at one time step.

    Attributes:
        ids: ``(k,)`` landmark indices (ground-truth correspondences; -1 if unknown).
        z: ``(k, 2)`` measured ``(range [m], bearing [rad])``; ranges are >= 0 (the
            estimators refuse a negative one).
    """

    ids: np.ndarray
    z: FloatArray


def checked_observation(obs: Any, name: str = "obs") -> tuple[np.ndarray, FloatArray]:
    """``(ids, z)`` of a :class:`LandmarkObservation`, validated.

    ``ids`` integers (``0.5`` was truncated to landmark 0) and ``z`` finite real ``(k, 2)``
    with as many rows as ids (``zip`` dropped the extra ones silently) and ranges >= 0.
    """
    if not isinstance(obs, LandmarkObservation):
        raise InvalidInputError(
            f"{name} must be a LandmarkObservation(ids=..., z=...), got {type(obs).__name__} "
            "(an empty step is LandmarkObservation(ids=np.zeros(0, int), z=np.zeros((0, 2))))"
        )
    raw = np.asarray(obs.ids) if not isinstance(obs.ids, (str, bytes)) else np.asarray(None)
    if raw.dtype.kind in "iu":
        ids = raw.astype(np.intp).ravel()
    else:
        arr = as_float_array(obs.ids, f"{name}.ids") if raw.dtype.kind != "b" else None
        if arr is None or not (np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))):
            raise InvalidInputError(f"{name}.ids must be integers, got {obs.ids!r}")
        ids = arr.astype(np.intp).ravel()
    z = as_float_array(obs.z, f"{name}.z")
    if z.size == 0 and ids.size == 0:
        return ids, np.zeros((0, 2))
    if z.ndim != 2 or z.shape[1] != 2 or z.shape[0] != ids.size:
        raise ShapeError(f"{name}.z (range, bearing) rows", (ids.size, 2), tuple(z.shape))
    check_finite(z, f"{name}.z")
    _check_ranges(z, f"{name}.z")
    return ids, z


@dataclass(frozen=True, kw_only=True)
class RangeBearingModel:
    """Range-bearing sensor with a limited range and field of view.

    Attributes:
        sigma_range: range noise std [m].
        sigma_bearing: bearing noise std [rad].
        max_range: landmarks farther than this are not observed [m].
        field_of_view: total opening angle [rad] (``2 pi`` sees all around).
    """

    sigma_range: float = 0.1
    sigma_bearing: float = 0.02
    max_range: float = 10.0
    field_of_view: float = 2.0 * np.pi

    def __post_init__(self) -> None:
        for name in ("sigma_range", "sigma_bearing"):  # NaN gave a NaN covariance R
            check_positive(getattr(self, name), name, strict=False)
        for name in ("max_range", "field_of_view"):  # inf allowed (no limit), NaN refused
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float, np.number))
                or not (value > 0)
            ):
                raise InvalidInputError(
                    f"{name} must be a number > 0 (inf: no limit), got {value!r}"
                )

    @property
    def R(self) -> FloatArray:
        """``(2, 2)`` measurement covariance."""
        return np.diag([self.sigma_range**2, self.sigma_bearing**2])

    @staticmethod
    def predict(x: Any, landmarks: Any) -> FloatArray:
        """``h(x, l)`` for poses ``(..., 3)`` and landmarks ``(..., 2)`` (broadcast)."""
        X = _batch(x, 3, "x (poses)")
        L = _batch(landmarks, 2, "landmarks")
        dx = L[..., 0] - X[..., 0]
        dy = L[..., 1] - X[..., 1]
        return np.stack([np.hypot(dx, dy), wrap_angle(np.arctan2(dy, dx) - X[..., 2])], axis=-1)

    @staticmethod
    def jacobians(x: Any, landmark: Any) -> tuple[FloatArray, FloatArray]:
        """``dh/dx`` ``(2, 3)`` and ``dh/dl`` ``(2, 2)`` at one pose and landmark."""
        px, py, _ = as_vector(x, 3, "x")
        lx, ly = as_vector(landmark, 2, "landmark")
        dx, dy = lx - px, ly - py
        q = max(dx * dx + dy * dy, 1e-12)
        r = np.sqrt(q)
        Hl = np.array([[dx / r, dy / r], [-dy / q, dx / q]])
        Hx = np.hstack([-Hl, np.array([[0.0], [-1.0]])])
        return Hx, Hl

    @staticmethod
    def inverse(x: Any, z: Any) -> FloatArray:
        """Landmark position(s) from pose and measurement: ``p + r (cos(th + b), sin(th + b))``.

        Raises:
            InvalidInputError: a negative range ``r`` (it placed the landmark behind the robot).
        """
        X = _batch(x, 3, "x (poses)")
        Z = _batch(z, 2, "z (range, bearing)")
        _check_ranges(Z, "z (range, bearing)")
        a = X[..., 2] + Z[..., 1]
        return np.stack(
            [X[..., 0] + Z[..., 0] * np.cos(a), X[..., 1] + Z[..., 0] * np.sin(a)], axis=-1
        )

    def residual(self, z: Any, z_hat: Any) -> FloatArray:
        """``z - z_hat`` with the bearing wrapped to ``[-pi, pi)``."""
        d = _batch(z, 2, "z") - _batch(z_hat, 2, "z_hat")
        d[..., 1] = wrap_angle(d[..., 1])
        return d

    def log_likelihood(
        self, particles: Any, obs: LandmarkObservation, landmarks: Any
    ) -> FloatArray:
        """``sum_j log N(z_j | h(x_i, l_{id_j}), R)`` for each particle (known correspondences).

        Args:
            particles: ``(N, 3)`` poses.
            obs: the observation (ids index ``landmarks``).
            landmarks: ``(L, 2)`` landmark map [m].

        Returns:
            ``(N,)`` log-likelihoods (up to a constant).

        Raises:
            InvalidInputError: ``obs`` not a valid observation (a negative range among them),
                or an id that is not a row of ``landmarks`` (``-1``, unknown, included).
        """
        ids, z = checked_observation(obs)
        P = _batch(particles, 3, "particles")
        landmark_map = _batch(landmarks, 2, "landmarks")
        if ids.size and not (ids.min() >= 0 and ids.max() < landmark_map.shape[0]):
            # -1 (unknown) read the last landmark silently; others were a bare IndexError
            bad = int(ids[(ids < 0) | (ids >= landmark_map.shape[0])][0])
            raise InvalidInputError(
                f"obs.ids: landmark id {bad} is outside [0, {landmark_map.shape[0]}) (the "
                "landmarks' rows; log_likelihood needs known correspondences)"
            )
        L = landmark_map[ids]  # (k, 2)
        zhat = self.predict(P[:, None, :], L[None, :, :])  # (N, k, 2)
        d = self.residual(z[None, :, :], zhat)
        return -0.5 * np.sum(
            (d[..., 0] / self.sigma_range) ** 2 + (d[..., 1] / self.sigma_bearing) ** 2, axis=1
        )

    def sample(self, x: Any, landmarks: Any, rng: np.random.Generator) -> LandmarkObservation:
        """Simulate the visible landmarks' noisy measurements from the true pose ``x``.

        The noisy range is clipped at 0: a sensor reports no negative distance (and the
        estimators refuse one), so a landmark closer than a few ``sigma_range`` has a range
        distribution with an atom at 0 instead of the Gaussian's negative tail.
        """
        xv = as_vector(x, 3, "x")
        L = as_matrix(landmarks, (None, 2), "landmarks")
        zt = self.predict(xv[None, :], L)
        visible = (zt[:, 0] <= self.max_range) & (np.abs(zt[:, 1]) <= 0.5 * self.field_of_view)
        ids = np.flatnonzero(visible)
        z = zt[ids] + rng.standard_normal((ids.size, 2)) * [self.sigma_range, self.sigma_bearing]
        z[:, 0] = np.maximum(z[:, 0], 0.0)
        z[:, 1] = wrap_angle(z[:, 1])
        return LandmarkObservation(ids=ids, z=z)


@dataclass(frozen=True, kw_only=True)
class PositionModel:
    """Position fix ``z = (p_x, p_y) + N(0, R)``.

    Attributes:
        R: ``(2, 2)`` covariance [m^2].
    """

    R: FloatArray = field(default_factory=lambda: 0.25 * np.eye(2))

    def __post_init__(self) -> None:
        R = as_float_array(self.R, "PositionModel.R")
        if R.shape != (2, 2) or not np.all(np.linalg.eigvalsh(0.5 * (R + R.T)) > 0):
            raise InvalidInputError("PositionModel.R must be a (2, 2) positive-definite matrix")

    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])

    def predict(self, x: Any) -> FloatArray:
        """``h(x) = (p_x, p_y)``."""
        return _batch(x, 3, "x (poses)")[..., :2]

    def log_likelihood(self, particles: Any, z: Any) -> FloatArray:
        """``log N(z | p_i, R)`` up to a constant, for each particle."""
        d = _batch(z, 2, "z") - _batch(particles, 3, "particles")[..., :2]
        Ri = np.linalg.inv(self.R)
        return -0.5 * np.einsum("ni,ij,nj->n", d, Ri, d)

    def sample(self, x: Any, rng: np.random.Generator) -> FloatArray:
        """Noisy position of the true pose ``x``."""
        xv = as_vector(x, 3, "x")
        return xv[:2] + np.linalg.cholesky(self.R) @ rng.standard_normal(2)
