"""ConfigurationSpace.path_valid / motion_valid / path_length on inputs not designed around.

``path_valid`` called a path through configurations outside the bounds (the joint limits)
valid, and an empty path (a failed plan's) valid; a NaN motion raised math.ceil's bare
ValueError.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.planning import ConfigurationSpace, EdgeCheckOptions, FunctionChecker, path_length


def disc_space() -> ConfigurationSpace:
    """The unit box with a disc of radius 0.2 at (0.5, 0.5) as the obstacle."""
    centre = np.array([0.5, 0.5])
    return ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(lambda Q: np.linalg.norm(Q - centre, axis=1) > 0.2)
    )


def test_path_outside_the_bounds_is_not_valid() -> None:
    space = disc_space()
    inside = np.array([[0.1, 0.1], [0.9, 0.1]])
    assert space.path_valid(inside)
    # free of the disc but through x = 1.5 > upper: it was called valid
    assert not space.path_valid(np.array([[0.1, 0.1], [1.5, 0.1], [0.9, 0.1]]))
    assert not space.path_valid(np.array([[-0.2, 0.1], [0.9, 0.1]]))
    # the checker alone says free: the bounds are what make it invalid
    assert space.is_valid(np.array([1.5, 0.1])) and not space.within_bounds(np.array([1.5, 0.1]))
    # and through the disc stays invalid
    assert not space.path_valid(np.array([[0.1, 0.1], [0.9, 0.9]]))


def test_path_valid_refuses_empty_and_nan_paths() -> None:
    space = disc_space()
    with pytest.raises(InvalidInputError, match="m >= 1"):
        space.path_valid(np.zeros((0, 2)))  # was True: a failed plan's path is not valid
    with pytest.raises(NotFiniteError):
        space.path_valid(np.array([[0.1, 0.1], [np.nan, 0.1]]))
    with pytest.raises(InvalidInputError, match="shape"):
        space.path_valid(np.zeros((2, 3)))
    assert space.path_valid([[0.1, 0.1]])  # one free waypoint


def test_motion_valid_names_a_nan_motion() -> None:
    space = disc_space()
    with pytest.raises(InvalidInputError, match="not finite"):
        space.motion_valid(np.array([0.1, 0.1]), np.array([np.nan, 0.1]))
    assert space.motion_valid(np.array([0.1, 0.1]), np.array([0.9, 0.1]))


def test_path_lengths_refuse_nan() -> None:
    space = disc_space()
    bad = np.array([[0.0, 0.0], [np.nan, 1.0], [1.0, 1.0]])
    with pytest.raises(NotFiniteError):
        path_length(bad)  # was nan
    with pytest.raises(NotFiniteError):
        space.path_length(bad)  # was nan
    good = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    assert path_length(good) == 2.0 and space.path_length(good) == 2.0
    assert path_length(np.zeros((0, 2))) == 0.0 and space.path_length(np.zeros((0, 2))) == 0.0


@pytest.mark.parametrize("max_batch", [2.5, True, 0, "8"])
def test_edge_max_batch_must_be_a_positive_integer(max_batch: object) -> None:
    # 2.5 was accepted and raised a bare TypeError (slice indices) at the first edge check;
    # True was a batch of 1
    checker = FunctionChecker(lambda Q: np.ones(len(Q), bool))
    edge = EdgeCheckOptions(resolution=0.01, max_batch=max_batch)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="max_batch"):
        ConfigurationSpace([0, 0], [1, 1], checker, edge=edge)


def test_edge_max_batch_numpy_integer() -> None:
    checker = FunctionChecker(lambda Q: np.ones(len(Q), bool))
    edge = EdgeCheckOptions(resolution=0.01, max_batch=np.int64(4))  # type: ignore[arg-type]
    space = ConfigurationSpace([0, 0], [1, 1], checker, edge=edge)
    assert space.motion_valid(np.zeros(2), np.ones(2))
