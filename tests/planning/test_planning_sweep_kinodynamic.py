"""kinodynamic_rrt when the start already reaches the goal (sweep of session 35).

The goal curve was tried only from new tree nodes: start == goal gave a 4 m drive out and
back (two 2 m Reeds-Shepp pieces), and a goal in free reach of the start a detour through a
random node, where the other planners return the start (the limits' edge cases).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace.planning import (
    CarModel,
    KinodynamicRRTOptions,
    RRTStatus,
    angle_distance,
    kinodynamic_rrt,
    parking_lot,
    reeds_shepp_distance,
)


def same_pose(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Equal positions and headings up to ``tol`` (headings modulo 2 pi)."""
    return bool(
        np.abs(a[:2] - b[:2]).max() <= tol and abs(float(angle_distance(a[2], b[2]))) <= tol
    )


@pytest.mark.parametrize("steering", ["reeds_shepp", "dubins", "controls"])
def test_start_equal_to_goal_is_the_empty_motion(steering: str) -> None:
    car = CarModel()
    world, start, _ = parking_lot()
    for limit in (math.inf, 0.0):  # whatever the limits
        res = kinodynamic_rrt(
            car,
            world,
            start,
            start.copy(),
            options=KinodynamicRRTOptions(steering=steering, max_iterations=50, time_limit_s=limit),
        )
        assert res.success and res.status is RRTStatus.REACHED
        assert res.length == 0.0 and res.iterations == 0
        for pose in (res.path[0], res.path[-1]):  # (headings wrapped to [-pi, pi))
            assert same_pose(pose, start, 0.0)


def test_goal_in_reach_of_the_start_is_the_exact_curve() -> None:
    car = CarModel()
    world, start, _ = parking_lot()
    goal = start + np.array([-1.5, 0.3, 0.2])  # in the lane, free, within connect_distance
    res = kinodynamic_rrt(
        car, world, start, goal, options=KinodynamicRRTOptions(max_iterations=200, seed=1)
    )
    exact = float(reeds_shepp_distance(start, goal, car.turning_radius)[0])
    assert res.success and res.iterations == 0
    assert res.length == pytest.approx(exact, rel=1e-12)  # the shortest car path, no detour
    assert same_pose(res.path[-1], goal, 1e-9)
