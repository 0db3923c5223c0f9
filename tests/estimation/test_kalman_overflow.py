"""KalmanFilter / ExtendedKalmanFilter at the edge of the floats: exact, or a SolverError that
names the step and what overflowed; never a numpy RuntimeWarning, never a non-finite belief.

References: the scalar Kalman filter in information form per coordinate, for diagonal models
(``x+ = (x/P + z/R) / (1/P + 1/R)``, ``P+ = 1 / (1/P + 1/R)``), and the closed-form Gaussian
log-density.

Before: ``H = 1e200 I`` made ``S = H P H^T + R`` infinite, whose Cholesky factor gave a zero gain:
the update ignored the measurement and returned NIS 0 (a finite, wrong belief); ``KalmanFilter.run``
carried NaN beliefs through every later step; ``as_covariance`` turned a finite covariance of
1.2e308 into inf (``A + A^T`` overflowed); each with RuntimeWarnings.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import SolverError
from taskspace.estimation import ExtendedKalmanFilter, KalmanFilter, KalmanFilterOptions
from taskspace.estimation.gaussian import gaussian_logpdf

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

I2 = np.eye(2)


def _kf(F: float = 1.0, H: float = 1.0, Q: float = 1.0, R: float = 1.0, x0=(1.0, 1.0), P0=1.0):  # type: ignore[no-untyped-def]
    return KalmanFilter(F * I2, H * I2, Q * I2, R * I2, list(x0), P0 * I2)


def _ekf(F: float = 1.0, H: float = 1.0, Q: float = 1.0, R: float = 1.0, x0=(1.0, 1.0), P0=1.0):  # type: ignore[no-untyped-def]
    return ExtendedKalmanFilter(
        lambda x, u: F * x,
        lambda x, u: F * I2,
        lambda x: H * x,
        lambda x: H * I2,
        Q * I2,
        R * I2,
        list(x0),
        P0 * I2,
    )


def _information_update(x: float, P: float, z: float, R: float) -> tuple[float, float]:
    info = 1.0 / P + 1.0 / R
    return (x / P + z / R) / info, 1.0 / info


@pytest.mark.parametrize("make", [_kf, _ekf])
def test_an_overflowing_innovation_covariance_is_refused_not_ignored(make) -> None:  # type: ignore[no-untyped-def]
    # H = 1e200: S = 1e400. The old update ignored the measurement (x stayed 1, NIS 0).
    f = make(H=1e200)
    with pytest.raises(SolverError, match=r"update overflowed: the innovation covariance S") as err:
        f.update([1e300, 1e300])
    assert "H 1e+200" in str(err.value)
    np.testing.assert_array_equal(f.x, [1.0, 1.0])
    np.testing.assert_array_equal(f.P, I2)


@pytest.mark.parametrize("make", [_kf, _ekf])
def test_an_overflowing_prediction_names_the_covariance(make) -> None:  # type: ignore[no-untyped-def]
    f = make(F=1e200)
    with pytest.raises(SolverError, match=r"prediction overflowed: the covariance F P F\^T \+ Q"):
        f.predict()
    np.testing.assert_array_equal(f.x, [1.0, 1.0])
    np.testing.assert_array_equal(f.P, I2)


def test_an_overflowing_mean_is_named() -> None:
    kf = _kf(F=1e10, x0=(1e300, 0.0))
    with pytest.raises(SolverError, match=r"prediction overflowed: the mean F x \+ B u"):
        kf.predict()


@pytest.mark.parametrize("make", [_kf, _ekf])
def test_run_names_the_step_that_overflowed(make) -> None:  # type: ignore[no-untyped-def]
    # F = 1e60, no measurements: P = 1e120, 1e240, then 1e360 at the prediction of step 2.
    # The old KalmanFilter.run returned NaN beliefs from there on (with overflow warnings).
    f = make(F=1e60, Q=0.0)
    with pytest.raises(SolverError, match=r"step 2") as err:
        f.run([None] * 4)
    assert "prediction" in str(err.value) and "F P F^T + Q" in str(err.value)
    assert np.isfinite(f.x).all() and np.isfinite(f.P).all()  # the belief of step 1


@pytest.mark.parametrize("make", [_kf, _ekf])
def test_huge_but_representable_updates_are_exact(make) -> None:  # type: ignore[no-untyped-def]
    # P = 1e200, R = 1e190, z = 1e300: the update is representable; NIS = r^2 / S = 1e400
    # is beyond the floats: inf (any gate refuses it), without a warning.
    f = make(x0=(0.0, 1.0), P0=1e200, R=1e190)
    nis = f.update([1e300, -1e300])
    assert nis == math.inf
    for i, (x0, z) in enumerate([(0.0, 1e300), (1.0, -1e300)]):
        x_ref, P_ref = _information_update(x0, 1e200, z, 1e190)
        assert f.x[i] == pytest.approx(x_ref, rel=1e-12)
        assert f.P[i, i] == pytest.approx(P_ref, rel=1e-9)
    # equal variances of 1e300: the mean halfway
    g = make(R=1e300, P0=1e300)
    g.update([1e300, 0.0])
    x_ref, P_ref = _information_update(1.0, 1e300, 1e300, 1e300)
    assert g.x[0] == pytest.approx(x_ref, rel=1e-12) and g.P[0, 0] == pytest.approx(P_ref)


def test_run_with_huge_states_matches_the_information_form() -> None:
    # x0 = 1e300, F = 10: the prediction reaches 1e301; the NIS overflows (inf), the means
    # are exact (old: the same means, with overflow warnings).
    kf = _kf(F=10.0, x0=(1e300, 1e300))
    result = kf.run(np.ones((3, 2)))
    x, P = 1e300, 1.0
    for k in range(3):
        x, P = _information_update(10.0 * x, 100.0 * P + 1.0, 1.0, 1.0)
        assert result.means[k, 0] == pytest.approx(x, rel=1e-12)
        assert result.covs[k, 0, 0] == pytest.approx(P, rel=1e-12)
    assert result.success and np.all(result.nis == math.inf)


def test_the_default_ekf_residual_overflow_is_the_update_s() -> None:
    ekf = _ekf(x0=(-1e308, 0.0))
    with pytest.raises(SolverError, match=r"update overflowed: the residual z - h\(x\)"):
        ekf.update([1e308, 0.0])
    np.testing.assert_array_equal(ekf.x, [-1e308, 0.0])


def test_covariances_near_the_float_limit_stay_finite() -> None:
    # A + A^T overflowed for entries above 9e307: the "validated" covariance was inf.
    kf = _kf(Q=1.2e308, R=1e300, x0=(0.0, 0.0))
    assert kf.Q[0, 0] == 1.2e308
    kf.predict()  # P = 1 + 1.2e308 (the symmetrization's P + P^T = 2.4e308 overflowed)
    np.testing.assert_array_equal(kf.P, 1.2e308 * I2)
    with pytest.raises(SolverError, match="F P F\\^T \\+ Q"):
        kf.predict()  # 2.4e308
    np.testing.assert_array_equal(kf.P, 1.2e308 * I2)
    kf.update([1e300, 2e300])  # S = 1.2e308 + 1e300
    for i, z in enumerate([1e300, 2e300]):
        x_ref, P_ref = _information_update(0.0, 1.2e308, z, 1e300)
        assert kf.x[i] == pytest.approx(x_ref, rel=1e-14)
        assert kf.P[i, i] == pytest.approx(P_ref, rel=1e-12)
    got = gaussian_logpdf([0.0, 0.0], [0.0, 0.0], 1.2e308 * I2)
    assert got == pytest.approx(-math.log(2.0 * math.pi) - math.log(1.2e308), rel=1e-14)


@pytest.mark.parametrize("p0", [1e8, 1e12, 1e16, 1e20, 1e24])
@pytest.mark.parametrize("joseph", [True, False])
def test_precise_measurements_keep_the_posterior_variance(p0: float, joseph: bool) -> None:
    # P - K S K^T cancels when the measurement dominates the prior: the short form gave
    # variances 0 for P = 1e16 R and 1e20 R; it is redone in Joseph form.
    kf = KalmanFilter(
        I2, I2, I2, I2, [0.0, 0.0], p0 * I2, options=KalmanFilterOptions(joseph_form=joseph)
    )
    kf.update([1.0, 2.0])
    for i, z in enumerate([1.0, 2.0]):
        x_ref, P_ref = _information_update(0.0, p0, z, 1.0)
        assert kf.x[i] == pytest.approx(x_ref, rel=1e-14)
        assert kf.P[i, i] == pytest.approx(P_ref, rel=1e-7)


@pytest.mark.parametrize("p0", [1e30, 1e40, 1.2e308])
@pytest.mark.parametrize("joseph", [True, False])
def test_a_covariance_update_that_loses_every_digit_is_refused(p0: float, joseph: bool) -> None:
    # The Joseph form knows (I - K H) to eps: P = 1e30 R gave 1.05 R, 1.2e308 R gave 5.9e276 R
    # (the short form: -5.6e14 for 1e30).
    kf = KalmanFilter(
        I2, I2, I2, I2, [0.0, 0.0], p0 * I2, options=KalmanFilterOptions(joseph_form=joseph)
    )
    with pytest.raises(SolverError, match=r"loses every digit .* variances of x\[0, 1\]"):
        kf.update([1.0, 2.0])
    np.testing.assert_array_equal(kf.P, p0 * I2)
