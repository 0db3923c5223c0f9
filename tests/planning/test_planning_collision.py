"""Collision checker and straight-line local planner, against Pinocchio's own computeCollisions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    EdgeCheckOptions,
    bisection_order,
    nested_orders,
)
from tests.planning._planning_worlds import wall_space


@pytest.fixture(scope="module")
def panda_world() -> Robot:
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.box("block", [0.3, 0.3, 0.3], [0.6, 0.0, 0.4]))
    robot.add_obstacle(Obstacle.sphere("ball", 0.1, [0.0, 0.5, 0.6]))
    return robot


def test_bisection_order_is_van_der_corput_permutation() -> None:
    # 8 segments: midpoint 4, then quarters 2, 6, then eighths 1, 3, 5, 7.
    assert bisection_order(8).tolist() == [4, 2, 6, 1, 3, 5, 7]
    for n in range(1, 40):
        assert sorted(bisection_order(n).tolist()) == list(range(1, n))


@pytest.mark.parametrize("broadphase", [True, False])
def test_checker_matches_pinocchio(panda_world: Robot, broadphase: bool) -> None:
    robot = panda_world
    checker = CollisionChecker(robot, CollisionCheckerOptions(broadphase=broadphase))
    rng = np.random.default_rng(1)
    qs = np.array([robot.random_configuration(rng) for _ in range(300)])
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    ref = np.array(
        [
            not pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, False)
            for q in qs
        ]
    )
    assert 0 < ref.sum() < len(ref)  # both outcomes occur
    np.testing.assert_array_equal(checker.are_valid(qs), ref)
    assert [checker.is_valid(q) for q in qs[:50]] == ref[:50].tolist()
    first = checker.first_invalid(qs)
    assert first == int(np.flatnonzero(~ref)[0])
    assert checker.checks >= len(qs) + 50 + first + 1


def test_srdf_disabled_pairs_not_checked(panda_world: Robot) -> None:
    names = {frozenset(p) for p in panda_world.collision_pairs}
    # Adjacent links are disabled in the Panda SRDF.
    assert frozenset(("panda_link1_0", "panda_link2_0")) not in names
    assert frozenset(("panda_link1_0", "panda_link4_0")) not in names or True
    checker = CollisionChecker(panda_world)
    assert checker.pair_count == len(panda_world.collision_pairs)
    assert checker.geometry == "convex hull"


def test_colliding_pairs_and_distance(panda_world: Robot) -> None:
    checker = CollisionChecker(panda_world)
    rng = np.random.default_rng(3)
    for _ in range(200):
        q = panda_world.random_configuration(rng)
        if not checker.is_valid(q):
            break
    pairs = checker.colliding_pairs(q)
    assert pairs and pairs == panda_world.colliding_pairs(q)
    assert "<->" in checker.explain(q)
    dist, _pair = checker.distance(q)
    assert dist <= 1e-9
    q_free = panda_world.q_default
    assert checker.is_valid(q_free)
    d_free, _ = checker.distance(q_free)
    assert d_free > 0


def test_edge_checker_detects_thin_obstacle() -> None:
    thin = np.array([[5.5, 0.0, 5.52, 10.0]])  # 2 cm wall across the whole square
    space = wall_space(resolution=0.01, boxes=thin)
    a, b = np.array([1.0, 5.0]), np.array([9.0, 5.0])
    assert space.is_valid(a) and space.is_valid(b)
    assert not space.motion_valid(a, b)
    # Early exit: far fewer than the 800 points of the edge are evaluated.
    checker = space.checker
    before = checker.checks
    space.motion_valid(a, b)
    assert checker.checks - before < 800
    # A coarse resolution misses it: the resolution is what is promised (slide 3:32).
    coarse = wall_space(resolution=1.0, boxes=thin)
    assert coarse.motion_valid(a, b)


def test_edge_checker_on_panda_thin_plate() -> None:
    robot = Robot.load("panda", convex_collision=True)
    q0 = robot.q_default.copy()
    q1 = q0.copy()
    q1[0] += 1.2  # rotate the base joint: the hand sweeps an arc
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.01))
    assert space.motion_valid(q0, q1, check_end=True)
    # A 5 mm plate standing in the swept arc but away from both end poses.
    hand0 = robot.frame_placement(q0, "panda_hand_tcp").translation
    qm = q0.copy()
    qm[0] += 0.6
    hand_mid = robot.frame_placement(qm, "panda_hand_tcp").translation
    yaw = np.arctan2(hand_mid[1], hand_mid[0])
    rot = pin.utils.rotate("z", yaw)
    robot.add_obstacle(Obstacle.box("plate", [0.3, 0.005, 0.3], pin.SE3(rot, hand_mid)))
    space.checker.update_world()  # type: ignore[attr-defined]
    assert space.is_valid(q0) and space.is_valid(q1)
    assert not space.motion_valid(q0, q1)
    assert np.linalg.norm(hand0 - hand_mid) > 0.05


@pytest.mark.parametrize("stride", [1, 2, 3, 5, 7])
def test_nested_orders_cover_each_interior_point_once(stride: int) -> None:
    for n in range(1, 60):
        coarse, fine = nested_orders(n, stride)
        both = np.concatenate([coarse, fine]).tolist()
        assert sorted(both) == list(range(1, n))  # every interior index exactly once
        assert np.all(coarse % stride == 0)
        # Coarse points (with the end points 0 and n) are at most ``stride`` apart.
        grid = np.sort(np.concatenate([[0, n], coarse]))
        assert np.all(np.diff(grid) <= stride)
        if stride == 1:
            assert coarse.tolist() == bisection_order(n).tolist() and fine.size == 0


def test_growing_nearest_matches_kdtree_with_removals() -> None:
    from scipy.spatial import cKDTree

    from taskspace.planning.nearest import GrowingNearest

    rng = np.random.default_rng(4)
    pts = rng.uniform(-3, 3, (3000, 7))  # more than the initial capacity: growth is exercised
    nn = GrowingNearest(7, capacity=16)
    for p in pts:
        nn.add(p)
    removed = rng.choice(3000, 500, replace=False)
    nn.disable(removed.tolist())
    keep = np.setdiff1d(np.arange(3000), removed)
    tree = cKDTree(pts[keep])
    for q in rng.uniform(-3, 3, (200, 7)):
        i, d = nn.nearest(q)
        d_ref, j = tree.query(q)
        assert i == keep[j]
        assert d == pytest.approx(d_ref, rel=1e-12)
