"""Locomotion objects shared by threads (#15 Build 5): each thread gets its sequential result.

* :class:`KneedWalker`: its Pinocchio data are per thread. Four threads evaluating one walker
  at different states (positions: forward kinematics then a read of ``oMf``; the knee-strike
  impulse: ``impulseDynamics`` then a read of ``impulse_c``) get what one thread gets; with one
  data shared, another thread's evaluation lands between the two and the answer is wrong.
* :class:`ZmpMpc`: runs on one controller hold its lock (the QP workspace and the half-space
  cache); two threads walking different references get the runs of fresh controllers.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from taskspace.locomotion import CartTable, KneedWalker, ZmpMpc, ZmpMpcOptions
from taskspace.locomotion.footsteps import StepTiming, arc_walk, straight_walk
from taskspace.locomotion.zmp_reference import support_polygons, zmp_reference


@pytest.fixture
def short_switch_interval() -> Iterator[None]:
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(old)


def _in_threads(jobs: list[Callable[[], Any]]) -> list[Any]:
    out: list[Any] = [None] * len(jobs)
    errors: list[BaseException] = []

    def run(i: int) -> None:
        try:
            out[i] = jobs[i]()
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    pool = [threading.Thread(target=run, args=(i,)) for i in range(len(jobs))]
    for th in pool:
        th.start()
    for th in pool:
        th.join(120.0)
    assert not errors, errors
    assert not any(th.is_alive() for th in pool)
    return out


def test_kneed_walker_evaluated_by_threads_gives_the_sequential_values(
    short_switch_interval: None,
) -> None:
    rng = np.random.default_rng(0)
    states = [np.concatenate([rng.uniform(-0.4, 0.4, 3), rng.uniform(-1, 1, 3)]) for _ in range(4)]
    alone = KneedWalker()
    expected = [(alone.positions(x[:3]), alone.knee_strike_impact(x)) for x in states]
    shared = KneedWalker()

    def evaluate(x: np.ndarray) -> list[Any]:
        return [(shared.positions(x[:3]), shared.knee_strike_impact(x)) for _ in range(300)]

    results = _in_threads([lambda x=x: evaluate(x) for x in states])
    for got, (pos, (post, impulse)) in zip(results, expected, strict=True):
        for p, (q, i) in got:
            for name in pos:
                np.testing.assert_allclose(p[name], pos[name], rtol=0, atol=1e-12)
            np.testing.assert_allclose(q, post, rtol=0, atol=1e-12)
            assert i == pytest.approx(impulse, abs=1e-12)


def test_zmp_mpc_shared_by_threads_gives_the_runs_of_fresh_controllers(
    short_switch_interval: None,
) -> None:
    model = CartTable(com_height=0.8, dt=0.05)
    timing = StepTiming(single_support=0.6)
    walks = [arc_walk(3, radius=1.0, angle=0.5, timing=timing), straight_walk(3, timing=timing)]
    inputs = []
    for plan in walks:
        times = model.dt * np.arange(int(np.ceil(plan.duration / model.dt)) + 1)
        inputs.append((zmp_reference(plan, times), support_polygons(plan, times)))
    options = ZmpMpcOptions(zmp_margin=0.01)
    expected = [ZmpMpc(model, options).simulate(r, p).trajectory.zmp for r, p in inputs]
    shared = ZmpMpc(model, options)
    results = _in_threads([lambda r=r, p=p: shared.simulate(r, p) for r, p in inputs])
    for res, zmp in zip(results, expected, strict=True):
        assert res.success
        np.testing.assert_allclose(res.trajectory.zmp, zmp, rtol=0, atol=1e-9)
