"""B-spline smoothing and shortcutting never return a colliding path; certified planner paths.

Independent references: an exact segment-box intersection test (Liang-Barsky clipping)
against the boxes shrunk by the checker's resolution (a path free at resolution ``delta``
can cut a box corner by less than ``delta``), and for the Panda Pinocchio's own
``computeCollisions`` on configurations 2 mrad apart along the returned path.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, PlanningError
from taskspace.model import Obstacle, Robot
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star
from taskspace.planning.shortcut import shortcut_path
from taskspace.planning.smoothing import SmoothingOptions, smooth_bspline
from tests.planning._planning_worlds import WALL, wall_space

RESOLUTION = 0.02


def segment_hits_box(a: np.ndarray, b: np.ndarray, box: np.ndarray) -> bool:
    """Exact: does the closed segment a-b meet the open box (xmin, ymin, xmax, ymax)?"""
    t0, t1 = 0.0, 1.0
    d = b - a
    for axis in (0, 1):
        lo, hi = box[axis], box[axis + 2]
        if abs(d[axis]) < 1e-15:
            if not lo < a[axis] < hi:
                return False
            continue
        ta, tb = sorted(((lo - a[axis]) / d[axis], (hi - a[axis]) / d[axis]))
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 >= t1:
            return False
    return True


def exactly_free(path: np.ndarray, margin: float) -> bool:
    shrunk = WALL + np.array([margin, margin, -margin, -margin])
    return not any(
        segment_hits_box(a, b, box) for a, b in itertools.pairwise(path) for box in shrunk
    )


def max_turn(path: np.ndarray) -> float:
    """Largest angle between consecutive non-degenerate segments [rad]."""
    seg = np.diff(path, axis=0)
    seg = seg[np.linalg.norm(seg, axis=1) > 1e-9]
    u = seg / np.linalg.norm(seg, axis=1)[:, None]
    return float(np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1, 1)).max())


ZIGZAG = np.array(
    [[1.0, 5.0], [3.0, 8.0], [4.4, 5.5], [5.0, 5.0], [5.6, 4.5], [7.0, 2.0], [9.0, 5.0]]
)
# Through the gap (y in [4, 6]) hugging its upper edge: cutting these corners enters the wall.
HUGGING = np.array([[1.0, 9.0], [4.45, 5.97], [5.55, 5.97], [9.0, 9.0]])


def test_smoothed_path_is_free_shorter_and_smoother() -> None:
    path = ZIGZAG
    space = wall_space(resolution=RESOLUTION)
    assert space.path_valid(path)
    result = smooth_bspline(space, path, SmoothingOptions(max_step=0.3, max_iterations=8))
    out = result.path
    np.testing.assert_array_equal(out[[0, -1]], path[[0, -1]])
    assert space.path_valid(out)
    assert exactly_free(out, margin=RESOLUTION)
    assert result.length_after <= result.length_before + 1e-12
    assert result.length_after == pytest.approx(np.linalg.norm(np.diff(out, axis=0), axis=1).sum())
    assert max_turn(out) < max_turn(path)
    assert result.moved > 0


def test_smoothing_refuses_moves_into_the_wall() -> None:
    space = wall_space(resolution=RESOLUTION)
    result = smooth_bspline(space, HUGGING, SmoothingOptions(max_step=0.3, max_iterations=8))
    assert result.rejected > 0  # corners next to the wall could not be cut
    assert space.path_valid(result.path) and exactly_free(result.path, margin=RESOLUTION)
    assert result.length_after <= result.length_before + 1e-12


@pytest.mark.parametrize(
    "path",
    [
        [[1.0, 5.0], [5.0, 8.0], [9.0, 5.0]],  # a waypoint in the wall
        [[1.0, 2.0], [9.0, 2.0]],  # free end points, the edge crosses the wall
    ],
    ids=["waypoint", "edge"],
)
def test_colliding_input_is_refused(path: list[list[float]]) -> None:
    space = wall_space(resolution=RESOLUTION)
    with pytest.raises(PlanningError, match="in collision"):
        smooth_bspline(space, path)
    with pytest.raises(PlanningError, match="in collision"):
        shortcut_path(space, path)


def test_shortcut_result_is_exactly_free() -> None:
    space = wall_space(resolution=RESOLUTION)
    out = shortcut_path(space, ZIGZAG).path
    assert space.path_valid(out) and exactly_free(out, margin=RESOLUTION)


def test_smoothing_options_are_checked() -> None:
    space = wall_space()
    with pytest.raises(InvalidInputError, match="max_step"):
        smooth_bspline(space, ZIGZAG, SmoothingOptions(max_step=0.0))
    with pytest.raises(InvalidInputError, match="time_limit_s"):
        smooth_bspline(space, ZIGZAG, SmoothingOptions(time_limit_s=math.nan))
    with pytest.raises(InvalidInputError, match="max_iterations"):
        smooth_bspline(space, ZIGZAG, SmoothingOptions(max_iterations=None, time_limit_s=None))


@pytest.fixture(scope="module")
def panda_block() -> tuple[Robot, ConfigurationSpace, np.ndarray, np.ndarray]:
    robot = Robot.load("panda", convex_collision=True)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_default)
    hand = data.oMf[robot.model.getFrameId("panda_hand_tcp")].translation
    robot.add_obstacle(Obstacle.box("block", [0.12, 0.12, 0.12], hand.copy()))
    space = ConfigurationSpace.from_robot(robot)
    q0 = robot.q_default.copy()
    start, goal = q0.copy(), q0.copy()
    start[0], goal[0] = -1.2, 1.2
    # the block sits at the hand: turning the base joint straight through it collides (the
    # former block at (0.5, 0, 0.35) did not, so the planners returned the straight line)
    assert not space.motion_valid(start, goal)
    return robot, space, start, goal


def _dense_collision_free(robot: Robot, path: np.ndarray, step: float = 0.002) -> bool:
    data, gdata = robot.model.createData(), robot.collision_model.createData()
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(np.linalg.norm(b - a) / step))
        for t in np.arange(n + 1) / n:
            q = a + t * (b - a)
            if pin.computeCollisions(robot.model, data, robot.collision_model, gdata, q, True):
                return False
    return True


@pytest.mark.parametrize("planner", ["rrt_connect", "rrt_star"])
def test_certified_planner_paths_are_free_everywhere(panda_block, planner: str) -> None:  # type: ignore[no-untyped-def]
    robot, space, start, goal = panda_block
    if planner == "rrt_connect":
        result = rrt_connect(space, start, goal, RRTConnectOptions(certify=True, seed=1))
    else:
        opts = RRTStarOptions(certify=True, max_iterations=300, time_limit_s=None, seed=1)
        result = rrt_star(space, start, goal, opts)
    assert result.success and result.log["certified"] == 1.0
    assert result.log["min_distance"] >= 1e-4
    assert _dense_collision_free(robot, result.path)


def test_uncertifiable_paths_are_reported(panda_block) -> None:  # type: ignore[no-untyped-def]
    _, space, start, goal = panda_block
    opts = RRTConnectOptions(certify=True, certify_retries=1, certify_tolerance=5.0, seed=1)
    result = rrt_connect(space, start, goal, opts)  # no path keeps 5 m from the block
    assert not result.success and result.status is PlannerStatus.UNCERTIFIED
    assert result.log["certify_attempts"] == 2.0 and result.log["certified"] == 0.0
    assert result.log["uncertified_segment"] == 0.0 and result.path.shape[0] >= 2


def test_certify_needs_a_robot() -> None:
    with pytest.raises(InvalidInputError, match="certify=True needs a space built on a robot"):
        rrt_connect(wall_space(), [1, 5], [9, 5], RRTConnectOptions(certify=True))
