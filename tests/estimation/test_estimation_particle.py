"""Particle filter and resampling against references (KF limit, expectations, enumeration)."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, ShapeError, UnknownNameError
from taskspace.estimation.kalman_filter import KalmanFilter
from taskspace.estimation.motion_models import VelocityMotionModel, wrap_angle
from taskspace.estimation.observation_models import PositionModel, RangeBearingModel
from taskspace.estimation.particle_filter import ParticleFilter, ParticleFilterOptions
from taskspace.estimation.resampling import (
    RESAMPLERS,
    effective_sample_size,
    get_resampler,
    residual_resample,
    systematic_resample,
)
from taskspace.estimation.simulation import loop_controls, simulate_landmark_world

SCHEMES = sorted(RESAMPLERS)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_resampling_is_unbiased(scheme):
    # E[count_i] = N w_i for every scheme (Douc et al.); check over many repetitions.
    rng = np.random.default_rng(0)
    w = rng.random(20) ** 3
    w /= w.sum()
    N, reps = 20, 4000
    counts = np.zeros(20)
    for _ in range(reps):
        idx = get_resampler(scheme)(w, rng)
        assert idx.shape == (N,) and idx.min() >= 0 and idx.max() < 20
        counts += np.bincount(idx, minlength=20)
    mean = counts / reps
    # multinomial std of a count is sqrt(N w (1-w)); the mean of reps draws shrinks it.
    tol = 5 * np.sqrt(N * w * (1 - w) / reps) + 1e-9
    assert np.all(np.abs(mean - N * w) <= tol)


def test_residual_and_systematic_count_bounds():
    rng = np.random.default_rng(1)
    w = rng.random(50)
    w /= w.sum()
    for _ in range(50):
        c = np.bincount(residual_resample(w, rng), minlength=50)
        assert np.all(c >= np.floor(50 * w))  # deterministic part of slide 7:23
        c = np.bincount(systematic_resample(w, rng), minlength=50)
        assert np.all(c >= np.floor(50 * w) - 1e-9) and np.all(c <= np.ceil(50 * w) + 1e-9)


def test_effective_sample_size_extremes_and_errors():
    assert effective_sample_size(np.ones(10)) == pytest.approx(10.0)
    assert effective_sample_size([0, 0, 5.0, 0]) == pytest.approx(1.0)
    with pytest.raises(InvalidInputError, match="weights sum to zero"):
        effective_sample_size(np.zeros(3))
    with pytest.raises(InvalidInputError, match="non-negative"):
        effective_sample_size([1.0, -1.0])
    with pytest.raises(UnknownNameError, match="valid resampling schemes are: multinomial, resid"):
        get_resampler("sistematic")


def _linear_gaussian_problem():
    F = np.array([[1.0, 0.1], [0.0, 1.0]])
    Q = np.diag([0.01, 0.04])
    H = np.array([[1.0, 0.0]])
    R = np.array([[0.25]])
    rng = np.random.default_rng(2)
    x = np.array([0.0, 1.0])
    zs = []
    for _ in range(15):
        x = F @ x + rng.multivariate_normal(np.zeros(2), Q)
        zs.append(H @ x + rng.normal(0, 0.5, size=1))
    return F, Q, H, R, np.array(zs)


def _pf_error(N, seed, F, Q, H, R, zs, kf_means):
    rng = np.random.default_rng(seed)
    LQ = np.linalg.cholesky(Q)
    pf = ParticleFilter(
        rng.multivariate_normal([0.0, 1.0], np.eye(2), size=N),
        lambda p, u, g: p @ F.T + g.standard_normal(p.shape) @ LQ.T,
        lambda p, z: -0.5 * (z[0] - p[:, 0]) ** 2 / R[0, 0],
        rng,
        options=ParticleFilterOptions(resampling="systematic", ess_threshold=0.5),
    )
    res = pf.run([None] * len(zs), list(zs))
    assert res.success
    return np.sqrt(np.mean((res.means - kf_means) ** 2))


def test_particle_filter_converges_to_kalman_filter():
    F, Q, H, R, zs = _linear_gaussian_problem()
    kf = KalmanFilter(F, H, Q, R, [0.0, 1.0], np.eye(2)).run(zs)
    errs = {
        N: np.mean([_pf_error(N, s, F, Q, H, R, zs, kf.means) for s in range(3)])
        for N in (100, 1000, 20000)
    }
    assert errs[100] > errs[1000] > errs[20000]
    assert errs[20000] < 0.03  # posterior std of position is ~0.3


def test_monte_carlo_localization_global_converges():
    rng = np.random.default_rng(3)
    motion = VelocityMotionModel(dt=0.2)
    sensor = RangeBearingModel(sigma_range=0.2, sigma_bearing=0.05, max_range=15.0)
    landmarks = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [5.0, 12.0]])
    sim = simulate_landmark_world(
        motion, sensor, [5.0, 2.0, 0.0], loop_controls(60, 1.0, 0.25), landmarks, rng
    )
    N = 3000
    init = np.column_stack(
        [rng.uniform(-2, 12, N), rng.uniform(-2, 12, N), rng.uniform(-np.pi, np.pi, N)]
    )
    pf = ParticleFilter(
        init,
        motion.sample,
        lambda p, obs: sensor.log_likelihood(p, obs, landmarks),
        rng,
        options=ParticleFilterOptions(angular_dims=(2,)),
    )
    res = pf.run(list(sim.controls), sim.observations)
    err = np.hypot(*(res.means[-20:, :2] - sim.states[-20:, :2]).T)
    assert err.max() < 0.5
    assert np.abs(wrap_angle(res.means[-20:, 2] - sim.states[-20:, 2])).max() < 0.15
    assert res.num_resamples > 0


def test_mixture_proposal_recovers_from_depletion():
    # Particles start concentrated far from the truth: the forward proposal alone never
    # reaches the true pose; the observation-driven proposal (slide 7:25) does.
    motion = VelocityMotionModel(dt=0.2, sigma_v=0.01, sigma_w=0.005)
    sensor = PositionModel(R=0.1 * np.eye(2))
    truth_rng = np.random.default_rng(4)
    x = np.array([0.0, 0.0, 0.0])
    us = loop_controls(40, 1.0, 0.1)
    states, zs = [], []
    for u in us:
        x = motion.sample(x, u, truth_rng)
        states.append(x)
        zs.append(sensor.sample(x, truth_rng))
    states = np.array(states)

    def obs_sampler(z, n, g):
        return np.column_stack(
            [
                z + g.standard_normal((n, 2)) @ np.linalg.cholesky(sensor.R).T,
                g.uniform(-np.pi, np.pi, n),
            ]
        )

    def run(frac):
        g = np.random.default_rng(5)
        init = np.column_stack([g.normal(20, 0.1, 500), g.normal(20, 0.1, 500), np.zeros(500)])
        pf = ParticleFilter(
            init,
            motion.sample,
            sensor.log_likelihood,
            g,
            observation_sampler=obs_sampler,
            options=ParticleFilterOptions(
                mixture_fraction=frac, ess_threshold=1.0, angular_dims=(2,)
            ),
        )
        res = pf.run(list(us), zs)
        return np.hypot(*(res.means[-5:, :2] - states[-5:, :2]).T).max(), res.num_injected

    err_plain, inj0 = run(0.0)
    err_mix, inj = run(0.1)
    assert inj0 == 0 and inj > 0
    assert err_plain > 5.0
    assert err_mix < 0.5


def test_particle_filter_errors():
    rng = np.random.default_rng(0)
    ok = (lambda p, u, g: p, lambda p, z: np.zeros(len(p)))
    with pytest.raises(UnknownNameError, match="unknown resampling scheme 'best'"):
        ParticleFilter(np.zeros((5, 2)), *ok, rng, options=ParticleFilterOptions(resampling="best"))
    with pytest.raises(InvalidInputError, match="needs an observation_sampler"):
        ParticleFilter(
            np.zeros((5, 2)), *ok, rng, options=ParticleFilterOptions(mixture_fraction=0.2)
        )
    with pytest.raises(InvalidInputError, match="particles has non-finite"):
        ParticleFilter(np.array([[0.0, np.nan]]), *ok, rng)
    pf = ParticleFilter(np.zeros((5, 2)), lambda p, u, g: p[:3], ok[1], rng)
    with pytest.raises(ShapeError, match=r"motion_sampler output must have shape \(5, 2\)"):
        pf.predict(None)
    pf = ParticleFilter(np.zeros((5, 2)), ok[0], lambda p, z: np.full(5, np.nan), rng)
    with pytest.raises(InvalidInputError, match="log_likelihood returned NaN"):
        pf.update(0.0)
    with pytest.raises(InvalidInputError, match="same length"):
        pf.run([None], [])
