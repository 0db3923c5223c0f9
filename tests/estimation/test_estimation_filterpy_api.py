"""The filter API that filterpy users expect, checked against closed forms.

Scalar and column measurements, ``update(None)``, per-call ``R``/``H``, process noise
matrices (the literal tables of filterpy's ``Q_discrete_white_noise`` and
``Q_continuous_white_noise``), and angle residual / mean functions for bearings.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, ShapeError, TaskspaceError
from taskspace.estimation import (
    ExtendedKalmanFilter,
    KalmanFilter,
    UnscentedKalmanFilter,
    angle_mean,
    angle_residual,
    continuous_white_noise,
    discrete_white_noise,
)

DEG = math.pi / 180.0


def _scalar_filter(
    x0: float = 1.0, p0: float = 2.0, q: float = 0.5, r: float = 3.0
) -> KalmanFilter:
    return KalmanFilter([[1.0]], [[1.0]], [[q]], [[r]], [x0], [[p0]])


def _scalar_reference(x: float, p: float, q: float, r: float, z: float) -> tuple[float, float]:
    """Closed form of one predict + update of the random walk ``x' = x``, ``z = x + v``."""
    pp = p + q
    k = pp / (pp + r)
    return x + k * (z - x), pp * r / (pp + r)


@pytest.mark.parametrize(
    "z", [4.0, np.float64(4.0), [4.0], np.array([4.0]), [[4.0]], np.array([[4.0]])]
)
def test_scalar_measurement_forms_match_closed_form(z: object) -> None:
    kf = _scalar_filter()
    kf.predict()
    nis = kf.update(z)
    x_ref, p_ref = _scalar_reference(1.0, 2.0, 0.5, 3.0, 4.0)
    assert kf.x == pytest.approx([x_ref], rel=1e-12)
    assert kf.P[0, 0] == pytest.approx(p_ref, rel=1e-12)
    assert nis == pytest.approx((4.0 - 1.0) ** 2 / (2.5 + 3.0), rel=1e-12)


def test_column_vector_measurement_and_state() -> None:
    F = [[1.0, 0.1], [0.0, 1.0]]
    H = np.eye(2)
    a = KalmanFilter(F, H, 0.01 * np.eye(2), 0.2 * np.eye(2), [0.0, 1.0], np.eye(2))
    b = KalmanFilter(F, H, 0.01 * np.eye(2), 0.2 * np.eye(2), [[0.0], [1.0]], np.eye(2))
    for kf, z in ((a, [0.3, 0.9]), (b, np.array([[0.3], [0.9]]))):
        kf.predict()
        kf.update(z)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=0)
    np.testing.assert_allclose(a.P, b.P, rtol=0, atol=0)
    with pytest.raises(ShapeError):
        a.update(np.array([[0.3, 0.9]]))  # a row is ambiguous: refused


def test_update_none_is_a_no_op_for_every_filter() -> None:
    kf = _scalar_filter()
    ekf = ExtendedKalmanFilter(
        lambda x, u: x,
        lambda x, u: np.eye(1),
        lambda x: x,
        lambda x: np.eye(1),
        0.5,
        3.0,
        [1.0],
        2.0,
    )
    ukf = UnscentedKalmanFilter(lambda x, u: x, lambda x: x, 0.5, 3.0, [1.0], 2.0)
    for f in (kf, ekf, ukf):
        f.predict()
        x, P = f.x.copy(), f.P.copy()
        assert math.isnan(f.update(None))
        np.testing.assert_array_equal(f.x, x)
        np.testing.assert_array_equal(f.P, P)
        assert f.P[0, 0] == pytest.approx(2.5)


def test_per_call_R_overrides_once() -> None:
    kf = _scalar_filter(r=3.0)
    kf.predict()
    kf.update(4.0, R=7.0)
    x_ref, p_ref = _scalar_reference(1.0, 2.0, 0.5, 7.0, 4.0)
    assert kf.x[0] == pytest.approx(x_ref, rel=1e-12)
    assert kf.P[0, 0] == pytest.approx(p_ref, rel=1e-12)
    np.testing.assert_array_equal(kf.R, [[3.0]])  # the filter's R is unchanged
    with pytest.raises(InvalidInputError, match="positive definite"):
        kf.update(4.0, R=-1.0)


def test_per_call_H_matches_information_form() -> None:
    """Observe the velocity once (H = [0 1]) in a position-measuring filter."""
    F = np.array([[1.0, 0.5], [0.0, 1.0]])
    Q = discrete_white_noise(2, dt=0.5, var=0.1)
    P0 = np.array([[1.0, 0.2], [0.2, 0.5]])
    x0 = np.array([0.3, -0.4])
    kf = KalmanFilter(F, [[1.0, 0.0]], Q, [[0.2]], x0, P0)
    kf.predict()
    xp, Pp = F @ x0, F @ P0 @ F.T + Q
    H2, R2, z2 = np.array([[0.0, 1.0]]), np.array([[0.05]]), np.array([0.1])
    kf.update(z2, R=R2, H=H2)
    # information form: P+ = (P^-1 + H^T R^-1 H)^-1, x+ = P+ (P^-1 x + H^T R^-1 z)
    P_ref = np.linalg.inv(np.linalg.inv(Pp) + H2.T @ np.linalg.inv(R2) @ H2)
    x_ref = P_ref @ (np.linalg.solve(Pp, xp) + H2.T @ np.linalg.solve(R2, z2))
    np.testing.assert_allclose(kf.x, x_ref, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(kf.P, P_ref, rtol=1e-10, atol=1e-12)
    # a 2-row H needs its own R (the filter's R is 1 x 1)
    with pytest.raises(InvalidInputError, match="pass the noise covariance R"):
        kf.update([0.0, 0.0], H=np.eye(2))
    kf.update([0.0, 0.0], H=np.eye(2), R=0.1)  # a scalar R means 0.1 I


def test_ekf_per_call_measurement_model_matches_kalman_filter() -> None:
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q, R_pos = 0.01 * np.eye(2), [[0.3]]
    ekf = ExtendedKalmanFilter(
        lambda x, u: F @ x,
        lambda x, u: F,
        lambda x: x[:1],
        lambda x: np.array([[1.0, 0.0]]),
        Q,
        R_pos,
        [0.0, 1.0],
        np.eye(2),
    )
    kf = KalmanFilter(F, [[1.0, 0.0]], Q, R_pos, [0.0, 1.0], np.eye(2))
    H_vel = np.array([[0.0, 1.0]])
    for f in (ekf, kf):
        f.predict()
    ekf.update(1.2, R=0.05, h=lambda x: H_vel @ x, H_jacobian=lambda x: H_vel)
    kf.update(1.2, R=0.05, H=H_vel)
    np.testing.assert_allclose(ekf.x, kf.x, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ekf.P, kf.P, rtol=1e-12, atol=1e-14)
    with pytest.raises(InvalidInputError, match="both h and H_jacobian"):
        ekf.update(1.0, h=lambda x: x[:1])


# literal tables of filterpy.common.Q_discrete_white_noise / Q_continuous_white_noise
def _filterpy_discrete(dim: int, dt: float) -> np.ndarray:
    if dim == 2:
        return np.array([[0.25 * dt**4, 0.5 * dt**3], [0.5 * dt**3, dt**2]])
    if dim == 3:
        return np.array(
            [
                [0.25 * dt**4, 0.5 * dt**3, 0.5 * dt**2],
                [0.5 * dt**3, dt**2, dt],
                [0.5 * dt**2, dt, 1.0],
            ]
        )
    return np.array(
        [
            [dt**6 / 36, dt**5 / 12, dt**4 / 6, dt**3 / 6],
            [dt**5 / 12, dt**4 / 4, dt**3 / 2, dt**2 / 2],
            [dt**4 / 6, dt**3 / 2, dt**2, dt],
            [dt**3 / 6, dt**2 / 2, dt, 1.0],
        ]
    )


def _filterpy_continuous(dim: int, dt: float) -> np.ndarray:
    if dim == 2:
        return np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    if dim == 3:
        return np.array(
            [
                [dt**5 / 20, dt**4 / 8, dt**3 / 6],
                [dt**4 / 8, dt**3 / 3, dt**2 / 2],
                [dt**3 / 6, dt**2 / 2, dt],
            ]
        )
    return np.array(
        [
            [dt**7 / 252, dt**6 / 72, dt**5 / 30, dt**4 / 24],
            [dt**6 / 72, dt**5 / 20, dt**4 / 8, dt**3 / 6],
            [dt**5 / 30, dt**4 / 8, dt**3 / 3, dt**2 / 2],
            [dt**4 / 24, dt**3 / 6, dt**2 / 2, dt],
        ]
    )


def _by_derivative(Q: np.ndarray, dim: int, block: int) -> np.ndarray:
    """filterpy's order_by_derivative, written out: entry (i, j) of Q on every axis."""
    out = np.zeros((dim * block, dim * block))
    for i in range(dim):
        for j in range(dim):
            for axis in range(block):
                out[i * block + axis, j * block + axis] = Q[i, j]
    return out


def _by_dim(Q: np.ndarray, dim: int, block: int) -> np.ndarray:
    out = np.zeros((dim * block, dim * block))
    for axis in range(block):
        out[axis * dim : (axis + 1) * dim, axis * dim : (axis + 1) * dim] = Q
    return out


@pytest.mark.parametrize("dim", [2, 3, 4])
@pytest.mark.parametrize("block_size", [1, 2, 3])
@pytest.mark.parametrize("order_by_dim", [True, False])
def test_white_noise_matrices_match_filterpy_tables(
    dim: int, block_size: int, order_by_dim: bool
) -> None:
    dt, var = 0.37, 2.3
    arrange = _by_dim if order_by_dim else _by_derivative
    np.testing.assert_allclose(
        discrete_white_noise(dim, dt, var, block_size, order_by_dim),
        var * arrange(_filterpy_discrete(dim, dt), dim, block_size),
        rtol=1e-13,
        atol=1e-15,
    )
    np.testing.assert_allclose(
        continuous_white_noise(dim, dt, var, block_size, order_by_dim),
        var * arrange(_filterpy_continuous(dim, dt), dim, block_size),
        rtol=1e-13,
        atol=1e-15,
    )


@pytest.mark.parametrize(
    "kwargs",
    [
        {"dim": 0},
        {"dim": 2.5},
        {"dim": None},
        {"dim": 2, "dt": 0.0},
        {"dim": 2, "dt": math.nan},
        {"dim": 2, "var": -1.0},
        {"dim": 2, "block_size": 0},
        {"dim": 4, "dt": 1e200},
        {"dim": 2, "order_by_dim": "yes"},
    ],
)
def test_white_noise_bad_arguments(kwargs: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        discrete_white_noise(**kwargs)  # type: ignore[arg-type]


def test_angle_residual_wraps_bearings() -> None:
    r = angle_residual(1)
    d = r(np.array([5.0, 179.0 * DEG]), np.array([2.0, -179.0 * DEG]))
    assert d[0] == pytest.approx(3.0)
    assert d[1] == pytest.approx(-2.0 * DEG, abs=1e-12)  # not 358 deg
    m = angle_mean(0)(np.array([[179.0 * DEG], [-179.0 * DEG]]), np.array([0.5, 0.5]))
    assert abs(m[0]) == pytest.approx(math.pi, abs=1e-12)  # not 0
    with pytest.raises(InvalidInputError):
        angle_residual(5)(np.zeros(2), np.zeros(2))
    with pytest.raises(InvalidInputError):
        angle_residual("a")  # type: ignore[arg-type]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_ekf_bearing_update_across_pi() -> None:
    """Prior -179 deg, bearing measured at 179 deg, P = R: the mean moves 1 deg, to -180 deg."""
    p = (3.0 * DEG) ** 2
    ekf = ExtendedKalmanFilter(
        lambda x, u: x,
        lambda x, u: np.eye(1),
        lambda x: x,
        lambda x: np.eye(1),
        0.0,
        p,
        [-179.0 * DEG],
        p,
        residual=angle_residual(0),
        state_normalize=lambda x: np.array([_wrap(x[0])]),
    )
    nis = ekf.update(179.0 * DEG)
    assert abs(_wrap(ekf.x[0] - (-180.0 * DEG))) < 1e-12
    assert nis == pytest.approx((2.0 * DEG) ** 2 / (2 * p), rel=1e-12)
    # the default residual takes the long way round (358 deg): the reason for the option
    plain = ExtendedKalmanFilter(
        lambda x, u: x,
        lambda x, u: np.eye(1),
        lambda x: x,
        lambda x: np.eye(1),
        0.0,
        p,
        [-179.0 * DEG],
        p,
    )
    plain.update(179.0 * DEG)
    assert abs(_wrap(plain.x[0] - (-180.0 * DEG))) > 170.0 * DEG


def test_ukf_bearing_update_across_pi() -> None:
    """A heading filter whose sigma points straddle +-pi equals the unwrapped Kalman filter."""
    p, r, q = (4.0 * DEG) ** 2, (2.0 * DEG) ** 2, (1.0 * DEG) ** 2
    turn = 3.0 * DEG
    ukf = UnscentedKalmanFilter(
        lambda x, u: np.array([_wrap(x[0] + turn)]),
        lambda x: np.array([_wrap(x[0])]),
        q,
        r,
        [-179.0 * DEG],
        p,
        residual=angle_residual(0),
        residual_x=angle_residual(0),
        mean_x=angle_mean(0),
        mean_z=angle_mean(0),
    )
    ukf.predict()
    ukf.update(179.0 * DEG)
    # unwrapped scalar Kalman filter: prior -176 deg (after the turn), z = -181 deg
    x_ref, p_ref = _scalar_reference(-176.0 * DEG, p, q, r, -181.0 * DEG)
    assert abs(_wrap(ukf.x[0] - x_ref)) < 1e-9
    assert ukf.P[0, 0] == pytest.approx(p_ref, rel=1e-9)


def test_ukf_nan_model_raises_and_keeps_belief() -> None:
    ukf = UnscentedKalmanFilter(
        lambda x, u: np.full(2, np.nan) if u else x,
        lambda x: x[:1],
        0.1 * np.eye(2),
        0.1,
        [0.0, 0.0],
        np.eye(2),
    )
    x, P = ukf.x.copy(), ukf.P.copy()
    with pytest.raises(TaskspaceError, match="returned non-finite"):
        ukf.predict(1)
    np.testing.assert_array_equal(ukf.x, x)
    np.testing.assert_array_equal(ukf.P, P)
    bad_h = UnscentedKalmanFilter(lambda x, u: x, lambda x: x[:1] / 0.0, 0.1, 0.1, [0.0], 1.0)
    with np.errstate(divide="ignore", invalid="ignore"), pytest.raises(TaskspaceError):
        bad_h.update(0.5)


def test_ekf_nan_jacobian_raises() -> None:
    ekf = ExtendedKalmanFilter(
        lambda x, u: x,
        lambda x, u: np.full((1, 1), np.nan),
        lambda x: x,
        lambda x: np.eye(1),
        0.1,
        0.1,
        [0.0],
        1.0,
    )
    with pytest.raises(TaskspaceError, match="returned non-finite"):
        ekf.predict()
    assert ekf.x[0] == 0.0 and ekf.P[0, 0] == 1.0


def test_complex_inputs_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="complex"):
        KalmanFilter([[1.0]], [[1.0]], [[0.1]], [[0.1]], np.array([1 + 1j]), [[1.0]])
    kf = _scalar_filter()
    with pytest.raises(InvalidInputError, match="complex"):
        kf.update(np.array([1 + 2j]))
    with pytest.raises(InvalidInputError, match="complex"):
        kf.update(1.0, R=np.array([[1 + 0j]]))


def test_overflowing_update_raises_and_keeps_belief() -> None:
    """A residual that overflows (1e308 - (-1e308)) is refused instead of a NaN mean."""
    from taskspace.errors import SolverError

    kf = KalmanFilter([[1.0]], [[1.0]], [[0.0]], [[1.0]], [-1e308], [[1.0]])
    with np.errstate(over="ignore", invalid="ignore"), pytest.raises(SolverError, match="overflow"):
        kf.update(1e308)
    assert kf.x[0] == -1e308 and kf.P[0, 0] == 1.0


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    A = rng.normal(size=(n, n))
    return A @ A.T + 0.1 * np.eye(n)


@pytest.mark.parametrize("seed", range(12))
def test_random_kalman_steps_match_information_form(seed: int) -> None:
    """Predict + update (per-call H and R, column z) against the information-form closed form."""
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(1, 5)), int(rng.integers(1, 4))
    F, H, Q, R = rng.normal(size=(n, n)), rng.normal(size=(m, n)), _spd(rng, n), _spd(rng, m)
    x0, P0, z = rng.normal(size=n), _spd(rng, n), rng.normal(size=m)
    kf = KalmanFilter(F, np.eye(n), Q, np.eye(n), x0[:, None], P0)
    kf.predict()
    kf.update(z[:, None], R=R, H=H)
    xp, Pp = F @ x0, F @ P0 @ F.T + Q
    P_ref = np.linalg.inv(np.linalg.inv(Pp) + H.T @ np.linalg.solve(R, H))
    x_ref = P_ref @ (np.linalg.solve(Pp, xp) + H.T @ np.linalg.solve(R, z))
    np.testing.assert_allclose(kf.x, x_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(kf.P, P_ref, rtol=1e-8, atol=1e-10)
