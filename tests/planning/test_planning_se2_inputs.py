"""SE(2) helpers refuse what has no answer (lead's new-user sweep).

Before: ``se2_distance`` took a negative or NaN rotation weight (a NaN distance), ``arc_pose``
a NaN curvature or arc length (NaN poses), and the curve distances of mismatched batches raised
a bare numpy broadcasting ValueError.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
from taskspace.planning.dubins import dubins_distance
from taskspace.planning.reeds_shepp import reeds_shepp_distance
from taskspace.planning.se2 import arc_pose, se2_distance


@pytest.mark.parametrize("weight", [-1.0, float("nan"), float("inf")])
def test_rotation_weight_is_checked(weight: float) -> None:
    with pytest.raises(InvalidInputError, match="rotation_weight"):
        se2_distance((0, 0, 0), (1, 2, 3), rotation_weight=weight)


def test_se2_distance_formula() -> None:
    # slide 3:58: sqrt(dx^2 + dy^2 + w^2 |e^{i t1} - e^{i t2}|^2)
    d = se2_distance((0.0, 0.0, 0.0), (3.0, 4.0, math.pi), rotation_weight=0.5)
    assert d == pytest.approx(math.sqrt(25.0 + 0.25 * 4.0))


@pytest.mark.parametrize(
    ("q", "k", "s"),
    [((0, 0, 0), float("nan"), 1.0), ((0, 0, 0), 0.5, float("inf")), ((0, np.nan, 0), 0.5, 1.0)],
)
def test_arc_pose_refuses_non_finite(q: tuple, k: float, s: float) -> None:
    with pytest.raises(NotFiniteError):
        arc_pose(q, k, s)


def test_arc_pose_shape_and_closed_form() -> None:
    with pytest.raises(ShapeError):
        arc_pose((0.0, 0.0), 1.0, 1.0)
    # a quarter circle of radius 2 to the left from the origin facing +x ends at (2, 2, pi/2)
    assert arc_pose((0.0, 0.0, 0.0), 0.5, math.pi) == pytest.approx([2.0, 2.0, math.pi / 2])


@pytest.mark.parametrize("distance", [dubins_distance, reeds_shepp_distance])
def test_mismatched_batches_are_named(distance) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="same number of poses"):
        distance(np.zeros((3, 3)), np.ones((2, 3)), 1.0)
    # one start against a batch of goals broadcasts
    assert distance(np.zeros(3), np.ones((2, 3)), 1.0).shape == (2,)


def test_car_duration_is_named() -> None:
    from taskspace.planning.car import CarModel

    with pytest.raises(NotFiniteError, match="duration"):
        CarModel().integrate((0.0, 0.0, 0.0), (1.0, 0.2), float("nan"))
