"""One reading of a path (``configuration_space.as_path``) by every function that takes one.

``interpolate([0, 1, 2], r)`` read one 3-D waypoint (a path of one point), whatever was
meant, and ``path_length([0, 1, 2])`` was 0. A 1-D array is now read only when the dimension
says how: by a space of dim 1 as that many waypoints, by a space (robot) of dim n = its size
as one waypoint; otherwise, and wherever the dimension is unknown, an InvalidInputError names
the shape to give. Expected paths are written by hand.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.planning import (
    ShortcutOptions,
    SmoothingOptions,
    certify_path,
    interpolate,
    shortcut_path,
    smooth_bspline,
)
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, path_length


def _free_space(dim: int) -> ConfigurationSpace:
    return ConfigurationSpace(
        [-5.0] * dim, [5.0] * dim, FunctionChecker(lambda q: np.ones(len(q), dtype=bool))
    )


def test_interpolate_refuses_a_1d_path_and_names_both_readings() -> None:
    with pytest.raises(InvalidInputError) as error:
        interpolate([0.0, 1.0, 2.0], 0.5)
    text = str(error.value)
    assert "path must have shape (m, d)" in text and "1-D array of 3 values" in text
    assert "[[q_1], ..., [q_3]]" in text and "[[q_1, ..., q_3]]" in text
    np.testing.assert_array_equal(
        interpolate([[0.0], [1.0], [2.0]], 0.5), [[0.0], [0.5], [1.0], [1.5], [2.0]]
    )
    np.testing.assert_array_equal(interpolate([[0.0, 1.0, 2.0]], 0.5), [[0.0, 1.0, 2.0]])


def test_path_length_refuses_a_1d_path() -> None:
    with pytest.raises(InvalidInputError, match="1-D array of 3 values"):
        path_length(np.array([0.0, 1.0, 2.0]))
    assert path_length(np.array([[0.0], [1.0], [3.0]])) == 3.0


def test_a_1d_space_reads_a_1d_path_as_waypoints() -> None:
    space = _free_space(1)
    np.testing.assert_array_equal(
        space.interpolate_path([0.0, 1.0, 2.0], 0.5), [[0.0], [0.5], [1.0], [1.5], [2.0]]
    )
    assert space.path_length([0.0, 1.0, 3.0]) == 3.0
    short = shortcut_path(space, [0.0, 1.0, 2.0], ShortcutOptions(seed=0)).path
    np.testing.assert_array_equal(short, [[0.0], [2.0]])  # a straight line, greedy
    smooth = smooth_bspline(space, [0.0, 1.0, 2.0], SmoothingOptions()).path
    assert smooth.shape[1] == 1
    np.testing.assert_array_equal(smooth[[0, -1]], [[0.0], [2.0]])


def test_a_space_of_the_path_s_size_reads_one_waypoint() -> None:
    space = _free_space(3)
    np.testing.assert_array_equal(space.interpolate_path([0.0, 1.0, 2.0], 0.5), [[0, 1, 2]])
    assert space.path_length([0.0, 1.0, 2.0]) == 0.0


CALLS: dict[str, Any] = {
    "interpolate_path": lambda space, p: space.interpolate_path(p, 0.5),
    "path_length": lambda space, p: space.path_length(p),
    "shortcut_path": lambda space, p: shortcut_path(space, p),
    "smooth_bspline": lambda space, p: smooth_bspline(space, p),
}


@pytest.mark.parametrize("call", CALLS)
def test_other_1d_sizes_are_refused_naming_the_shape(call: str) -> None:
    with pytest.raises(InvalidInputError) as error:
        CALLS[call](_free_space(2), [0.0, 1.0, 2.0])
    text = str(error.value)
    assert "path must have shape (m, 2)" in text and "1-D array of 3 values" in text


@pytest.mark.parametrize("call", CALLS)
def test_wrong_2d_shapes_and_empty_paths_are_refused(call: str) -> None:
    # (path_length, called on every planner's result, checks the shape only)
    for bad in ([[0.0, 1.0, 2.0]], np.empty((0, 2)), [[0.0, np.nan]])[
        : 1 if "length" in call else 3
    ]:
        with pytest.raises(InvalidInputError, match="path"):
            CALLS[call](_free_space(2), bad)


def test_certify_path_reads_paths_as_the_spaces_do() -> None:
    robot = Robot.load("planar_2link")
    assert robot.nq == 2
    with pytest.raises(InvalidInputError, match=r"path must have shape \(m, 2\)"):
        certify_path(robot, [0.0, 0.1, 0.2])
    one = certify_path(robot, [0.0, 0.1])  # one waypoint of the robot's nq
    two = certify_path(robot, [[0.0, 0.1]])
    assert one.certified == two.certified and one.min_distance == two.min_distance
