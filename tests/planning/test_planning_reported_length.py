"""Every planner reports ``path_length`` in the space's metric (issue #22 audit, stop 23).

``rrt_connect`` (Python path), ``rrt_star``, ``bit_star`` and ``prm_star`` reported the
Euclidean length of the raw coordinates on a joint-manifold space (solo12: 1.094 instead of
4.266, the quaternion's components counted as coordinates). Reference, computed here: the sum
along the returned path of ``|w * pinocchio.difference(model, q_i, q_{i+1})|`` on the robot's
own model, with the space's weights ``w`` (ones on the Euclidean panda). Both spaces, every
planner (the compiled RRT-Connect on the Euclidean one, where it runs).
"""

from __future__ import annotations

import dataclasses
import itertools
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.lazy_prm import lazy_prm
from taskspace.planning.planner_result import PlannerResult
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

Problem = tuple[Robot, ConfigurationSpace, np.ndarray, np.ndarray, np.ndarray]
_T = 5.0  # time limits: generous, the problems are solved in a fraction of it


def _first(out: Any) -> PlannerResult:
    return out[0] if isinstance(out, tuple) else out


def _prm_query(s: ConfigurationSpace, a: np.ndarray, b: np.ndarray) -> PlannerResult:
    opts = PRMOptions(max_iterations=60, seed=1)
    return prm_query(s, build_prm(s, opts), a, b, opts)


PLANNERS: dict[str, Callable[[ConfigurationSpace, np.ndarray, np.ndarray], Any]] = {
    "rrt": lambda s, a, b: rrt(s, a, b, RRTOptions(time_limit_s=_T, seed=1)),
    "rrt_connect_python": lambda s, a, b: rrt_connect(
        s, a, b, RRTConnectOptions(time_limit_s=_T, seed=1, native=False)
    ),
    "rrt_connect": lambda s, a, b: rrt_connect(s, a, b, RRTConnectOptions(time_limit_s=_T, seed=1)),
    "rrt_star": lambda s, a, b: rrt_star(
        s, a, b, RRTStarOptions(max_iterations=60, time_limit_s=_T, seed=1, informed=False)
    ),
    "informed_rrt_star": lambda s, a, b: rrt_star(
        s, a, b, RRTStarOptions(max_iterations=60, time_limit_s=_T, seed=1, informed=True)
    ),
    "bit_star": lambda s, a, b: bit_star(
        s, a, b, BITStarOptions(max_iterations=60, time_limit_s=_T, seed=1)
    ),
    "prm_star": lambda s, a, b: prm_star(
        s, a, b, PRMStarOptions(max_iterations=60, time_limit_s=_T, seed=1)
    ),
    "lazy_prm_star": lambda s, a, b: lazy_prm_star(
        s, a, b, PRMStarOptions(max_iterations=60, time_limit_s=_T, seed=1)
    ),
    "prm": lambda s, a, b: prm(s, a, b, PRMOptions(max_iterations=60, seed=1)),
    "prm_query": _prm_query,
    "lazy_prm": lambda s, a, b: lazy_prm(
        s, a, b, PRMOptions(max_iterations=200, time_limit_s=_T, seed=1)
    ),
}


@pytest.fixture(scope="module")
def solo() -> Problem:
    """solo12 on a free flyer, base translation weighted 4: start and goal turned apart."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("solo12")
    w = np.ones(robot.model.nv)
    w[:3] = 4.0
    space = ConfigurationSpace.from_robot(
        robot, weights=w, base_lower=[-1, -1, 0.2], base_upper=[1, 1, 0.6]
    )
    start = robot.q_default.copy()
    goal = start.copy()
    start[:3] = [-0.5, 0.0, 0.4]
    goal[:3] = [0.5, 0.2, 0.4]
    goal[3:7] = [0.0, 0.0, np.sin(0.4), np.cos(0.4)]
    assert not space.is_euclidean
    return robot, space, start, goal, w


@pytest.fixture(scope="module")
def panda() -> Problem:
    """Panda turning its base joint through a block at its hand (Euclidean, no weights)."""
    robot = Robot.load("panda", convex_collision=True)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_default)
    hand = data.oMf[robot.model.getFrameId("panda_hand_tcp")].translation
    robot.add_obstacle(Obstacle.box("block", [0.12, 0.12, 0.12], hand.copy()))
    space = ConfigurationSpace.from_robot(robot)
    start, goal = robot.q_default.copy(), robot.q_default.copy()
    start[0], goal[0] = -1.2, 1.2
    assert space.is_euclidean and not space.motion_valid(start, goal)
    return robot, space, start, goal, np.ones(robot.model.nv)


def _reference(model: pin.Model, w: np.ndarray, path: np.ndarray) -> float:
    return sum(
        float(np.linalg.norm(w * pin.difference(model, a, b))) for a, b in itertools.pairwise(path)
    )


@pytest.mark.parametrize("space_name", ["solo12", "panda"])
@pytest.mark.parametrize("name", list(PLANNERS))
def test_reported_length_is_the_weighted_pinocchio_length(
    name: str, space_name: str, request: pytest.FixtureRequest
) -> None:
    robot, space, start, goal, w = request.getfixturevalue(
        "solo" if space_name == "solo12" else "panda"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        result = _first(PLANNERS[name](space, start, goal))
    assert result.success, (name, result.status)
    native = bool(result.log.get("native"))
    assert native == (name == "rrt_connect" and space_name == "panda")  # it ran where it runs
    reference = _reference(robot.model, w, result.path)
    assert result.path_length == pytest.approx(reference, rel=1e-9)
    assert space.path_length(result.path) == pytest.approx(reference, rel=1e-9)
    if space_name == "solo12":  # the raw coordinates' length is far from it (the old answer)
        raw = float(np.linalg.norm(np.diff(result.path, axis=0), axis=1).sum())
        assert abs(raw - reference) > 0.1 * reference
    if result.cost is not None and result.log.get("costs"):
        assert result.log["costs"][-1] == pytest.approx(result.cost)


def test_reported_length_of_a_replaced_option_set(solo: Problem) -> None:
    """RRT* growing its first path itself (not by RRT-Connect) reports it the same way."""
    robot, space, start, goal, w = solo
    opts = RRTStarOptions(max_iterations=300, time_limit_s=_T, seed=2)
    result = rrt_star(space, start, goal, dataclasses.replace(opts, first_solution="rrt_star"))
    assert result.success
    assert result.path_length == pytest.approx(_reference(robot.model, w, result.path), rel=1e-9)
