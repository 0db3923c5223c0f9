"""Polygon worlds, Bug and potential fields refuse what they cannot answer.

Before: two overlapping obstacles made bug2 report GOAL_UNREACHABLE for a reachable goal
(boundary following walked the edges inside the other polygon), although PolygonWorld's
docstring asked for disjoint obstacles; a NaN or negative Bug tolerance, NaN or negative
potential-field tolerances and a goal inside an obstacle were accepted (descent then ended in
a "local minimum" that was the obstacle), and the potential of NaN points was NaN, of (N, 3)
points a bare numpy ValueError.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError, PlanningError
from taskspace.planning.bug import BugOptions, BugStatus, bug1, bug2
from taskspace.planning.polygon_world import Polygon, PolygonWorld, make_world
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    gradient_descent,
)

SQUARE = [[2, 2], [4, 2], [4, 4], [2, 4]]
BOUNDS = (0.0, 0.0, 10.0, 10.0)


@pytest.mark.parametrize(
    ("other", "how"),
    [
        ([[3, 3], [5, 3], [5, 5], [3, 5]], "cross"),  # corners overlap
        ([[2.5, 2.5], [3.5, 2.5], [3.5, 3.5], [2.5, 3.5]], "inside"),  # contained
        ([[1, 1], [5, 1], [5, 5], [1, 5]], "inside"),  # contains the square
    ],
)
def test_overlapping_polygons_are_refused(other: list, how: str) -> None:
    with pytest.raises(InvalidInputError, match=f"polygons\\[0\\] and polygons\\[1\\].*{how}"):
        make_world([SQUARE, other], bounds=BOUNDS)


def test_disjoint_touching_and_hole_polygons_are_accepted() -> None:
    make_world([SQUARE, [[4, 2], [6, 2], [6, 4], [4, 4]]], bounds=BOUNDS)  # shared edge
    make_world([SQUARE, [[4, 4], [6, 4], [6, 6], [4, 6]]], bounds=BOUNDS)  # shared corner
    ring = Polygon(
        np.array([[1.0, 1.0], [9.0, 1.0], [9.0, 9.0], [1.0, 9.0]]),
        holes=(np.array([[2.0, 2.0], [2.0, 8.0], [8.0, 8.0], [8.0, 2.0]]),),
    )
    PolygonWorld((ring, Polygon(np.array(SQUARE, float) + 1.0)), BOUNDS)  # inside the hole


def test_merged_obstacle_is_walked_around() -> None:
    # the union of the two overlapping squares of the first case, as one polygon
    merged = [[2, 2], [4, 2], [4, 3], [5, 3], [5, 5], [3, 5], [3, 4], [2, 4]]
    world = make_world([merged], bounds=BOUNDS)
    for run in (bug1, bug2):
        res = run(world, (0.5, 3.5), (9.0, 3.5))
        assert res.status is BugStatus.REACHED
        # every path point free or on the boundary (segments sampled at 1 mm)
        pts = np.concatenate(
            [
                np.linspace(a, b, 2 + int(np.linalg.norm(b - a) / 1e-3))
                for a, b in zip(res.path[:-1], res.path[1:])
            ]
        )
        inner = pts[world.contains(pts)]
        if inner.size:
            d, _ = world.closest_points(inner)
            assert d.min(axis=1).max() < 1e-6


@pytest.mark.parametrize("tol", [float("nan"), -1.0, float("inf")])
def test_bug_tolerance_is_checked(tol: float) -> None:
    world = make_world([SQUARE], bounds=BOUNDS)
    with pytest.raises(InvalidInputError):
        bug2(world, (0.5, 3.0), (9.0, 3.0), options=BugOptions(tolerance=tol))


@pytest.mark.parametrize("name", ["goal_tolerance", "gradient_tolerance", "stall_distance"])
@pytest.mark.parametrize("value", [float("nan"), -1.0])
def test_potential_tolerances_are_checked(name: str, value: float) -> None:
    world = make_world([SQUARE], bounds=BOUNDS)
    with pytest.raises(InvalidInputError, match=name):
        PotentialField(world, (9.0, 3.0), PotentialFieldOptions(**{name: value}))


def test_potential_goal_must_be_free() -> None:
    world = make_world([SQUARE], bounds=BOUNDS)
    with pytest.raises(PlanningError, match="goal"):
        gradient_descent(PotentialField(world, (3.0, 3.0)), (0.5, 3.0))
    with pytest.raises(PlanningError, match="goal"):
        gradient_descent(PotentialField(world, (30.0, 3.0)), (0.5, 3.0))


def test_potential_points_are_checked() -> None:
    field = PotentialField(make_world([SQUARE], bounds=BOUNDS), (9.0, 3.0))
    with pytest.raises(NotFiniteError):
        field.value([[np.nan, 1.0]])
    with pytest.raises(InvalidInputError, match=r"\(N, 2\)"):
        field.gradient([[1.0, 2.0, 3.0]])
    # the attractive potential and gradient of a valid point: the notes' formulas (slide 3:15)
    u, g = field.attractive([1.0, 3.0])
    r = 8.0  # distance to the goal, beyond d* = 2: conic
    assert u[0] == pytest.approx(2.0 * r - 0.5 * 4.0)
    assert g[0] == pytest.approx([-2.0, 0.0])
