"""Bad inputs to the estimation helpers (resampling, ellipses, hallway transitions, landmark
simulation, RTS smoother; issue #15): a right answer or a TaskspaceError.

References: resampling equal weights of any scale draws every particle equally often
(systematic resampling of N equal weights returns each index once); the 1-sigma ellipse of
``diag(4, 1)`` has semi-axes 2 and 1; a cyclic shift by 1 is the permutation matrix.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation.covariance import covariance_ellipse
from taskspace.estimation.histogram_filter import shift_transition_matrix
from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.observation_models import RangeBearingModel
from taskspace.estimation.resampling import (
    multinomial_resample,
    residual_resample,
    stratified_resample,
    systematic_resample,
)
from taskspace.estimation.rts_smoother import rts_smooth
from taskspace.estimation.simulation import loop_controls, simulate_landmark_world

RNG = np.random.default_rng(0)


@pytest.mark.parametrize("scale", [1e-300, 1.0, 1e308])
def test_equal_weights_of_any_scale_resample_every_particle(scale: float) -> None:
    # [1e308, 1e308] summed to inf: every normalized weight was 0 and only the last particle
    # was drawn
    idx = systematic_resample(np.full(4, scale), np.random.default_rng(1))
    np.testing.assert_array_equal(np.sort(idx), [0, 1, 2, 3])
    idx = residual_resample(np.full(4, scale), np.random.default_rng(1))
    np.testing.assert_array_equal(np.sort(idx), [0, 1, 2, 3])


@pytest.mark.parametrize(
    "resample", [multinomial_resample, stratified_resample, systematic_resample, residual_resample]
)
@pytest.mark.parametrize("num, rng", [(2.5, RNG), (10**13, RNG), (0, RNG), (None, None)])
def test_resampling_counts_and_rng_are_checked(resample, num, rng) -> None:  # type: ignore[no-untyped-def]
    # 2.5 was truncated to 2, 10**13 a bare MemoryError, rng=None a bare AttributeError
    with pytest.raises(InvalidInputError):
        resample([0.5, 0.5], rng, num)


def test_covariance_ellipse() -> None:
    pts = covariance_ellipse(np.diag([4.0, 1.0]), 1.0, 5)
    np.testing.assert_allclose(np.abs(pts).max(axis=0), [2.0, 1.0], atol=1e-12)
    for kw in ({"n_sigma": np.nan}, {"num_points": 10**12}, {"num_points": 2.5}):
        with pytest.raises(InvalidInputError):  # NaN points / bare MemoryError / truncated
            covariance_ellipse(np.eye(2), **kw)  # type: ignore[arg-type]


def test_shift_transition_matrix() -> None:
    np.testing.assert_array_equal(shift_transition_matrix(3, 1), np.roll(np.eye(3), 1, axis=0))
    with pytest.raises(InvalidInputError):  # bare IndexError
        shift_transition_matrix(5, 2.5)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError):  # bare MemoryError (7.3 TiB)
        shift_transition_matrix(10**6, 1)


def test_landmark_world_helpers() -> None:
    assert loop_controls(3, 1.0, 0.2).shape == (3, 2)
    for args in ((2.5,), (np.nan,), (-1,), (10**13,), (5, np.nan)):
        with pytest.raises(InvalidInputError):  # truncated / bare ValueError / MemoryError / NaN
            loop_controls(*args)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError):  # bare AttributeError at the first sample
        simulate_landmark_world(
            VelocityMotionModel(),
            RangeBearingModel(),
            np.zeros(3),
            loop_controls(3),
            np.zeros((2, 2)),
            None,  # type: ignore[arg-type]
        )


@pytest.mark.parametrize("result", [5, None])
def test_rts_smooth_needs_a_filter_result(result: object) -> None:
    with pytest.raises(InvalidInputError, match="FilterResult"):  # bare AttributeError
        rts_smooth(result)  # type: ignore[arg-type]
