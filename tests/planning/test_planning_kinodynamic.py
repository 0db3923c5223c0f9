import numpy as np
import pytest
from _curve_reference import integrate_car

from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.car import CarModel
from taskspace.planning.kinodynamic_rrt import (
    KinodynamicRRTOptions,
    RRTStatus,
    kinodynamic_rrt,
    parking_lot,
)
from taskspace.planning.polygon_world import PolygonWorld

MODEL = CarModel()


def check_solution(res, world, start, goal, exact=True):
    assert res.success and res.status is RRTStatus.REACHED
    assert np.all(MODEL.poses_free(world, res.path))
    # integrating the controls with the car ODE reproduces the path end
    q = integrate_car(start, res.controls, MODEL.wheelbase)
    tol = 1e-7 if exact else None
    if exact:
        assert np.allclose(q[:2], goal[:2], atol=tol)
        assert abs((q[2] - goal[2] + np.pi) % (2 * np.pi) - np.pi) < tol
    assert np.all(np.abs(res.controls[:, 1]) <= MODEL.max_steering + 1e-12)
    assert res.length == pytest.approx(np.sum(np.abs(res.controls[:, 0] * res.controls[:, 2])))
    # consecutive path samples are at most collision_step apart
    assert np.max(np.linalg.norm(np.diff(res.path[:, :2], axis=0), axis=1)) <= 0.1 + 1e-9
    assert res.n_nodes == len(res.tree_nodes) == len(res.tree_parents)


def test_parking_with_reverse_succeeds_in_narrow_lane():
    world, start, goal = parking_lot(lane_width=8.4)
    res = kinodynamic_rrt(MODEL, world, start, goal, options=KinodynamicRRTOptions(seed=0))
    check_solution(res, world, start, goal)
    assert np.any(res.controls[:, 0] < 0)  # it reversed
    # same seed, same result
    again = kinodynamic_rrt(MODEL, world, start, goal, options=KinodynamicRRTOptions(seed=0))
    assert again.length == res.length and again.n_nodes == res.n_nodes


def test_forward_only_fails_in_narrow_lane_and_succeeds_in_wide_lane():
    # a U-turn needs 2 r + car width = 9.1 m > 8.4 m of lane: no forward-only solution
    world, start, goal = parking_lot(lane_width=8.4)
    opts = KinodynamicRRTOptions(steering="dubins", max_iterations=300)
    res = kinodynamic_rrt(MODEL, world, start, goal, options=opts)
    assert not res.success and res.status is RRTStatus.ITERATION_LIMIT
    assert res.path.shape == (0, 3) and np.isinf(res.length)
    world, start, goal = parking_lot(lane_width=12.0)
    res = kinodynamic_rrt(
        MODEL, world, start, goal, options=KinodynamicRRTOptions(steering="dubins")
    )
    check_solution(res, world, start, goal)
    assert np.all(res.controls[:, 0] > 0)


def test_control_sampling_steering_reaches_goal_region():
    world, start, goal = parking_lot(lane_width=12.0)
    opts = KinodynamicRRTOptions(
        steering="controls", seed=1, goal_position_tolerance=0.5, goal_angle_tolerance=0.3
    )
    res = kinodynamic_rrt(MODEL, world, start, goal, options=opts)
    assert res.success
    q = integrate_car(start, res.controls, MODEL.wheelbase)
    assert np.linalg.norm(q[:2] - goal[:2]) <= 0.5 + 1e-6


def test_time_limit_and_errors():
    world, start, goal = parking_lot(lane_width=8.4)
    res = kinodynamic_rrt(
        MODEL,
        world,
        start,
        goal,
        options=KinodynamicRRTOptions(steering="dubins", time_limit_s=0.0),
    )
    assert res.status is RRTStatus.TIME_LIMIT and not res.success
    with pytest.raises(PlanningError, match=r"goal pose \(12, 1, -1.5708\) is in collision"):
        kinodynamic_rrt(MODEL, world, start, (12, 1, -np.pi / 2))
    with pytest.raises(PlanningError, match="outside the world bounds"):
        kinodynamic_rrt(MODEL, world, (50, 5, 0), goal)
    with pytest.raises(PlanningError, match=r"needs world\.bounds"):
        kinodynamic_rrt(MODEL, PolygonWorld(()), start, goal)
    with pytest.raises(
        UnknownNameError, match="valid steerings are: controls, dubins, reeds_shepp"
    ):
        kinodynamic_rrt(MODEL, world, start, goal, options=KinodynamicRRTOptions(steering="rrt"))
    with pytest.raises(InvalidInputError, match="goal_bias must be in"):
        kinodynamic_rrt(MODEL, world, start, goal, options=KinodynamicRRTOptions(goal_bias=2.0))
