"""Motion/observation models (finite differences, moments); histogram filter (enumeration)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation.histogram_filter import (
    HallwayWorld,
    HistogramFilter,
    shift_transition_matrix,
)
from taskspace.estimation.motion_models import (
    KinematicCarModel,
    OdometryMotionModel,
    VelocityMotionModel,
    wrap_angle,
)
from taskspace.estimation.observation_models import RangeBearingModel

MODELS = [
    (VelocityMotionModel(dt=0.1), np.array([1.0, 0.5])),
    (VelocityMotionModel(dt=0.1), np.array([1.0, 0.0])),
    (OdometryMotionModel(), np.array([0.2, 0.5, -0.1])),
    (KinematicCarModel(dt=0.1), np.array([2.0, 0.3])),
]


def _fd(fun, x, eps=1e-6):
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((fun(x + d) - fun(x - d)) / (2 * eps))
    return np.array(cols).T


@pytest.mark.parametrize("model,u", MODELS)
def test_motion_jacobians_match_finite_differences(model, u):
    x = np.array([1.0, -2.0, 0.7])
    F, V = model.jacobians(x, u)
    np.testing.assert_allclose(F, _fd(lambda y: model.mean(y, u), x), atol=1e-6)
    np.testing.assert_allclose(V, _fd(lambda v: model.mean(x, v), u), atol=1e-6)


@pytest.mark.parametrize("model,u", MODELS)
def test_motion_samples_match_linearized_covariance(model, u):
    rng = np.random.default_rng(0)
    x = np.array([1.0, -2.0, 0.7])
    s = model.sample(np.tile(x, (100_000, 1)), u, rng)
    np.testing.assert_allclose(s.mean(0), model.mean(x, u), atol=3e-3)
    np.testing.assert_allclose(np.cov(s.T), model.state_covariance(x, u), rtol=0.05, atol=1e-6)


def test_odometry_from_poses_inverts_mean():
    rng = np.random.default_rng(1)
    m = OdometryMotionModel()
    for _ in range(20):
        a, b = rng.normal(size=3), rng.normal(size=3)
        a[2], b[2] = wrap_angle(a[2]), wrap_angle(b[2])
        np.testing.assert_allclose(m.mean(a, m.odometry_from_poses(a, b)), b, atol=1e-12)


def test_velocity_model_is_exact_circle():
    # constant (v, w) from the origin stays on the circle of radius v / w centred at (0, v/w)
    m = VelocityMotionModel(dt=0.1)
    x = np.zeros(3)
    for _ in range(50):
        x = m.mean(x, [2.0, 0.5])
        assert np.hypot(x[0], x[1] - 4.0) == pytest.approx(4.0, abs=1e-12)


def test_range_bearing_jacobians_and_inverse():
    x, lm = np.array([1.0, 2.0, 0.4]), np.array([4.0, -1.0])
    Hx, Hl = RangeBearingModel.jacobians(x, lm)
    np.testing.assert_allclose(Hx, _fd(lambda y: RangeBearingModel.predict(y, lm), x), atol=1e-7)
    np.testing.assert_allclose(Hl, _fd(lambda l: RangeBearingModel.predict(x, l), lm), atol=1e-7)
    z = RangeBearingModel.predict(x, lm)
    np.testing.assert_allclose(RangeBearingModel.inverse(x, z), lm, atol=1e-12)


def test_model_errors():
    with pytest.raises(ShapeError, match=r"x must have shape \(-1, 3\)"):
        VelocityMotionModel().mean(np.zeros(2), [1.0, 0.0])
    with pytest.raises(InvalidInputError, match="wheelbase must be finite and > 0"):
        KinematicCarModel(wheelbase=0.0)


# ---------------------------------------------------------------- histogram filter


def test_histogram_filter_equals_enumeration_of_all_paths():
    world = HallwayWorld(num_cells=7, doors=(1, 4), p_detect=0.9, p_false_alarm=0.2)
    shifts, seen = [1, 2, 1], [True, False, True]
    prior = np.full(7, 1 / 7)
    hf = HistogramFilter(prior)
    res = hf.run([world.transition(s) for s in shifts], [world.likelihood(y) for y in seen])
    # brute force: P(x_3 | y_1:3) = sum over x_0..x_2 of the joint (slides 6:6-6:7)
    post = np.zeros(7)
    Ts = [world.transition(s) for s in shifts]
    for path in itertools.product(range(7), repeat=4):
        p = prior[path[0]]
        for t in range(3):
            p *= Ts[t][path[t + 1], path[t]] * world.likelihood(seen[t])[path[t + 1]]
        post[path[-1]] += p
    np.testing.assert_allclose(res.beliefs[-1], post / post.sum(), atol=1e-14)
    assert np.prod(res.evidence) == pytest.approx(post.sum(), rel=1e-12)


def test_hallway_localizes_and_dead_reckoning_spreads():
    world = HallwayWorld(motion_kernel=(0.05, 0.9, 0.05), p_detect=0.9, p_false_alarm=0.05)
    rng = np.random.default_rng(2)
    cells, seen = world.simulate(10, [1] * 60, rng)
    hf = HistogramFilter(np.ones(world.num_cells))
    res = hf.run([world.transition(1)] * 60, [world.likelihood(y) for y in seen])
    near = [res.beliefs[t][(cells[t] + np.arange(-2, 3)) % 60].sum() for t in range(60)]
    # belief mass within +-2 cells of the truth: 5/60 = 0.083 when uniform
    assert near[0] < 0.15 and np.mean(near[30:]) > 0.35
    # dead reckoning from a known start: entropy never decreases (doubly-stochastic T)
    dr = HistogramFilter(np.eye(world.num_cells)[10])
    dres = dr.run([world.transition(1)] * 30, [None] * 30)
    ent = [-(b[b > 0] * np.log(b[b > 0])).sum() for b in dres.beliefs]
    assert np.all(np.diff(ent) >= -1e-12) and ent[-1] > 1.0


def test_shift_transition_non_cyclic_and_errors():
    T = shift_transition_matrix(5, 2, (0.2, 0.6, 0.2), cyclic=False)
    np.testing.assert_allclose(T.sum(0), 1.0)
    assert T[4, 4] == pytest.approx(1.0)
    with pytest.raises(InvalidInputError, match="odd length"):
        shift_transition_matrix(5, 1, (0.5, 0.5))
    hf = HistogramFilter(np.ones(3))
    with pytest.raises(InvalidInputError, match="column-stochastic"):
        hf.predict(np.ones((3, 3)))
    with pytest.raises(InvalidInputError, match="zero probability"):
        hf.update(np.zeros(3))
    with pytest.raises(InvalidInputError, match="door cells must be in"):
        HallwayWorld(num_cells=5, doors=(7,))
