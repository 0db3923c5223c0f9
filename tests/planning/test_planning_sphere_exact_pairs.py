"""Self pairs whose spheres touch at every configuration are checked exactly by "spheres_only".

On the Unitree Z1 the spheres' margin closes the gap between two pairs of neighbouring links
whose meshes never touch: counting their touch a collision made every configuration collide
for ``checker="spheres_only"``, which then planned only through its fallback to "spheres".
:meth:`CollisionChecker.sphere_kernel` finds such pairs (spheres touching on all of 16 random
configurations, geometries apart on one at least) and the kernel tests them with coal's exact
narrow phase. References: the spheres' clearances from Pinocchio's kinematics and NumPy
(``_sphere_reference.PairClearances``) for the other pairs, Pinocchio's ``computeCollision``
for the marked ones.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from _sphere_reference import PairClearances, mesh_collides

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda
from tests.planning._mbm import ROOT

pytest.importorskip("taskspace._native._planning_kernel")

SPHERES_ONLY = 2  # CollisionKernel checker code
OFF, TRUSTED = 0, 2  # CollisionKernel.set_sphere_filter
Z1_PAIRS = {("link03_1", "link04_0"), ("link04_0", "link06_0")}


def _z1() -> tuple[Robot, ConfigurationSpace]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # example-robot-data's missing limits
        robot = Robot.load("z1", convex_collision=True)
    robot.add_obstacles(
        [
            Obstacle.box("block", [0.12, 0.2, 0.08], (0.35, 0.05, 0.25)),
            Obstacle.sphere("ball", 0.06, (-0.2, 0.25, 0.35)),
            Obstacle.cylinder("post", 0.03, 0.5, (0.15, -0.3, 0.25)),
        ]
    )
    return robot, ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))


@pytest.fixture(scope="module")
def z1() -> tuple[Robot, ConfigurationSpace]:
    return _z1()


def _marked_indices(robot: Robot, names: tuple[tuple[str, str], ...]) -> set[int]:
    geom = robot.collision_model
    objs = geom.geometryObjects
    return {
        k
        for k, p in enumerate(geom.collisionPairs)
        if (objs[p.first].name, objs[p.second].name) in names
    }


def test_z1_pairs_are_found_and_none_on_the_mbm_panda():
    _, space = _z1()  # a new checker (the fixture's may have built its kernel already)
    assert space.checker.sphere_exact_pairs == ()  # before the sphere kernel is built
    assert space.checker.sphere_kernel() is not None
    assert set(space.checker.sphere_exact_pairs) == Z1_PAIRS
    if ROOT is not None:  # the MotionBenchMaker Panda: no such pair (its answers unchanged)
        panda = ConfigurationSpace.from_robot(motionbenchmaker_panda())
        assert panda.checker.sphere_kernel() is not None
        assert panda.checker.sphere_exact_pairs == ()


def test_spheres_only_answers_with_the_exact_test_of_the_marked_pairs(
    z1: tuple[Robot, ConfigurationSpace],
):
    robot, space = z1
    kernel = space.checker.sphere_kernel()
    marked = _marked_indices(robot, space.checker.sphere_exact_pairs)
    assert len(marked) == len(Z1_PAIRS)
    clearances = PairClearances(robot, space.checker.sphere_model())
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    qs = np.random.default_rng(3).uniform(lo, hi, (300, robot.nq))
    expected, decided = [], []
    for q in qs:
        values = clearances(q)
        others = [v for k, v in values.items() if k not in marked]
        # the marked pairs' spheres touch (the kernel then asks coal, as Pinocchio does here)
        assert all(values[k] <= 0.0 for k in marked)
        pin.updateGeometryPlacements(model, data, geom, gdata, q)
        exact = any(pin.computeCollision(geom, gdata, k) for k in marked)
        expected.append(min(others) <= 0.0 or exact)
        decided.append(min(abs(v) for v in others) > 1e-6)
    expected_arr, keep = np.array(expected), np.array(decided)
    assert keep.sum() > 250
    flags = kernel.collisions_with(qs, SPHERES_ONLY).astype(bool)
    np.testing.assert_array_equal(flags[keep], expected_arr[keep])
    # free configurations exist for "spheres_only" now (all collided before the marks)
    assert (~flags).sum() > 30
    # the double test alone (no single-precision filter) gives the same answers
    kernel.set_sphere_filter(OFF)
    try:
        np.testing.assert_array_equal(kernel.collisions_with(qs, SPHERES_ONLY), flags)
    finally:
        kernel.set_sphere_filter(TRUSTED)


def test_spheres_only_plans_on_the_z1(z1: tuple[Robot, ConfigurationSpace]):
    """Without the marks every configuration collided for "spheres_only": no tree grew and
    every plan fell back to "spheres". Now its trees grow and the free straight lines are
    solved by it alone; the paths are free for Pinocchio."""
    robot, space = z1
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = np.random.default_rng(7).uniform(lo, hi, (300, robot.nq))
    # free for "spheres_only" (its margin still closes other gaps), hence for the exact checker
    kernel = space.checker.sphere_kernel()
    free = qs[kernel.collisions_with(qs, SPHERES_ONLY) == 0]
    assert len(free) >= 12
    collides = mesh_collides(robot)
    alone = 0
    for k in range(6):
        start, goal = free[2 * k], free[2 * k + 1]
        opts = RRTConnectOptions(seed=k, checker="spheres_only", validator="spheres")
        res = rrt_connect(space, start, goal, opts)
        assert res.success and res.log["native"] == 1.0
        nodes = res.log["start_tree_nodes"] + res.log["goal_tree_nodes"]
        if res.log["spheres_fallback"] == 0.0:
            alone += 1
        else:  # the trees grew with "spheres_only" before the fallback
            assert nodes > 2
        dense = space.interpolate_path(res.path, 0.01)
        assert not any(collides(q) for q in dense)  # Pinocchio's exact check
    assert alone >= 2


def test_mark_exact_pairs_refuses_bad_configurations(z1: tuple[Robot, ConfigurationSpace]):
    robot, space = z1
    kernel = space.checker.sphere_kernel()
    qs = np.random.default_rng(3).uniform(
        robot.model.lowerPositionLimit, robot.model.upperPositionLimit, (200, robot.nq)
    )
    flags = kernel.collisions_with(qs, SPHERES_ONLY)
    for bad in (
        np.full((2, robot.nq), np.nan),
        np.full((1, robot.nq), np.inf),
        np.zeros((3, robot.nq + 1)),
        np.zeros((0, robot.nq)),
    ):
        with pytest.raises(InvalidInputError, match="qs must be finite rows of size nq"):
            kernel.mark_exact_pairs(bad)
    # a refused call leaves the marks (the answers) as they were
    np.testing.assert_array_equal(kernel.collisions_with(qs, SPHERES_ONLY), flags)
