"""A goal region whose samples are not configurations of the space (sweep of session 35).

Samples of another shape, or NaN, were skipped: every planner then ran to its limits and
reported ITERATION_LIMIT for a goal region in plain reach, without a word of why.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning import (
    BITStarOptions,
    ConfigurationSpace,
    FunctionChecker,
    PRMOptions,
    PRMStarOptions,
    RRTConnectOptions,
    RRTOptions,
    RRTStarOptions,
    bit_star,
    lazy_prm_star,
    prm,
    prm_star,
    rrt,
    rrt_connect,
    rrt_star,
)

CENTRE = np.array([0.9, 0.9])


class Disc:
    """The goal disc of radius 0.02 around (0.9, 0.9), sampled by ``make(centre)``."""

    def __init__(self, make: object) -> None:
        self.make = make

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(np.asarray(q) - CENTRE) <= 0.02)

    def sample(self, rng: np.random.Generator) -> object:
        return self.make(CENTRE.copy())  # type: ignore[operator]


PLANNERS = {
    "rrt": lambda s, g: rrt(s, [0.1, 0.1], g, RRTOptions(max_iterations=200)),
    "rrt_connect": lambda s, g: rrt_connect(
        s, [0.1, 0.1], g, RRTConnectOptions(max_iterations=200)
    ),
    "rrt_star": lambda s, g: rrt_star(s, [0.1, 0.1], g, RRTStarOptions(max_iterations=200)),
    "prm": lambda s, g: prm(s, [0.1, 0.1], g, PRMOptions(max_iterations=100))[0],
    "prm_star": lambda s, g: prm_star(s, [0.1, 0.1], g, PRMStarOptions(max_iterations=50))[0],
    "lazy_prm_star": lambda s, g: lazy_prm_star(
        s, [0.1, 0.1], g, PRMStarOptions(max_iterations=50)
    )[0],
    "bit_star": lambda s, g: bit_star(s, [0.1, 0.1], g, BITStarOptions(max_iterations=50)),
}


def free_square() -> ConfigurationSpace:
    return ConfigurationSpace([0, 0], [1, 1], FunctionChecker(lambda Q: np.ones(len(Q), bool)))


@pytest.mark.parametrize("planner", PLANNERS)
@pytest.mark.parametrize(
    "make",
    [lambda c: c[None, :], lambda c: np.append(c, 0.0), lambda c: np.array([np.nan, 0.9])],
    ids=["row", "size3", "nan"],
)
def test_bad_region_samples_are_named(planner: str, make: object) -> None:
    with pytest.raises(InvalidInputError, match=r"Disc.sample.*shape \(2,\)"):
        PLANNERS[planner](free_square(), Disc(make))


@pytest.mark.parametrize("planner", PLANNERS)
def test_good_region_samples_reach_the_region(planner: str) -> None:
    res = PLANNERS[planner](free_square(), Disc(lambda c: c.tolist()))  # a list is fine
    assert res.success
    assert np.linalg.norm(res.path[-1] - CENTRE) <= 0.02
    np.testing.assert_array_equal(res.path[0], [0.1, 0.1])
