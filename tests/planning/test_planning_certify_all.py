"""``certify=True`` for plain RRT, PRM (and its query), Lazy PRM (and its query) (#22 item 5).

A disc (radius 0.02 m) slides in the plane on two prismatic joints; a wall 0.01 m thick
stands across ``x = 0`` from ``y = -1`` to ``y = 0`` (a gap above it). The space checks
edges at 0.08 m, so a segment crossing the wall is often passed between two checked points
(the disc and wall together span only 0.05 m; the straight start-goal line is caught).
The reference is independent of the certificate: Pinocchio/coal's ``computeDistances``
every 1e-3 m along each returned segment must stay > 0. Each planner with
``certify=True`` returns such a free path or reports failure, never ``SOLVED`` with a
colliding path; the same planners without it do return colliding paths here (the set-up
bites). Skipping the certification in
:func:`~taskspace.planning.certify.certify_planned` fails these tests.
"""

from __future__ import annotations

import itertools
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot
from taskspace.planning import certify as certify_module
from taskspace.planning.car import CarModel
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.kinodynamic_rrt import (
    KinodynamicRRTOptions,
    kinodynamic_rrt,
    parking_lot,
)
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.rrt import RRTOptions, rrt
from tests.planning._planning_worlds import wall_space

_URDF = """<?xml version="1.0"?>
<robot name="disc">
  <link name="world"/>
  <link name="slider"/>
  <link name="disc">
    <collision><geometry><sphere radius="0.02"/></geometry></collision>
    <inertial><mass value="1"/>
      <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="x" type="prismatic"><parent link="world"/><child link="slider"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="y" type="prismatic"><parent link="slider"/><child link="disc"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""
START = np.array([-0.3, -0.3])
GOAL = np.array([0.3, -0.3])
SEEDS = range(8)


@pytest.fixture(scope="module")
def disc(tmp_path_factory: pytest.TempPathFactory) -> tuple[Robot, ConfigurationSpace]:
    path = Path(tmp_path_factory.mktemp("disc")) / "disc.urdf"
    path.write_text(_URDF)
    robot = Robot.from_urdf(path)
    robot.add_obstacle(Obstacle.box("wall", [0.01, 1.0, 0.2], [0.0, -0.5, 0.0]))
    return robot, ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.08))


def dense_least_distance(robot: Robot, path: np.ndarray, step: float = 1e-3) -> float:
    """Pinocchio/coal signed distance every ``step`` m along the straight segments."""
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    least = math.inf
    for a, b in itertools.pairwise(path if len(path) > 1 else [path[0], path[0]]):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / step))
        for t in np.arange(n + 1) / n:
            pin.computeDistances(model, data, gm, gd, a + t * (b - a))
            least = min(least, min(r.min_distance for r in gd.distanceResults))
    return least


def _run(name: str, space: ConfigurationSpace, seed: int, certify: bool) -> Any:
    if name == "rrt":
        opts = RRTOptions(step_size=0.3, seed=seed, certify=certify, time_limit_s=None)
        return rrt(space, START, GOAL, opts)
    prm_opts = PRMOptions(max_iterations=60, batch_size=30, seed=seed, certify=certify)
    if name == "prm":
        return prm(space, START, GOAL, prm_opts)[0]
    if name == "lazy_prm":
        return lazy_prm(space, START, GOAL, prm_opts, time_limit_s=math.inf)[0]
    if name == "prm_query":
        roadmap = build_prm(space, PRMOptions(max_iterations=60, seed=seed))
        return prm_query(space, roadmap, START, GOAL, prm_opts)
    lazy = build_lazy_prm(space, PRMOptions(max_iterations=60, seed=seed))
    return lazy_prm_query(space, lazy, START, GOAL, prm_opts)


PLANNERS = ["rrt", "prm", "lazy_prm", "prm_query", "lazy_prm_query"]


def test_the_wall_is_missed_at_the_resolution(disc) -> None:  # type: ignore[no-untyped-def]
    robot, space = disc
    a, b = np.array([-0.5, -0.5]), np.array([0.5, -0.5])  # checked at x = +-0.038, not 0
    assert space.motion_valid(a, b)
    assert dense_least_distance(robot, np.array([a, b])) < 0.0
    assert not space.motion_valid(START, GOAL)  # checked at x = 0: the straight line is out


def _tally(robot: Robot, space: ConfigurationSpace, name: str) -> tuple[int, int]:
    """Over the seeds: (uncertified paths that collide, certified paths); checks each result."""
    colliding_uncertified = certified = 0
    for seed in SEEDS:
        plain = _run(name, space, seed, certify=False)
        if plain.success and dense_least_distance(robot, plain.path) <= 0.0:
            colliding_uncertified += 1
        result = _run(name, space, seed, certify=True)
        assert "certify_attempts" in result.log
        if result.success:
            assert result.status is PlannerStatus.SOLVED
            assert result.log["certified"] == 1.0
            np.testing.assert_allclose(result.path[[0, -1]], [START, GOAL])
            least = dense_least_distance(robot, result.path)
            assert least > 0.0
            # min_distance is the least distance at the certificate's query points: the
            # dense minimum is not above it (up to the 1e-3 m sampling of the reference).
            assert least <= result.log["min_distance"] + 1e-3
            certified += 1
        elif result.log.get("certified") == 0.0:
            assert result.status is PlannerStatus.UNCERTIFIED
            assert result.log["uncertified_segment"] >= 0.0
            assert 0.0 <= result.log["uncertified_t"] <= 1.0
    return colliding_uncertified, certified


@pytest.mark.parametrize("name", PLANNERS)
def test_certified_paths_are_free_everywhere_or_refused(disc, name: str) -> None:  # type: ignore[no-untyped-def]
    colliding_uncertified, certified = _tally(*disc, name)
    assert colliding_uncertified > 0  # without certify the wall is crossed
    if not name.endswith("query"):  # re-planned: certified paths are found (through the gap)
        assert certified > 0


def test_queries_certify_some_paths(disc) -> None:  # type: ignore[no-untyped-def]
    # The queries search their fixed roadmaps again without the failed segment: over both,
    # some path is certified, so the free branch of _tally is exercised for them too.
    assert _tally(*disc, "prm_query")[1] + _tally(*disc, "lazy_prm_query")[1] > 0


def test_retries_replan_without_the_failed_line(disc) -> None:  # type: ignore[no-untyped-def]
    # PRM and Lazy PRM try the straight line first; it is not certified, and the re-plans
    # (new roadmaps for prm/lazy_prm, the same for the queries) do not take it again
    # (test_planning_certify_retries checks every failed segment, for PRM* too).
    _, space = disc
    a, b = np.array([-0.5, -0.5]), np.array([0.5, -0.5])  # the straight line is taken first
    opts = PRMOptions(max_iterations=20, certify=True, certify_retries=2)
    roadmap = build_prm(space, PRMOptions(max_iterations=20))
    lazy = build_lazy_prm(space, PRMOptions(max_iterations=20))
    for result in (
        prm(space, a, b, opts)[0],
        lazy_prm(space, a, b, opts, time_limit_s=math.inf)[0],
        prm_query(space, roadmap, a, b, opts),
        lazy_prm_query(space, lazy, a, b, opts),
    ):
        assert not result.success and result.log["certify_attempts"] > 1.0
        if result.status is PlannerStatus.UNCERTIFIED:
            assert result.log["stopped_by"] == "uncertified"
            assert result.log["certified"] == 0.0
            assert result.path.shape[0] > 2  # not the line through the wall


@pytest.mark.parametrize("name", PLANNERS)
def test_certification_gets_the_time_limit(disc, monkeypatch, name: str) -> None:  # type: ignore[no-untyped-def]
    _, space = disc
    seen: list[float] = []
    real = certify_module.certify_path

    def spy(*args: Any, **kwargs: Any) -> Any:
        seen.append(kwargs["deadline"])
        return real(*args, **kwargs)

    monkeypatch.setattr(certify_module, "certify_path", spy)
    a, b = np.array([-0.5, -0.5]), np.array([0.5, -0.5])
    t0 = time.perf_counter()
    if name == "rrt":
        rrt(space, a, b, RRTOptions(certify=True, time_limit_s=30.0, max_iterations=None))
    elif name == "prm":
        prm(space, a, b, PRMOptions(max_iterations=20, certify=True, time_limit_s=30.0))
    elif name == "lazy_prm":
        lazy_prm(space, a, b, PRMOptions(max_iterations=20, certify=True, time_limit_s=30.0))
    elif name == "prm_query":
        roadmap = build_prm(space, PRMOptions(max_iterations=20))
        prm_query(space, roadmap, a, b, PRMOptions(certify=True, time_limit_s=30.0))
    else:
        lazy = build_lazy_prm(space, PRMOptions(max_iterations=20))
        lazy_prm_query(space, lazy, a, b, PRMOptions(certify=True), time_limit_s=30.0)
    t1 = time.perf_counter()
    assert seen and all(t0 + 30.0 <= d <= t1 + 30.0 for d in seen)


def test_a_spent_budget_stops_the_certification(disc, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # The certification reads the clock before each distance query: with the deadline
    # already passed (a clock jumping by 1 h after planning) the result is TIME_LIMIT.
    _, space = disc
    real = certify_module.certify_path

    def late(*args: Any, **kwargs: Any) -> Any:
        kwargs["deadline"] = kwargs["deadline"] - 3600.0
        return real(*args, **kwargs)

    monkeypatch.setattr(certify_module, "certify_path", late)
    a, b = np.array([-0.5, -0.5]), np.array([-0.5, 0.5])  # a free line
    result = prm(space, a, b, PRMOptions(max_iterations=5, certify=True, time_limit_s=60.0))[0]
    assert not result.success and result.status is PlannerStatus.TIME_LIMIT
    assert result.log["stopped_by"] == "time" and result.log["certified"] == 0.0


@pytest.mark.parametrize("name", PLANNERS)
def test_certify_needs_a_robot(name: str) -> None:
    space = wall_space()
    a, b = np.array([1.0, 5.0]), np.array([9.0, 5.0])
    with pytest.raises(InvalidInputError, match="certify=True needs a space built on a robot"):
        if name == "rrt":
            rrt(space, a, b, RRTOptions(certify=True))
        elif name == "prm":
            prm(space, a, b, PRMOptions(certify=True))
        elif name == "lazy_prm":
            lazy_prm(space, a, b, PRMOptions(certify=True, time_limit_s=1.0))
        elif name == "prm_query":
            prm_query(space, build_prm(space, PRMOptions(max_iterations=5)), a, b,
                      PRMOptions(certify=True))  # fmt: skip
        else:
            lazy_prm_query(space, build_lazy_prm(space, PRMOptions(max_iterations=5)), a, b,
                           PRMOptions(certify=True))  # fmt: skip


def test_kinodynamic_rrt_refuses_certify() -> None:
    world, start, goal = parking_lot()
    model = CarModel()
    with pytest.raises(InvalidInputError, match="kinodynamic_rrt cannot certify"):
        kinodynamic_rrt(model, world, start, goal, options=KinodynamicRRTOptions(certify=True))
    plain = kinodynamic_rrt(
        model, world, start, goal, options=KinodynamicRRTOptions(max_iterations=50)
    )
    assert plain.iterations > 0  # certify=False (the default) still plans
