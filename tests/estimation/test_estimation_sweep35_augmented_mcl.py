"""Augmented MCL (adaptive mixture) with small likelihoods (sweep35).

``w_slow`` and ``w_fast`` averaged ``exp(log-likelihood)``: with log-likelihoods near -800 (a
scan of many beams) every average underflowed to 0 and no particle was ever injected, even
after a kidnapping. The filter's posterior and the fraction ``1 - w_fast / w_slow`` do not
change when a constant is added to every log-likelihood; that invariance is the reference,
with the fraction recomputed from its definition.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.estimation import ParticleFilter, ParticleFilterOptions

SIGMA = 0.3  # measurement noise [m]


def _run(offset: float) -> ParticleFilter:
    """1-D robot localized at 0, kidnapped to 8 m at step 20, measured directly."""

    def motion(x: np.ndarray, u: float, rng: np.random.Generator) -> np.ndarray:
        return x + u + 0.05 * rng.standard_normal(x.shape)

    def log_likelihood(x: np.ndarray, z: float) -> np.ndarray:
        return offset - 0.5 * ((z - x[:, 0]) / SIGMA) ** 2

    def proposal(z: float, k: int, rng: np.random.Generator) -> np.ndarray:
        return z + SIGMA * rng.standard_normal((k, 1))

    opts = ParticleFilterOptions(
        ess_threshold=1.0, mixture_fraction=0.3, adaptive_mixture=True, alpha_fast=0.5
    )
    rng = np.random.default_rng(3)
    pf = ParticleFilter(
        rng.normal(0.0, 0.1, (300, 1)),
        motion,
        log_likelihood,
        np.random.default_rng(7),
        observation_sampler=proposal,
        options=opts,
    )
    truth = 0.0
    for k in range(40):
        truth = 8.0 if k == 20 else truth
        pf.predict(0.0)
        pf.update(truth + SIGMA * rng.standard_normal())
    return pf


@pytest.mark.parametrize("offset", [-800.0, -1e5, 700.0])
def test_adaptive_mixture_is_invariant_to_a_likelihood_constant(offset: float) -> None:
    reference = _run(0.0)
    assert reference.num_injected > 0  # the kidnapping is recovered by injected particles
    assert abs(reference.estimate()[0][0] - 8.0) < 0.5
    shifted = _run(offset)
    assert shifted.num_injected == reference.num_injected
    np.testing.assert_allclose(shifted.particles, reference.particles, atol=1e-12)


def test_fraction_follows_the_definition() -> None:
    # uniform weights: w_avg = mean_i P(z | x_i); one step from the initial average
    pf = ParticleFilter(
        np.array([[0.0], [1.0], [2.0]]),
        lambda x, u, rng: x,
        lambda x, z: -800.0 - 0.5 * (z - x[:, 0]) ** 2,
        np.random.default_rng(0),
        observation_sampler=lambda z, k, rng: np.full((k, 1), z),
        options=ParticleFilterOptions(
            ess_threshold=0.0,
            mixture_fraction=0.9,
            adaptive_mixture=True,
            alpha_slow=0.1,
            alpha_fast=0.5,
        ),
    )
    pf.update(0.0)  # initializes both averages to w0
    w0 = np.mean(np.exp(-0.5 * np.array([0.0, 1.0, 4.0])))  # without the exp(-800) factor
    pf.update(5.0)  # weighted average of the new likelihoods with the updated weights
    w = np.exp(-0.5 * np.array([0.0, 1.0, 4.0]))
    w /= w.sum()
    w1 = float(w @ np.exp(-0.5 * (5.0 - np.array([0.0, 1.0, 2.0])) ** 2))
    slow, fast = 0.9 * w0 + 0.1 * w1, 0.5 * w0 + 0.5 * w1
    assert pf._log_w_slow == pytest.approx(math.log(slow) - 800.0, abs=1e-9)
    assert pf._log_w_fast == pytest.approx(math.log(fast) - 800.0, abs=1e-9)
