"""ParticleFilter checks its options when it is made (audit 31).

angular_dims=(5,) on 2-D particles filtered a whole sequence and then failed in estimate()
with a bare IndexError (angular_dims=1: TypeError, (1.5,): IndexError); alpha_slow=-1 or NaN
and alpha_fast=5 were accepted and made the adaptive mixture fraction meaningless;
ess_threshold="0.5" was a bare TypeError.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation import ParticleFilter, ParticleFilterOptions


def _motion(p, u, rng):
    return p + u + 0.1 * rng.standard_normal(p.shape)


def _loglik(p, z):
    return -0.5 * ((p[:, 0] - z) / 0.3) ** 2


def _obs(z, n, rng):
    return np.column_stack([z + 0.3 * rng.standard_normal(n), rng.standard_normal(n)])


def _filter(**options):
    particles = np.random.default_rng(0).normal(size=(50, 2))
    return ParticleFilter(
        particles,
        _motion,
        _loglik,
        np.random.default_rng(np.int64(5)),
        observation_sampler=_obs,
        options=ParticleFilterOptions(**options),
    )


@pytest.mark.parametrize("bad", [(5,), (-3,), (1.5,), (True,), (0, 0), (1, -1), "1"])
def test_angular_dims_outside_the_state_are_refused_at_construction(bad):
    with pytest.raises(InvalidInputError, match="angular_dims"):
        _filter(angular_dims=bad)


def test_angular_dims_inside_the_state_still_work():
    a = _filter(angular_dims=(1,))
    b = _filter(angular_dims=1)
    c = _filter(angular_dims=(np.int64(-1),))
    for pf in (a, b, c):
        pf.predict(np.array([0.1, 0.0]))
        pf.update(0.5)
    mean = a.estimate()[0]
    w = a.weights
    ref = np.arctan2(w @ np.sin(a.particles[:, 1]), w @ np.cos(a.particles[:, 1]))
    assert mean[1] == pytest.approx(ref)
    np.testing.assert_array_equal(b.estimate()[0], mean)
    np.testing.assert_array_equal(c.estimate()[0], mean)


@pytest.mark.parametrize(
    "options",
    [
        {"alpha_slow": -1.0},
        {"alpha_slow": float("nan")},
        {"alpha_slow": 0.0},
        {"alpha_fast": 5.0},
        {"alpha_fast": float("inf")},
        {"ess_threshold": "0.5"},
        {"mixture_fraction": None},
    ],
)
def test_rates_and_thresholds_outside_their_ranges_are_refused(options):
    name = next(iter(options))
    with pytest.raises(InvalidInputError, match=name):
        _filter(**options)
