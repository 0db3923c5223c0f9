"""Resampling schemes of the particle filter (slides 7:22-7:23).

Each scheme draws ``num`` indices ``i`` with ``P(i) = w_i`` (or with counts whose expectation
is ``num * w_i``). Following Douc, Cappe & Moulines (2005):

* multinomial: ``num`` independent draws ``u_j ~ U(0, 1)`` inverted through the CDF;
* residual (slide 7:23): ``n_i = floor(num w_i) + nbar_i`` with
  ``nbar ~ Multi(num - sum floor(num w), {num w_i - floor(num w_i)})``;
* stratified: one draw per stratum, ``u_j = (j + U_j) / num``;
* systematic: one shared offset, ``u_j = (j + U) / num`` (lowest variance, ``O(num)``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._validation import FloatArray, as_float_array, check_count
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError, UnknownNameError

IndexArray = npt.NDArray[np.intp]


def normalize_weights(weights: Any, name: str = "weights") -> FloatArray:
    """Validate non-negative finite weights with a positive sum and return ``w / sum(w)``."""
    w = as_float_array(weights, "weights")
    if w.ndim != 1 or w.shape[0] == 0:
        raise ShapeError(name, (-1,), tuple(w.shape))
    if not np.isfinite(w).all():
        raise NotFiniteError(name, [int(i) for i in np.flatnonzero(~np.isfinite(w))[:20]])
    if (w < 0.0).any():
        raise InvalidInputError(f"{name} must be non-negative; min is {float(w.min()):.3g}")
    top = float(w.max())
    if not top > 0.0:
        raise InvalidInputError(f"{name} sum to zero: every particle has zero weight")
    # divided by the largest weight first: [1e308, 1e308] summed to inf, every normalized
    # weight became 0 and resampling returned the last particle only
    w = w / top
    return w / float(w.sum())


def effective_sample_size(weights: Any) -> float:
    """Effective sample size ``N_eff = 1 / sum_i w_i^2`` of normalized weights (in ``[1, N]``)."""
    w = normalize_weights(weights)
    return float(1.0 / np.dot(w, w))


MAX_DRAWS = 100_000_000
"""Largest number of indices drawn by one resampling call."""


def _draws(w: FloatArray, num: Any, rng: Any) -> int:
    """``num`` (default ``N``) as an integer in ``[1, MAX_DRAWS]``; ``rng`` a Generator.

    ``num = 2.5`` was truncated to 2, ``10**13`` a bare MemoryError, ``rng = None`` a bare
    AttributeError.
    """
    if not isinstance(rng, np.random.Generator):
        raise InvalidInputError(
            f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {rng!r}"
        )
    k = w.shape[0] if num is None else check_count(num, "num", minimum=1)
    if k > MAX_DRAWS:
        raise InvalidInputError(f"num must be at most {MAX_DRAWS:,}, got {k:,}")
    return k


def _inverse_cdf(w: FloatArray, u: FloatArray) -> IndexArray:
    cdf = np.cumsum(w)
    cdf[-1] = 1.0
    idx = np.searchsorted(cdf, u, side="right")
    return np.minimum(idx, w.shape[0] - 1)


def multinomial_resample(
    weights: Any, rng: np.random.Generator, num: int | None = None
) -> IndexArray:
    """Multinomial resampling: ``num`` i.i.d. draws from ``{w_i}``.

    Args:
        weights: ``(N,)`` non-negative weights (normalized internally).
        rng: random generator.
        num: number of indices to draw (default ``N``).

    Returns:
        ``(num,)`` particle indices.
    """
    w = normalize_weights(weights)
    k = _draws(w, num, rng)
    return _inverse_cdf(w, rng.random(k))


def residual_resample(weights: Any, rng: np.random.Generator, num: int | None = None) -> IndexArray:
    """Residual resampling (slide 7:23): deterministic ``floor(num w_i)`` copies + multinomial rest.

    Args:
        weights: ``(N,)`` non-negative weights (normalized internally).
        rng: random generator.
        num: number of indices to draw (default ``N``).

    Returns:
        ``(num,)`` particle indices (sorted).
    """
    w = normalize_weights(weights)
    k = _draws(w, num, rng)
    scaled = k * w
    counts = np.floor(scaled).astype(np.intp)
    rest = k - int(counts.sum())
    if rest > 0:
        resid = scaled - counts
        counts += rng.multinomial(rest, resid / resid.sum())
    return np.repeat(np.arange(w.shape[0]), counts)


def stratified_resample(
    weights: Any, rng: np.random.Generator, num: int | None = None
) -> IndexArray:
    """Stratified resampling: ``u_j = (j + U_j) / num`` with independent ``U_j ~ U(0, 1)``."""
    w = normalize_weights(weights)
    k = _draws(w, num, rng)
    return _inverse_cdf(w, (np.arange(k) + rng.random(k)) / k)


def systematic_resample(
    weights: Any, rng: np.random.Generator, num: int | None = None
) -> IndexArray:
    """Systematic resampling: ``u_j = (j + U) / num`` with one shared ``U ~ U(0, 1)``."""
    w = normalize_weights(weights)
    k = _draws(w, num, rng)
    return _inverse_cdf(w, (np.arange(k) + rng.random()) / k)


RESAMPLERS: dict[str, Callable[..., IndexArray]] = {
    "multinomial": multinomial_resample,
    "residual": residual_resample,
    "stratified": stratified_resample,
    "systematic": systematic_resample,
}


def get_resampler(name: str) -> Callable[..., IndexArray]:
    """Resampling function by name (``multinomial``, ``residual``, ``stratified``, ``systematic``).

    Raises:
        UnknownNameError: for any other name (the message lists the valid ones).
    """
    try:
        return RESAMPLERS[name]
    except KeyError:
        raise UnknownNameError("resampling scheme", name, RESAMPLERS) from None
