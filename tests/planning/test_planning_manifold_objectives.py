"""Optimization objectives on joint-manifold spaces (planar base, continuous wheels, floating
base): path length in a weighted metric, clearance, mechanical work and their weighted sum,
with RRT*, PRM* and BIT*.

References, computed in the test from Pinocchio alone (not from taskspace's manifold):
``pinocchio.difference`` / ``pinocchio.interpolate`` for lengths and the geodesic's points;
for the work, the potential energy ``pinocchio.computePotentialEnergy`` (the work against
gravity of a small piece is the change of potential energy, ``tau_g = dU/dq``): the sum of
``|dU|`` over a fine subdivision of each edge.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.objectives import (
    Clearance,
    MechanicalWork,
    OptimizationObjective,
    PathLength,
    WeightedSum,
)
from taskspace.planning.prm_star import PRMStarOptions, prm_star
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star
from tests.planning.test_planning_manifold import _reduced

POST = np.array([0.0, 0.4])  # a post of radius 0.2 m (a cost only: nothing collides with it)


def _post_clearance(q: np.ndarray) -> np.ndarray:
    return np.asarray(np.linalg.norm(np.atleast_2d(q)[:, :2] - POST, axis=1) - 0.2)


@pytest.fixture(scope="module")
def tiago_mobile() -> Robot:
    tiago = Robot.load("tiago", convex_collision=True)
    keep = {"wheel_left_joint", "wheel_right_joint", "torso_lift_joint"}
    return _reduced(tiago, keep, "tiago_mobile_objectives", root=pin.JointModelPlanar())


@pytest.fixture(scope="module")
def talos_floating() -> Robot:
    talos = Robot.load("talos", convex_collision=True)
    keep = {"root_joint", "torso_1_joint", "torso_2_joint"}
    return _reduced(talos, keep, "talos_floating_objectives")


def _ref_length(model: pin.Model, path: np.ndarray, w: np.ndarray) -> float:
    return sum(
        float(np.linalg.norm(w * pin.difference(model, a, b))) for a, b in itertools.pairwise(path)
    )


def _ref_clearance(
    model: pin.Model, path: np.ndarray, w: np.ndarray, res: float, eps: float
) -> float:
    """The trapezoidal rule on ``pinocchio.interpolate`` points, ``ds`` in the metric ``w``."""
    total = 0.0
    for a, b in itertools.pairwise(path):
        length = float(np.linalg.norm(w * pin.difference(model, a, b)))
        n = max(1, math.ceil(length / res - 1e-12))
        pts = np.array([pin.interpolate(model, a, b, k / n) for k in range(n + 1)])
        f = 1.0 / (eps + np.maximum(_post_clearance(pts), 0.0))
        total += length / n * float(f[0] / 2 + f[1:-1].sum() + f[-1] / 2)
    return total


def _ref_work(model: pin.Model, path: np.ndarray, pieces: int) -> float:
    """``sum |U(q_{k+1}) - U(q_k)|`` over ``pieces`` pieces of each edge (potential energy)."""
    data = model.createData()
    total = 0.0
    for a, b in itertools.pairwise(path):
        u = [
            pin.computePotentialEnergy(model, data, pin.interpolate(model, a, b, k / pieces))
            for k in range(pieces + 1)
        ]
        total += float(np.abs(np.diff(u)).sum())
    return total


def _tiago_problem(robot: Robot) -> tuple[ConfigurationSpace, np.ndarray, np.ndarray]:
    space = ConfigurationSpace.from_robot(robot, base_lower=[-2, -2], base_upper=[2, 2])
    start, goal = robot.q_default.copy(), robot.q_default.copy()
    start[:4] = [-1.0, 0.3, 1.0, 0.0]
    goal[:4] = [1.0, 0.5, 0.0, 1.0]  # and turn the base 90 degrees
    lift = robot.model.joints[robot.model.getJointId("torso_lift_joint")].idx_q
    goal[lift] = start[lift] + 0.2  # the torso rises 20 cm (work against gravity)
    return space, start, goal


PLANNERS: dict[str, Callable[[ConfigurationSpace, Any, Any, Any], Any]] = {
    "rrt_star": lambda s, a, b, obj: rrt_star(
        s, a, b, RRTStarOptions(max_iterations=120, time_limit_s=None, seed=1), objective=obj
    ),
    "prm_star": lambda s, a, b, obj: prm_star(
        s,
        a,
        b,
        PRMStarOptions(max_iterations=24, batch_size=24, time_limit_s=None, seed=1),
        objective=obj,
    )[0],
    "bit_star": lambda s, a, b, obj: bit_star(
        s,
        a,
        b,
        BITStarOptions(max_iterations=100, batch_size=50, time_limit_s=None, seed=1),
        objective=obj,
    ),
}


@pytest.mark.parametrize("planner", list(PLANNERS))
def test_planners_report_the_objective_along_their_path(tiago_mobile: Robot, planner: str) -> None:
    robot = tiago_mobile
    model = robot.model
    space, start, goal = _tiago_problem(robot)
    nv = model.nv
    w = np.ones(nv)
    w[2] = 0.5  # the base angle counts half
    clearance = Clearance(_post_clearance, epsilon=0.05, resolution=0.1)
    work = MechanicalWork(robot, resolution=0.1)
    objectives: dict[str, tuple[OptimizationObjective, Callable[[np.ndarray], float]]] = {
        "length": (PathLength(w), lambda p: _ref_length(model, p, w)),
        "clearance": (
            clearance,
            lambda p: _ref_clearance(model, p, space.manifold.weights, 0.1, 0.05),
        ),
        "sum": (
            WeightedSum([(1.0, PathLength(w)), (0.2, clearance)]),
            lambda p: (
                _ref_length(model, p, w)
                + 0.2 * _ref_clearance(model, p, space.manifold.weights, 0.1, 0.05)
            ),
        ),
    }
    if planner == "rrt_star":
        objectives["work"] = (work, lambda p: _ref_work(model, p, 400))
    for name, (objective, reference) in objectives.items():
        res = PLANNERS[planner](space, start, goal, objective)
        assert res.success, name
        assert space.path_valid(res.path)
        assert max(space.manifold.unit_error(q) for q in res.path) < 1e-9
        ref = reference(res.path)
        if name == "work":  # the midpoint rule at 0.1 against the fine potential-energy sum
            assert res.cost == pytest.approx(ref, rel=0.02, abs=1e-3), name
        else:
            assert res.cost == pytest.approx(ref, rel=1e-7), name
        costs = res.log["costs"]
        assert all(a >= b for a, b in itertools.pairwise(costs))


def test_clearance_is_the_integral_along_the_geodesic(tiago_mobile: Robot) -> None:
    """A fine reference (resolution 1 mm) and the objective at 5 cm agree to 0.5 %."""
    robot = tiago_mobile
    space, start, goal = _tiago_problem(robot)
    obj = Clearance(_post_clearance, epsilon=0.05, resolution=0.05).on_manifold(space.manifold)
    path = np.stack([start, goal])
    fine = _ref_clearance(robot.model, path, space.manifold.weights, 0.001, 0.05)
    assert obj.path_cost(path) == pytest.approx(fine, rel=0.005)
    # the straight line in coordinates (cos, sin of the angle averaged) would differ: the
    # geodesic of the planar joint is a screw motion, whose base path bends
    mid = space.interpolate(start, goal, [0.5])[0]
    assert not np.allclose(mid[:2], (start[:2] + goal[:2]) / 2, atol=1e-3)
    lower = obj.cost_lower_bounds(start, goal)[0]
    assert 0.0 <= lower <= obj.motion_cost(start, goal)


def test_work_of_a_floating_humanoid_is_its_potential_energy_change(
    talos_floating: Robot,
) -> None:
    """Lifting the floating base by 0.3 m while turning it: work = m g dz (all pieces rise)."""
    robot = talos_floating
    model = robot.model
    a = robot.q_default.copy()
    b = a.copy()
    b[2] += 0.3
    yaw = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, 0.8))
    b[3:7] = yaw.coeffs()
    work = MechanicalWork(robot, resolution=0.02)
    cost = work.motion_cost(a, b)
    mass = sum(inertia.mass for inertia in model.inertias[1:])
    g = float(np.linalg.norm(model.gravity.linear))
    data = model.createData()
    du = pin.computePotentialEnergy(model, data, b) - pin.computePotentialEnergy(model, data, a)
    assert cost == pytest.approx(abs(du), rel=1e-3)
    assert abs(du) == pytest.approx(mass * g * 0.3, rel=0.05)  # (the torso joints stay put)
    assert cost == pytest.approx(_ref_work(model, np.stack([a, b]), 200), rel=1e-3)
    # symmetric, and non-negative when coming down again
    assert work.motion_cost(b, a) == pytest.approx(cost, rel=1e-9)


def test_what_cannot_be_evaluated_on_a_manifold_is_refused(tiago_mobile: Robot) -> None:
    space, start, goal = _tiago_problem(tiago_mobile)

    class Custom(OptimizationObjective):
        def motion_costs(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
            return np.asarray(np.linalg.norm(np.atleast_2d(q1) - np.atleast_2d(q0), axis=1))

    with pytest.raises(InvalidInputError, match="Custom is evaluated on straight lines"):
        rrt_star(space, start, goal, objective=Custom())
    with pytest.raises(InvalidInputError, match="velocity coordinates"):
        rrt_star(space, start, goal, objective=PathLength(np.ones(tiago_mobile.model.nq)))
    panda = Robot.load("panda")
    with pytest.raises(InvalidInputError, match="MechanicalWork: the space's manifold"):
        rrt_star(space, start, goal, objective=MechanicalWork(panda))
