"""BatchKalmanFilter at extreme scales (#15): raise or be right, never zeros or NaN.

Reference: the scalar Kalman filter in information form, per coordinate, for diagonal models
(``x+ = (x/P + z/R) / (1/P + 1/R)``, ``P+ = 1 / (1/P + 1/R)``: no cancellation).
Before: F = 1e200 I returned zeros (m = 3: NaN) with overflow warnings; a prediction that
overflowed stored inf beliefs.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, SolverError
from taskspace.estimation import BatchKalmanFilter


def _reference(f: float, q: float, r: float, x0: np.ndarray, p0: float, zs: list, m: int):
    x = x0.astype(float).copy()
    P = np.full_like(x, p0)
    for z in zs:
        x, P = f * x, f * f * P + q
        xm, Pm, zm = x[:, :m], P[:, :m], z
        info = 1.0 / Pm + 1.0 / r
        x[:, :m] = (xm / Pm + zm / r) / info
        P[:, :m] = 1.0 / info
    return x, P


@pytest.mark.parametrize("f", [1e200, 1e160, -1e155])
@pytest.mark.parametrize("m", [1, 2, 3])
def test_overflowing_transition_is_refused(f: float, m: int) -> None:
    n = 3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InvalidInputError, match="rescale"):
            BatchKalmanFilter(
                f * np.eye(n), np.eye(m, n), np.eye(n), np.eye(m), np.ones((4, n)), np.eye(n)
            )


@pytest.mark.parametrize("f", [1e-150, 1e-20, 1.0, 1e20, 1e100, 1e150])
@pytest.mark.parametrize("m", [1, 2, 3])
def test_large_and_small_transitions_raise_or_are_right(f: float, m: int) -> None:
    n, N = 3, 4
    rng = np.random.default_rng(m)
    x0 = rng.normal(size=(N, n))
    zs = [rng.normal(size=(N, m)) for _ in range(3)]
    kf = BatchKalmanFilter(f * np.eye(n), np.eye(m, n), np.eye(n), np.eye(m), x0, np.eye(n))
    x_ref, P_ref = x0.copy(), np.ones((N, n))
    for k, z in enumerate(zs):
        x_before, P_before = kf.x.copy(), kf.P.copy()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                kf.step(z)
        except SolverError:
            np.testing.assert_array_equal(kf.x, x_before)  # beliefs left unchanged
            np.testing.assert_array_equal(kf.P, P_before)
            return
        x_ref, P_ref = _reference(f, 1.0, 1.0, x0, 1.0, zs[: k + 1], m)
        # forward error of a backward-stable step: eps times the size of the prediction
        scale = np.abs(f * x_before) + np.abs(np.pad(z, ((0, 0), (0, n - m)))) + 1.0
        assert np.all(np.abs(kf.x - x_ref) <= 1e-12 * scale)
        diag = np.diagonal(kf.P, axis1=1, axis2=2)
        np.testing.assert_allclose(diag, P_ref, rtol=1e-9)
        assert np.isfinite(kf.P).all() and np.isfinite(kf.x).all()


@pytest.mark.parametrize("m", [1, 2, 3])
def test_prediction_overflow_keeps_the_beliefs(m: int) -> None:
    n = 3
    x0 = np.array([[1.0, 2.0, 3.0], [1e306, 0.0, 0.0]])
    kf = BatchKalmanFilter(1e3 * np.eye(n), np.eye(m, n), np.eye(n), np.eye(m), x0, np.eye(n))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SolverError, match=r"tracks \[1\]"):
            kf.predict()
    np.testing.assert_array_equal(kf.x, x0)
