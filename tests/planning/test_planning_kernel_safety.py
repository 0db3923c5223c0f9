"""The compiled RRT-Connect: interruptible, overflow-safe, argument-checked, thread-safe (#15).

The problem that cannot be solved: the Panda's base joint must turn by 1.2 rad, a thin plate
stands across the arc the hand sweeps, and the bounds of the space pin every other joint
(width 2e-6 rad) so that nothing can go around the plate: every plan runs to its limits.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import planning_kernel, status
from taskspace.errors import InvalidInputError, TaskspaceError
from taskspace.model import Robot
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

pytestmark = pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}")

ROOT = Path(__file__).resolve().parents[2]
DELTA = 0.03  # planner resolution [rad]

SCENE = """
import numpy as np
import pinocchio as pin
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions


def plate_robot():
    robot = Robot.load("panda", convex_collision=True)
    q0 = robot.q_default.copy()
    q1 = q0.copy()
    q1[0] += 1.2
    qm = q0.copy()
    qm[0] += 0.6
    hand = robot.frame_placement(qm, "panda_hand_tcp").translation
    yaw = float(np.arctan2(hand[1], hand[0]))
    plate = Obstacle.box("plate", [0.3, 0.005, 0.3], pin.SE3(pin.utils.rotate("z", yaw), hand))
    robot.add_obstacle(plate)
    return robot, q0, q1


def pinned_space(robot, q0):
    lower, upper = q0 - 1e-6, q0 + 1e-6
    lower[0] = robot.model.lowerPositionLimit[0]
    upper[0] = robot.model.upperPositionLimit[0]
    return ConfigurationSpace(
        lower, upper, CollisionChecker(robot), edge=EdgeCheckOptions(resolution=0.03)
    )
"""
_scene: dict[str, object] = {}
exec(SCENE, _scene)  # the same scene in this process and in the subprocess


@pytest.fixture(scope="module")
def plate() -> tuple[Robot, np.ndarray, np.ndarray]:
    return _scene["plate_robot"]()  # type: ignore[operator,no-any-return]


def _pinned(plate: tuple[Robot, np.ndarray, np.ndarray]) -> ConfigurationSpace:
    robot, q0, _ = plate
    return _scene["pinned_space"](robot, q0)  # type: ignore[operator,no-any-return]


CHILD = SCENE + textwrap.dedent(
    """
    import json, math, os, signal, sys, threading, time
    from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect

    robot, q0, q1 = plate_robot()
    out = []
    for limit in (None, math.inf):
        space = pinned_space(robot, q0)
        kernel = space.checker.native_kernel()  # the handle rrt_connect plans with
        sent = []

        def interrupt():
            # Wait until the kernel is planning (on a loaded machine the Python set-up before
            # it can take longer than any fixed delay), then interrupt.
            end = time.perf_counter() + 30.0
            while kernel.checks <= 100 and time.perf_counter() < end:
                time.sleep(0.005)
            sent.append((time.perf_counter(), time.process_time()))
            os.kill(os.getpid(), signal.SIGINT)

        # on a kernel that holds the GIL this thread never runs: the plan never stops
        threading.Thread(target=interrupt, daemon=True).start()
        opts = RRTConnectOptions(time_limit_s=limit, max_iterations=10**15)
        try:
            rrt_connect(space, q0, q1, opts)
            out.append({"limit": str(limit), "error": "returned"})
        except KeyboardInterrupt:
            delay = time.perf_counter() - sent[0][0]
            cpu = time.process_time() - sent[0][1]
            checks = space.checker.native_kernel().checks  # counted inside the kernel
            out.append({"limit": str(limit), "delay": delay, "cpu": cpu, "checks": checks})
    print(json.dumps(out))
    """
)


def test_sigint_stops_a_compiled_plan_within_a_tenth_of_a_cpu_second() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    try:
        done = subprocess.run(
            [sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=60, env=env
        )
    except subprocess.TimeoutExpired:
        pytest.fail("the compiled plan ignored SIGINT (subprocess killed after 60 s)")
    assert done.returncode == 0, done.stderr
    runs = json.loads(done.stdout.strip().splitlines()[-1])
    assert [r["limit"] for r in runs] == ["None", "inf"]
    for run in runs:
        assert "delay" in run, run
        # measured in the child between os.kill and the KeyboardInterrupt: the CPU time the
        # process spent (a kernel that goes on planning spends it; a loaded machine that does
        # not schedule the child adds wall time only) and, loosely, the wall time
        assert 0.0 <= run["cpu"] < 0.1, run
        assert 0.0 <= run["delay"] < 5.0, run
        assert run["checks"] > 100  # the kernel was planning when the signal came


@pytest.mark.parametrize("limit", [math.inf, 1e10, 1e300, None])
def test_unbounded_time_limit_with_an_iteration_cap_runs_every_iteration(
    plate: tuple[Robot, np.ndarray, np.ndarray], limit: float | None
) -> None:
    _, q0, q1 = plate
    space = _pinned(plate)
    opts = RRTConnectOptions(time_limit_s=limit, max_iterations=300)
    result = rrt_connect(space, q0, q1, opts)
    assert result.log["native"] == 1.0
    assert result.status is PlannerStatus.ITERATION_LIMIT
    assert result.iterations == 300
    assert result.collision_checks > 300


def test_zero_time_limit_stops_before_the_first_iteration(
    plate: tuple[Robot, np.ndarray, np.ndarray],
) -> None:
    _, q0, q1 = plate
    result = rrt_connect(_pinned(plate), q0, q1, RRTConnectOptions(time_limit_s=0.0))
    assert result.status is PlannerStatus.TIME_LIMIT
    assert result.iterations == 0


def test_iteration_cap_beyond_int64_is_clamped(
    plate: tuple[Robot, np.ndarray, np.ndarray],
) -> None:
    _, q0, q1 = plate
    opts = RRTConnectOptions(max_iterations=10**20, time_limit_s=0.05)
    result = rrt_connect(_pinned(plate), q0, q1, opts)
    assert result.status is PlannerStatus.TIME_LIMIT
    assert result.iterations > 0


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("max_iterations", 2.5, "max_iterations must be an integer"),
        ("max_iterations", -1, "max_iterations must be an integer >= 0"),
        ("max_iterations", math.inf, "max_iterations must be an integer"),
        ("max_iterations", True, "max_iterations must be an integer"),
        ("seed", -1, "seed must be an integer >= 0"),
        ("seed", 1.5, "seed must be an integer >= 0"),
        ("time_limit_s", math.nan, "time_limit_s must be a number of seconds >= 0"),
        ("time_limit_s", -1.0, "time_limit_s must be a number of seconds >= 0"),
        ("time_limit_s", "1", "time_limit_s must be a number of seconds"),
        ("step_size", 1e-12, "too small for bounds"),
    ],
)
def test_bad_numbers_raise_a_taskspace_error(
    plate: tuple[Robot, np.ndarray, np.ndarray], field: str, value: object, match: str
) -> None:
    _, q0, q1 = plate
    opts = RRTConnectOptions(**{field: value})  # type: ignore[arg-type]
    for native in (True, False):
        with pytest.raises(InvalidInputError, match=match):
            rrt_connect(
                _pinned(plate), q0, q1, RRTConnectOptions(**{**opts.__dict__, "native": native})
            )


def test_seed_beyond_64_bits_is_accepted(plate: tuple[Robot, np.ndarray, np.ndarray]) -> None:
    _, q0, q1 = plate
    opts = RRTConnectOptions(seed=2**70 + 5, max_iterations=20)
    result = rrt_connect(_pinned(plate), q0, q1, opts)
    assert result.iterations == 20
    same = rrt_connect(_pinned(plate), q0, q1, RRTConnectOptions(seed=5, max_iterations=20))
    np.testing.assert_array_equal(result.trees[0].nodes, same.trees[0].nodes)  # modulo 2^64


def test_kernel_checks_its_own_arguments(plate: tuple[Robot, np.ndarray, np.ndarray]) -> None:
    """Direct calls of the compiled function (no Python validation) raise TaskspaceErrors."""
    _, q0, q1 = plate
    space = _pinned(plate)
    kernel = space.checker.native_kernel()  # type: ignore[attr-defined]
    module = planning_kernel()
    good = dict(
        checker=kernel,
        start=q0,
        goal=q1,
        lower=space.lower,
        upper=space.upper,
        alpha=0.5,
        delta=DELTA,
        delta_c=0.15,
        local=0.5,
        sigma=0.5,
        trapped=0.75,
        max_iterations=5,
        time_limit=-1.0,
        seed=0,
    )
    assert module.rrt_connect(**good)[2] == 5  # 5 iterations
    bad_start = q0.copy()
    bad_start[1] = math.nan
    for change in (
        {"time_limit": math.nan},
        {"max_iterations": -3},
        {"alpha": math.inf},
        {"alpha": 1e-12},
        {"sigma": 0.0},
        {"local": math.nan},
        {"lower": space.upper, "upper": space.lower},
        {"start": q0[:3]},
    ):
        with pytest.raises(TaskspaceError):
            module.rrt_connect(**{**good, **change})
    # a non-finite or out-of-bounds endpoint is a status (the wrapper raises PlanningError)
    assert module.rrt_connect(**{**good, "start": bad_start})[0] == module.START_INVALID
    assert module.rrt_connect(**{**good, "goal": space.upper + 1.0})[0] == module.GOAL_INVALID
    with pytest.raises(TaskspaceError, match="nq = 7 columns"):
        kernel.first_invalid(np.zeros((2, 3)))


def _free_problem(robot: Robot) -> ConfigurationSpace:
    return ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=DELTA))


def test_two_threads_plan_as_sequential_runs(plate: tuple[Robot, np.ndarray, np.ndarray]) -> None:
    """Separate checkers in two threads: the paths of sequential runs with the same seeds."""
    robot, q0, q1 = plate
    seeds = [3, 4, 5, 6]
    opts = [RRTConnectOptions(seed=s, time_limit_s=None, max_iterations=50_000) for s in seeds]
    sequential = [rrt_connect(_free_problem(robot), q0, q1, o) for o in opts]
    assert all(r.success for r in sequential)
    spaces = [_free_problem(robot) for _ in seeds]
    results: dict[int, object] = {}

    def plan(k: int) -> None:
        results[k] = rrt_connect(spaces[k], q0, q1, opts[k])

    threads = [threading.Thread(target=plan, args=(k,)) for k in range(len(seeds))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k, ref in enumerate(sequential):
        got = results[k]
        np.testing.assert_array_equal(got.path, ref.path)  # type: ignore[attr-defined]
        assert got.iterations == ref.iterations  # type: ignore[attr-defined]
    # the GIL is released: a plan in the main thread runs while a long one runs in a thread
    blocked = _pinned(plate)
    # (4 s: the main thread's set-up and plan below must end before it, also on a loaded
    # machine that stalls this process for a second or two)
    long_plan = threading.Thread(
        target=rrt_connect, args=(blocked, q0, q1, RRTConnectOptions(time_limit_s=4.0))
    )
    long_plan.start()
    time.sleep(0.1)  # with a kernel that holds the GIL this returns after the long plan
    assert rrt_connect(_free_problem(robot), q0, q1, opts[0]).success
    assert long_plan.is_alive()
    long_plan.join()
    # one checker shared by two threads: the plans run one after the other, both paths free
    shared = _free_problem(robot)
    out: list[object] = []
    threads = [
        threading.Thread(target=lambda o=o: out.append(rrt_connect(shared, q0, q1, o)))
        for o in opts[:2]
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(out) == 2
    reference = robot.model.createData(), robot.collision_model.createData()
    for r in out:
        assert r.success  # type: ignore[attr-defined]
        for a, b in zip(r.path[:-1], r.path[1:]):  # type: ignore[attr-defined]
            n = max(1, math.ceil(float(np.linalg.norm(b - a)) / DELTA - 1e-12))
            for t in np.arange(n + 1) / n:
                q = a + t * (b - a)
                assert not pin.computeCollisions(
                    robot.model, reference[0], robot.collision_model, reference[1], q, True
                )
