from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.learning import (
    DiscreteDMP,
    DMPOptions,
    PolicySearchOptions,
    ViaPointTask,
    pi2,
    power,
)


def _task() -> ViaPointTask:
    t = np.linspace(0, 1, 101)
    mj = 10 * t**3 - 15 * t**4 + 6 * t**5
    dmp = DiscreteDMP.fit(t, np.stack([mj, mj], axis=1), DMPOptions(num_basis=8))
    return ViaPointTask(dmp=dmp, via_time=0.5, via_point=np.array([0.5, 0.8]))


@pytest.mark.parametrize("method", [power, pi2])
def test_power_and_pi2_learn_the_via_point(method) -> None:  # type: ignore[no-untyped-def]
    task = _task()
    theta0 = task.dmp.weights.ravel()
    err0 = task.via_error(theta0)
    assert err0 > 0.25  # the demonstration passes (0.5, 0.5), far from (0.5, 0.8)
    res = method(
        task.rollout,
        theta0,
        PolicySearchOptions(
            iterations=25, population=10, elite=4, exploration=20.0, exploration_decay=0.93
        ),
    )
    assert task.via_error(res.parameters) < 0.25 * err0
    assert res.mean_returns[-1] > res.mean_returns[0]
    # Start and goal stay those of the demonstration (the DMP still converges to its goal).
    y = task.trajectory(res.parameters)
    assert y[0] == pytest.approx(task.dmp.y0) and y[-1] == pytest.approx(task.dmp.goal, abs=0.05)


def test_errors() -> None:
    task = _task()
    with pytest.raises(InvalidInputError, match="16 finite DMP weights"):
        task.rollout(np.zeros(3), 0)


@pytest.mark.parametrize("method", [power, pi2])
def test_power_and_pi2_reach_the_via_point_within_2cm(method) -> None:  # type: ignore[no-untyped-def]
    # The benchmark's settings (sigma 20 decaying by 0.93): PoWER with the linear reward
    # R - min R stopped 3-6 cm away (0 of 5 seeds within 2 cm after 400 rollouts).
    task = _task()
    res = method(
        task.rollout,
        task.dmp.weights.ravel(),
        PolicySearchOptions(
            iterations=30, population=10, elite=4, exploration=20.0, exploration_decay=0.93
        ),
    )
    assert task.via_error(res.parameters) < 0.02
