"""Shortcutting and B-spline smoothing on joint manifolds (planar and floating bases).

References: the geodesic ``pinocchio.interpolate`` and the metric ``|W pinocchio.difference|``
(a zigzag in free space shortcuts to the single geodesic, of length ``d(start, goal)``), and
Pinocchio's ``computeCollisions`` on fresh data every 1 cm / 10 mrad along the returned
paths.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import PlanningError
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.shortcut import ShortcutOptions, shortcut_path
from taskspace.planning.smoothing import SmoothingOptions, smooth_bspline


def _reduced(robot: Robot, keep: set[str], name: str, root: object = None) -> Robot:
    model, geom = robot.model, robot.collision_model
    lock = [j for j in range(1, model.njoints) if model.names[j] not in keep]
    reduced, rgeom = pin.buildReducedModel(model, geom, lock, robot.q_default)
    if root is not None:  # a planar base under the whole model
        base = pin.Model()
        jid = base.addJoint(0, root, pin.SE3.Identity(), "base_planar")
        fid = base.addFrame(
            pin.Frame("base_body", jid, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME)
        )
        reduced, rgeom = pin.appendModel(
            base, reduced, pin.GeometryModel(), rgeom, fid, pin.SE3.Identity()
        )
    return Robot(
        reduced, rgeom, pin.GeometryModel(), name=name, default_configuration=pin.neutral(reduced)
    )


def _dense_free(robot: Robot, space: ConfigurationSpace, path: np.ndarray) -> bool:
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(space.distance(a, b) / 0.01))
        for t in np.arange(n + 1) / n:
            q = pin.interpolate(robot.model, a, b, t)
            if pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, True):
                return False
    return True


def _free_space(base: object, n_t: int) -> ConfigurationSpace:
    model = pin.Model()
    j = model.addJoint(0, base, pin.SE3.Identity(), "base")
    model.addJoint(j, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    manifold = JointManifold(
        model,
        base_lower=-np.ones(n_t),
        base_upper=np.ones(n_t),
        weights=np.linspace(1, 2, model.nv),
    )

    def free(q: np.ndarray) -> np.ndarray:
        return np.ones(np.atleast_2d(q).shape[0], dtype=bool)

    return ConfigurationSpace(
        manifold.lower, manifold.upper, FunctionChecker(free), manifold=manifold
    )


@pytest.mark.parametrize(
    ("base", "n_t"), [(pin.JointModelFreeFlyer(), 3), (pin.JointModelPlanar(), 2)]
)
def test_zigzag_in_free_space_shortcuts_to_the_geodesic(base: object, n_t: int) -> None:
    space = _free_space(base, n_t)
    path = space.sample_uniform(np.random.default_rng(4), 6)
    res = shortcut_path(space, path)
    np.testing.assert_allclose(res.path, path[[0, -1]])
    assert res.length_before == pytest.approx(
        sum(space.distance(a, b) for a, b in itertools.pairwise(path))
    )
    assert res.length_after == pytest.approx(space.distance(path[0], path[-1]), rel=1e-12)
    # Random shortcuts alone (no greedy pass) cut corners on the geodesics: shorter, and the
    # cut points lie on the input's geodesics (unit norm, on the old segments).
    rnd = shortcut_path(space, path, ShortcutOptions(greedy=False, max_iterations=50))
    assert rnd.accepted > 0 and rnd.length_after < rnd.length_before
    assert max(space.manifold.unit_error(q) for q in rnd.path) < 1e-9
    assert rnd.length_after == pytest.approx(space.path_length(rnd.path))
    smooth = smooth_bspline(space, path, SmoothingOptions(max_step=0.3))
    assert smooth.moved > 0 and smooth.length_after < smooth.length_before
    assert max(space.manifold.unit_error(q) for q in smooth.path) < 1e-9
    np.testing.assert_allclose(smooth.path[[0, -1]], path[[0, -1]])


def test_smoothing_cuts_corners_in_the_tangent_space() -> None:
    space = _free_space(pin.JointModelPlanar(), 2)
    a, b, c = space.sample_uniform(np.random.default_rng(1), 3)
    res = smooth_bspline(
        space, np.array([a, b, c]), SmoothingOptions(max_step=10.0, max_iterations=1)
    )
    # One pass, no subdivision: the middle point moves to b (+) ((a (-) b) + (c (-) b)) / 4.
    model = space.manifold.model
    expected = pin.integrate(
        model, b, 0.25 * (pin.difference(model, b, a) + pin.difference(model, b, c))
    )
    np.testing.assert_allclose(res.path[1], expected, atol=1e-12)


@pytest.fixture(scope="module")
def tiago_mobile() -> Robot:
    with pytest.warns(Warning):  # tiago's hand pairs in contact at the default posture
        tiago = Robot.load("tiago", convex_collision=True)
    keep = {"wheel_left_joint", "wheel_right_joint", "torso_lift_joint"}
    return _reduced(tiago, keep, "tiago_mobile", root=pin.JointModelPlanar())


@pytest.fixture(scope="module")
def talos_floating() -> Robot:
    talos = Robot.load("talos", convex_collision=True)
    return _reduced(talos, {"root_joint", "torso_1_joint", "torso_2_joint"}, "talos_floating")


def test_tiago_path_shortcut_and_smoothed_stays_free(tiago_mobile: Robot) -> None:
    robot = tiago_mobile
    robot.add_obstacle(Obstacle.box("wall", [0.3, 1.6, 1.0], [0.0, 0.0, 0.5]))
    try:
        space = ConfigurationSpace.from_robot(
            robot,
            base_lower=[-3, -3],
            base_upper=[3, 3],
            edge=EdgeCheckOptions(resolution=0.01),  # as fine as the dense check
        )
        start, goal = robot.q_default.copy(), robot.q_default.copy()
        start[:4], goal[:4] = [-1.5, 0.0, 1.0, 0.0], [1.5, 0.0, 0.0, 1.0]
        res = rrt_connect(space, start, goal, RRTConnectOptions(time_limit_s=20.0, seed=0))
        assert res.success
        # every shortcut attempt runs (no clock: the same path on a loaded machine)
        short = shortcut_path(space, res.path, ShortcutOptions(time_limit_s=None))
        assert short.length_after <= short.length_before + 1e-12
        assert short.length_before == pytest.approx(space.path_length(res.path))
        smooth = smooth_bspline(
            space, short.path, SmoothingOptions(max_step=0.3, time_limit_s=None)
        )
        assert smooth.length_after <= short.length_after + 1e-12
        for path in (short.path, smooth.path):
            np.testing.assert_allclose(path[[0, -1]], [start, goal], atol=1e-12)
            assert max(space.manifold.unit_error(q) for q in path) < 1e-9
            assert space.path_valid(path) and _dense_free(robot, space, path)
    finally:
        robot.remove_obstacle("wall")


def test_floating_robot_path_shortcut_and_smoothed_stays_free(talos_floating: Robot) -> None:
    robot = talos_floating
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 3.0], [0.0, 0.0, 1.5]))
    try:
        space = ConfigurationSpace.from_robot(
            robot,
            base_lower=[-2.0, -2.0, 0.9],
            base_upper=[2.0, 2.0, 1.2],
            weights=[1, 1, 1, 0.3, 0.3, 0.3, 1, 1],
            edge=EdgeCheckOptions(resolution=0.01),  # as fine as the dense check
        )
        # A detour around the wall, turning and bending the torso on the way (rrt_connect's
        # paths leave the base's translation box along their screw motions).
        waypoints = []
        for xyz, yaw, torso in (
            ([-1.2, 0.0, 1.0], 0.0, 0.0),
            ([-1.2, 1.0, 1.1], 0.5, 0.3),
            ([-1.0, 1.8, 1.0], 0.0, -0.2),
            ([0.0, 1.9, 1.1], 0.4, 0.3),
            ([1.0, 1.8, 1.0], -0.3, 0.0),
            ([1.2, 1.0, 0.95], 0.2, 0.2),
            ([1.2, 0.0, 1.0], 0.0, 0.0),
        ):
            q = robot.q_default.copy()
            q[:3] = xyz
            q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, yaw)).coeffs()
            q[7] = torso
            waypoints.append(q)
        path = np.array(waypoints)
        assert space.path_valid(path)
        start, goal = path[0], path[-1]
        short = shortcut_path(space, path)
        smooth = smooth_bspline(space, short.path, SmoothingOptions(max_step=0.3))
        assert short.length_after <= short.length_before + 1e-12
        assert smooth.length_after <= short.length_after + 1e-12
        assert short.length_after < 0.9 * short.length_before  # the detour was cut
        for out in (short.path, smooth.path):
            np.testing.assert_allclose(out[[0, -1]], [start, goal], atol=1e-12)
            assert max(space.manifold.unit_error(q) for q in out) < 1e-9
            assert space.path_valid(out) and _dense_free(robot, space, out)
        through = np.array([start, goal])
        with pytest.raises(PlanningError, match="in collision"):
            shortcut_path(space, through)
        with pytest.raises(PlanningError, match="in collision"):
            smooth_bspline(space, through)
    finally:
        robot.remove_obstacle("wall")


def test_unnormalized_waypoint_is_refused() -> None:
    space = _free_space(pin.JointModelPlanar(), 2)
    path = space.sample_uniform(np.random.default_rng(0), 3)
    path[1, 2:4] = [0.5, 0.5]
    with pytest.raises(PlanningError, match="unit norm"):
        shortcut_path(space, path)


def test_planned_floating_path_leaving_the_sampling_box_is_shortened(
    talos_floating: Robot,
) -> None:
    robot = talos_floating
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 3.0], [0.0, 0.0, 1.5]))
    try:
        space = ConfigurationSpace.from_robot(
            robot,
            base_lower=[-1.5, -1.5, 0.9],
            base_upper=[1.5, 1.5, 1.2],
            weights=[1, 1, 1, 0.3, 0.3, 0.3, 1, 1],
            edge=EdgeCheckOptions(resolution=0.01),
        )
        start, goal = robot.q_default.copy(), robot.q_default.copy()
        start[:3], goal[:3] = [-0.8, 0.0, 1.0], [0.8, 0.0, 1.0]
        res = rrt_connect(space, start, goal, RRTConnectOptions(time_limit_s=20.0, seed=0))
        assert res.success
        # The screw motions of the tree leave the translation box the samples came from.
        assert np.any(res.path[:, 2] > 1.2 + 1e-6) or np.any(res.path[:, 2] < 0.9 - 1e-6)
        short = shortcut_path(space, res.path)
        smooth = smooth_bspline(space, short.path, SmoothingOptions(max_step=0.3))
        assert smooth.length_after <= short.length_after <= short.length_before + 1e-12
        assert space.path_valid(smooth.path) and _dense_free(robot, space, smooth.path)
        bad = res.path.copy()
        bad[1, 7] = robot.model.upperPositionLimit[7] + 0.1  # a torso joint past its limit
        with pytest.raises(PlanningError, match="waypoint 1 is outside the bounds"):
            shortcut_path(space, bad)
    finally:
        robot.remove_obstacle("wall")
