"""Motion models, Gaussian and the CV model on bad parameters (#15): refused at construction.

Before: VelocityMotionModel(dt=NaN) gave NaN poses, dt="x" or alphas=(1, 2) a bare error at
the first use, dt < 0 ran the model backward; OdometryMotionModel took negative noise
coefficients and stds; KinematicCarModel(dt="x") raised a bare TypeError and
max_steering=NaN gave NaN headings; constant_velocity_model(dt=1e160) a bare OverflowError;
Gaussian accepted any covariance (negative, NaN, text, wrong size).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation import (
    Gaussian,
    KinematicCarModel,
    OdometryMotionModel,
    VelocityMotionModel,
    constant_velocity_model,
)

BAD_POSITIVE = [0.0, -1.0, np.nan, np.inf, "x", None, 1j]
BAD_NON_NEGATIVE = [-1.0, np.nan, np.inf, "x", None]
BAD_ALPHAS = [(np.nan, 0, 0, 0), (-1, 0, 0, 0), (1, 2), "abcd", None]


@pytest.mark.parametrize("value", BAD_POSITIVE)
@pytest.mark.parametrize(
    ("cls", "field"),
    [
        (VelocityMotionModel, "dt"),
        (KinematicCarModel, "dt"),
        (KinematicCarModel, "wheelbase"),
        (KinematicCarModel, "max_steering"),
    ],
)
def test_positive_fields(cls: type, field: str, value: Any) -> None:
    with pytest.raises(InvalidInputError, match=field):
        cls(**{field: value})


@pytest.mark.parametrize("value", BAD_NON_NEGATIVE)
@pytest.mark.parametrize(
    ("cls", "field"),
    [
        (VelocityMotionModel, "sigma_v"),
        (VelocityMotionModel, "sigma_w"),
        (OdometryMotionModel, "min_std"),
        (KinematicCarModel, "sigma_v"),
        (KinematicCarModel, "sigma_delta"),
    ],
)
def test_non_negative_fields(cls: type, field: str, value: Any) -> None:
    with pytest.raises(InvalidInputError, match=field):
        cls(**{field: value})


@pytest.mark.parametrize("alphas", BAD_ALPHAS)
@pytest.mark.parametrize("cls", [VelocityMotionModel, OdometryMotionModel])
def test_alphas(cls: type, alphas: Any) -> None:
    with pytest.raises(InvalidInputError, match="alphas"):
        cls(alphas=alphas)


def test_valid_models_keep_their_analytic_motion() -> None:
    # straight line: v dt along the heading; the fields are stored as floats
    model = VelocityMotionModel(dt=0.5, alphas=(0, 0, 0, 0), sigma_v=0, sigma_w=0)
    np.testing.assert_allclose(model.mean(np.zeros(3), [2.0, 0.0]), [1.0, 0.0, 0.0], atol=1e-15)
    assert model.alphas == (0.0, 0.0, 0.0, 0.0) and isinstance(model.dt, float)
    car = KinematicCarModel(dt=1, wheelbase=2)  # ints are accepted
    np.testing.assert_allclose(car.mean(np.zeros(3), [3.0, 0.0]), [3.0, 0.0, 0.0], atol=1e-15)
    odo = OdometryMotionModel(alphas=[0, 0, 0, 0], min_std=0)
    np.testing.assert_allclose(odo.mean(np.zeros(3), [0.0, 1.5, 0.0]), [1.5, 0.0, 0.0])


@pytest.mark.parametrize("dt", [1e160, 1e300])
def test_constant_velocity_model_overflow(dt: float) -> None:
    with pytest.raises(InvalidInputError, match="overflows"):
        constant_velocity_model(dt, 1.0)


@pytest.mark.parametrize("dim", [0, -1, 2.5, "x"])
def test_constant_velocity_model_dim(dim: Any) -> None:
    with pytest.raises(InvalidInputError, match="dim"):
        constant_velocity_model(0.1, 1.0, dim)


def test_constant_velocity_model_large_dt_is_exact() -> None:
    F, Q, _H = constant_velocity_model(1e100, 2.0, dim=1)
    np.testing.assert_allclose(Q, 2.0 * np.array([[1e300 / 3, 1e200 / 2], [1e200 / 2, 1e100]]))
    np.testing.assert_array_equal(F, [[1.0, 1e100], [0.0, 1.0]])


@pytest.mark.parametrize(
    "cov", [-np.eye(2), "x", None, np.eye(3), np.full((2, 2), np.nan), [[1.0, 2.0], [0.0, 1.0]]]
)
def test_gaussian_refuses_bad_covariances(cov: Any) -> None:
    with pytest.raises(InvalidInputError):
        Gaussian(np.zeros(2), cov)


def test_gaussian_stores_float_arrays() -> None:
    g = Gaussian([1, 2], [[2, 0], [0, 1]])
    assert g.mean.dtype == np.float64 and g.cov.dtype == np.float64
    np.testing.assert_array_equal(g.cov, [[2.0, 0.0], [0.0, 1.0]])
    with pytest.raises(InvalidInputError, match="mean"):
        Gaussian([np.nan, 0.0], np.eye(2))
