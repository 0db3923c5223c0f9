"""Residual and mean functions for states and measurements that hold angles [rad].

An angle is a point on the circle: the difference of two bearings is the shortest signed
arc, ``wrap(a - b)`` in ``[-pi, pi)`` (179 deg minus -179 deg is -2 deg, not 358 deg), and
the mean of angles ``theta_i`` with weights ``w_i`` is the circular mean
``atan2(sum w_i sin theta_i, sum w_i cos theta_i)``, not ``sum w_i theta_i``.

The Kalman-family filters take these as their ``residual`` / ``residual_x`` / ``mean_x`` /
``mean_z`` arguments (the roles of filterpy's ``residual_x``, ``residual_z``, ``x_mean_fn``
and ``z_mean_fn``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from taskspace._validation import FloatArray, as_float_array, check_finite, check_int
from taskspace.errors import InvalidInputError
from taskspace.estimation.motion_models import wrap_angle

ResidualFn = Callable[[FloatArray, FloatArray], FloatArray]
MeanFn = Callable[[FloatArray, FloatArray], FloatArray]


def _indices(angular: int | Sequence[int], name: str) -> list[int]:
    scalar = isinstance(angular, (int, np.integer)) or (
        isinstance(angular, np.ndarray) and angular.ndim == 0
    )
    items = [angular] if scalar else angular
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence | np.ndarray):
        raise InvalidInputError(
            f"{name} must be an index or a list of indices of the angles, got {angular!r}"
        )
    out = [check_int(i, f"{name} entry") for i in items]
    if len(set(out)) != len(out):
        raise InvalidInputError(f"{name} has repeated indices: {out}")
    return out


def angle_residual(angular: int | Sequence[int]) -> ResidualFn:
    """Difference ``a - b`` with the entries ``angular`` wrapped to ``[-pi, pi)``.

    Args:
        angular: index (or indices) of the angles in the vectors [rad].

    Returns:
        ``residual(a, b) -> a - b`` for vectors of equal length; out-of-range indices raise
        :class:`~taskspace.errors.InvalidInputError` when it is called.
    """
    idx = _indices(angular, "angular")

    def residual(a: FloatArray, b: FloatArray) -> FloatArray:
        # NaN/inf inputs gave a NaN residual silently (angle_residual(0)(nan, zeros(3)))
        a_arr, b_arr = as_float_array(a, "a"), as_float_array(b, "b")
        check_finite(a_arr, "a")
        check_finite(b_arr, "b")
        d = np.subtract(a_arr, b_arr)
        if d.ndim != 1 or any(not -d.shape[0] <= i < d.shape[0] for i in idx):
            raise InvalidInputError(
                f"angle_residual({idx}) got vectors of shape {d.shape}: the angle indices must "
                "be inside the vector"
            )
        d[idx] = wrap_angle(d[idx])
        return d

    return residual


def angle_mean(angular: int | Sequence[int]) -> MeanFn:
    """Weighted mean of points whose entries ``angular`` are angles (circular mean there).

    ``mean(points, weights)`` with ``points`` of shape ``(N, n)`` and ``weights`` ``(N,)``
    (weights may be negative, as the unscented transform's are) returns
    ``sum_i w_i x_i`` for ordinary entries and ``atan2(sum_i w_i sin x_i, sum_i w_i cos x_i)``
    for angles.

    Args:
        angular: index (or indices) of the angles [rad].

    Returns:
        The mean function.
    """
    idx = _indices(angular, "angular")

    def mean(points: FloatArray, weights: FloatArray) -> FloatArray:
        X = as_float_array(points, "points")
        w = as_float_array(weights, "weights")
        if X.ndim != 2 or w.shape != (X.shape[0],):
            raise InvalidInputError(
                f"angle_mean needs points (N, n) and weights (N,), got {X.shape} and {w.shape}"
            )
        if any(not -X.shape[1] <= i < X.shape[1] for i in idx):
            raise InvalidInputError(
                f"angle_mean({idx}) got points of dimension {X.shape[1]}: the angle indices must "
                "be inside the vector"
            )
        check_finite(X, "points")  # NaN points or weights gave a NaN mean silently
        check_finite(w, "weights")
        out = w @ X
        out[idx] = np.arctan2(w @ np.sin(X[:, idx]), w @ np.cos(X[:, idx]))
        return np.asarray(out)

    return mean


def weighted_mean(points: FloatArray, weights: FloatArray) -> FloatArray:
    """Ordinary weighted mean ``sum_i w_i x_i`` (the default mean function)."""
    return np.asarray(weights @ points)


def subtract(a: FloatArray, b: FloatArray) -> FloatArray:
    """Ordinary difference ``a - b`` (the default residual function)."""
    return np.asarray(a - b)


__all__ = ["angle_mean", "angle_residual", "subtract", "weighted_mean"]
