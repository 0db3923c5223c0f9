"""Bounds far larger than the resolution, as a new user may give for an "unbounded" axis.

On a 2-D box of +-1e100 (resolution 0.03), bit_star, prm_star, lazy_prm_star, prm and
lazy_prm checked a line of ~1e101 segments: ``bisection_order`` queued them one by one in
Python (hung, then killed for its memory; bit_star ignored its 0.5 s limit). With +-1e154
the squared distances of the nearest-neighbour searches overflowed: IndexError. Now the
order is refused beyond 2^30 segments (the compiled kernel's and rrt_connect's limit) with
InvalidInputError, the order is built a level at a time in NumPy (the same order, tested
against the queue written here), and bounds whose squared diameter overflows are refused
when the space is made.
"""

from __future__ import annotations

import resource
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning import (
    BITStarOptions,
    PRMOptions,
    PRMStarOptions,
    bit_star,
    lazy_prm,
    lazy_prm_star,
    prm,
    prm_star,
)
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, bisection_order


def _queue_order(n: int) -> list[int]:
    """Midpoints of [0, n] breadth-first (the definition, one interval at a time)."""
    out, queue = [], deque([(0, n)])
    while queue:
        a, b = queue.popleft()
        if b - a >= 2:
            mid = (a + b) // 2
            out.append(mid)
            queue.extend([(a, mid), (mid, b)])
    return out


@contextmanager
def _memory_cap(extra: int = 1 << 30) -> Iterator[None]:
    """The address space of this process capped at its current size + ``extra`` bytes
    (a MemoryError, not a killed test run, if an order is built for a huge n)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    with open("/proc/self/statm") as f:
        size = int(f.read().split()[0]) * resource.getpagesize()
    cap = size + extra
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


@pytest.mark.parametrize("n", [*range(0, 300), 1023, 1024, 1025, 65_537, 1_000_003])
def test_the_order_is_the_breadth_first_midpoints(n: int) -> None:
    assert bisection_order(n).tolist() == _queue_order(n)


def test_an_order_beyond_2_30_segments_is_refused() -> None:
    with _memory_cap(), pytest.raises(InvalidInputError, match="more than 2\\^30"):
        bisection_order((1 << 30) + 1)
    assert bisection_order(1 << 20).size == (1 << 20) - 1


PLANNERS: dict[str, tuple[Any, Any]] = {
    "bit_star": (bit_star, BITStarOptions),
    "prm": (prm, PRMOptions),
    "lazy_prm": (lazy_prm, PRMOptions),
    "prm_star": (prm_star, PRMStarOptions),
    "lazy_prm_star": (lazy_prm_star, PRMStarOptions),
}


def _box(bound: float) -> ConfigurationSpace:
    return ConfigurationSpace(
        [-bound, -bound], [bound, bound], FunctionChecker(lambda q: np.ones(len(q), bool))
    )


@pytest.mark.parametrize("name", PLANNERS)
def test_planners_on_bounds_of_1e100_raise_a_clear_error(name: str) -> None:
    fn, options = PLANNERS[name]
    space = _box(1e100)
    with _memory_cap(), pytest.raises(InvalidInputError, match="resolution is too small"):
        fn(space, [-5e99, -5e99], [5e99, 5e99], options(time_limit_s=0.5))


@pytest.mark.parametrize("bound", [1e154, 1e300])
def test_bounds_whose_squared_diameter_overflows_are_refused(bound: float) -> None:
    with pytest.raises(InvalidInputError, match="bounds are too large"):
        _box(bound)
    assert _box(1e153).dim == 2
