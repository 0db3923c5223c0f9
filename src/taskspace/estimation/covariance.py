"""Validation and small utilities for covariance matrices (slide 6:9-6:10).

A covariance ``A`` of a Gaussian ``N(x | a, A)`` must be square, finite, symmetric and positive
semi-definite. Every public estimator checks its covariances once, at the boundary, with
:func:`as_covariance`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, check_count, check_positive
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError

_SYM_RTOL = 1e-8
_PSD_RTOL = 1e-10


def as_covariance(
    x: Any, size: int | None, name: str, *, positive_definite: bool = False
) -> FloatArray:
    """Convert ``x`` to a validated covariance matrix.

    Args:
        x: array-like square matrix (a scalar is accepted when ``size == 1``).
        size: required dimension ``n`` (matrix is ``n x n``), or ``None`` for any.
        name: argument name used in error messages.
        positive_definite: require strictly positive eigenvalues (needed for inverses).

    Returns:
        A float64 ``(n, n)`` array, symmetrized as ``(A + A^T) / 2``.

    Raises:
        ShapeError: if ``x`` is not square of the right size.
        NotFiniteError: if ``x`` has NaN or inf entries.
        InvalidInputError: if ``x`` is not symmetric or not positive (semi-)definite.
    """
    arr = as_float_array(x, name)
    if arr.ndim == 0 and size == 1:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or (size is not None and arr.shape[0] != size):
        n = -1 if size is None else size
        raise ShapeError(name, (n, n), tuple(arr.shape))
    if not np.all(np.isfinite(arr)):
        bad = np.flatnonzero(~np.isfinite(arr.ravel()))
        raise NotFiniteError(name, [int(i) for i in bad[:20]])
    scale = max(1.0, float(np.max(np.abs(arr))) if arr.size else 1.0)
    with np.errstate(over="ignore"):  # (entries near the float limit: inf, refused below)
        asym = float(np.max(np.abs(arr - arr.T))) if arr.size else 0.0
    if asym > _SYM_RTOL * scale:
        raise InvalidInputError(
            f"{name} must be a symmetric covariance matrix; max |{name} - {name}^T| = {asym:.3g}"
        )
    with np.errstate(over="ignore"):
        sym = 0.5 * (arr + arr.T)
    if not np.isfinite(sym).all():  # entries above 9e307: the sum overflowed, not the mean
        sym = 0.5 * arr + 0.5 * arr.T
    if sym.size:
        lam_min = float(np.linalg.eigvalsh(sym)[0])
        if positive_definite and lam_min <= 0.0:
            raise InvalidInputError(
                f"{name} must be positive definite; smallest eigenvalue is {lam_min:.3g}"
            )
        if lam_min < -_PSD_RTOL * scale:
            raise InvalidInputError(
                f"{name} must be positive semi-definite; smallest eigenvalue is {lam_min:.3g}"
            )
    return np.ascontiguousarray(sym)


def covariance_ellipse(cov: Any, n_sigma: float = 2.0, num_points: int = 64) -> FloatArray:
    """Points of the ``n_sigma`` contour of a 2-D Gaussian centred at the origin.

    The contour ``{x : x^T A^-1 x = n_sigma^2}`` is
    ``n_sigma * V diag(sqrt(lambda)) [cos t; sin t]``
    with ``A = V diag(lambda) V^T``.

    Args:
        cov: ``(2, 2)`` covariance [units^2].
        n_sigma: number of standard deviations.
        num_points: number of contour points.

    Returns:
        ``(num_points, 2)`` array of contour points [units].
    """
    a = as_covariance(cov, 2, "cov")
    n_sigma = check_positive(n_sigma, "n_sigma", strict=False)  # NaN gave NaN points
    num_points = check_count(num_points, "num_points", minimum=1)
    if num_points > 10_000_000:  # 10**12 was a bare MemoryError
        raise InvalidInputError(f"num_points must be at most 10,000,000, got {num_points:,}")
    lam, vec = np.linalg.eigh(a)
    t = np.linspace(0.0, 2.0 * np.pi, num_points)
    circle = np.stack([np.cos(t), np.sin(t)])
    pts = n_sigma * (vec * np.sqrt(np.maximum(lam, 0.0))) @ circle
    return np.ascontiguousarray(pts.T)
