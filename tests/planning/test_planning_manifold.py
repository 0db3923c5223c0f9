"""Planning with any joint type: continuous joints, planar and floating bases (on the manifold).

References: Pinocchio's ``difference`` and ``interpolate`` for the metric and the local path,
the uniform distribution on SO(3) for rotation samples (``P(angle < pi/2) = (pi/2 - 1)/pi``),
and Pinocchio's ``computeCollisions`` on fresh data, every 1 cm / 10 mrad along
``pinocchio.interpolate``, for the collision-freeness of planned paths.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, PlanningError
from taskspace.model import Obstacle, Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import CollisionCheckerOptions, FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.objectives import PathLength
from taskspace.planning.prm import PRMOptions, build_prm
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star


def _model(base: object, n_t: int) -> tuple[pin.Model, JointManifold]:
    model = pin.Model()
    j = model.addJoint(0, base, pin.SE3.Identity(), "base")
    j = model.addJoint(j, pin.JointModelRUBZ(), pin.SE3.Random(), "wheel")
    j = model.addJoint(j, pin.JointModelSpherical(), pin.SE3.Random(), "ball")
    j = model.addJoint(j, pin.JointModelRX(), pin.SE3.Random(), "elbow")
    model.lowerPositionLimit[:] = -1.0
    model.upperPositionLimit[:] = 1.0
    return model, JointManifold(model, base_lower=-np.ones(n_t), base_upper=np.ones(n_t))


@pytest.mark.parametrize(
    ("base", "n_t"), [(pin.JointModelFreeFlyer(), 3), (pin.JointModelPlanar(), 2)]
)
def test_difference_and_interpolation_are_pinocchios(base: object, n_t: int) -> None:
    model, manifold = _model(base, n_t)
    rng = np.random.default_rng(0)
    q0, q1 = manifold.sample(rng, 300), manifold.sample(rng, 300)
    q1[:10] = q0[:10]  # zero motion
    reference = np.array([pin.difference(model, a, b) for a, b in zip(q0, q1)])
    np.testing.assert_allclose(manifold.difference(q0, q1), reference, atol=1e-9)
    d = manifold.distances(q0, q1)
    np.testing.assert_allclose(d, np.linalg.norm(reference, axis=1), atol=1e-9)
    np.testing.assert_allclose(d, manifold.distances(q1, q0), atol=1e-9)  # symmetric
    t = np.array([0.0, 0.25, 0.5, 1.0])
    for a, b in zip(q0[10:20], q1[10:20]):
        points = manifold.interpolate(a, b, t)
        expected = np.array([pin.interpolate(model, a, b, tk) for tk in t])
        np.testing.assert_allclose(points, expected, atol=1e-12)
        # A geodesic: the point at t is t d(a, b) from a.
        np.testing.assert_allclose(
            manifold.distances(a, points), t * manifold.distances(a, b), atol=1e-8
        )


def test_rotation_samples_are_uniform_on_so3() -> None:
    _, manifold = _model(pin.JointModelFreeFlyer(), 3)
    q = manifold.sample(np.random.default_rng(1), 20_000)
    quat = q[:, 3:7]
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
    angle = 2 * np.arccos(np.clip(np.abs(quat[:, 3]), 0, 1))
    assert np.mean(angle < math.pi / 2) == pytest.approx((math.pi / 2 - 1) / math.pi, abs=0.01)
    assert np.all((q[:, :3] >= -1) & (q[:, :3] <= 1))


def _wheel_space(blocked: float | None) -> ConfigurationSpace:
    """One continuous joint; ``blocked``: angles within it of pi are in collision."""
    model = pin.Model()
    model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    manifold = JointManifold(model)

    def free(q: np.ndarray) -> np.ndarray:
        angle = np.arctan2(q[:, 1], q[:, 0])
        return np.ones(len(q), bool) if blocked is None else np.abs(angle) < math.pi - blocked

    return ConfigurationSpace(
        manifold.lower, manifold.upper, FunctionChecker(free), manifold=manifold
    )


def _angles(path: np.ndarray) -> np.ndarray:
    return np.unwrap(np.arctan2(path[:, 1], path[:, 0]))


@pytest.mark.parametrize(
    "planner", ["rrt_connect", "rrt_star", "prm_star", "lazy_prm_star", "bit_star"]
)
def test_continuous_joint_turns_the_short_way_unless_blocked(planner: str) -> None:
    a, b = 2.8, -2.8  # 0.683 rad apart through pi, 5.6 rad through 0
    start, goal = np.array([math.cos(a), math.sin(a)]), np.array([math.cos(b), math.sin(b)])

    def plan(space: ConfigurationSpace) -> np.ndarray:
        if planner == "rrt_connect":
            res = rrt_connect(space, start, goal, RRTConnectOptions(step_size=0.5, seed=0))
        elif planner == "rrt_star":
            opts = RRTStarOptions(max_iterations=300, time_limit_s=None)
            res = rrt_star(space, start, goal, opts)
        elif planner == "bit_star":
            res = bit_star(
                space, start, goal, BITStarOptions(max_iterations=200, time_limit_s=None)
            )
        else:
            fn = prm_star if planner == "prm_star" else lazy_prm_star
            res = fn(space, start, goal, PRMStarOptions(max_iterations=200, time_limit_s=None))[0]
        assert res.success and space.path_valid(res.path)
        return space.interpolate_path(res.path, 0.01)

    short = _angles(plan(_wheel_space(None)))
    assert abs(short[-1] - short[0]) == pytest.approx(2 * math.pi - 5.6, abs=1e-9)
    assert np.all(np.abs(np.arctan2(np.sin(short), np.cos(short))) > 2.79)  # never near 0
    long = _angles(plan(_wheel_space(0.2)))
    assert abs(long[-1] - long[0]) == pytest.approx(5.6, abs=1e-9)


def _dense_free(robot: Robot, space: ConfigurationSpace, path: np.ndarray) -> bool:
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(space.distance(a, b) / 0.01))
        for t in np.arange(n + 1) / n:
            q = pin.interpolate(robot.model, a, b, t)
            if pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, True):
                return False
    return True


def _reduced(robot: Robot, keep: set[str], name: str, root: object = None) -> Robot:
    model, geom = robot.model, robot.collision_model
    lock = [j for j in range(1, model.njoints) if model.names[j] not in keep]
    reduced, rgeom = pin.buildReducedModel(model, geom, lock, robot.q_default)
    q_ref = pin.neutral(reduced)
    if root is not None:  # a planar base under the whole model
        base = pin.Model()
        jid = base.addJoint(0, root, pin.SE3.Identity(), "base_planar")
        fid = base.addFrame(
            pin.Frame("base_body", jid, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME)
        )
        reduced, rgeom = pin.appendModel(
            base, reduced, pin.GeometryModel(), rgeom, fid, pin.SE3.Identity()
        )
        q_ref = pin.neutral(reduced)
    return Robot(reduced, rgeom, pin.GeometryModel(), name=name, default_configuration=q_ref)


@pytest.fixture(scope="module")
def talos_floating() -> Robot:
    talos = Robot.load("talos", convex_collision=True)
    return _reduced(talos, {"root_joint", "torso_1_joint", "torso_2_joint"}, "talos_floating")


@pytest.fixture(scope="module")
def tiago_mobile() -> Robot:
    tiago = Robot.load("tiago", convex_collision=True)
    keep = {"wheel_left_joint", "wheel_right_joint", "torso_lift_joint"}
    return _reduced(tiago, keep, "tiago_mobile", root=pin.JointModelPlanar())


@pytest.mark.parametrize("native", [True, False])
def test_checker_on_a_floating_robot_agrees_with_pinocchio(
    talos_floating: Robot, native: bool
) -> None:
    robot = talos_floating
    space = ConfigurationSpace.from_robot(
        robot, base_lower=[-1, -1, 0.5], base_upper=[1, 1, 1.5],
        checker_options=CollisionCheckerOptions(native=native),
    )  # fmt: skip
    robot.add_obstacle(Obstacle.box("post", [0.3, 0.3, 3.0], [0.0, 0.0, 1.5]))
    try:
        q = space.sample_uniform(np.random.default_rng(0), 200)
        data, gdata = robot.model.createData(), robot.collision_model.createData()
        ref = [
            not pin.computeCollisions(robot.model, data, robot.collision_model, gdata, x, True)
            for x in q
        ]
        np.testing.assert_array_equal(space.checker.are_valid(q), ref)
        assert 0 < sum(ref) < len(ref)
    finally:
        robot.remove_obstacle("post")


def test_floating_humanoid_walks_around_a_wall(talos_floating: Robot) -> None:
    robot = talos_floating
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 3.0], [0.0, 0.0, 1.5]))
    try:
        space = ConfigurationSpace.from_robot(
            robot,
            base_lower=[-1.5, -1.5, 0.9],
            base_upper=[1.5, 1.5, 1.2],
            weights=[1, 1, 1, 0.3, 0.3, 0.3, 1, 1],
        )
        start, goal = robot.q_default.copy(), robot.q_default.copy()
        start[:3], goal[:3] = [-0.8, 0.0, 1.0], [0.8, 0.0, 1.0]
        assert not space.motion_valid(start, goal)  # the wall is in the way
        res = rrt_connect(space, start, goal, RRTConnectOptions(time_limit_s=20.0, seed=0))
        assert res.success
        assert max(space.manifold.unit_error(q) for q in res.path) < 1e-9
        assert space.path_valid(res.path) and _dense_free(robot, space, res.path)
    finally:
        robot.remove_obstacle("wall")


def test_mobile_manipulator_base_goes_around_an_obstacle(tiago_mobile: Robot) -> None:
    robot = tiago_mobile
    robot.add_obstacle(Obstacle.box("wall", [0.3, 1.6, 1.0], [0.0, 0.0, 0.5]))
    try:
        space = ConfigurationSpace.from_robot(robot, base_lower=[-3, -3], base_upper=[3, 3])
        kinds = sorted(b.kind for b in space.manifold.blocks)
        assert kinds == ["circle", "circle", "planar", "vector"]
        start, goal = robot.q_default.copy(), robot.q_default.copy()
        start[:4], goal[:4] = [-1.5, 0.0, 1.0, 0.0], [1.5, 0.0, 0.0, 1.0]  # and turn 90 deg
        res = rrt_connect(space, start, goal, RRTConnectOptions(time_limit_s=20.0, seed=0))
        assert res.success
        assert space.path_valid(res.path) and _dense_free(robot, space, res.path)
        dense = space.interpolate_path(res.path, 0.05)
        assert np.abs(dense[:, 1]).max() > 0.8  # the base went around the 1.6 m wall
    finally:
        robot.remove_obstacle("wall")


def test_what_the_manifold_space_refuses(tiago_mobile: Robot) -> None:
    with pytest.raises(InvalidInputError, match="base_lower/base_upper"):
        ConfigurationSpace.from_robot(tiago_mobile)
    space = ConfigurationSpace.from_robot(tiago_mobile, base_lower=[-3, -3], base_upper=[3, 3])
    q = tiago_mobile.q_default.copy()
    with pytest.raises(InvalidInputError, match="joint manifold"):
        build_prm(space, PRMOptions(sampler="gaussian"))  # uniform sampling only
    with pytest.raises(InvalidInputError, match="joint-manifold space"):  # weights: nv
        bit_star(space, q, q, objective=PathLength(np.ones(q.size)))
    bad = q.copy()
    bad[2:4] = [0.5, 0.5]  # cos, sin of the base angle not of unit norm
    with pytest.raises(PlanningError, match="unit norm"):
        rrt_connect(space, bad, q)
