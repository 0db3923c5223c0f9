"""CurvePath.pose_at / truncated on NaN and negative lengths (sweep of session 35).

``pose_at(nan)`` returned a NaN pose, ``truncated(nan)`` the whole path and
``truncated(-1)`` an empty one, all without a word.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.planning import dubins_shortest, reeds_shepp_shortest


@pytest.mark.parametrize("shortest", [dubins_shortest, reeds_shepp_shortest])
def test_pose_at_refuses_nan_and_inf(shortest: object) -> None:
    path = shortest([0.0, 0.0, 0.0], [3.0, 4.0, 1.0], 1.0)  # type: ignore[operator]
    with pytest.raises(NotFiniteError, match="s"):
        path.pose_at(math.nan)
    with pytest.raises(NotFiniteError, match="s"):
        path.pose_at(np.array([0.0, np.nan]))
    with pytest.raises(NotFiniteError, match="s"):
        path.pose_at(math.inf)
    # the ends, exactly: the start pose, and the goal (x, y and the heading wrapped)
    assert tuple(path.pose_at(0.0)) == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(path.pose_at(path.length), [3.0, 4.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(path.pose_at(0), [0.0, 0.0, 0.0])


@pytest.mark.parametrize("shortest", [dubins_shortest, reeds_shepp_shortest])
def test_truncated_refuses_nan_and_negative(shortest: object) -> None:
    path = shortest([0.0, 0.0, 0.0], [3.0, 4.0, 1.0], 1.0)  # type: ignore[operator]
    with pytest.raises(InvalidInputError, match="max_length"):
        path.truncated(math.nan)  # was the whole path
    with pytest.raises(InvalidInputError, match="max_length"):
        path.truncated(-1.0)  # was an empty path
    with pytest.raises(InvalidInputError, match="max_length"):
        path.truncated(True)  # type: ignore[arg-type]
    assert path.truncated(math.inf) is path
    assert path.truncated(0.0).length == 0.0
    half = path.truncated(np.float32(0.5) * path.length)
    assert half.length == pytest.approx(0.5 * path.length, rel=1e-7)
    # a prefix: its end is the full path's pose at that distance
    np.testing.assert_allclose(half.end, path.pose_at(half.length), atol=1e-12)
