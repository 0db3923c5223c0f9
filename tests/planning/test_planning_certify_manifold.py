"""certify_path on floating and mobile robots (free-flyer, planar, continuous, prismatic).

References: Pinocchio/coal ``computeDistances`` every few millimetres of link motion along
``pinocchio.interpolate`` (the signed distance must stay positive on certified paths), and
the true motion of every collision-mesh vertex, measured by sampling the segment, against
the motion bound.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, StaleModelError
from taskspace.model import Obstacle, Robot
from taskspace.planning.certify import certify_path, motion_bound, motion_bounds
from taskspace.planning.joint_manifold import JointManifold


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


@pytest.fixture(scope="module")
def talos_floating() -> Robot:
    talos = Robot.load("talos", convex_collision=True)
    return _reduced(talos, {"root_joint", "torso_1_joint", "torso_2_joint"}, "talos_floating")


@pytest.fixture(scope="module")
def tiago_mobile() -> Robot:
    with pytest.warns(Warning):  # tiago's hand pairs in contact at the default posture
        tiago = Robot.load("tiago", convex_collision=True)
    keep = {"wheel_left_joint", "wheel_right_joint", "torso_lift_joint"}
    return _reduced(tiago, keep, "tiago_mobile", root=pin.JointModelPlanar())


def _vertices(robot: Robot) -> list[np.ndarray]:
    gm = robot.collision_model
    out = []
    for k in range(robot.robot_geometry_count):
        g = gm.geometryObjects[k].geometry
        out.append(np.array(g.points()) if hasattr(g, "points") else np.zeros((1, 3)))
    return out


def _true_motion(robot: Robot, q0: np.ndarray, q1: np.ndarray, vertices: list[np.ndarray]) -> float:
    """Largest distance travelled by a vertex (polyline over 64 steps: <= the arc length)."""
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    previous: list[np.ndarray] | None = None
    travelled = [np.zeros(len(v)) for v in vertices]
    for t in np.linspace(0.0, 1.0, 65):
        pin.updateGeometryPlacements(model, data, gm, gd, pin.interpolate(model, q0, q1, t))
        points = [v @ gd.oMg[k].rotation.T + gd.oMg[k].translation for k, v in enumerate(vertices)]
        if previous is not None:
            for k, (a, b) in enumerate(zip(previous, points)):
                travelled[k] += np.linalg.norm(b - a, axis=1)
        previous = points
    return max(float(t.max()) for t in travelled)


def _dense_min_distance(robot: Robot, path: np.ndarray, step: float = 0.005) -> float:
    """Least signed distance over all pairs, every ``step`` [m] of the fastest link point."""
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    bound = motion_bound(robot, path)
    least = math.inf
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(bound(pin.difference(model, a, b)) / step))
        for t in np.arange(n + 1) / n:
            pin.computeDistances(model, data, gm, gd, pin.interpolate(model, a, b, t))
            least = min(least, min(r.min_distance for r in gd.distanceResults))
    return least


@pytest.mark.parametrize("name", ["talos_floating", "tiago_mobile"])
def test_bound_is_never_below_the_true_motion_of_any_vertex(
    name: str, request: pytest.FixtureRequest
) -> None:
    robot: Robot = request.getfixturevalue(name)
    model = robot.model
    n_t = 3 if name == "talos_floating" else 2
    manifold = JointManifold(model, base_lower=-np.ones(n_t), base_upper=np.ones(n_t))
    rng = np.random.default_rng(3)
    vertices = _vertices(robot)
    q0, q1 = manifold.sample(rng, 8), manifold.sample(rng, 8)
    # Short motions too, where a loose sum over coordinates would hide nothing.
    q1[4:] = [pin.interpolate(model, a, b, 0.05) for a, b in zip(q0[4:], q1[4:])]
    bound = motion_bound(robot)
    per_coordinate = motion_bounds(robot)
    for a, b in zip(q0, q1):
        delta = pin.difference(model, a, b)
        moved = _true_motion(robot, a, b, vertices)
        assert moved <= bound(delta) + 1e-9
        assert bound(delta) <= per_coordinate @ np.abs(delta) + 1e-12
        assert moved > 0.2 * bound(delta)  # and not uselessly loose


def test_bound_reaches_through_a_prismatic_joint(tiago_mobile: Robot) -> None:
    # The base's rotation moves the head farther when the torso is lifted.
    low = motion_bound(tiago_mobile, np.zeros((1, tiago_mobile.nq)))
    high_path = np.zeros((1, tiago_mobile.nq))
    i = tiago_mobile.model.joints[tiago_mobile.model.getJointId("torso_lift_joint")].idx_q
    high_path[0, i] = 0.35
    high = motion_bound(tiago_mobile, high_path)
    turn = np.zeros(tiago_mobile.nv)
    turn[2] = 1.0
    assert high(turn) == pytest.approx(low(turn) + 0.35)


def test_floating_humanoid_path_around_a_wall_is_certified(talos_floating: Robot) -> None:
    robot = talos_floating
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 3.0], [0.0, 0.0, 1.5]))
    try:
        waypoints = []
        for xyz, yaw, torso in (
            ([-1.2, 0.0, 1.0], 0.0, 0.0),
            ([-1.2, 1.8, 1.05], 0.8, 0.3),
            ([1.2, 1.8, 1.0], 1.6, -0.3),
            ([1.2, 0.0, 0.95], 3.0, 0.0),
        ):
            q = robot.q_default.copy()
            q[:3] = xyz
            q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.1, 0.0, yaw)).coeffs()
            q[7] = torso
            waypoints.append(q)
        path = np.array(waypoints)
        cert = certify_path(robot, path)
        assert cert.certified and cert.failed_segment == -1
        dense = _dense_min_distance(robot, path)
        assert dense > 0.0
        assert cert.min_distance >= dense - 1e-9  # it never saw less than the dense check
        across = waypoints[0].copy()
        across[0] = 1.2
        through = np.array([waypoints[0], across])  # straight through the wall
        blocked = certify_path(robot, through)
        assert not blocked.certified and blocked.failed_segment == 0
        assert 0.0 < blocked.failed_t < 1.0
    finally:
        robot.remove_obstacle("wall")


@pytest.mark.slow  # ~1400 dense distance queries on 64 geometries (5-25 s under load)
def test_mobile_manipulator_path_is_certified(tiago_mobile: Robot) -> None:
    robot = tiago_mobile
    robot.add_obstacle(Obstacle.box("wall", [0.3, 1.6, 1.0], [0.0, 0.0, 0.5]))
    try:
        model = robot.model
        lift = model.joints[model.getJointId("torso_lift_joint")].idx_q
        wheel = model.joints[model.getJointId("wheel_left_joint")].idx_q
        waypoints = []
        for x, y, yaw, h, w in (
            (-1.5, 0.0, 0.0, 0.0, 0.0),
            (-1.2, 2.2, 0.5, 0.2, 2.5),
            (1.2, 2.2, 0.0, 0.3, -2.5),
            (1.5, 0.0, 0.5, 0.1, 3.0),
        ):
            q = robot.q_default.copy()
            q[:4] = [x, y, math.cos(yaw), math.sin(yaw)]
            q[lift] = h
            q[wheel : wheel + 2] = [math.cos(w), math.sin(w)]
            waypoints.append(q)
        path = np.array(waypoints)
        cert = certify_path(robot, path)
        assert cert.certified
        # Every 8 mm of the bound (the fastest vertex moves less between checks).
        assert _dense_min_distance(robot, path, step=0.008) > 0.0
        blocked = certify_path(robot, path[[0, 3]])
        assert not blocked.certified and blocked.failed_segment == 0
    finally:
        robot.remove_obstacle("wall")


def test_unnormalized_quaternion_is_refused(talos_floating: Robot) -> None:
    q = talos_floating.q_default.copy()
    q[3:7] = [0.5, 0.5, 0.5, 0.6]
    with pytest.raises(InvalidInputError, match="unit norm"):
        certify_path(talos_floating, np.array([q, talos_floating.q_default]))


@pytest.mark.slow  # a dense check of a planned path: 5-12 s
def test_rrt_connect_certifies_a_floating_humanoid_path(talos_floating: Robot) -> None:
    from taskspace.planning.configuration_space import ConfigurationSpace
    from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

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
        options = RRTConnectOptions(time_limit_s=20.0, seed=0, certify=True)
        res = rrt_connect(space, start, goal, options)
        assert res.success and res.log["certified"] == 1.0
        assert _dense_min_distance(robot, res.path) > 0.0
    finally:
        robot.remove_obstacle("wall")


def _chain_robot() -> Robot:
    """Free flyer, spherical, revolute, prismatic and continuous joints, a box on each body."""
    import coal

    model, geom = pin.Model(), pin.GeometryModel()
    rng = np.random.default_rng(7)
    joint = 0
    for k, jm in enumerate(
        [pin.JointModelFreeFlyer(), pin.JointModelSpherical(), pin.JointModelRX(),
         pin.JointModelPY(), pin.JointModelRUBZ()]
    ):  # fmt: skip
        placement = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-1, 1, 3)), rng.uniform(-0.3, 0.3, 3))
        joint = model.addJoint(joint, jm, placement if k else pin.SE3.Identity(), f"j{k}")
        model.appendBodyToJoint(joint, pin.Inertia.Random(), pin.SE3.Identity())
        box = pin.GeometryObject(
            f"box{k}", joint, pin.SE3(np.eye(3), rng.uniform(-0.2, 0.2, 3)),
            coal.Box(*rng.uniform(0.05, 0.3, 3)),
        )  # fmt: skip
        geom.addGeometryObject(box)
    model.lowerPositionLimit[:] = -1.0
    model.upperPositionLimit[:] = 1.0
    return Robot(model, geom, pin.GeometryModel(), name="chain",
                 default_configuration=pin.neutral(model))  # fmt: skip


def test_bound_holds_on_spherical_and_prismatic_chains() -> None:
    robot = _chain_robot()
    model, gm = robot.model, robot.collision_model
    manifold = JointManifold(model, base_lower=-np.ones(3), base_upper=np.ones(3))
    rng = np.random.default_rng(0)
    corners = []
    for k in range(robot.robot_geometry_count):
        g = gm.geometryObjects[k].geometry
        g.computeLocalAABB()
        lo, hi = g.aabb_local.min_, g.aabb_local.max_
        corners.append(np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                                 for z in (lo[2], hi[2])]))  # fmt: skip
    q0, q1 = manifold.sample(rng, 20), manifold.sample(rng, 20)
    q1[10:] = [pin.interpolate(model, a, b, 0.02) for a, b in zip(q0[10:], q1[10:])]
    pairs = list(zip(q0, q1))
    for blk in manifold.blocks:  # one joint at a time too: the others' terms cannot hide it
        for a, b in zip(q0[:4], q1[:4]):
            c = a.copy()
            c[blk.idx_q : blk.idx_q + blk.nq] = b[blk.idx_q : blk.idx_q + blk.nq]
            pairs.append((a, c))
    for a, b in pairs:
        bound = motion_bound(robot, np.array([a, b]))
        moved = _true_motion(robot, a, b, corners)
        assert moved <= bound(pin.difference(model, a, b)) + 1e-9


def test_bound_kept_across_set_limits_is_refused(tiago_mobile: Robot) -> None:
    # The torso's reach comes from its limits: widening them makes an old bound too small.
    robot = tiago_mobile
    i = robot.model.joints[robot.model.getJointId("torso_lift_joint")].idx_q
    old_upper = robot.upper_limits.copy()
    kept = motion_bound(robot)
    for_path = motion_bound(robot, np.zeros((1, robot.nq)))
    turn = np.zeros(robot.nv)
    turn[2] = 1.0
    wider = old_upper.copy()
    wider[i] = old_upper[i] + 0.25
    robot.set_limits(upper=wider)
    try:
        with pytest.raises(StaleModelError, match="MotionBound"):
            kept.check(robot)
        for_path.check(robot)  # made for a path: independent of the limits
        fresh = motion_bound(robot)
        fresh.check(robot)
        assert fresh(turn) == pytest.approx(kept(turn) + 0.25)
    finally:
        robot.set_limits(upper=old_upper)
