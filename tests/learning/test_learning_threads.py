"""Learning objects shared by threads (#15 Build 5): the sequential result or a clear error.

* Gymnasium environments are one per thread: a second thread calling ``reset``/``step`` while
  another is inside one of them gets :class:`ConcurrentUseError` (the first call is held
  inside ``reset`` at a known point, so the overlap is certain, not left to the scheduler);
  the first thread's result is the one of an environment used alone.
* :class:`DMPTaskTarget` serializes ``step``: four threads stepping one target end in the
  state of the same number of sequential steps (a coupling that sleeps makes the threads
  switch inside a step; without the lock steps are lost).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from taskspace.errors import ConcurrentUseError
from taskspace.features import JointConfiguration
from taskspace.learning import DiscreteDMP, DMPTaskTarget
from taskspace.learning.envs import (
    CartPoleEnv,
    CartPoleVectorEnv,
    PendulumEnv,
    PendulumVectorEnv,
)
from taskspace.model import Robot
from taskspace.tasks import Task

ENVS: dict[str, Callable[[], Any]] = {
    "pendulum": PendulumEnv,
    "cartpole": CartPoleEnv,
    "pendulum_vector": lambda: PendulumVectorEnv(3),
    "cartpole_vector": lambda: CartPoleVectorEnv(3),
}


@pytest.fixture
def short_switch_interval() -> Iterator[None]:
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    yield
    sys.setswitchinterval(old)


@pytest.mark.parametrize("name", list(ENVS))
def test_an_environment_used_by_a_second_thread_raises(name: str) -> None:
    env = ENVS[name]()
    env.reset(seed=3)
    inside, release = threading.Event(), threading.Event()
    plain_obs = env._obs

    def held_obs(*args: Any) -> Any:
        inside.set()
        assert release.wait(30.0)
        return plain_obs(*args)

    env._obs = held_obs
    out: list[Any] = []
    first = threading.Thread(target=lambda: out.append(env.reset(seed=7)))
    first.start()
    try:
        assert inside.wait(30.0)
        with pytest.raises(ConcurrentUseError, match=type(env).__name__):
            env.step(env.action_space.sample())
        with pytest.raises(ConcurrentUseError, match="reset"):
            env.reset(seed=7)
    finally:
        release.set()
        first.join(30.0)
    assert not first.is_alive() and len(out) == 1
    del env._obs
    alone = ENVS[name]()
    obs_alone, _ = alone.reset(seed=7)
    np.testing.assert_array_equal(out[0][0], obs_alone)
    # Once the first thread is done, another thread may use the environment.
    later: list[Any] = []
    action = alone.action_space.sample()
    worker = threading.Thread(target=lambda: later.append(env.step(action)))
    worker.start()
    worker.join(30.0)
    np.testing.assert_array_equal(later[0][0], alone.step(action)[0])


class _SlowCoupling:
    """A coupling term (zero) that takes a moment: the threads switch inside a step."""

    def term(self, y: np.ndarray, yd: np.ndarray) -> np.ndarray:
        time.sleep(1e-4)
        return np.zeros_like(y)


def _driver() -> DMPTaskTarget:
    t = np.linspace(0.0, 1.0, 101)
    s = t[:, None]
    demo = np.hstack([s, -0.5 * s**2, np.sin(s)])
    dmp = DiscreteDMP.fit(t, demo)
    task = Task(JointConfiguration(Robot.load("planar_3link")), np.zeros(3))
    return DMPTaskTarget(dmp, task, couplings=[_SlowCoupling()])


def test_dmp_task_target_stepped_by_threads_matches_the_sequential_steps(
    short_switch_interval: None,
) -> None:
    threads, steps, dt = 4, 40, 0.01
    sequential = _driver()
    for _ in range(threads * steps):
        sequential.step(dt)
    shared = _driver()
    errors: list[BaseException] = []

    def run() -> None:
        try:
            for _ in range(steps):
                shared.step(dt)
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    pool = [threading.Thread(target=run) for _ in range(threads)]
    for th in pool:
        th.start()
    for th in pool:
        th.join(60.0)
    assert not errors
    # Reference: the same number of steps one after the other (each step is the same map of
    # the state, so the order of the threads does not matter).
    assert shared.time == pytest.approx(sequential.time, abs=1e-12)
    np.testing.assert_allclose(shared.y, sequential.y, rtol=0, atol=1e-12)
    np.testing.assert_allclose(shared.z, sequential.z, rtol=0, atol=1e-12)
    assert shared.phase == pytest.approx(sequential.phase, abs=1e-15)
    np.testing.assert_allclose(shared.task.target, sequential.y, rtol=0, atol=1e-12)
