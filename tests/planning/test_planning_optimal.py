"""PRM*, Lazy PRM* and BIT* converge toward analytic optima (2-D obstacle, 7-D Panda).

References: the shortest path around a square obstacle (two tangent segments and one side:
``2 sqrt(0.3^2 + 0.2^2) + 0.2``) and, for the Panda without obstacles, the straight line in
joint space (checked free at 5 mm first), whose length is ``|q_goal - q_start|``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, PlanningError
from taskspace.model import Obstacle, Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

OPTIMUM_2D = 2 * math.hypot(0.3, 0.2) + 0.2
START_2D, GOAL_2D = [0.1, 0.5], [0.9, 0.5]


def square_world(resolution: float = 0.005) -> ConfigurationSpace:
    """[0,1]^2 with the square obstacle [0.4,0.6]x[0.3,0.7]."""

    def free(Q: np.ndarray) -> np.ndarray:
        inside = (Q[:, 0] > 0.4) & (Q[:, 0] < 0.6) & (Q[:, 1] > 0.3) & (Q[:, 1] < 0.7)
        return ~inside

    return ConfigurationSpace(
        [0, 0], [1, 1], FunctionChecker(free), edge=EdgeCheckOptions(resolution=resolution)
    )


def _plan(name: str, space: ConfigurationSpace, start, goal, n: int, seed: int = 0):  # type: ignore[no-untyped-def]
    if name == "bit_star":
        return bit_star(
            space, start, goal, BITStarOptions(max_iterations=n, time_limit_s=None, seed=seed)
        )
    fn = prm_star if name == "prm_star" else lazy_prm_star
    return fn(space, start, goal, PRMStarOptions(max_iterations=n, time_limit_s=None, seed=seed))[0]


def _check_anytime(result, optimum: float, tolerance: float) -> None:  # type: ignore[no-untyped-def]
    assert result.success and result.status is PlannerStatus.SOLVED
    costs = result.log["costs"]
    assert all(b < a for a, b in itertools.pairwise(costs))  # anytime: only improves
    assert len(result.log["cost_times"]) == len(costs)
    assert result.cost == pytest.approx(costs[-1])
    assert result.path_length == pytest.approx(result.cost)  # Euclidean length objective
    assert optimum - 1e-9 <= result.path_length <= optimum * (1 + tolerance)


@pytest.mark.parametrize(
    ("name", "n"), [("prm_star", 600), ("lazy_prm_star", 1000), ("bit_star", 500)]
)
def test_converges_toward_the_shortest_path_around_a_square(name: str, n: int) -> None:
    space = square_world()
    result = _plan(name, space, START_2D, GOAL_2D, n, seed=1)
    _check_anytime(result, OPTIMUM_2D, 0.03)
    assert result.log["costs"][0] > result.path_length  # it did improve on its first path
    assert square_world().path_valid(result.path)  # at the planner's resolution
    assert result.iterations == n


def test_lazy_prm_star_returns_the_eager_roadmap_path() -> None:
    """Lazy checking changes which edges are checked, not the answer (same samples: no
    expansion walks, whose sources differ between eager and lazy checking)."""
    eager, roadmap = prm_star(
        square_world(), START_2D, GOAL_2D,
        PRMStarOptions(max_iterations=300, time_limit_s=None, expand_fraction=0.0),
    )  # fmt: skip
    lazy, lazy_roadmap = lazy_prm_star(
        square_world(), START_2D, GOAL_2D,
        PRMStarOptions(max_iterations=300, time_limit_s=None, expand_fraction=0.0),
    )  # fmt: skip
    np.testing.assert_array_equal(eager.path, lazy.path)
    assert lazy.edge_checks < eager.edge_checks / 10
    assert np.count_nonzero(lazy_roadmap.status == 0) > 0  # most edges never checked
    assert roadmap.size == lazy_roadmap.roadmap.size == 302  # start, goal, 300 samples


def test_prm_star_uses_k_log_n_neighbours() -> None:
    """Every sample is joined to its k_n = ceil(e (1 + 1/d) log n) nearest nodes.

    A small box blocks the straight line (which would be optimal at once and end the plan);
    Lazy PRM* keeps every candidate edge in ``pairs``, checked or not.
    """

    def free(Q: np.ndarray) -> np.ndarray:
        return ~((np.abs(Q[:, 0] - 0.5) < 0.02) & (np.abs(Q[:, 1] - 0.5) < 0.02))

    space = ConfigurationSpace([0, 0], [1, 1], FunctionChecker(free))
    opts = PRMStarOptions(
        max_iterations=64, batch_size=64, time_limit_s=None, expand_fraction=0.0
    )  # uniform samples only (no expansion walks)
    _, lazy = lazy_prm_star(space, [0.1, 0.1], [0.9, 0.9], opts)
    n = lazy.roadmap.size
    assert n == 66
    k = math.ceil(math.e * 1.5 * math.log(n))
    degrees = np.bincount(lazy.pairs.ravel(), minlength=n)[2:]  # the 64 samples of one batch
    assert degrees.min() >= k  # each joined its k nearest (plus the nodes that chose it)
    assert (degrees == k).any()  # and not more of its own


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda", convex_collision=True)


@pytest.fixture(scope="module")
def panda_free(panda: Robot) -> tuple[ConfigurationSpace, np.ndarray, np.ndarray]:
    robot = panda
    space = ConfigurationSpace.from_robot(robot)
    q0 = robot.q_default.copy()
    start, goal = q0.copy(), q0.copy()
    start[[0, 2, 3]] += [-2.0, -1.0, 0.6]
    goal[[0, 1, 2, 5]] += [2.0, 0.5, 1.0, 1.0]
    assert space.path_valid(np.stack([start, goal]), resolution=0.005)
    return space, start, goal


@pytest.mark.parametrize(
    ("name", "n", "tolerance"), [("bit_star", 600, 0.005), ("lazy_prm_star", 300, 1e-9)]
)
def test_panda_in_free_space_converges_to_the_straight_line(
    panda_free, name: str, n: int, tolerance: float
) -> None:  # type: ignore[no-untyped-def]
    space, start, goal = panda_free
    result = _plan(name, space, start, goal, n)
    _check_anytime(result, float(np.linalg.norm(goal - start)), tolerance)
    assert space.path_valid(result.path, resolution=0.01)


ALL_PLANNERS = {
    "rrt": lambda s, it, t: rrt(
        s, START_2D, GOAL_2D, RRTOptions(max_iterations=it, time_limit_s=t)
    ),
    "rrt_connect": lambda s, it, t: rrt_connect(
        s, START_2D, GOAL_2D, RRTConnectOptions(max_iterations=it, time_limit_s=t)
    ),
    "rrt_star": lambda s, it, t: rrt_star(
        s, START_2D, GOAL_2D, RRTStarOptions(max_iterations=it, time_limit_s=t)
    ),
    "prm_star": lambda s, it, t: prm_star(
        s, START_2D, GOAL_2D, PRMStarOptions(max_iterations=it, time_limit_s=t)
    )[0],
    "lazy_prm_star": lambda s, it, t: lazy_prm_star(
        s, START_2D, GOAL_2D, PRMStarOptions(max_iterations=it, time_limit_s=t)
    )[0],
    "bit_star": lambda s, it, t: bit_star(
        s, START_2D, GOAL_2D, BITStarOptions(max_iterations=it, time_limit_s=t)
    ),
    "prm": lambda s, it, t: prm(
        s, START_2D, GOAL_2D, PRMOptions(max_iterations=it, time_limit_s=t)
    )[0],
    "lazy_prm": lambda s, it, t: lazy_prm(
        s, START_2D, GOAL_2D, PRMOptions(max_iterations=it, batch_size=50), time_limit_s=t
    )[0],
}


@pytest.mark.parametrize("name", list(ALL_PLANNERS))
def test_one_limit_convention(name: str) -> None:
    plan = ALL_PLANNERS[name]
    for bad in (math.nan, -1.0, True, "1"):
        with pytest.raises(InvalidInputError, match="time_limit_s"):
            plan(square_world(), 100, bad)
    with pytest.raises(InvalidInputError, match="max_iterations"):
        plan(square_world(), None, None)  # no limit at all (PRM: no roadmap size)
    with pytest.raises(InvalidInputError, match="max_iterations"):
        plan(square_world(), -1, 1.0)
    if name != "prm":  # PRM's cap is its roadmap size
        res = plan(square_world(), None, 0.0)  # no cap, no time: stops at once
        assert res.status in (PlannerStatus.TIME_LIMIT, PlannerStatus.SOLVED)
        if not res.success:
            assert res.status is PlannerStatus.TIME_LIMIT
    res = plan(square_world(), 0 if name != "prm" else 1, None)
    if not res.success:
        assert res.status is PlannerStatus.ITERATION_LIMIT
        assert res.log["stopped_by"] == "iterations"
    # the same result fields: what stopped it and the cost over time
    res = plan(square_world(), 400, 10.0)
    assert res.success and res.status is PlannerStatus.SOLVED
    assert res.log["stopped_by"] in ("first solution", "iterations", "optimal")
    costs, times = res.log["costs"], res.log["cost_times"]
    assert len(costs) == len(times) >= 1 and np.all(np.diff(costs) < 0)
    assert np.all(np.diff(times) >= 0) and 0 <= times[-1] <= res.time_s
    assert costs[-1] == pytest.approx(res.cost if res.cost is not None else res.path_length)


def test_roadmaps_refuse_a_changed_world(panda: Robot) -> None:
    """Roadmaps record the world version; a query after an obstacle change is refused."""
    robot, space = panda, ConfigurationSpace.from_robot(panda)
    q0 = robot.q_default.copy()
    q1 = q0.copy()
    q1[0] += 1.0
    _, roadmap = prm_star(space, q0, q1, PRMStarOptions(max_iterations=64, time_limit_s=None))
    eager = build_prm(space, PRMOptions(max_iterations=30, k_neighbors=4))
    lazy = build_lazy_prm(space, PRMOptions(max_iterations=30, k_neighbors=4))
    assert roadmap.world_version == eager.world_version == space.world_version is not None
    prm_query(space, eager, q0, q1, PRMOptions(k_neighbors=4))  # same world: answered
    robot.add_obstacle(Obstacle.sphere("ball", 0.05, [2.0, 2.0, 2.0]))  # touches nothing
    for query in (
        lambda: prm_query(space, roadmap, q0, q1),
        lambda: prm_query(space, eager, q0, q1),
        lambda: lazy_prm_query(space, lazy, q0, q1),
    ):
        with pytest.raises(PlanningError, match=r"world version .* build a new roadmap"):
            query()
    try:
        rebuilt = build_prm(space, PRMOptions(max_iterations=30, k_neighbors=4))
        assert rebuilt.world_version == space.world_version != roadmap.world_version
        prm_query(space, rebuilt, q0, q1, PRMOptions(k_neighbors=4))
    finally:
        robot.remove_obstacle("ball")


def test_kinodynamic_rrt_follows_the_limit_convention() -> None:
    from taskspace.planning.car import CarModel
    from taskspace.planning.kinodynamic_rrt import (
        KinodynamicRRTOptions,
        kinodynamic_rrt,
        parking_lot,
    )

    scene = parking_lot(lane_width=8.4)
    with pytest.raises(InvalidInputError, match="max_iterations=None needs a finite time_limit_s"):
        kinodynamic_rrt(CarModel(), *scene, options=KinodynamicRRTOptions(max_iterations=None))
    res = kinodynamic_rrt(
        CarModel(), *scene, options=KinodynamicRRTOptions(max_iterations=None, time_limit_s=0.0)
    )
    assert not res.success and res.status.value == "time_limit"


class Disk:
    """A goal region: the disk of radius r about c (sampled uniformly)."""

    def __init__(self, c: list[float], r: float) -> None:
        self.c, self.r = np.array(c), r

    def contains(self, q: np.ndarray) -> bool:
        return bool(np.linalg.norm(q - self.c) <= self.r)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        a, u = rng.uniform(0, 2 * np.pi), np.sqrt(rng.random())
        return self.c + self.r * u * np.array([np.cos(a), np.sin(a)])


@pytest.mark.parametrize("name", ["prm_star", "lazy_prm_star", "bit_star"])
def test_goal_region_is_reached_near_its_analytic_optimum(name: str) -> None:
    """Around the square's corner to the nearest point of a disk behind it."""
    region = Disk([0.9, 0.5], 0.05)
    result = _plan(name, square_world(), START_2D, region, 400)
    assert result.success and region.contains(result.path[-1])
    corner = np.array([0.6, 0.7])
    optimum = math.hypot(0.3, 0.2) + 0.2 + float(np.linalg.norm(region.c - corner)) - region.r
    assert optimum - 1e-9 <= result.path_length <= optimum * 1.05
    assert square_world().path_valid(result.path)


def test_prm_time_limit_cuts_the_roadmap_and_says_so() -> None:
    """PRM's max_iterations is its roadmap size (the cap); a time limit that ends the edge
    checks gives TIME_LIMIT."""
    res, roadmap = prm(
        square_world(), START_2D, GOAL_2D, PRMOptions(max_iterations=200, time_limit_s=0.0)
    )
    assert not res.success and res.status is PlannerStatus.TIME_LIMIT
    assert roadmap.edges_tried == 0 and roadmap.edges.shape[0] == 0
    res, roadmap = prm(
        square_world(), START_2D, GOAL_2D, PRMOptions(max_iterations=200, time_limit_s=None)
    )
    assert res.success and roadmap.edges_tried > 0


def test_bit_star_keeps_its_solution_when_pruning() -> None:
    """After pruning (every batch after the first solution) the best path is still there."""
    for seed in range(4):
        opts = BITStarOptions(max_iterations=300, batch_size=50, time_limit_s=None, seed=seed)
        res = bit_star(square_world(), START_2D, GOAL_2D, opts)
        assert res.success and res.log["batches"] > 1
        assert res.cost == pytest.approx(res.log["costs"][-1])
        assert res.path_length == pytest.approx(res.cost)


@pytest.mark.parametrize("name", ["prm_star", "lazy_prm_star", "bit_star"])
def test_planners_stop_once_the_cost_reaches_its_lower_bound(panda_free, name: str) -> None:  # type: ignore[no-untyped-def]
    """The straight line's length bounds every path's: reaching it proves optimality."""
    space, start, goal = panda_free
    result = _plan(name, space, start, goal, 5000)
    assert result.log["stopped_by"] == "optimal" and result.iterations < 5000
    assert result.cost == pytest.approx(float(np.linalg.norm(goal - start)), rel=1e-9)
