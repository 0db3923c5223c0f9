"""Dubins and Reeds-Shepp distances refuse NaN and inf poses (they returned inf silently).

The compiled kernel answers finite poses (values checked against the NumPy reference); a
non-finite answer sends the query to the Python path, which names the bad pose.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.planning.dubins import dubins_distance, dubins_distance_numpy
from taskspace.planning.reeds_shepp import reeds_shepp_distance, reeds_shepp_distance_numpy

CURVES = [
    (dubins_distance, dubins_distance_numpy),
    (reeds_shepp_distance, reeds_shepp_distance_numpy),
]


@pytest.mark.parametrize(("distance", "reference"), CURVES)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_pose_is_named(distance, reference, bad: float) -> None:  # type: ignore[no-untyped-def]
    good = np.array([0.0, 0.0, 0.0])
    for start, goal, name in (
        ([bad, 0.0, 0.0], good, "start"),
        (good, [1.0, 2.0, bad], "goal"),
        (np.array([[0.0, 0.0, 0.0], [bad, 1.0, 0.0]]), good, "start"),
    ):
        with pytest.raises(NotFiniteError, match=name):
            distance(start, goal, 1.0)
        with pytest.raises(NotFiniteError, match=name):
            distance(np.asarray(start, dtype=float), np.asarray(goal, dtype=float), 1.0)


@pytest.mark.parametrize(("distance", "reference"), CURVES)
def test_finite_poses_keep_their_distances(distance, reference) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(4)
    s = rng.uniform(-3, 3, (200, 3))
    g = rng.uniform(-3, 3, (200, 3))
    np.testing.assert_allclose(distance(s, g, 0.7), reference(s, g, 0.7), rtol=1e-9, atol=1e-12)
    assert distance(s[0], g[0], 0.7)[0] == pytest.approx(reference(s[:1], g[:1], 0.7)[0])


@pytest.mark.parametrize(("distance", "reference"), CURVES)
def test_poses_too_far_apart_for_a_float_are_named(distance, reference) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="too far apart"):
        distance([-1e308, 0.0, 0.0], [1e308, 0.0, 0.0], 1e-300)
