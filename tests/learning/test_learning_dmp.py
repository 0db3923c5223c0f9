from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import DiscreteDMP, DMPOptions, RhythmicDMP


def _min_jerk(t: np.ndarray) -> np.ndarray:
    s = t / t[-1]
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def _demo() -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0, 1, 201)
    mj = _min_jerk(t)
    return t, np.stack([mj, 0.5 * np.sin(np.pi * t) - 0.3 * mj], axis=1)


def test_reproduces_the_demonstration() -> None:
    t, Y = _demo()
    dmp = DiscreteDMP.fit(t, Y)
    traj = dmp.rollout(0.0005, duration=1.0)
    ref = np.stack([np.interp(traj.time, t, Y[:, j]) for j in range(2)], axis=1)
    assert np.abs(traj.y - ref).max() < 5e-3
    # Without learning (zero weights) the spring alone is far from the demonstration.
    plain = DiscreteDMP(np.zeros_like(dmp.weights), dmp.y0, dmp.goal, dmp.tau, dmp.options)
    plain.initial_velocity = dmp.initial_velocity
    assert np.abs(plain.rollout(0.0005, duration=1.0).y - ref).max() > 0.05


def test_least_squares_recovers_known_weights() -> None:
    # Generate a demonstration from a DMP with known weights, then fit it back.
    rng = np.random.default_rng(0)
    opts = DMPOptions(num_basis=10)
    truth = DiscreteDMP(rng.normal(0, 50, (1, 10)), np.zeros(1), np.ones(1), 1.0, opts)
    traj = truth.rollout(1e-4, duration=1.0)
    fit = DiscreteDMP.fit(traj.time, traj.y, opts)
    replay = fit.rollout(1e-4, duration=1.0)
    assert np.abs(replay.y - traj.y).max() < 1e-3 * np.ptp(traj.y)


@pytest.mark.parametrize("goal", [2.0, -1.0, 0.3, 5.0])
def test_new_goal_reached_without_overshoot(goal: float) -> None:
    t = np.linspace(0, 1, 201)
    dmp = DiscreteDMP.fit(t, _min_jerk(t))
    traj = dmp.rollout(0.002, duration=4.0, goal=goal)
    y = traj.y[:, 0]
    assert y[-1] == pytest.approx(goal, abs=1e-5 * max(1, abs(goal)))
    tol = 1e-4 * abs(goal)
    assert (y.max() <= goal + tol) if goal > 0 else (y.min() >= goal - tol)
    assert (y.min() >= -tol) if goal > 0 else (y.max() <= tol)  # no motion away from it first


def test_goal_change_during_the_motion() -> None:
    t = np.linspace(0, 1, 201)
    dmp = DiscreteDMP.fit(t, _min_jerk(t))
    farther = dmp.rollout(0.002, duration=4.0, goal_changes=((0.5, 2.0),)).y[:, 0]
    assert farther[-1] == pytest.approx(2.0, abs=1e-5) and farther.max() <= 2.0 + 1e-6
    # The filtered goal gives a continuous acceleration at the change.
    acc = dmp.rollout(0.002, duration=4.0, goal_changes=((0.5, 2.0),)).ydd[:, 0]
    k = 250  # t = 0.5 s
    jump = np.abs(np.diff(acc))[k - 3 : k + 3].max()
    # An unfiltered goal would jump the acceleration by alpha_z beta_z (2 - 1) / tau^2.
    unfiltered = dmp.options.alpha_z * dmp.beta_z * 1.0 / dmp.tau**2
    assert jump < 0.04 * unfiltered, jump  # per 2 ms step
    nearer = dmp.rollout(0.002, duration=4.0, goal_changes=((0.3, 0.5),)).y[:, 0]
    assert nearer[-1] == pytest.approx(0.5, abs=1e-5)
    assert nearer.max() < 0.5 + 0.01 * 0.5  # at most 1 % of the distance


def test_temporal_scaling() -> None:
    t, Y = _demo()
    dmp = DiscreteDMP.fit(t, Y)
    a = dmp.rollout(0.0005, duration=1.0)
    b = dmp.rollout(0.0005, duration=2.0, tau=2.0, yd0=dmp.initial_velocity / 2)
    assert b.y[::2] == pytest.approx(a.y, abs=2e-3)


def test_rhythmic_dmp_reproduces_the_period() -> None:
    period = 2.0
    t = np.linspace(0, period, 401)
    Y = np.sin(np.pi * t) + 0.3 * np.sin(2 * np.pi * t)
    dmp = RhythmicDMP.fit(t, Y)
    assert dmp.tau == pytest.approx(period / (2 * np.pi))
    traj = dmp.rollout(0.001, duration=10.0, y0=[Y[0]])
    late = traj.time >= 8.0
    ref = np.sin(np.pi * traj.time) + 0.3 * np.sin(2 * np.pi * traj.time)
    assert np.abs(traj.y[late, 0] - ref[late]).max() < 5e-3
    # Amplitude modulation scales the oscillation about the anchor.
    big = dmp.rollout(0.001, duration=10.0, amplitude=2.0)
    assert np.ptp(big.y[late, 0]) == pytest.approx(2 * np.ptp(traj.y[late, 0]), rel=0.02)


def test_errors() -> None:
    with pytest.raises(InvalidInputError, match="increase"):
        DiscreteDMP.fit([0.0, 1.0, 0.5], [0.0, 1.0, 2.0])
    with pytest.raises(InvalidInputError, match="at least 3"):
        DiscreteDMP.fit([0.0, 1.0], [0.0, 1.0])
    with pytest.raises(InvalidInputError, match="uniformly"):
        RhythmicDMP.fit([0.0, 0.1, 0.3, 0.4], [0.0, 1.0, 0.0, 0.0])
