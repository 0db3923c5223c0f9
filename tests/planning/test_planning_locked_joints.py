"""Locked joints: plan the free joints, hold the others, check the full configuration.

References independent of the space's lifting: the full configuration is assembled here from
the model's joint slices (``idx_q``/``nq``) and checked by Pinocchio's ``computeCollisions``
on the robot's own models; paths are checked densely along Pinocchio's interpolation.
"""

from __future__ import annotations

import itertools
import math

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.model import Obstacle, Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.objectives import MechanicalWork
from taskspace.planning.prm_star import PRMStarOptions, prm_star
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star


def _assemble(model: pin.Model, free: np.ndarray, values: dict[str, np.ndarray]) -> np.ndarray:
    """The full configuration from the free coordinates and the locked values (reference)."""
    q = np.empty(model.nq)
    it = iter(free.tolist())
    for j in range(1, model.njoints):
        joint = model.joints[j]
        sl = slice(joint.idx_q, joint.idx_q + joint.nq)
        name = str(model.names[j])
        q[sl] = values[name] if name in values else [next(it) for _ in range(joint.nq)]
    assert next(it, None) is None
    return q


def _collides(robot: Robot, q: np.ndarray) -> bool:
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    return bool(pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, True))


def _dense_hits(robot: Robot, full_path: np.ndarray, step: float = 0.01) -> int:
    model = robot.model
    hits = 0
    for a, b in itertools.pairwise(full_path):
        n = max(1, math.ceil(np.linalg.norm(pin.difference(model, a, b)) / step))
        hits += sum(_collides(robot, pin.interpolate(model, a, b, t)) for t in np.arange(n + 1) / n)
    return hits


@pytest.fixture(scope="module")
def panda_table() -> Robot:
    """A Panda of its own (not the session's: an obstacle is added) with a box in front."""
    robot = Robot.load("panda")
    robot.add_obstacle(Obstacle.box("block", [0.3, 0.6, 0.3], [0.55, 0.0, 0.35]))
    return robot


LOCKED = {"panda_joint2": 0.9, "panda_joint7": -1.2}  # leaning forward, hand turned


def test_checker_sees_the_full_configuration_with_the_locked_values(panda_table: Robot) -> None:
    robot = panda_table
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    assert (space.dim, space.full_dim) == (5, 7)
    values = {k: np.array([v]) for k, v in LOCKED.items()}
    free = space.sample_uniform(np.random.default_rng(3), 150)
    ref = np.array([not _collides(robot, _assemble(robot.model, f, values)) for f in free])
    np.testing.assert_array_equal(space.checker.are_valid(free), ref)
    assert 0 < ref.sum() < ref.size
    # the locked values matter here: with the joints at 0 the answers differ
    upright = {k: np.array([0.0]) for k in LOCKED}
    other = np.array([not _collides(robot, _assemble(robot.model, f, upright)) for f in free])
    assert np.any(other != ref)
    # first_invalid and explain see the same configurations
    bad = int(np.flatnonzero(~ref)[0])
    assert space.first_invalid(free[: bad + 1]) == bad
    assert "block" in space.checker.explain(free[bad])


def test_compiled_checker_of_the_free_joints_agrees_with_pinocchio(panda_table: Robot) -> None:
    robot = panda_table
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    kernel = space.checker.native_kernel()
    if kernel is None:
        pytest.skip("compiled planning kernel not built")
    assert kernel.nq == 5
    values = {k: np.array([v]) for k, v in LOCKED.items()}
    free = space.sample_uniform(np.random.default_rng(11), 300)
    ref = np.array([_collides(robot, _assemble(robot.model, f, values)) for f in free])
    assert 0 < ref.sum() < ref.size
    np.testing.assert_array_equal(np.asarray(kernel.collisions(free)) != 0, ref)
    assert space.checker.native_kernel() is kernel  # cached while nothing changed
    # a new obstacle: the next plan gets a kernel of the new world
    robot.add_obstacle(Obstacle.box("extra", [0.2, 0.2, 0.2], [-0.4, 0.4, 0.5]))
    try:
        again = space.checker.native_kernel()
        assert again is not kernel
        ref2 = np.array([_collides(robot, _assemble(robot.model, f, values)) for f in free])
        assert np.any(ref2 != ref)
        np.testing.assert_array_equal(np.asarray(again.collisions(free)) != 0, ref2)
    finally:
        robot.remove_obstacle("extra")


ANYTIME_ITERATIONS = 300
"""Iterations of RRT*, BIT* and PRM* in the locked-joint plans (each finds its first path within
a few dozen; with the former 0.5 s limits they ran 450-2,200 iterations, as many as fitted)."""


@pytest.mark.parametrize(
    "planner", ["rrt_connect", "rrt_connect_python", "rrt_star", "prm_star", "bit_star"]
)
def test_paths_keep_the_locked_values_exactly_and_are_free(
    panda_table: Robot, planner: str
) -> None:
    robot = panda_table
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    model = robot.model
    idx = {n: model.joints[model.getJointId(n)].idx_q for n in LOCKED}
    start = robot.q_default.copy()
    for name, value in LOCKED.items():
        start[idx[name]] = value
    goal = start.copy()
    start[0], goal[0] = -1.2, 1.2  # swing around the block
    free_start = space.check_endpoint(start, "start")  # a full configuration, reduced
    np.testing.assert_array_equal(free_start, np.delete(start, list(idx.values())))
    assert not space.motion_valid(free_start, space.check_endpoint(goal, "goal"))
    if planner.startswith("rrt_connect"):
        native = planner == "rrt_connect"
        opts = RRTConnectOptions(seed=1, time_limit_s=10.0, native=native, checker="spheres")
        res = rrt_connect(space, start, goal, opts)
        compiled = space.checker.native_kernel() is not None and native
        assert ("kernel_run_us" in res.log) == compiled  # the compiled planner served it
    # The anytime planners get an iteration budget, not a time limit: the answer (a first
    # path found after a few dozen iterations) must not depend on how many iterations a
    # loaded machine fits into a fraction of a second.
    elif planner == "rrt_star":
        opts_star = RRTStarOptions(seed=1, max_iterations=ANYTIME_ITERATIONS, time_limit_s=None)
        res = rrt_star(space, start, goal, opts_star)
    elif planner == "bit_star":
        opts_bit = BITStarOptions(seed=1, max_iterations=ANYTIME_ITERATIONS, time_limit_s=None)
        res = bit_star(space, start, goal, opts_bit)
    else:
        opts_prm = PRMStarOptions(seed=1, max_iterations=ANYTIME_ITERATIONS, time_limit_s=None)
        res = prm_star(space, start, goal, opts_prm)[0]
    assert res.success
    assert res.path.shape[1] == 5
    full = space.full_configurations(res.path)
    for name, value in LOCKED.items():
        assert np.all(full[:, idx[name]] == value)  # exactly, not approximately
    np.testing.assert_array_equal(full[0], start)
    np.testing.assert_array_equal(full[-1], goal)
    assert _dense_hits(robot, full, 0.02) == 0


def test_floating_base_with_locked_arm_joints_plans_on_the_manifold() -> None:
    robot = Robot.load("ur5", base="free_flyer")
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.2, 2.0], [0.0, 0.0, 1.0]))
    locked = {"wrist_1_joint": -1.0, "wrist_2_joint": 0.5, "wrist_3_joint": 0.0}
    space = ConfigurationSpace.from_robot(
        robot, locked_joints=locked, base_lower=[-1.5, -1.5, 0.2], base_upper=[1.5, 1.5, 1.0]
    )
    kinds = [b.kind for b in space.manifold.blocks]
    assert kinds == ["free_flyer", "vector", "vector", "vector"]
    assert (space.dim, space.tangent_dim, space.full_dim) == (10, 9, 13)
    values = {k: np.array([v]) for k, v in locked.items()}
    # the checker against Pinocchio on configurations assembled here
    free = space.sample_uniform(np.random.default_rng(0), 60)
    ref = [not _collides(robot, _assemble(robot.model, f, values)) for f in free]
    np.testing.assert_array_equal(space.checker.are_valid(free), ref)
    start = _assemble(robot.model, np.r_[-1.3, 0, 0.5, 0, 0, 0, 1, 0, -1.0, 1.0], values)
    goal = _assemble(robot.model, np.r_[1.3, 0, 0.5, 0, 0, 1, 0, 0.5, -1.2, 1.2], values)
    res = rrt_connect(space, start, goal, RRTConnectOptions(seed=0, time_limit_s=20.0))
    assert res.success
    full = space.full_configurations(res.path)
    assert np.all(full[:, -3:] == [-1.0, 0.5, 0.0])
    np.testing.assert_allclose(np.linalg.norm(full[:, 3:7], axis=1), 1.0, atol=1e-9)
    assert _dense_hits(robot, full, 0.02) == 0
    # locking the floating base itself: a fixed arm at a given base pose
    pose = [0.6, 0.0, 0.3, 0.0, 0.0, 0.0, 1.0]
    fixed = ConfigurationSpace.from_robot(robot, locked_joints={"root_joint": pose})
    assert fixed.is_euclidean and fixed.dim == 6
    arm = robot.q_default[7:]
    q = fixed.full_configurations(arm)
    assert np.array_equal(q[:7], pose)
    assert fixed.is_valid(arm) == (not _collides(robot, np.r_[pose, arm]))


def _wheel_arm() -> Robot:
    """A continuous joint ``wheel`` (z) carrying a revolute ``elbow`` (z), two box links."""
    model = pin.Model()
    wheel = model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    elbow = model.addJoint(
        wheel, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([0.5, 0, 0])), "elbow",
        np.array([10.0]), np.array([10.0]), np.array([-2.5]), np.array([2.5]),
    )  # fmt: skip
    for jid in (wheel, elbow):
        model.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    geom = pin.GeometryModel()
    for jid, name in ((wheel, "link1"), (elbow, "link2")):
        place = pin.SE3(np.eye(3), np.array([0.25, 0, 0]))
        geom.addGeometryObject(pin.GeometryObject(name, jid, 0, place, coal.Box(0.5, 0.05, 0.05)))
    return Robot(model, geom, pin.GeometryModel(), name="wheel_arm")


def test_continuous_joints_locked_by_angle_or_planned_on_the_circle() -> None:
    robot = _wheel_arm()
    robot.add_obstacle(Obstacle.box("post", [0.1, 0.1, 0.5], [-0.3, 0.75, 0.0]))
    theta = 2.0
    space = ConfigurationSpace.from_robot(robot, locked_joints={"wheel": theta})
    assert space.is_euclidean and space.dim == 1
    elbows = np.linspace(-2.5, 2.5, 101)[:, None]
    cs = np.array([math.cos(theta), math.sin(theta)])
    ref = [not _collides(robot, np.r_[cs, e]) for e in elbows]
    np.testing.assert_array_equal(space.checker.are_valid(elbows), ref)
    assert 0 < sum(ref) < len(ref)
    assert np.array_equal(space.full_configurations(elbows)[:, :2], np.tile(cs, (101, 1)))
    # the elbow locked instead: the wheel is planned on the circle (the short way round
    # unless blocked)
    wheel = ConfigurationSpace.from_robot(robot, locked_joints={"elbow": 0.0})
    assert [b.kind for b in wheel.manifold.blocks] == ["circle"]
    a, b = 0.5 * math.pi, 0.75 * math.pi  # the post sits at about 0.6 pi on a 1 m arm
    start, goal = [math.cos(a), math.sin(a)], [math.cos(b), math.sin(b)]
    assert not wheel.motion_valid(np.array(start), np.array(goal))
    res = rrt_connect(wheel, start, goal, RRTConnectOptions(seed=0, time_limit_s=5.0))
    assert res.success
    full = wheel.full_configurations(res.path)
    assert np.all(full[:, 2] == 0.0)
    angles = np.unwrap(np.arctan2(full[:, 1], full[:, 0]))
    assert abs(angles[-1] - angles[0]) > math.pi  # went the long way round the post
    assert _dense_hits(robot, full, 0.01) == 0


def test_bad_locked_joints_are_refused(panda_table: Robot) -> None:
    robot = panda_table
    with pytest.raises(UnknownNameError, match="panda_joint1, panda_joint2"):
        ConfigurationSpace.from_robot(robot, locked_joints={"panda_joint9": 0.0})
    with pytest.raises(InvalidInputError, match="outside its limits"):
        ConfigurationSpace.from_robot(robot, locked_joints={"panda_joint4": 1.0})
    with pytest.raises(InvalidInputError, match="1 coordinates"):
        ConfigurationSpace.from_robot(robot, locked_joints={"panda_joint4": [-1.0, 0.0]})
    with pytest.raises(InvalidInputError, match="not finite"):
        ConfigurationSpace.from_robot(robot, locked_joints={"panda_joint4": math.nan})
    with pytest.raises(InvalidInputError, match="every joint"):
        ConfigurationSpace.from_robot(
            robot,
            locked_joints={n: 0.0 for n in robot.joint_names if n != "panda_joint4"}
            | {"panda_joint4": -1.0},
        )
    with pytest.raises(InvalidInputError, match="non-empty mapping"):
        ConfigurationSpace.from_robot(robot, locked_joints={})
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    q = robot.q_default.copy()  # panda_joint2 not at 0.9
    with pytest.raises(PlanningError, match=r"panda_joint2=\[.*\] \(locked at \[0.9\]\)"):
        rrt_connect(space, q, q)
    floating = Robot.load("ur5", base="free_flyer")
    with pytest.raises(InvalidInputError, match="unit norm"):
        ConfigurationSpace.from_robot(floating, locked_joints={"root_joint": [0] * 7})


def test_mechanical_work_of_the_free_joints_on_the_reduced_model(panda_table: Robot) -> None:
    """The reduced model's gravity torques are the full model's on the free joints."""
    robot = panda_table
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    assert space.planning_model is not None and space.planning_model.nq == 5
    assert ConfigurationSpace.from_robot(robot).planning_model is robot.model
    work = MechanicalWork(space.planning_model, resolution=math.inf)
    rng = np.random.default_rng(4)
    a, b = space.sample_uniform(rng, 20), space.sample_uniform(rng, 20)
    values = {k: np.array([v]) for k, v in LOCKED.items()}
    model, data = robot.model, robot.model.createData()
    free_v = [model.joints[model.getJointId(n)].idx_v for n in robot.joint_names if n not in LOCKED]
    ref = []
    for x, y in zip(a, b, strict=True):
        tau = pin.computeGeneralizedGravity(model, data, _assemble(model, (x + y) / 2, values))
        ref.append(abs(float(tau[free_v] @ (y - x))))
    np.testing.assert_allclose(work.motion_costs(a, b), ref, rtol=1e-10, atol=1e-12)


@pytest.mark.slow  # Talos loads in ~5 s; RRT* and a dense check of its path
@pytest.mark.parametrize("informed", [False, True])
def test_floating_humanoid_rrt_star_with_locked_limbs(informed: bool) -> None:
    """Talos's floating base and torso plan around a wall, every limb locked (8 of 38 dof)."""
    robot = Robot.load("talos", convex_collision=True)
    robot.add_obstacle(Obstacle.box("wall", [0.2, 1.0, 3.0], [0.0, 0.0, 1.5]))
    model, q0 = robot.model, robot.q_default
    free = {"root_joint", "torso_1_joint", "torso_2_joint"}
    locked = {
        n: q0[model.joints[model.getJointId(n)].idx_q : model.joints[model.getJointId(n)].idx_q
              + model.joints[model.getJointId(n)].nq]
        for n in robot.joint_names
        if n not in free
    }  # fmt: skip
    space = ConfigurationSpace.from_robot(
        robot, locked_joints=locked, base_lower=[-1.5, -1.5, 0.9], base_upper=[1.5, 1.5, 1.2],
        weights=[1, 1, 1, 0.3, 0.3, 0.3, 1, 1],
    )  # fmt: skip
    assert space.tangent_dim == 8 and space.full_dim == 39
    start, goal = q0.copy(), q0.copy()
    start[:3], goal[:3] = [-0.8, 0.0, 1.0], [0.8, 0.0, 1.0]
    opts = RRTStarOptions(max_iterations=300, time_limit_s=None, seed=0, informed=informed)
    res = rrt_star(space, start, goal, opts)
    assert res.success and res.cost <= res.log["costs"][0]
    full = space.full_configurations(res.path)
    moving = [model.joints[model.getJointId(n)] for n in free]
    moving_q = np.concatenate([np.arange(j.idx_q, j.idx_q + j.nq) for j in moving])
    lock_q = np.setdiff1d(np.arange(model.nq), moving_q)
    assert lock_q.size == 39 - 9
    assert np.array_equal(full[:, lock_q], np.tile(q0[lock_q], (full.shape[0], 1)))
    np.testing.assert_array_equal(full[0], start)
    np.testing.assert_array_equal(full[-1], goal)
    assert _dense_hits(robot, full, 0.02) == 0


def test_goal_region_of_the_full_robot_is_refused_naming_the_locked_joints(
    panda_table: Robot,
) -> None:
    # before: "... must be None or a finite configuration of the space, shape (5,); got shape
    # (7,)" after an IK sample, naming neither the locked joints nor how to build the region
    from taskspace.ik import PoseGoalRegion
    from taskspace.planning.goals import goal_states

    robot = panda_table
    space = ConfigurationSpace.from_robot(robot, locked_joints=LOCKED)
    q_goal = np.array([1.5, 0.9, 0.0, -1.5, 0.0, 1.8, -1.2])  # holds the locked values
    pose = robot.frame_placement(q_goal, "panda_hand")
    start = space.locked.reduce(np.array([-1.5, 0.9, 0.0, -1.5, 0.0, 1.8, -1.2]))  # type: ignore[union-attr]
    full = PoseGoalRegion(robot, "panda_hand", pose)
    for plan in (
        lambda: rrt_connect(space, start, full, RRTConnectOptions(seed=0)),
        lambda: rrt_star(space, start, full, RRTStarOptions(seed=0)),
    ):
        with pytest.raises(InvalidInputError) as info:
            plan()
        msg = str(info.value)
        assert "nq = 7" in msg and "size 5" in msg
        assert "locked joints (panda_joint2, panda_joint7" in msg
        assert "space.planning_model" in msg and "reduced robot" in msg
    # the recipe of the message: the region on the reduced robot is accepted, and at any free
    # coordinates its frame errors are those of the full robot at the lifted configuration
    reduced = Robot(
        space.planning_model,
        pin.GeometryModel(),
        pin.GeometryModel(),
        name="reduced",
        default_configuration=start,
    )
    region = PoseGoalRegion(reduced, "panda_hand", pose)
    assert goal_states(space, region) == ([], region)
    free = np.vstack(
        [space.locked.reduce(q_goal), space.sample_uniform(np.random.default_rng(2), 5)]
    )  # type: ignore[union-attr]
    for qf in free:
        lifted = _assemble(robot.model, qf, {k: np.array([v]) for k, v in LOCKED.items()})
        np.testing.assert_allclose(region.errors(qf), full.errors(lifted), atol=1e-12)
    lifted = space.full_configurations(free[0])
    assert region.contains(free[0]) and full.contains(lifted)
    np.testing.assert_array_equal(lifted, q_goal)


def test_region_sample_of_the_wrong_size_names_the_locked_joints(panda_table: Robot) -> None:
    from taskspace.planning.goals import region_sample

    space = ConfigurationSpace.from_robot(panda_table, locked_joints=LOCKED)

    class FullSizeRegion:  # no robot attribute: found only at its first sample
        def contains(self, q: np.ndarray) -> bool:
            return False

        def sample(self, rng: np.random.Generator) -> np.ndarray:
            return np.zeros(7)

    with pytest.raises(InvalidInputError, match=r"got shape \(7,\).*panda_joint2, panda_joint7"):
        region_sample(space, FullSizeRegion(), np.random.default_rng(0))
