"""UnscentedKalmanFilter at the edge of the floats: equal to the Kalman filter (exact for a
linear model), or a SolverError naming the step and what overflowed or lost its digits; never a
numpy RuntimeWarning, never a non-finite or silently wrong belief.

Reference: the KalmanFilter on the same linear model (its updates at these limits are checked
against the information form in test_kalman_overflow.py), and the scalar information form.

Before: P0 = 1e200 I returned x = -1.4e83 for a measurement 1 with variance 0 (the sigma-point
mean of +-1.4e100 cancelled); P0 = 1e16 I gave the variance 2 R instead of R (P - K S K^T
cancelled); x0 = 1e300 kept every sigma point at x (x + 1.4 rounds to x): the covariance became
Q and the gain 0 silently; h near 1e160 and P near 1e308 raised RuntimeWarnings.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import SolverError
from taskspace.estimation import KalmanFilter, UnscentedKalmanFilter

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

F = np.array([[1.0, 0.1], [0.0, 1.0]])
H = np.array([[1.0, 0.0]])
Q = 0.01 * np.eye(2)


def _ukf(P0: float = 1.0, x0=(0.0, 0.0), h=None, Qs=Q, R: float = 1.0) -> UnscentedKalmanFilter:  # type: ignore[no-untyped-def]
    return UnscentedKalmanFilter(
        lambda x, u: F @ x, h or (lambda x: H @ x), Qs, R * np.eye(1), list(x0), P0 * np.eye(2)
    )


def _kf(P0: float = 1.0, x0=(0.0, 0.0), Qs=Q, R: float = 1.0) -> KalmanFilter:  # type: ignore[no-untyped-def]
    return KalmanFilter(F, H, Qs, R * np.eye(1), list(x0), P0 * np.eye(2))


@pytest.mark.parametrize("p0", [1.0, 1e8, 1e16, 1e20])
def test_a_precise_measurement_gives_the_kalman_filter_posterior(p0: float) -> None:
    # P0 = 1e16: P - K S K^T gave the variance 2 instead of 1 (the KF's Joseph form gives 1)
    u, k = _ukf(p0), _kf(p0)
    for f in (u, k):
        f.predict()
        f.update([1.0])
    # the sigma-point mean h(chi) carries eps sqrt(S) (the points spread by sqrt(S))
    np.testing.assert_allclose(u.x, k.x, rtol=1e-9, atol=1e-14 * np.sqrt(p0))
    np.testing.assert_allclose(np.diag(u.P), np.diag(k.P), rtol=1e-6)
    prior = 1.01 * p0 + 0.01  # (F P F^T + Q)_00, information form of the scalar update
    np.testing.assert_allclose(u.P[0, 0], 1.0 / (1.0 / prior + 1.0), rtol=1e-6)


@pytest.mark.parametrize("p0", [1e30, 1e160, 1e200, 1e300])
def test_an_update_losing_every_digit_is_refused_as_the_kalman_filter(p0: float) -> None:
    # P0 = 1e200 returned x = -1.4e83, variance 0 (the KF refuses)
    u, k = _ukf(p0), _kf(p0)
    u.predict()
    k.predict()
    x, P = u.x.copy(), u.P.copy()
    with pytest.raises(SolverError, match="loses every digit"):
        k.update([1.0])
    with pytest.raises(SolverError, match="update loses every digit"):
        u.update([1.0])
    np.testing.assert_array_equal(u.x, x)
    np.testing.assert_array_equal(u.P, P)


def test_a_spread_below_the_precision_of_the_mean_is_refused() -> None:
    # x0 = 1e300, P0 = I: every sigma point was x, P became Q and the gain 0
    u = _ukf(x0=(1e300, 1e300))
    with pytest.raises(SolverError, match=r"sigma points .* lose the covariance") as err:
        u.predict()
    assert "1e+300" in str(err.value)
    with pytest.raises(SolverError, match=r"sigma points .* lose the covariance"):
        u.update([1.0])
    np.testing.assert_array_equal(u.P, np.eye(2))


def test_large_states_with_a_resolvable_spread_match_the_kalman_filter() -> None:
    # 5e6 (a UTM northing) with a unit prior: the sigma points resolve the spread
    u, k = _ukf(x0=(5e6, 1.0)), _kf(x0=(5e6, 1.0))
    for f in (u, k):
        f.predict()
        f.update([5e6 + 3.0])
    np.testing.assert_allclose(u.x, k.x, rtol=1e-12)
    np.testing.assert_allclose(u.P, k.P, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("scale", [1e160, 1e300])
def test_a_huge_measurement_function_is_named(scale: float) -> None:
    u = _ukf(h=lambda x: np.array([scale * (1.0 + x[0])]))
    with pytest.raises(SolverError, match=r"update overflowed: the innovation covariance S"):
        u.update([0.0])
    np.testing.assert_array_equal(u.x, [0.0, 0.0])


def test_covariances_near_the_float_limit_predict_as_the_kalman_filter() -> None:
    # (n + lambda) P overflowed before the Cholesky factor (P0 = 1e308)
    u, k = _ukf(1e308), _kf(1e308)
    u.predict()
    k.predict()
    np.testing.assert_allclose(u.P, k.P, rtol=1e-12)
    assert np.isfinite(u.P).all()


def test_an_overflowing_prediction_names_the_covariance() -> None:
    u = _ukf(1.7e308, Qs=1.7e308 * np.eye(2))
    with pytest.raises(SolverError, match=r"prediction overflowed: the covariance"):
        u.predict()
    np.testing.assert_array_equal(u.P, 1.7e308 * np.eye(2))


@pytest.mark.parametrize("wrap", [False, True])
def test_the_joseph_form_is_the_ukf_covariance_on_a_nonlinear_model(monkeypatch, wrap) -> None:  # type: ignore[no-untyped-def]
    # the branch taken when P - K S K^T cancels is the same matrix in exact arithmetic:
    # forced on a moderate nonlinear model (with a wrapping angle residual for the state),
    # it must equal the direct formula to rounding
    import taskspace.estimation.unscented_kalman_filter as ukf_module
    from taskspace.estimation import angle_residual

    def make() -> UnscentedKalmanFilter:
        return UnscentedKalmanFilter(
            lambda x, u: x,
            lambda x: np.array([x[0] + 0.3 * x[0] ** 2 + np.sin(x[1]), x[1] * x[0]]),
            0.01 * np.eye(2),
            0.5 * np.eye(2),
            [0.3, 3.0],
            np.array([[1.0, 0.3], [0.3, 2.0]]),
            residual_x=angle_residual(1) if wrap else None,
        )

    direct = make()
    direct.update([1.0, 0.2])
    monkeypatch.setattr(ukf_module, "_CANCELLED", np.inf)
    joseph = make()
    joseph.update([1.0, 0.2])
    np.testing.assert_array_equal(joseph.x, direct.x)
    np.testing.assert_allclose(joseph.P, direct.P, rtol=1e-12, atol=1e-14)


def test_run_names_the_overflowing_prediction() -> None:
    # run's statistical linearization F_k = C^T P^-1 overflowed first (a RuntimeWarning)
    u = UnscentedKalmanFilter(
        lambda x, u: 1e200 * x, lambda x: H @ x, Q, np.eye(1), [0.0, 0.0], 1e200 * np.eye(2)
    )
    with pytest.raises(SolverError, match=r"prediction overflowed: the covariance"):
        u.run([None])
    np.testing.assert_array_equal(u.P, 1e200 * np.eye(2))
