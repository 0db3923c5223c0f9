"""A subdivision step far too small for the path is a named error, not numpy's MemoryError.

``interpolate(path, 1e-9)`` on a 1 km segment asked numpy for terabytes; ``smooth_bspline``
with ``max_step=1e-9`` for tens of gigabytes (found by a new-user audit). Usual steps keep
their waypoints (checked against points written by hand).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning import SmoothingOptions, smooth_bspline
from taskspace.planning.rrt_star import interpolate
from tests.planning._planning_worlds import wall_space


@pytest.mark.parametrize("resolution", [1e-9, 1e-300, 5e-324])
def test_a_step_too_small_for_memory_is_named(resolution: float) -> None:
    path = [[0.0, 0.0], [1e3, 0.0]]
    with pytest.raises(InvalidInputError, match=r"resolution=.*2 GiB"):
        interpolate(path, resolution)
    with pytest.raises(InvalidInputError, match=r"resolution=.*2 GiB"):
        wall_space().interpolate_path(np.array([[1.0, 1.0], [3.0, 1.0]]), resolution)


def test_smoothing_names_a_max_step_too_small() -> None:
    space = wall_space()
    path = np.array([[1.0, 1.0], [3.0, 1.0], [3.0, 3.0]])
    with pytest.raises(InvalidInputError, match=r"max_step=1e-09"):
        smooth_bspline(space, path, SmoothingOptions(max_step=1e-9))
    result = smooth_bspline(space, path, SmoothingOptions(max_step=0.5))
    np.testing.assert_array_equal(result.path[[0, -1]], path[[0, -1]])


def test_usual_steps_give_the_same_waypoints() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5]])
    expected = np.array(
        [[0, 0], [0.25, 0], [0.5, 0], [0.75, 0], [1, 0], [1, 0.25], [1, 0.5]], dtype=float
    )
    np.testing.assert_allclose(interpolate(path, 0.3), expected, atol=1e-15)
    np.testing.assert_allclose(wall_space().interpolate_path(path + 1.0, 0.3), expected + 1.0)
    assert interpolate(path, 10.0).shape == (3, 2)  # one piece per segment
