import numpy as np
import pytest

from taskspace.errors import InvalidInputError, PlanningError, UnknownNameError
from taskspace.planning.bug import BugOptions, BugStatus, bug1, bug2
from taskspace.planning.polygon_world import Polygon, PolygonWorld

BOUNDS = (-1.0, -6.0, 14.0, 6.0)
RECT = PolygonWorld((Polygon.rectangle(3, -2, 5, 2),), BOUNDS)
# C-shaped obstacle open to the right (away from the start): the m-line crosses it 4 times.
C_SHAPE = Polygon(
    np.array([[3, -3], [7, -3], [7, -2], [4, -2], [4, 2], [7, 2], [7, 3], [3, 3]], float)
)
CLASSIC = PolygonWorld((C_SHAPE, Polygon.regular((10, 0.3), 1.0, 10)), BOUNDS)


def assert_path_valid(world, res, start, goal):
    assert np.allclose(res.path[0], start)
    if res.success:
        assert np.allclose(res.path[-1], goal)
    u = np.linspace(0, 1, 101)
    for a, b in zip(res.path, res.path[1:]):
        pts = a + u[:, None] * (b - a)
        assert np.all(world.signed_distance(pts) > -1e-9)  # never inside an obstacle
    seg = np.linalg.norm(np.diff(res.path, axis=0), axis=1).sum()
    assert res.length == pytest.approx(seg)


@pytest.mark.parametrize("turn", ["left", "right"])
def test_rectangle_analytic_lengths(turn):
    opts = BugOptions(turn=turn)
    # Bug2: 3 to the wall, half the perimeter (6) around, 6 to the goal
    r2 = bug2(RECT, (0, 0), (11, 0), options=opts)
    assert r2.success and r2.status is BugStatus.REACHED
    assert r2.length == pytest.approx(15.0)
    assert np.allclose(r2.leave_points[0], (5, 0))
    # Bug1: full circumnavigation (12) + back to the closest point (6)
    r1 = bug1(RECT, (0, 0), (11, 0), options=opts)
    assert r1.success and r1.length == pytest.approx(3 + 12 + 6 + 6)
    assert np.allclose(r1.hit_points[0], (3, 0)) and np.allclose(r1.leave_points[0], (5, 0))
    assert_path_valid(RECT, r1, (0, 0), (11, 0))
    assert_path_valid(RECT, r2, (0, 0), (11, 0))


@pytest.mark.parametrize("algo", [bug1, bug2])
@pytest.mark.parametrize("turn", ["left", "right"])
@pytest.mark.parametrize("goal", [(12.5, 0.0), (5.5, 0.0), (12.0, 4.0)])
def test_classic_example_reaches_goal(algo, turn, goal):
    res = algo(CLASSIC, (0, 0), goal, options=BugOptions(turn=turn))
    assert res.success, res.status
    assert_path_valid(CLASSIC, res, (0, 0), goal)
    # Bug1 bound: |SG| + 1.5 * sum of perimeters
    per = sum(
        np.linalg.norm(np.diff(np.vstack([v, v[:1]]), axis=0), axis=1).sum()
        for v in CLASSIC.loop_vertices
    )
    if algo is bug1:
        assert res.length <= np.hypot(*np.subtract(goal, (0, 0))) + 1.5 * per + 1e-9


def test_bug2_leaves_only_on_mline_closer_to_goal():
    res = bug2(CLASSIC, (0, 0), (12.5, 0.0))
    d_prev = np.inf
    for h, leave in zip(res.hit_points, res.leave_points):
        assert abs(leave[1]) < 1e-9  # on the m-line y = 0
        assert np.linalg.norm(leave - (12.5, 0)) < np.linalg.norm(h - (12.5, 0))
        assert np.linalg.norm(h - (12.5, 0)) < d_prev
        d_prev = np.linalg.norm(leave - (12.5, 0))


@pytest.mark.parametrize("algo", [bug1, bug2])
def test_enclosed_goal_reports_failure(algo):
    ring = PolygonWorld((Polygon.ring((6, 0), (1.5, 1.5), (2.5, 2.5)),), BOUNDS)
    res = algo(ring, (0, 0), (6, 0.5))
    assert not res.success and res.status is BugStatus.GOAL_UNREACHABLE
    # the robot circled the whole outer boundary (perimeter 20) at least once
    assert res.length >= 2.5 + 20 - 1e-9
    assert_path_valid(ring, res, (0, 0), (6, 0.5))


def test_goal_on_far_side_of_ring_hole_is_reached_when_start_is_inside():
    ring = PolygonWorld((Polygon.ring((6, 0), (1.5, 1.5), (2.5, 2.5)),), BOUNDS)
    res = bug2(ring, (5, 0), (7, 1))
    assert res.success and res.length == pytest.approx(np.hypot(2, 1))


def test_errors():
    with pytest.raises(PlanningError, match=r"start \(4, 0\) is inside obstacle 0"):
        bug2(RECT, (4, 0), (11, 0))
    with pytest.raises(PlanningError, match=r"goal \(20, 0\) is outside the world bounds"):
        bug1(RECT, (0, 0), (20, 0))
    with pytest.raises(UnknownNameError, match="valid turns are: left, right"):
        bug1(RECT, (0, 0), (11, 0), options=BugOptions(turn="up"))  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="max_hits must be an integer >= 1"):
        bug2(RECT, (0, 0), (11, 0), options=BugOptions(max_hits=0))


def test_polygon_world_queries_against_references():
    from matplotlib.path import Path

    rng = np.random.default_rng(1)
    pts = rng.uniform([-1, -6], [14, 6], (2000, 2))
    ref = Path(np.vstack([C_SHAPE.vertices, C_SHAPE.vertices[:1]]), closed=True).contains_points(
        pts
    )
    world = PolygonWorld((C_SHAPE,))
    np.testing.assert_array_equal(world.contains(pts), ref)
    # distance to a rectangle: analytic box distance outside
    box = PolygonWorld((Polygon.rectangle(0, 0, 2, 1),))
    q = rng.uniform(-3, 5, (500, 2))
    dx = np.maximum(np.maximum(-q[:, 0], q[:, 0] - 2), 0)
    dy = np.maximum(np.maximum(-q[:, 1], q[:, 1] - 1), 0)
    outside = (dx > 0) | (dy > 0)
    np.testing.assert_allclose(box.signed_distance(q)[outside], np.hypot(dx, dy)[outside])
    inside_d = np.minimum.reduce([q[:, 0], 2 - q[:, 0], q[:, 1], 1 - q[:, 1]])
    np.testing.assert_allclose(box.signed_distance(q)[~outside], -inside_d[~outside])
    # segment intersections: horizontal line through the box at y = 0.5
    hits = box.segment_hits((-1, 0.5), (3, 0.5))
    assert [round(h.t, 12) for h in hits] == [0.25, 0.75]
    assert not box.segment_free((-1, 0.5), (3, 0.5)) and box.segment_free((-1, 2), (3, 2))
    with pytest.raises(InvalidInputError, match="at least 3 vertices"):
        Polygon(np.zeros((2, 2)))
