"""Failed certificate regions (``FailedRegions``) on joint manifolds: planar and free-flyer bases.

References: the edge sampled 100 times finer than the space's resolution
(``space.interpolate``) and each point's distance to the ball's centre in the space's metric
(``space.distance``, one pair at a time), for the intervals of ``crossings``; Pinocchio/coal's
``computeDistances`` every 1e-3 (metric units) along ``pinocchio.interpolate`` for a re-planned
path (independent of the certifier).
"""

from __future__ import annotations

import itertools
import math
import warnings

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot
from taskspace.planning.certify import FailedRegions, certify_path
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

DELTA = 0.08


def _base_robot(joint: object, name: str) -> Robot:
    """A disc (radius 0.02 m) on a planar or free-flyer base joint (or a slider)."""
    model, geom = pin.Model(), pin.GeometryModel()
    jid = model.addJoint(0, joint, pin.SE3.Identity(), "base")
    model.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    geom.addGeometryObject(pin.GeometryObject("disc", jid, pin.SE3.Identity(), coal.Sphere(0.02)))
    if model.nq == 1:  # a slider: its limits (a base's translation is bounded by the space)
        model.lowerPositionLimit[:], model.upperPositionLimit[:] = -1.0, 1.0
    return Robot(
        model, geom, pin.GeometryModel(), name=name, default_configuration=pin.neutral(model)
    )


@pytest.fixture(scope="module")
def planar() -> tuple[Robot, ConfigurationSpace]:
    robot = _base_robot(pin.JointModelPlanar(), "planar_disc")
    robot.add_obstacle(Obstacle.box("post", [0.01, 0.1, 0.2], [0.0, -0.5, 0.0]))
    space = ConfigurationSpace.from_robot(
        robot, edge=EdgeCheckOptions(resolution=DELTA), base_lower=[-1, -1], base_upper=[1, 1]
    )
    return robot, space


@pytest.fixture(scope="module")
def flyer() -> ConfigurationSpace:
    robot = _base_robot(pin.JointModelFreeFlyer(), "flying_disc")
    return ConfigurationSpace.from_robot(
        robot,
        edge=EdgeCheckOptions(resolution=DELTA),
        base_lower=[-1, -1, -1],
        base_upper=[1, 1, 1],
    )


def _planar(x: float, y: float, theta: float) -> np.ndarray:
    return np.array([x, y, math.cos(theta), math.sin(theta)])


def _inside(space: ConfigurationSpace, q0: np.ndarray, q1: np.ndarray, c: np.ndarray, r: float):  # type: ignore[no-untyped-def]
    """The fractions ``t`` (100 per resolution step) whose point is nearer than ``r`` to ``c``."""
    t = np.linspace(0.0, 1.0, 100 * space.segments(q0, q1) + 1)
    points = space.interpolate(q0, q1, t)
    d = np.array([space.distance(p, c) for p in points])
    return t[d < r], float(d.min())


def _covered(ts: np.ndarray, intervals: list[tuple[float, float]]) -> bool:
    return all(any(lo <= t <= hi for lo, hi in intervals) for t in ts)


def _check_random_edges(space: ConfigurationSpace, regions: FailedRegions, seed: int) -> int:
    """Edges from random points near the centres: every point nearer than the radius covered,
    an edge whose every point is beyond radius + resolution gets no interval."""
    rng = np.random.default_rng(seed)
    hits = far = 0
    for _ in range(40):
        c = regions.centers[rng.integers(len(regions.centers))]
        a = space.interpolate(c, space.sample_uniform(rng), rng.uniform(0.0, 0.5))[0]
        b = space.interpolate(c, space.sample_uniform(rng), rng.uniform(0.0, 0.5))[0]
        got = regions.crossings(a, b)
        inside: list[float] = []
        least = math.inf
        for centre in regions.centers:
            ts, d = _inside(space, a, b, centre, regions.radius)
            inside.extend(ts.tolist())
            least = min(least, d)
        assert _covered(np.array(inside), got), (a, b, got)
        assert all(0.0 <= lo <= hi <= 1.0 for lo, hi in got)
        hits += bool(inside)
        if least > regions.radius + DELTA:
            far += 1
            assert got == []
    return hits


def test_planar_crossings_cover_every_point_inside_the_balls(planar) -> None:  # type: ignore[no-untyped-def]
    _, space = planar
    assert not space.is_euclidean
    regions = FailedRegions(space, 1e-4)
    path = np.stack([_planar(-0.5, -0.5, 0.3), _planar(0.5, -0.5, 2.5)])
    regions.add(0, path, 0, 0.5)
    assert space.distance(regions.centers[0], space.interpolate(*path, 0.5)[0]) < 1e-12
    assert _check_random_edges(space, regions, 0) > 10
    regions.add(1, path, 0, 0.1)  # two balls, the radius doubled
    assert regions.radius == pytest.approx(2 * 4 * DELTA)
    assert _check_random_edges(space, regions, 1) > 10


def test_planar_edge_through_the_centre_and_far_from_it(planar) -> None:  # type: ignore[no-untyped-def]
    _, space = planar
    regions = FailedRegions(space, 1e-4)
    c = _planar(0.0, -0.5, 3.0)  # theta near pi: the angle wraps along the edges below
    regions.add(0, c[None, :], 0, 0.0)
    r = regions.radius
    # through the centre, the angle crossing +-pi: one interval, holding the chord
    a, b = _planar(-0.6, -0.5, 2.9), _planar(0.6, -0.5, -3.0)
    ((lo, hi),) = regions.crossings(a, b)
    ts, _ = _inside(space, a, b, c, r)
    assert ts.size and lo <= ts[0] and ts[-1] <= hi
    # widened by less than two steps on each side (a point within half a step of the
    # sphere, and one more)
    step = 1.0 / space.segments(a, b)
    assert ts[0] - lo < 2 * step and hi - ts[-1] < 2 * step
    # the same positions, the angle a full turn away: far in the metric, no interval
    a2, b2 = _planar(-0.6, -0.5, 2.9 - math.pi), _planar(0.6, -0.5, -3.0 - math.pi)
    assert _inside(space, a2, b2, c, r)[0].size == 0
    assert regions.crossings(a2, b2) == []
    # far away in position
    assert regions.crossings(_planar(-0.9, 0.8, 0.0), _planar(0.9, 0.8, 1.0)) == []
    # a one-point edge at the centre: inside
    assert regions.crossings(c, c) != []


@pytest.mark.parametrize("depth", [1e-3, 1e-2, 3e-2])
@pytest.mark.parametrize("theta", [0.0, 1.0])
def test_an_edge_grazing_a_ball_between_two_points_is_caught(planar, depth, theta) -> None:  # type: ignore[no-untyped-def]
    # The edge passes ``depth`` inside the ball, its chord there (<= 0.14 m) lying between
    # two of its points at the resolution (x = -0.04 and 0.04 of 15 steps of 0.08): the chord
    # must still be in an interval (an edge that enters a ball is proven there).
    _, space = planar
    regions = FailedRegions(space, 1e-4)
    c = _planar(0.0, -0.5, theta)
    regions.add(0, c[None, :], 0, 0.0)
    h = regions.radius - depth
    a, b = _planar(-0.6, -0.5 + h, theta), _planar(0.6, -0.5 + h, theta)
    assert space.segments(a, b) == 15
    ts, least = _inside(space, a, b, c, regions.radius)
    assert ts.size and least == pytest.approx(h)
    got = regions.crossings(a, b)
    assert got and _covered(ts, got)


def test_free_flyer_crossings_cover_every_point_inside_the_balls(flyer) -> None:  # type: ignore[no-untyped-def]
    space = flyer
    assert not space.is_euclidean
    rng = np.random.default_rng(5)
    regions = FailedRegions(space, 1e-4)
    regions.add(0, np.stack([space.sample_uniform(rng), space.sample_uniform(rng)]), 0, 0.4)
    assert _check_random_edges(space, regions, 2) > 10


def test_free_flyer_edges_near_the_sphere_are_covered(flyer) -> None:  # type: ignore[no-untyped-def]
    # Edges through a point just inside the ball (radius - 0.04 .. radius), in random
    # directions: every point nearer than the radius (20 per step) is in an interval (2 of
    # these 300 edges were not, before the samples were compared with radius + step / 2).
    space = flyer
    rng = np.random.default_rng(0)
    regions = FailedRegions(space, 1e-4)
    c = space.sample_uniform(rng)
    regions.add(0, c[None, :], 0, 0.0)
    r = regions.radius
    for _ in range(300):
        v = rng.standard_normal(6)
        p = space.retract(c, v * rng.uniform(r - 0.04, r) / np.linalg.norm(v))
        w = rng.standard_normal(6)
        w *= 0.6 / np.linalg.norm(w)
        a = space.retract(p, -w * rng.uniform(0.2, 1.0))
        b = space.retract(p, w * rng.uniform(0.2, 1.0))
        t = np.linspace(0.0, 1.0, 20 * space.segments(a, b) + 1)  # vectorized: 300 edges
        ts = t[space.distances(space.interpolate(a, b, t), c) < r]
        assert ts.size and _covered(ts, regions.crossings(a, b))


def test_a_centre_stored_with_the_opposite_quaternion_sign_is_found(flyer) -> None:  # type: ignore[no-untyped-def]
    # q and -q are the same rotation; space.distance treats them as equal, so must crossings.
    space = flyer
    rng = np.random.default_rng(11)
    q = space.sample_uniform(rng)
    flipped = q.copy()
    flipped[3:7] *= -1.0
    assert space.distance(q, flipped) < 1e-12
    plain, other = FailedRegions(space, 1e-4), FailedRegions(space, 1e-4)
    plain.add(0, q[None, :], 0, 0.0)
    other.add(0, flipped[None, :], 0, 0.0)
    hits = 0
    for _ in range(20):
        a = space.interpolate(q, space.sample_uniform(rng), rng.uniform(0.0, 0.1))[0]
        b = space.interpolate(q, space.sample_uniform(rng), rng.uniform(0.0, 0.1))[0]
        got = plain.crossings(a, b)
        assert got == other.crossings(a, b)
        ts, _ = _inside(space, a, b, q, plain.radius)
        assert _covered(ts, got)
        hits += bool(ts.size)
        # the edge's own ends stored with flipped signs: the same answer
        fa, fb = a.copy(), b.copy()
        fa[3:7] *= -1.0
        fb[3:7] *= -1.0
        ts, _ = _inside(space, fa, fb, q, plain.radius)
        assert _covered(ts, plain.crossings(fa, fb))
    assert hits > 10


def _dense_least_distance(robot: Robot, path: np.ndarray, step: float = 1e-3) -> float:
    """Pinocchio/coal signed distance every ``step`` along ``pinocchio.interpolate``."""
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    least = math.inf
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(float(np.linalg.norm(pin.difference(model, a, b))) / step))
        for t in np.arange(n + 1) / n:
            pin.computeDistances(model, data, gm, gd, pin.interpolate(model, a, b, t))
            least = min(least, min(r.min_distance for r in gd.distanceResults))
    return least


def test_a_replan_on_a_planar_base_certifies_around_the_post(planar) -> None:  # type: ignore[no-untyped-def]
    robot, space = planar
    start, goal = _planar(-0.5, -0.5, 0.0), _planar(0.5, -0.5, 0.0)
    # the straight line passes the edge check (its points straddle the post) and collides
    assert space.motion_valid(start, goal)
    assert _dense_least_distance(robot, np.stack([start, goal])) < 0.0
    for seed in range(2):
        common = {"seed": seed, "max_iterations": 5000, "time_limit_s": None}
        plain = rrt_connect(space, start, goal, RRTConnectOptions(certify=False, **common))  # type: ignore[arg-type]
        assert plain.success and _dense_least_distance(robot, plain.path) < 0.0
        result = rrt_connect(space, start, goal, RRTConnectOptions(certify=True, **common))  # type: ignore[arg-type]
        assert result.success and result.status is PlannerStatus.SOLVED, seed
        assert result.log["certified"] == 1.0
        assert result.log["certify_attempts"] >= 2 and result.log["region_certifications"] > 0
        assert result.log["certify_failures"][0][:2] == (0, 0)
        assert _dense_least_distance(robot, result.path) > 0.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_inputs_are_refused(planar, flyer, bad: float) -> None:  # type: ignore[no-untyped-def]
    # A NaN centre or edge compares false with every radius: no interval, the edge would
    # pass unproven. add and crossings refuse them (both branches: box and manifold).
    box = FailedRegions(
        ConfigurationSpace.from_robot(
            _base_robot(pin.JointModelPX(), "slider"), edge=EdgeCheckOptions(resolution=DELTA)
        ),
        1e-4,
    )
    for space in [planar[1], flyer, box.space]:
        regions = FailedRegions(space, 1e-4)
        q = space.sample_uniform(np.random.default_rng(0))
        bad_q = q.copy()
        bad_q[0] = bad
        with pytest.raises(InvalidInputError):
            regions.add(0, np.stack([q, bad_q]), 0, 0.5)
        with pytest.raises(InvalidInputError):
            regions.add(0, np.stack([q, q]), 0, bad)
        assert regions.centers.shape[0] == 0 and regions.failures == []
        regions.add(0, q[None, :], 0, 0.0)
        with pytest.raises(InvalidInputError):
            regions.crossings(q, bad_q)
        with pytest.raises(InvalidInputError):
            regions.crossings(bad_q, q)
        near = space.interpolate(q, space.sample_uniform(np.random.default_rng(1)), 0.01)[0]
        assert regions.crossings(q, near) != []  # the finite edge is still answered


@pytest.mark.parametrize("native", [True, False])
def test_a_robot_without_collision_pairs_is_certified(native: bool) -> None:
    # One body, no obstacle: nothing can collide. The Python certifier (native=False, a
    # planar or floating base, which the compiled certifier does not serve, or a tree
    # without compiled kernels) raised a TypeError here (an empty pair list made float
    # arrays, which ``&`` refuses).
    robot = _base_robot(pin.JointModelPlanar(), "lonely_disc")
    assert len(robot.collision_model.collisionPairs) == 0
    path = np.stack([_planar(-0.5, 0.0, 0.0), _planar(0.5, 0.2, 2.0)])
    cert = certify_path(robot, path, native=native)
    assert cert.certified and cert.min_distance == math.inf


@pytest.mark.parametrize("weights", [[1.0, 1.0, 0.05], [0.05, 0.05, 0.05], [0.3, 1.0, 0.5]])
def test_weighted_balls_are_four_edge_checks_wide(planar, weights) -> None:  # type: ignore[no-untyped-def]
    # The ball around a failure must hold the failed edge's checked points on either side of
    # q(t) (the failure lies between them) and span 4 check spacings each way: the spacing is
    # space.edge_resolution (edge.resolution * min(w) with weights below 1), not
    # edge.resolution, which made balls 1 / min(w) times wider (with weights of 0.05, wider
    # than the whole space: every re-planned edge certified).
    robot, _ = planar
    space = ConfigurationSpace.from_robot(
        robot,
        edge=EdgeCheckOptions(resolution=DELTA),
        base_lower=[-1, -1],
        base_upper=[1, 1],
        weights=weights,
    )
    delta = space.edge_resolution
    assert delta == pytest.approx(DELTA * min(min(weights), 1.0))
    regions = FailedRegions(space, 1e-4)
    a, b = _planar(-0.9, -0.5, 0.0), _planar(0.9, -0.5, 0.4)
    regions.add(0, np.stack([a, b]), 0, 0.5)
    c = regions.centers[0]
    # the failed edge's checked points (the planar joint's interpolation is its exponential:
    # metric distances along the edge are |t - 0.5| times its length)
    n = space.segments(a, b)
    checked = space.interpolate(a, b, np.arange(n + 1) / n)
    d = np.array([space.distance(p, c) for p in checked])
    length = space.distance(a, b)
    assert d == pytest.approx(np.abs(np.arange(n + 1) / n - 0.5) * length, abs=1e-9)
    inside = np.flatnonzero(d < regions.radius)
    assert n >= 20 and 2 <= inside.size <= 2 * 4 + 1
    assert {math.floor(n / 2), math.ceil(n / 2)} <= set(inside.tolist())
    ((lo, hi),) = regions.crossings(a, b)
    assert lo <= 0.5 <= hi
    # a parallel edge 8 spacings away in y (in the metric: 8 delta times the weights of the
    # base's local x, y at its angle), farther than radius + one spacing: outside
    dy = 8 * delta / weights[1]
    a2, b2 = a.copy(), b.copy()
    a2[1] += dy
    b2[1] += dy
    ts, least = _inside(space, a2, b2, c, regions.radius)
    assert ts.size == 0 and least > regions.radius + delta
    assert regions.crossings(a2, b2) == []
    assert regions.radius == pytest.approx(4 * delta)


def test_nearest_skips_disabled_points_on_a_manifold(planar) -> None:  # type: ignore[no-untyped-def]
    # A disabled node's coordinates are zeros: a (cos, sin) pair of norm 0, which the planar
    # metric turned into NaN with a RuntimeWarning at every query of the tree. Reference:
    # space.distance to each live point, one at a time.
    from taskspace.planning.nearest import GrowingNearest

    _, space = planar
    rng = np.random.default_rng(3)
    nn = GrowingNearest(space.dim, capacity=4, metric=space.distances)
    points = [space.sample_uniform(rng) for _ in range(12)]
    for q in points:
        nn.add(q)
    nn.disable([2, 5, 6])
    for _ in range(20):
        q = space.sample_uniform(rng)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            i, d = nn.nearest(q)
        ref = [(space.distance(p, q), j) for j, p in enumerate(points) if j not in (2, 5, 6)]
        assert (d, i) == pytest.approx(min(ref))


def test_rrt_connect_on_a_weighted_planar_base_warns_nothing() -> None:
    # Thin posts: the lazy fine pass removes subtrees (disabled nodes), whose zeros reached the
    # metric at the next nearest-neighbour queries (RuntimeWarnings, 48 in these 30 seeds).
    robot = _base_robot(pin.JointModelPlanar(), "planar_disc_posts")
    for k, y in enumerate(np.linspace(-0.9, 0.9, 7)):
        robot.add_obstacle(Obstacle.box(f"post{k}", [0.001, 0.2, 0.2], [0.0, y, 0.0]))
    space = ConfigurationSpace.from_robot(
        robot,
        edge=EdgeCheckOptions(resolution=DELTA),
        base_lower=[-1, -1],
        base_upper=[1, 1],
        weights=[0.05] * 3,
    )
    for seed in range(30):
        rng = np.random.default_rng(seed)
        start = _planar(-0.5, rng.uniform(-0.9, 0.9), 0.0)
        goal = _planar(0.5, rng.uniform(-0.9, 0.9), 0.0)
        opts = RRTConnectOptions(seed=seed, max_iterations=20000, time_limit_s=None)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = rrt_connect(space, start, goal, opts)
        assert result.success and np.isfinite(result.path).all()
