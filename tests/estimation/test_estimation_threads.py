"""Stateful estimators shared by threads (issue #15, threads): calls are serialized.

Before, no estimator had a lock: two threads updating one filter read the same belief and
the second write dropped the first update. References:

* linear filters and the histogram / particle filters with updates only: the posterior does
  not depend on the order of the updates (information form: sums of ``H^T R^-1 H`` and
  ``H^T R^-1 z``; products of likelihoods), so the shared filter must end exactly where the
  closed form says, whatever the interleaving;
* EKF, UKF, EKF-SLAM, FastSLAM: user models (measurement function, motion model) that take a
  moment and count how many calls run at once: never more than one.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import pytest

from taskspace.estimation import (
    EKFSLAM,
    BatchKalmanFilter,
    ConstantVelocityKalmanFilter,
    ExtendedKalmanFilter,
    FastSLAM,
    FastSLAMOptions,
    HistogramFilter,
    KalmanFilter,
    ParticleFilter,
    ParticleFilterOptions,
    PoseGraph,
    RangeBearingModel,
    UnscentedKalmanFilter,
    VelocityMotionModel,
)
from taskspace.estimation.observation_models import LandmarkObservation
from tests._threads import run_in_threads

THREADS = 4
UPDATES = 40


def _zs(dim: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.normal(size=dim) for _ in range(THREADS * UPDATES)]


def _information_posterior(x0, P0, H, R, zs):  # type: ignore[no-untyped-def]
    info = np.linalg.inv(P0)
    vec = info @ x0
    HtRi = H.T @ np.linalg.inv(R)
    for z in zs:
        info = info + HtRi @ H
        vec = vec + HtRi @ z
    return np.linalg.solve(info, vec), np.linalg.inv(info)


def _updates_in_threads(update, zs) -> None:  # type: ignore[no-untyped-def]
    def work(i: int) -> np.ndarray:
        for z in zs[i * UPDATES : (i + 1) * UPDATES]:
            update(z)
        return np.zeros(1)

    run_in_threads(work, THREADS)


def test_kalman_filter_loses_no_update() -> None:
    H, R = np.eye(2, 3), np.diag([0.5, 2.0])
    x0, P0 = np.zeros(3), np.diag([4.0, 3.0, 1.0])
    kf = KalmanFilter(np.eye(3), H, np.zeros((3, 3)), R, x0, P0)
    zs = _zs(2, 0)
    _updates_in_threads(kf.update, zs)
    x, P = _information_posterior(x0, P0, H, R, zs)
    np.testing.assert_allclose(kf.x, x, atol=1e-10)
    np.testing.assert_allclose(kf.P, P, atol=1e-10)


def test_constant_velocity_filter_loses_no_update() -> None:
    R = np.array([[0.5, 0.1], [0.1, 0.3]])
    x0, P0 = np.zeros(4), np.eye(4)
    cv = ConstantVelocityKalmanFilter(0.1, np.zeros((4, 4)), R, x0, P0)
    zs = _zs(2, 1)
    _updates_in_threads(cv.update, zs)
    x, P = _information_posterior(x0, P0, np.eye(2, 4), R, zs)
    np.testing.assert_allclose(cv.x, x, atol=1e-10)
    np.testing.assert_allclose(cv.P, P, atol=1e-10)


def test_batch_kalman_filter_loses_no_update() -> None:
    N, H, R = 5, np.eye(2, 4), np.diag([0.5, 2.0])
    x0, P0 = np.zeros((N, 4)), np.eye(4)
    bkf = BatchKalmanFilter(np.eye(4), H, np.zeros((4, 4)), R, x0, P0)
    zs = [z.reshape(N, 2) for z in _zs(2 * N, 2)]
    _updates_in_threads(bkf.update, zs)
    for t in range(N):
        x, P = _information_posterior(x0[t], P0, H, R, [z[t] for z in zs])
        np.testing.assert_allclose(bkf.x[t], x, atol=1e-10)
        np.testing.assert_allclose(bkf.P[t], P, atol=1e-10)


def test_histogram_filter_loses_no_update() -> None:
    rng = np.random.default_rng(3)
    likelihoods = [rng.uniform(0.5, 1.5, size=20) for _ in range(THREADS * UPDATES)]
    hf = HistogramFilter(np.full(20, 1 / 20))
    _updates_in_threads(hf.update, likelihoods)
    log_post = np.sum(np.log(likelihoods), axis=0)
    post = np.exp(log_post - log_post.max())
    np.testing.assert_allclose(hf.belief, post / post.sum(), rtol=1e-9)


def test_particle_filter_loses_no_update() -> None:
    particles = np.linspace(-2, 2, 50)[:, None]
    pf = ParticleFilter(
        particles,
        lambda p, u, rng: p,
        lambda p, z: -0.5 * ((p[:, 0] - z) / 3.0) ** 2,
        np.random.default_rng(0),
        options=ParticleFilterOptions(ess_threshold=0.0),  # no resampling: weights only
    )
    zs = [float(z) for z in np.random.default_rng(4).normal(size=THREADS * UPDATES)]
    _updates_in_threads(pf.update, zs)
    log_w = sum(-0.5 * ((particles[:, 0] - z) / 3.0) ** 2 for z in zs)
    w = np.exp(log_w - np.max(log_w))
    np.testing.assert_allclose(pf.weights, w / w.sum(), rtol=1e-9)


class _Concurrency:
    """Wraps callables: each call takes a moment and the most calls at once is recorded."""

    def __init__(self) -> None:
        self.active = 0
        self.most = 0
        self._count = threading.Lock()

    def wrap(self, fn: Any) -> Any:
        def slow(*args: Any, **kwargs: Any) -> Any:
            with self._count:
                self.active += 1
                self.most = max(self.most, self.active)
            try:
                time.sleep(2e-4)
                return fn(*args, **kwargs)
            finally:
                with self._count:
                    self.active -= 1

        return slow


class _SlowProxy:
    """Every method of ``target`` through :class:`_Concurrency` (a user model)."""

    def __init__(self, target: Any, counter: _Concurrency) -> None:
        self._target, self._counter = target, counter

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._target, name)
        return self._counter.wrap(value) if callable(value) else value


def _steps_in_threads(step: Any) -> None:
    def work(i: int) -> np.ndarray:
        for k in range(10):
            step(i, k)
        return np.zeros(1)

    run_in_threads(work, THREADS)


@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_nonlinear_filters_run_one_call_at_a_time(kind: str) -> None:
    c = _Concurrency()
    h = c.wrap(lambda x: np.array([x[0] + 0.1 * x[1] ** 2]))
    f = c.wrap(lambda x, u: x + 0.01)
    if kind == "ekf":
        filt: Any = ExtendedKalmanFilter(
            f, lambda x, u: np.eye(2), h, lambda x: np.array([[1.0, 0.2 * x[1]]]),
            0.01 * np.eye(2), [[0.5]], [0.0, 1.0], np.eye(2),
        )  # fmt: skip
    else:
        filt = UnscentedKalmanFilter(f, h, 0.01 * np.eye(2), [[0.5]], [0.0, 1.0], np.eye(2))

    def step(i: int, k: int) -> None:
        if (i + k) % 2:
            filt.predict()
        else:
            filt.update([0.1 * i])

    _steps_in_threads(step)
    assert c.most == 1, f"{c.most} calls of the user models ran at once"
    assert np.isfinite(filt.x).all()


def _landmark_obs() -> LandmarkObservation:
    return LandmarkObservation(ids=np.array([0, 1]), z=np.array([[3.0, 0.3], [4.0, -0.5]]))


@pytest.mark.parametrize("kind", ["ekf_slam", "fastslam"])
def test_slam_runs_one_call_at_a_time(kind: str) -> None:
    c = _Concurrency()
    motion = _SlowProxy(VelocityMotionModel(dt=0.1), c)
    sensor = RangeBearingModel(sigma_range=0.1, sigma_bearing=0.02)
    if kind == "ekf_slam":
        est: Any = EKFSLAM(motion, sensor, [0.0, 0.0, 0.0], 1e-6 * np.eye(3))
    else:
        est = FastSLAM(
            motion, sensor, [0.0, 0.0, 0.0], 2, np.random.default_rng(0),
            FastSLAMOptions(num_particles=10),
        )  # fmt: skip
    obs = _landmark_obs()

    def step(i: int, k: int) -> None:
        if (i + k) % 2:
            est.predict([0.5, 0.1])
        else:
            est.update(obs)

    _steps_in_threads(step)
    assert c.most == 1, f"{c.most} calls of the motion model ran at once"


@pytest.mark.parametrize(
    "cls",
    [
        KalmanFilter, ConstantVelocityKalmanFilter, BatchKalmanFilter, ExtendedKalmanFilter,
        UnscentedKalmanFilter, ParticleFilter, HistogramFilter, EKFSLAM, FastSLAM, PoseGraph,
    ],
)  # fmt: skip
def test_estimator_docstrings_state_thread_safety(cls: type) -> None:
    assert "Thread safety" in (cls.__doc__ or ""), cls.__name__
