"""After a failed certificate: the reason in the log, and re-plans that avoid the failed edge.

The scene of ``test_planning_certify_all``: a disc (radius 0.02 m) sliding in the plane, a
wall 0.01 m thick across ``x = 0`` for ``y < 0``, edges checked at 0.08 m. The straight line
from ``(-0.5, -0.5)`` to ``(0.5, -0.5)`` passes the edge check (its points straddle the wall)
but collides: Pinocchio/coal's ``computeDistances`` every 1e-3 m along it (the independent
reference) is negative there. Every planner with ``certify=True``:

* reports the reason that ended it: ``log["stopped_by"]`` is ``"uncertified"`` with status
  ``UNCERTIFIED`` (not the ``"first solution"`` or ``"optimal"`` of the uncertified path it
  planned) and ``"time"`` when the time ran out in the certification;
* PRM, Lazy PRM, their queries, PRM* and Lazy PRM*: a re-plan never uses a segment whose
  certificate failed before (they took the same straight line again, ``certify_retries``
  times); the result is then a path free by the reference, or a failure.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _certify_spy import spy_certificates

from taskspace.model import Obstacle, Robot
from taskspace.planning import certify as certify_module
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.lazy_prm import build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.prm import PRMOptions, build_prm, prm, prm_query
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star
from tests.planning.test_planning_certify_all import _URDF, dense_least_distance

A = np.array([-0.5, -0.5])
B = np.array([0.5, -0.5])  # the straight line A-B crosses the wall between checked points


@pytest.fixture(scope="module")
def disc(tmp_path_factory: pytest.TempPathFactory) -> tuple[Robot, ConfigurationSpace]:
    path = Path(tmp_path_factory.mktemp("disc")) / "disc.urdf"
    path.write_text(_URDF)
    robot = Robot.from_urdf(path)
    robot.add_obstacle(Obstacle.box("wall", [0.01, 1.0, 0.2], [0.0, -0.5, 0.0]))
    return robot, ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.08))


def _plan(name: str, space: ConfigurationSpace, seed: int, retries: int, limit: Any) -> Any:
    """One certified plan A -> B with ``retries`` re-plans and time limit ``limit`` [s]."""
    common: dict[str, Any] = {
        "seed": seed,
        "certify": True,
        "certify_retries": retries,
        "time_limit_s": limit,
    }
    prm_opts = PRMOptions(max_iterations=60, batch_size=30, **common)
    if name == "rrt":
        return rrt(space, A, B, RRTOptions(step_size=0.3, max_iterations=2000, **common))
    if name == "rrt_connect":
        return rrt_connect(space, A, B, RRTConnectOptions(max_iterations=2000, **common))
    if name == "rrt_star":
        return rrt_star(space, A, B, RRTStarOptions(max_iterations=300, **common))
    if name == "bit_star":
        return bit_star(space, A, B, BITStarOptions(max_iterations=200, **common))
    if name == "prm_star":
        return prm_star(space, A, B, PRMStarOptions(max_iterations=60, **common))[0]
    if name == "lazy_prm_star":
        return lazy_prm_star(space, A, B, PRMStarOptions(max_iterations=60, **common))[0]
    if name == "prm":
        return prm(space, A, B, prm_opts)[0]
    if name == "lazy_prm":
        return lazy_prm(space, A, B, prm_opts, time_limit_s=limit)[0]
    if name == "prm_query":
        roadmap = build_prm(space, PRMOptions(max_iterations=60, seed=seed))
        return prm_query(space, roadmap, A, B, prm_opts)
    lazy = build_lazy_prm(space, PRMOptions(max_iterations=60, seed=seed))
    return lazy_prm_query(space, lazy, A, B, prm_opts, time_limit_s=limit)


ALL = [
    "rrt",
    "rrt_connect",
    "rrt_star",
    "bit_star",
    "prm",
    "prm_query",
    "lazy_prm",
    "lazy_prm_query",
    "prm_star",
    "lazy_prm_star",
]
ROADMAPS = ["prm", "prm_query", "lazy_prm", "lazy_prm_query", "prm_star", "lazy_prm_star"]


@pytest.mark.parametrize("name", ALL)
def test_an_uncertified_result_says_so(disc, monkeypatch, name: str) -> None:  # type: ignore[no-untyped-def]
    robot, space = disc
    seen = spy_certificates(monkeypatch)
    uncertified = 0
    for seed in range(4):
        seen.clear()
        result = _plan(name, space, seed, retries=0, limit=math.inf)
        if result.status is PlannerStatus.UNCERTIFIED:
            uncertified += 1
            # the path it planned collides by the reference: the status is right ...
            assert dense_least_distance(robot, seen[-1][0]) <= 0.0
            # ... and the log says why the planner ended (not "first solution", "optimal")
            assert result.log["stopped_by"] == "uncertified"
            assert not result.success and result.log["certified"] == 0.0
        else:
            assert result.log["stopped_by"] != "uncertified"
    assert uncertified > 0  # the wall is crossed by some planned path


@pytest.mark.parametrize("name", ALL)
def test_a_certification_out_of_time_says_time(disc, monkeypatch, name: str) -> None:  # type: ignore[no-untyped-def]
    # The certification reads the clock before each distance query: a deadline already
    # passed (moved 1 h back) stops it at once: TIME_LIMIT and stopped_by "time".
    _, space = disc
    real = certify_module.certify_path

    def late(*args: Any, **kwargs: Any) -> Any:
        kwargs["deadline"] = kwargs["deadline"] - 3600.0
        return real(*args, **kwargs)

    monkeypatch.setattr(certify_module, "certify_path", late)
    result = _plan(name, space, 0, retries=2, limit=60.0)
    assert not result.success and result.status is PlannerStatus.TIME_LIMIT
    assert result.log["stopped_by"] == "time" and result.log["certified"] == 0.0


def _same_segment(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    return bool(
        (np.array_equal(p, a) and np.array_equal(q, b))
        or (np.array_equal(p, b) and np.array_equal(q, a))
    )


@pytest.mark.parametrize("name", ROADMAPS)
def test_a_replan_avoids_the_segment_that_failed(disc, monkeypatch, name: str) -> None:  # type: ignore[no-untyped-def]
    robot, space = disc
    seen = spy_certificates(monkeypatch)
    replans = 0
    for seed in range(4):
        seen.clear()
        result = _plan(name, space, seed, retries=2, limit=math.inf)
        # the first path is the straight line A-B: passed by the edge check, not certified
        assert np.array_equal(seen[0][0], [A, B]) and not seen[0][1].certified
        failed: list[tuple[np.ndarray, np.ndarray]] = []
        for path, cert in seen:
            for p, q in zip(path[:-1], path[1:]):  # noqa: RUF007
                assert not any(_same_segment(p, q, a, b) for a, b in failed)
            if not cert.certified:
                s = cert.failed_segment
                failed.append((path[s], path[s + 1]))
        replans += len(seen) - 1
        assert result.log["certify_attempts"] == float(len(seen))
        if result.success:
            assert result.log["certified"] == 1.0 and result.log["stopped_by"] != "uncertified"
            assert dense_least_distance(robot, result.path) > 0.0
        else:  # out of re-plans, or no other path in the roadmap: a failure, said so
            assert result.status in (
                PlannerStatus.UNCERTIFIED,
                PlannerStatus.NO_PATH,
                PlannerStatus.ITERATION_LIMIT,
            )
            if result.status is PlannerStatus.UNCERTIFIED:
                assert len(seen) == 3 and result.log["stopped_by"] == "uncertified"
                assert dense_least_distance(robot, result.path) <= 0.0
    assert replans > 0
