"""The compiled RRT-Connect and collision check (taskspace/_native) against the Python path."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

import taskspace._native
from taskspace._native import planning_kernel, status
from taskspace.errors import PlanningError
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import (
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from tests.planning._mbm import ROOT, SKIP_REASON
from tests.planning._planning_worlds import wall_space

DELTA = 0.03  # planner resolution [rad]
POOL = CollisionCheckerOptions(native=False)  # Pinocchio's broad-phase pool, no kernel

if os.environ.get("TASKSPACE_REQUIRE_NATIVE"):

    def test_kernel_is_built() -> None:
        assert planning_kernel() is not None, status()


pytestmark = [
    pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}"),
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
]


@pytest.fixture(scope="module")
def robot():  # type: ignore[no-untyped-def]
    return motionbenchmaker_panda()


def _space(robot, scenario: str, index: int):  # type: ignore[no-untyped-def]
    req = motionbenchmaker_problems(ROOT, scenario, [index])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=DELTA))
    return space, req.start, req.goal


def _edge_points(path: np.ndarray, resolution: float) -> np.ndarray:
    """Points k / n of every edge, n = ceil(|edge| / resolution) (end points included)."""
    out = []
    for a, b in zip(path[:-1], path[1:]):  # noqa: RUF007
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / resolution - 1e-12))
        out.append(a + (np.arange(n + 1) / n)[:, None] * (b - a))
    return np.vstack(out)


@pytest.mark.parametrize("scenario", ["bookshelf_small", "cage", "table_under_pick"])
def test_compiled_checker_agrees_with_python_checker(robot, scenario: str) -> None:  # type: ignore[no-untyped-def]
    space, _, _ = _space(robot, scenario, 2)
    checker = CollisionChecker(robot, POOL)
    kernel = CollisionChecker(robot).native_kernel()
    rng = np.random.default_rng(1)
    qs = rng.uniform(space.lower, space.upper, size=(1500, space.dim))
    reference = ~checker.are_valid(qs)
    assert 0.05 < reference.mean() < 0.95  # both answers occur
    assert kernel.mode == 2  # default: the pair list
    for mode in (0, 1, 2):  # Pinocchio's tree manager, with the fast update, the pair list
        kernel.mode = mode
        got = np.asarray(kernel.collisions(qs), dtype=bool)
        differ = np.flatnonzero(got != reference)
        # coal's GJK keeps a warm start per pair, so a configuration that grazes an obstacle
        # (|penetration| below a millimetre) may be answered differently after another history.
        assert differ.size <= 3
        for i in differ:
            assert abs(checker.distance(qs[i])[0]) < 1e-3
    # first_invalid: the index of the first colliding row
    first = int(np.argmax(got))
    assert kernel.first_invalid(qs) == first
    assert kernel.first_invalid(qs[~got][:50]) == -1
    # CollisionChecker's queries through the kernel (options.native, the default)
    native = CollisionChecker(robot)
    assert native.first_invalid(qs) == first and native.checks == first + 1
    assert native.is_valid(qs[~got][0]) and not native.is_valid(qs[first])
    np.testing.assert_array_equal(native.are_valid(qs[:200]), ~got[:200])


@pytest.mark.parametrize(
    ("scenario", "index"),
    [("bookshelf_small", 3), ("bookshelf_tall", 1), ("box", 2), ("table_under_pick", 13)],
)
def test_compiled_paths_are_free(robot, scenario: str, index: int) -> None:  # type: ignore[no-untyped-def]
    space, start, goal = _space(robot, scenario, index)
    reference = CollisionChecker(robot, POOL)  # Pinocchio's broad-phase pool, not the kernel
    for seed in range(2):
        res = rrt_connect(space, start, goal, RRTConnectOptions(seed=seed, time_limit_s=1.0))
        assert res.log.get("native") == 1.0
        assert res.success and res.status is PlannerStatus.SOLVED
        assert res.time_s < 1.0
        np.testing.assert_allclose(res.path[0], start)
        np.testing.assert_allclose(res.path[-1], goal)
        assert res.path_length == pytest.approx(
            float(np.linalg.norm(np.diff(res.path, axis=0), axis=1).sum())
        )
        # The promise (as for the Python planner): every edge is free at the resolution delta.
        assert reference.are_valid(_edge_points(res.path, DELTA)).all()
        # Twice finer, a path may graze an obstacle between two checked points, only there.
        assert reference.are_valid(_edge_points(res.path, DELTA / 2)).mean() > 0.98
        assert res.collision_checks > 0 and res.edge_checks > 0
        # Tree edges are steps of at most alpha; removed nodes have no parent.
        for tree in res.trees:
            child = np.flatnonzero(tree.parents >= 0)
            seg = np.linalg.norm(tree.nodes[child] - tree.nodes[tree.parents[child]], axis=1)
            assert np.all(seg <= 0.5 + 1e-9)


def test_seeded_runs_are_deterministic(robot) -> None:  # type: ignore[no-untyped-def]
    space, start, goal = _space(robot, "bookshelf_small", 3)
    runs = [rrt_connect(space, start, goal, RRTConnectOptions(seed=s)) for s in (4, 4, 5)]
    assert runs[0].success and runs[1].success
    np.testing.assert_array_equal(runs[0].path, runs[1].path)
    assert runs[0].collision_checks == runs[1].collision_checks
    assert runs[0].iterations == runs[1].iterations
    assert runs[2].collision_checks != runs[0].collision_checks  # the seed matters
    # a passed generator seeds the kernel
    a = rrt_connect(space, start, goal, rng=np.random.default_rng(7))
    b = rrt_connect(space, start, goal, rng=np.random.default_rng(7))
    np.testing.assert_array_equal(a.path, b.path)


@pytest.mark.parametrize("n", [1, 7, 8, 9, 300, 1001])
def test_tree_nearest_is_exact(n: int) -> None:
    """The blocked nearest-neighbour scan of the kernel's trees against a brute force.

    Sizes around the block width, removed nodes (never returned), duplicated nodes (the lowest
    index wins) and queries on the nodes themselves.
    """
    module = planning_kernel()
    rng = np.random.default_rng(n)
    nodes = rng.uniform(-3.0, 3.0, (n, 7))
    if n > 8:
        nodes[n // 2] = nodes[n // 3]  # a tie
    removed = rng.choice(np.arange(1, n), size=(n - 1) // 3, replace=False) if n > 1 else []
    removed = np.asarray(removed, dtype=np.int32)
    queries = np.vstack([rng.uniform(-3.5, 3.5, (200, 7)), nodes, nodes[:: max(1, n // 5)] + 1e-9])
    got = module.tree_nearest(nodes, removed, queries)
    alive = np.setdiff1d(np.arange(n), removed)
    d2 = ((queries[:, None, :] - nodes[None, alive, :]) ** 2).sum(axis=2)
    expected = alive[np.argmin(d2, axis=1)]  # argmin: the first (lowest index) of equal ones
    np.testing.assert_array_equal(got, expected)
    assert not np.isin(got, removed).any()


_NEAREST_SCRIPT = """
import numpy as np
from taskspace._native import planning_kernel
module = planning_kernel()
for n in (1, 8, 9, 301):
    rng = np.random.default_rng(n)
    nodes = rng.uniform(-3.0, 3.0, (n, 7))
    if n > 8:
        nodes[n // 2] = nodes[n // 3]
    k = (n - 1) // 3
    removed = np.asarray(rng.choice(np.arange(1, n), size=k, replace=False) if n > 1 else [])
    removed = removed.astype(np.int32)
    queries = np.vstack([rng.uniform(-3.5, 3.5, (100, 7)), nodes])
    got = module.tree_nearest(nodes, removed, queries)
    alive = np.setdiff1d(np.arange(n), removed)
    d2 = ((queries[:, None, :] - nodes[None, alive, :]) ** 2).sum(axis=2)
    assert np.array_equal(got, alive[np.argmin(d2, axis=1)]), n
print("ok")
"""


def test_tree_nearest_sse2_code_is_exact() -> None:
    """The SSE2 version of the nearest-neighbour scan (the AVX2 one runs where the processor
    has AVX2; TASKSPACE_SIMD=sse2, read once per process, forces SSE2) against a brute force,
    in a new process."""
    import subprocess
    import sys

    env = dict(os.environ, TASKSPACE_SIMD="sse2")
    out = subprocess.run(
        [sys.executable, "-c", _NEAREST_SCRIPT],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "ok"


def test_trivial_and_limited_problems_end(robot) -> None:  # type: ignore[no-untyped-def]
    space, start, goal = _space(robot, "cage", 3)
    # start == goal
    res = rrt_connect(space, start, start)
    assert res.success and res.path.shape == (2, space.dim) and res.log.get("native") == 1.0
    # a straight line that is free: solved without a tree
    near = start + 0.01
    assert space.is_valid(near)
    res = rrt_connect(space, start, near)
    assert res.success and res.iterations == 0 and res.path.shape == (2, space.dim)
    # iteration limit
    opts = RRTConnectOptions(max_iterations=3, time_limit_s=None)
    res = rrt_connect(space, start, goal, opts)
    assert not res.success and res.status is PlannerStatus.ITERATION_LIMIT
    assert res.iterations == 3 and res.path.shape == (0, space.dim)
    assert res.path_length == math.inf
    # time limit (the iteration budget would last far longer)
    opts = RRTConnectOptions(max_iterations=10**9, time_limit_s=0.003, local_sampling=0.0)
    res = rrt_connect(space, start, goal, opts)
    assert res.status in (PlannerStatus.TIME_LIMIT, PlannerStatus.SOLVED)
    assert res.time_s < 0.2
    res = rrt_connect(space, start, goal, RRTConnectOptions(time_limit_s=0.0))
    assert res.status is PlannerStatus.TIME_LIMIT and res.time_s < 0.1


def test_bad_input_raises_before_the_kernel(robot) -> None:  # type: ignore[no-untyped-def]
    space, start, goal = _space(robot, "bookshelf_small", 1)
    bad = start.copy()
    bad[0] = np.nan
    with pytest.raises(PlanningError, match="start"):
        rrt_connect(space, bad, goal)
    with pytest.raises(PlanningError, match="goal"):
        rrt_connect(space, start, goal[:3])
    with pytest.raises(PlanningError, match="goal"):
        rrt_connect(space, start, [0.0] * 6 + ["x"])
    # outside the bounds (the kernel refuses it; the message is the Python check's)
    high = start.copy()
    high[2] = space.upper[2] + 0.25
    with pytest.raises(PlanningError, match=r"start is outside the joint limits: panda_joint3="):
        rrt_connect(space, high, goal)
    with pytest.raises(PlanningError, match=r"goal is outside the joint limits: panda_joint3="):
        rrt_connect(space, start, high.tolist())  # a list: converted by the wrapper
    closed = motionbenchmaker_panda(finger_opening=0.001)  # closed fingers hit the can
    space_c, start_c, goal_c = _space(closed, "bookshelf_small", 1)
    assert CollisionChecker(closed, POOL).are_valid(np.stack([start_c, goal_c])).tolist() == [
        True,
        False,
    ]  # Pinocchio's pool: the goal collides, the start is free
    with pytest.raises(PlanningError, match="goal is in collision: colliding pairs"):
        rrt_connect(space_c, start_c, goal_c)
    with pytest.raises(PlanningError, match="start is in collision: colliding pairs"):
        rrt_connect(space_c, goal_c, start_c)
    for checker in ("spheres", "spheres_only"):  # the endpoints are checked exactly
        with pytest.raises(PlanningError, match="goal is in collision"):
            rrt_connect(space_c, start_c, goal_c, RRTConnectOptions(checker=checker))
    # the kernel counts its two endpoint checks: a free straight line costs 2 + its points
    near = start + 0.05 * (goal - start) / np.linalg.norm(goal - start)
    res = rrt_connect(space, start, near)
    assert res.success and len(res.path) == 2
    assert res.collision_checks == 2 + math.ceil(0.05 / DELTA - 1e-12) - 1
    assert res.path_length == pytest.approx(0.05)


def test_python_path_without_kernel(robot, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(taskspace._native, "planning_kernel", lambda: None)
    space, start, goal = _space(robot, "table_pick", 1)
    assert space.checker.native_kernel() is None  # type: ignore[attr-defined]
    res = rrt_connect(space, start, goal)
    assert res.success and "native" not in res.log
    assert CollisionChecker(robot).are_valid(_edge_points(res.path, DELTA)).all()


def test_other_checkers_and_options_take_the_python_path(robot) -> None:  # type: ignore[no-untyped-def]
    res = rrt_connect(wall_space(), np.array([1.0, 1.0]), np.array([9.0, 9.0]))
    assert res.success and "native" not in res.log
    space, start, goal = _space(robot, "table_pick", 1)
    for opts in (RRTConnectOptions(native=False), RRTConnectOptions(partial_extend=True)):
        res = rrt_connect(space, start, goal, opts)
        assert res.success and "native" not in res.log
