"""Sampling strategies for roadmaps (slide 3:35).

* uniform: ``q ~ U(Q)``, kept if ``q in Q_free``;
* Gaussian: ``q1 ~ U(Q)``, ``q2 ~ N(q1, sigma^2 I)``; if exactly one of them is free, keep the
  free one (samples concentrate near obstacle boundaries);
* bridge test: ``q1 ~ U(Q)``, ``q2 ~ N(q1, sigma^2 I)``, ``q3 = (q1 + q2) / 2``; if ``q1`` and
  ``q2`` are in collision and ``q3`` is free, keep ``q3`` (samples concentrate in narrow
  passages, slide 3:33).

Samples are drawn and checked in vectorized batches (one checker call per batch).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from taskspace._validation import check_positive
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray

Sampler = Literal["uniform", "gaussian", "bridge"]
SAMPLERS = ("uniform", "gaussian", "bridge")


def _candidates(
    space: ConfigurationSpace, strategy: str, batch: int, sigma: float, rng: np.random.Generator
) -> FloatArray:
    q1 = space.sample_uniform(rng, batch)
    if strategy == "uniform":
        return q1[space.checker.are_valid(q1)]
    q2 = np.clip(q1 + sigma * rng.standard_normal(q1.shape), space.lower, space.upper)
    v1 = space.checker.are_valid(q1)
    v2 = space.checker.are_valid(q2)
    if strategy == "gaussian":
        return np.vstack([q1[v1 & ~v2], q2[v2 & ~v1]])
    both = ~v1 & ~v2
    q3 = 0.5 * (q1[both] + q2[both])
    if q3.shape[0] == 0:
        return q3
    return q3[space.checker.are_valid(q3)]


def sample_free(
    space: ConfigurationSpace,
    n: int,
    rng: np.random.Generator,
    *,
    strategy: Sampler = "uniform",
    sigma: float = 0.3,
    batch: int = 256,
    max_draws: int | None = None,
) -> FloatArray:
    """Draw ``n`` free configurations with a sampling strategy (slide 3:35).

    Args:
        space: configuration space.
        n: number of samples wanted.
        rng: random generator.
        strategy: ``"uniform"``, ``"gaussian"`` or ``"bridge"``.
        sigma: standard deviation of the Gaussian offset [rad or m].
        batch: candidates drawn per checker call.
        max_draws: stop after this many uniform draws (default ``1000 n``); fewer than ``n``
            samples may then be returned.

    Returns:
        Samples, shape (m, d) with ``m <= n`` (``m == n`` unless ``max_draws`` was hit).
    """
    if strategy not in SAMPLERS:
        raise UnknownNameError("sampler", str(strategy), SAMPLERS)
    if strategy != "uniform":
        space.require_euclidean(f"the {strategy!r} sampler")
    if n < 0:
        raise InvalidInputError(f"n must be >= 0, got {n}")
    check_positive(sigma, "sigma")
    limit = max_draws if max_draws is not None else 1000 * max(n, 1)
    out: list[FloatArray] = []
    have = draws = 0
    while have < n and draws < limit:
        got = _candidates(space, strategy, batch, sigma, rng)
        draws += batch
        out.append(got)
        have += got.shape[0]
    if not out:
        return np.empty((0, space.dim))
    return np.vstack(out)[:n]
