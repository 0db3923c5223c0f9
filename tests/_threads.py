"""Shared set-up of the thread tests: one solver shared by threads gives the sequential results.

The reference is the same work run one thread after the other on the same object. A feature
or task whose evaluation takes a moment (as a user feature written in Python does) and a short
interpreter switch interval make the threads interleave inside the assembly of a step,
reliably: without the object's lock a thread then solves rows that belong partly to another
thread's state, and its results drift far beyond the tolerance of the warm starts (used by
tests/ik/test_ik_threads.py, tests/ik/test_ik_hierarchical_threads.py and
tests/control/test_control_threads.py; each fails with the locks disabled).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

import numpy as np

from taskspace.features import CenterOfMass, Position
from taskspace.features.rows import TaskRows
from taskspace.model import Robot, State
from taskspace.tasks import Task

THREADS = 4
DELAY_S = 2e-4
"""How long a slow feature or task takes (long enough for the interpreter to switch)."""
SWITCH_INTERVAL_S = 1e-5
JOIN_TIMEOUT_S = 60.0

T = TypeVar("T")


class SlowResidualMixin:
    """Makes ``residual_and_jacobian`` of a feature take :data:`DELAY_S` longer."""

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[np.ndarray, np.ndarray]:
        out = super().residual_and_jacobian(state, target)  # type: ignore[misc]
        time.sleep(DELAY_S)
        return out  # type: ignore[no-any-return]


class SlowPosition(SlowResidualMixin, Position):
    """A position feature that takes a moment (as a Python feature would)."""


class SlowCenterOfMass(SlowResidualMixin, CenterOfMass):
    """A centre-of-mass feature that takes a moment."""


class SlowTask(Task):
    """A task whose rows take a moment (a Python feature): the thread switches inside."""

    def rows(self, state: State) -> TaskRows:
        time.sleep(DELAY_S)
        return super().rows(state)


@contextmanager
def fast_switching(interval: float = SWITCH_INTERVAL_S) -> Iterator[None]:
    """Let the interpreter switch threads every ``interval`` seconds (restored after)."""
    saved = sys.getswitchinterval()
    sys.setswitchinterval(interval)
    try:
        yield
    finally:
        sys.setswitchinterval(saved)


def run_in_threads(work: Callable[[int], T], threads: int = THREADS) -> list[T]:
    """``[work(0), ..., work(threads - 1)]``, each in its own thread, all at once.

    The threads run with a short switch interval (:func:`fast_switching`). An exception in a
    thread fails the test with the thread's index; a thread still running after
    :data:`JOIN_TIMEOUT_S` fails it too (a deadlock).
    """
    results: list[T | None] = [None] * threads
    errors: list[tuple[int, BaseException]] = []

    def run(i: int) -> None:
        try:
            results[i] = work(i)
        except BaseException as exc:  # reported below with the thread's index
            errors.append((i, exc))

    pool = [threading.Thread(target=run, args=(i,), daemon=True) for i in range(threads)]
    with fast_switching():
        for t in pool:
            t.start()
        for t in pool:
            t.join(timeout=JOIN_TIMEOUT_S)
    assert not any(t.is_alive() for t in pool), "a thread did not finish (deadlock?)"
    assert not errors, errors
    assert all(r is not None for r in results)
    return [r for r in results if r is not None]


def assert_matches_sequential(
    threaded: list[np.ndarray],
    sequential: list[np.ndarray],
    tolerance: float,
    *,
    relative: bool = False,
) -> None:
    """Each thread's results equal the sequential run's within ``tolerance``.

    With ``relative``, the tolerance is scaled by ``max(1, max |sequential|)`` per thread.
    """
    assert len(threaded) == len(sequential)
    for i, (got, want) in enumerate(zip(threaded, sequential)):
        scale = max(1.0, float(np.abs(want).max())) if relative else 1.0
        err = float(np.abs(got - want).max())
        assert err < tolerance * scale, f"thread {i} drifted from the sequential run by {err:.3g}"


def assert_threads_match_sequential(
    work: Callable[[int], np.ndarray],
    tolerance: float,
    *,
    threads: int = THREADS,
    relative: bool = False,
) -> None:
    """Run ``work(i)`` for every ``i`` one after the other, then all at once in threads, and
    compare (:func:`run_in_threads`, :func:`assert_matches_sequential`)."""
    sequential = [work(i) for i in range(threads)]
    threaded = run_in_threads(work, threads)
    assert_matches_sequential(threaded, sequential, tolerance, relative=relative)


def random_starts(robot: Robot, n: int = THREADS, seed: int = 0) -> list[np.ndarray]:
    """``n`` configurations near ``q_default`` inside the joint limits."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.lower_limits, robot.upper_limits
    return [
        np.clip(robot.q_default + 0.3 * rng.standard_normal(robot.nq), lo, hi) for _ in range(n)
    ]


def ik_trajectory(ik: Any, robot: Robot, q0: np.ndarray, steps: int, dt: float) -> np.ndarray:
    """``steps`` IK steps from ``q0`` (each must succeed), shape (steps, nq)."""
    state = robot.state(q0)
    out = []
    for _ in range(steps):
        q, result = ik.step(state, dt)
        assert result.success
        state.update(q)
        out.append(q)
    return np.array(out)


def offset_tcp_task(robot: Robot, task: type[Task] = Task) -> Task:
    """Panda TCP pose task with its target 10 cm x, -10 cm y, +5 cm z from ``q_default``."""
    from taskspace.features import FramePose

    tcp = task(FramePose(robot, "panda_hand_tcp"), name="tcp")
    tcp.set_target_from_state(robot.state())
    target = tcp.target.copy()
    target.translation = target.translation + np.array([0.1, -0.1, 0.05])
    tcp.set_target(target)
    return tcp
