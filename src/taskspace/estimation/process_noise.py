"""Process noise of kinematic (constant velocity, acceleration, jerk) models.

A chain of ``dim`` integrators (position, velocity, acceleration...) driven by noise on its
highest derivative, sampled with period ``dt``, has one of two standard process noise
covariances:

* **discrete white noise** (a random constant of variance ``var`` over each period):
  ``Q = var G G^T``. With ``dim >= 3`` the constant is the increment of the highest
  derivative, ``G_i = dt^(dim-1-i) / (dim-1-i)!`` (``G = (dt^2/2, dt, 1)`` for position,
  velocity, acceleration); with ``dim == 2`` (constant velocity) it is the acceleration,
  ``G = (dt^2/2, dt)`` (Bar-Shalom's discrete white noise acceleration model);
* **continuous white noise** (power spectral density ``q``):
  ``Q_ij = q dt^(2 dim - 1 - i - j) / ((dim-1-i)! (dim-1-j)! (2 dim - 1 - i - j))``.

With ``block_size > 1`` the same model applies to each of ``block_size`` independent axes:
ordered by dimension (``x, x', x'', y, y', y''``: ``Q = I_b (x) Q_1``) or by derivative
(``x, y, x', y', ...``: ``Q = Q_1 (x) I_b``). The values equal filterpy's
``Q_discrete_white_noise`` and ``Q_continuous_white_noise``.
"""

from __future__ import annotations

import math

import numpy as np

from taskspace._validation import FloatArray, check_int, check_positive
from taskspace.errors import InvalidInputError


def _arrange(Q1: FloatArray, block_size: int, order_by_dim: bool) -> FloatArray:
    if block_size == 1:  # ``np.kron`` with I_1 would copy Q1 (twice its memory at the cap)
        return Q1
    eye = np.eye(block_size)
    return np.asarray(np.kron(eye, Q1) if order_by_dim else np.kron(Q1, eye), dtype=np.float64)


def _finite(Q1: FloatArray, dt: float) -> FloatArray:
    # NaN propagates through min and max: no boolean array of the size of Q1
    if not (math.isfinite(Q1.max()) and math.isfinite(Q1.min())):
        raise InvalidInputError(
            f"the process noise overflows for dt = {dt!r} and this variance: use a smaller dt "
            "(or other time units)"
        )
    return Q1


def _check(dim: int, dt: float, block_size: int, order_by_dim: bool) -> tuple[int, float, int]:
    d = check_int(dim, "dim (number of derivatives: 2 = position and velocity)", minimum=1)
    b = check_int(block_size, "block_size (number of independent axes)", minimum=1)
    if d * b > 10_000:
        raise InvalidInputError(f"dim * block_size = {d * b} is too large (at most 10000)")
    if not isinstance(order_by_dim, (bool, np.bool_)):
        raise InvalidInputError(f"order_by_dim must be True or False, got {order_by_dim!r}")
    return d, check_positive(dt, "dt [s]"), b


def discrete_white_noise(
    dim: int, dt: float = 1.0, var: float = 1.0, block_size: int = 1, order_by_dim: bool = True
) -> FloatArray:
    """Process noise of a piecewise-constant white noise (filterpy's ``Q_discrete_white_noise``).

    ``Q = var G G^T`` with ``G = (dt^2/2, dt)`` for ``dim == 2`` and
    ``G_i = dt^(dim-1-i) / (dim-1-i)!`` for ``dim >= 3`` (module docstring).

    Args:
        dim: number of states per axis (2: position and velocity; 3: with acceleration...).
        dt: sampling period [s].
        var: variance of the driving noise (acceleration for ``dim`` 2 and 3, jerk for 4...).
        block_size: number of independent axes.
        order_by_dim: states ordered per axis (``x, x', y, y'``) rather than per derivative
            (``x, y, x', y'``).

    Returns:
        The ``(dim * block_size)`` square covariance.

    Raises:
        InvalidInputError: ``dim`` or ``block_size`` not a positive integer, ``dt`` not
            ``> 0``, ``var`` negative or not finite.
    """
    d, h, b = _check(dim, dt, block_size, order_by_dim)
    if d < 2:
        raise InvalidInputError(
            f"dim must be >= 2 (position and velocity at least), got {dim!r}; for a random walk "
            "use Q = var * dt * I"
        )
    v = check_positive(var, "var", strict=False)
    top = max(d - 1, 2)  # dim 2: the acceleration drives (position, velocity)
    with np.errstate(over="ignore", invalid="ignore"):
        G = np.array([np.power(h, top - i) * math.exp(-math.lgamma(top - i + 1)) for i in range(d)])
        Q1 = v * np.outer(G, G)
    return _arrange(_finite(Q1, dt), b, bool(order_by_dim))


def continuous_white_noise(
    dim: int,
    dt: float = 1.0,
    spectral_density: float = 1.0,
    block_size: int = 1,
    order_by_dim: bool = True,
) -> FloatArray:
    """Process noise of a continuous white noise on the highest derivative.

    ``Q_ij = q dt^(2 dim - 1 - i - j) / ((dim-1-i)! (dim-1-j)! (2 dim - 1 - i - j))``.

    Args:
        dim: number of states per axis.
        dt: sampling period [s].
        spectral_density: power spectral density ``q`` of the noise.
        block_size: number of independent axes.
        order_by_dim: as :func:`discrete_white_noise`.

    Returns:
        The ``(dim * block_size)`` square covariance.
    """
    d, h, b = _check(dim, dt, block_size, order_by_dim)
    q = check_positive(spectral_density, "spectral_density", strict=False)
    # Q_ij = q h a_i a_j / p_ij with a_i = h^k / k!, k = dim-1-i, p_ij = 2 dim - 1 - i - j,
    # summed in logs (h^k and k! overflow a float for dim > 85; their ratio may not). Vectorized:
    # the double Python loop took 38 s for dim 2000 and ~30 min at the cap of 10000.
    k = np.arange(d - 1, -1, -1, dtype=float)
    with np.errstate(over="ignore", invalid="ignore", under="ignore", divide="ignore"):
        log_h = math.log(h)
        la = np.array([ki * log_h - math.lgamma(ki + 1.0) for ki in k])
        Q1 = la[:, None] + la[None, :]
        np.exp(Q1, out=Q1)
        Q1 *= q * h
        for r in range(0, d, 256):  # in row blocks: no second d x d array
            Q1[r : r + 256] /= k[r : r + 256, None] + k[None, :] + 1.0
    return _arrange(_finite(Q1, dt), b, bool(order_by_dim))


__all__ = ["continuous_white_noise", "discrete_white_noise"]
