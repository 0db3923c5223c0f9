"""RRT on joint manifolds: a continuous joint and a mobile manipulator's planar base.

References: the circle's geometry (a wheel blocked around 0 can only turn through pi), and
Pinocchio's ``computeCollisions`` on fresh data every 1 cm along ``pinocchio.interpolate``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.rrt import RRTOptions, rrt


def _wheel_space() -> ConfigurationSpace:
    """One continuous joint, in collision within 0.5 rad of angle 0."""
    model = pin.Model()
    model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    manifold = JointManifold(model)

    def free(q: np.ndarray) -> np.ndarray:
        return np.abs(np.arctan2(q[:, 1], q[:, 0])) > 0.5

    return ConfigurationSpace(
        manifold.lower, manifold.upper, FunctionChecker(free), manifold=manifold
    )


def test_rrt_turns_a_blocked_wheel_through_pi() -> None:
    space = _wheel_space()
    start = np.array([math.cos(1.0), math.sin(1.0)])
    goal = np.array([math.cos(-1.0), math.sin(-1.0)])
    res = rrt(space, start, goal, RRTOptions(step_size=0.3, seed=0))
    assert res.success
    dense = space.interpolate_path(res.path, 0.01)
    angles = np.arctan2(dense[:, 1], dense[:, 0])
    assert np.all(np.abs(angles) > 0.5)  # never through the blocked arc
    np.testing.assert_allclose(np.linalg.norm(dense, axis=1), 1.0, atol=1e-12)
    steps = space.distances(res.path[:-1], res.path[1:])
    assert np.all(steps <= 0.3 + 1e-12)  # steps of at most alpha in the circle's metric
    assert res.path_length == pytest.approx(steps.sum())
    assert res.path_length >= 2 * math.pi - 2.0 - 1e-9  # the long way, through pi


def test_rrt_moves_a_mobile_base_around_a_wall() -> None:
    with pytest.warns(Warning):  # tiago's hand pairs in contact at the default posture
        tiago = Robot.load("tiago", convex_collision=True)
    model, geom = tiago.model, tiago.collision_model
    keep = {"wheel_left_joint", "wheel_right_joint", "torso_lift_joint"}
    lock = [j for j in range(1, model.njoints) if model.names[j] not in keep]
    reduced, rgeom = pin.buildReducedModel(model, geom, lock, tiago.q_default)
    base = pin.Model()
    jid = base.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "base_planar")
    fid = base.addFrame(pin.Frame("base_body", jid, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    full, fgeom = pin.appendModel(
        base, reduced, pin.GeometryModel(), rgeom, fid, pin.SE3.Identity()
    )
    robot = Robot(full, fgeom, pin.GeometryModel(), name="tiago_mobile",
                  default_configuration=pin.neutral(full))  # fmt: skip
    robot.add_obstacle(Obstacle.box("wall", [0.3, 1.6, 1.0], [0.0, 0.0, 0.5]))
    space = ConfigurationSpace.from_robot(robot, base_lower=[-3, -3], base_upper=[3, 3])
    start, goal = robot.q_default.copy(), robot.q_default.copy()
    start[:4], goal[:4] = [-1.5, 0.0, 1.0, 0.0], [1.5, 0.0, 0.0, 1.0]
    res = rrt(space, start, goal, RRTOptions(step_size=0.5, goal_bias=0.1, seed=0))
    assert res.success
    assert max(space.manifold.unit_error(q) for q in res.path) < 1e-9
    assert space.path_valid(res.path)
    data, gdata = full.createData(), fgeom.createData()
    for a, b in itertools.pairwise(res.path):
        n = max(1, math.ceil(space.distance(a, b) / 0.01))
        for t in np.arange(n + 1) / n:
            q = pin.interpolate(full, a, b, t)
            assert not pin.computeCollisions(full, data, fgeom, gdata, q, True)


def test_prm_turns_a_blocked_wheel_through_pi_and_answers_queries() -> None:
    space = _wheel_space()
    start = np.array([math.cos(1.0), math.sin(1.0)])
    goal = np.array([math.cos(-1.0), math.sin(-1.0)])
    roadmap = build_prm(space, PRMOptions(max_iterations=60, k_neighbors=4, seed=0))
    assert all(space.is_valid(q) for q in roadmap.nodes)
    for i, neighbours in enumerate(roadmap.adjacency):
        for j, cost in neighbours:  # edge costs are the circle's metric
            assert cost == pytest.approx(space.distance(roadmap.nodes[i], roadmap.nodes[j]))
    for search in ("dijkstra", "astar"):
        res = prm_query(space, roadmap, start, goal, PRMOptions(k_neighbors=4, search=search))
        assert res.success
        dense = space.interpolate_path(res.path, 0.01)
        assert np.all(np.abs(np.arctan2(dense[:, 1], dense[:, 0])) > 0.5)
        assert res.path_length == pytest.approx(space.path_length(res.path))
        # Dense roadmap on the circle: nearly the long way's exact length 2 pi - 2.
        assert 2 * math.pi - 2.0 - 1e-9 <= res.path_length < 2 * math.pi - 2.0 + 0.05
    free = np.array([math.cos(2.0), math.sin(2.0)])
    short = prm(space, free, -free * np.array([1.0, -1.0]), PRMOptions(max_iterations=40, seed=1))[
        0
    ]
    # From 2 rad to pi - 2 rad: a free arc, joined directly the short way (4 - pi rad).
    assert short.path_length == pytest.approx(4.0 - math.pi, abs=1e-9)


def test_lazy_prm_turns_a_blocked_wheel_through_pi() -> None:
    space = _wheel_space()
    start = np.array([math.cos(1.0), math.sin(1.0)])
    goal = np.array([math.cos(-1.0), math.sin(-1.0)])
    opts = PRMOptions(batch_size=40, max_iterations=800, k_neighbors=4, sigma=0.3, seed=0)
    res, lazy = lazy_prm(space, start, goal, opts, time_limit_s=None)
    assert res.success
    np.testing.assert_allclose(
        lazy.costs, space.distances(lazy.roadmap.nodes[lazy.pairs[:, 0]],
                                    lazy.roadmap.nodes[lazy.pairs[:, 1]])
    )  # fmt: skip
    dense = space.interpolate_path(res.path, 0.01)
    assert np.all(np.abs(np.arctan2(dense[:, 1], dense[:, 0])) > 0.5)
    np.testing.assert_allclose(np.linalg.norm(lazy.roadmap.nodes, axis=1), 1.0, atol=1e-12)
    assert 2 * math.pi - 2.0 - 1e-9 <= res.path_length < 2 * math.pi - 2.0 + 0.1
    again = lazy_prm_query(space, lazy, start, goal, PRMOptions(k_neighbors=4))
    assert again.success and again.path_length == pytest.approx(res.path_length)
    assert build_lazy_prm(space, PRMOptions(max_iterations=10, seed=0)).roadmap.size == 10
