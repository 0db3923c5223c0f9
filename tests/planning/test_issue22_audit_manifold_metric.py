"""Issue #22 audit, item 3: the weighted metric of a floating-base / continuous-joint space.

``ConfigurationSpace.from_robot(robot, weights=w)`` must measure ``|w * (q1 (-) q0)|`` with
Pinocchio's ``difference`` (SE(3) for a free flyer, the circle for a continuous joint). The
manifold tests compared ``difference`` and ``interpolate`` with Pinocchio's but no test saw the
weights: dropping them from ``JointManifold.distances`` passed every manifold, objective and
audit test. Reference here: ``pinocchio.difference`` on the robot's own model times the
weights; the path length a planner reports should be the sum of those along its path —
every planner reports it (``rrt_connect`` (Python path), ``rrt_star``, ``bit_star`` and
``prm_star`` reported the Euclidean length of the raw coordinates until stop 23).
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.lazy_prm import lazy_prm
from taskspace.planning.prm import PRMOptions, prm
from taskspace.planning.prm_star import PRMStarOptions, prm_star
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star


@pytest.fixture(scope="module")
def solo() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("solo12")


def _reference(model: pin.Model, w: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(w * pin.difference(model, a, b)))


@pytest.mark.parametrize("name", ["solo12", "double_pendulum_continuous"])
def test_distances_are_the_weighted_pinocchio_difference(name: str, solo: Robot) -> None:
    if name == "solo12":
        robot = solo
        kw = {"base_lower": [-1, -1, 0.2], "base_upper": [1, 1, 0.6]}
    else:
        robot = Robot.load(name)
        kw = {}
    model = robot.model
    rng = np.random.default_rng(0)
    w = rng.uniform(0.2, 3.0, model.nv)
    space = ConfigurationSpace.from_robot(robot, weights=w, **kw)
    plain = ConfigurationSpace.from_robot(robot, **kw)
    Q = space.sample_uniform(rng, 40)
    for a, b in itertools.pairwise(Q):
        assert space.distance(a, b) == pytest.approx(_reference(model, w, a, b), rel=1e-10)
        assert plain.distance(a, b) == pytest.approx(
            _reference(model, np.ones(model.nv), a, b), rel=1e-10
        )
    batch = space.distances(Q[1:], Q[0])
    expected = [_reference(model, w, q, Q[0]) for q in Q[1:]]
    np.testing.assert_allclose(batch, expected, rtol=1e-10)
    assert space.path_length(Q[:5]) == pytest.approx(
        sum(_reference(model, w, a, b) for a, b in itertools.pairwise(Q[:5])), rel=1e-10
    )


def _plan(name: str, space: ConfigurationSpace, start: np.ndarray, goal: np.ndarray):  # type: ignore[no-untyped-def]
    if name == "rrt_connect":
        return rrt_connect(space, start, goal, RRTConnectOptions(time_limit_s=5.0, seed=0))
    if name == "rrt":
        return rrt(space, start, goal, RRTOptions(time_limit_s=5.0, seed=0))
    if name == "prm":
        return prm(space, start, goal, PRMOptions(max_iterations=50, seed=0))[0]
    if name == "lazy_prm":
        return lazy_prm(space, start, goal, PRMOptions(max_iterations=50, seed=0))[0]
    if name == "rrt_star":
        return rrt_star(space, start, goal, RRTStarOptions(max_iterations=50, seed=0))
    if name == "bit_star":
        return bit_star(space, start, goal, BITStarOptions(max_iterations=50, seed=0))
    return prm_star(space, start, goal, PRMStarOptions(max_iterations=50, seed=0))[0]


@pytest.mark.parametrize(
    "name", ["rrt", "prm", "lazy_prm", "rrt_connect", "rrt_star", "bit_star", "prm_star"]
)
def test_a_planned_floating_path_is_measured_in_the_weighted_metric(name: str, solo: Robot) -> None:
    model = solo.model
    w = np.ones(model.nv)
    w[:3] = 4.0  # base translation counts four times
    space = ConfigurationSpace.from_robot(
        solo, weights=w, base_lower=[-1, -1, 0.2], base_upper=[1, 1, 0.6]
    )
    start = solo.q_default.copy()
    goal = start.copy()
    start[:3] = [-0.5, 0.0, 0.4]
    goal[:3] = [0.5, 0.2, 0.4]
    goal[3:7] = [0.0, 0.0, np.sin(0.4), np.cos(0.4)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        result = _plan(name, space, start, goal)
    assert result.success
    length = sum(_reference(model, w, a, b) for a, b in itertools.pairwise(result.path))
    assert space.path_length(result.path) == pytest.approx(length, rel=1e-9)
    assert length >= _reference(model, w, start, goal) - 1e-9  # the geodesic is shortest
    assert result.path_length == pytest.approx(length, rel=1e-9)
