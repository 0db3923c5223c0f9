"""A re-plan after a failed certificate never returns a motion through the failed spot again.

The scene: a disc (radius 0.02 m) sliding in the plane (two prismatic joints: the compiled
planner and the compiled certifier serve it), a thin post (0.01 m by 0.1 m) at
``(0, -0.5)``, edges checked at 0.08 m. The straight line from ``A = (-0.5, -0.5)`` to
``B = (0.5, -0.5)`` passes the edge check (its points straddle the post) but collides:
Pinocchio/coal's ``computeDistances`` every 1e-3 m along it (the independent reference) is
negative there. RRT-Connect (compiled and Python), RRT* and BIT* took that line again on
every re-plan (a new seed does not change a free straight line): ``UNCERTIFIED`` after all
retries although a certified path around the post exists. With the failed regions
(:class:`~taskspace.planning.certify.FailedRegions`) each re-plan must certify its motions
near the spot: the result is a certified path, free by the reference, and the log names the
attempts and the failed segments.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _certify_spy import spy_certificates

from taskspace.errors import InvalidInputError
from taskspace.model import Obstacle, Robot
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.certify import FailedRegions
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.planner_result import PlannerStatus
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star
from tests.planning.test_planning_certify_all import _URDF, dense_least_distance

A = np.array([-0.5, -0.5])
B = np.array([0.5, -0.5])  # the straight line A-B crosses the post between checked points
SEEDS = range(4)


@pytest.fixture(scope="module")
def post(tmp_path_factory: pytest.TempPathFactory) -> tuple[Robot, ConfigurationSpace]:
    path = Path(tmp_path_factory.mktemp("post")) / "disc.urdf"
    path.write_text(_URDF)
    robot = Robot.from_urdf(path)
    robot.add_obstacle(Obstacle.box("post", [0.01, 0.1, 0.2], [0.0, -0.5, 0.0]))
    return robot, ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.08))


def _plan(name: str, space: ConfigurationSpace, seed: int, certify: bool = True) -> Any:
    common: dict[str, Any] = {"seed": seed, "certify": certify, "time_limit_s": None}
    if name == "rrt_connect":
        return rrt_connect(space, A, B, RRTConnectOptions(max_iterations=5000, **common))
    if name == "rrt_connect_spheres":
        opts = RRTConnectOptions(
            max_iterations=5000, checker="spheres_only", validator="spheres", **common
        )
        return rrt_connect(space, A, B, opts)
    if name == "rrt_connect_python":
        return rrt_connect(
            space, A, B, RRTConnectOptions(max_iterations=5000, native=False, **common)
        )
    if name == "rrt":
        return rrt(space, A, B, RRTOptions(step_size=0.3, max_iterations=5000, **common))
    if name == "rrt_star":
        return rrt_star(space, A, B, RRTStarOptions(max_iterations=300, **common))
    return bit_star(space, A, B, BITStarOptions(max_iterations=200, **common))


STRAIGHT = ["rrt_connect", "rrt_connect_spheres", "rrt_connect_python", "rrt_star"]
"""The planners whose first path here is the straight line A-B."""

CROSSING = [*STRAIGHT, "bit_star"]
"""The planners whose first path here crosses the post whatever the seed (BIT*: a line
through a sample near A)."""


def test_the_straight_line_passes_the_edge_check_and_collides(post) -> None:  # type: ignore[no-untyped-def]
    robot, space = post
    assert space.motion_valid(A, B)  # its points straddle the post ...
    assert dense_least_distance(robot, np.stack([A, B])) < 0.0  # ... which it crosses
    for name in CROSSING:  # and these planners cross the post whatever the seed
        for seed in SEEDS:
            plain = _plan(name, space, seed, certify=False)
            assert plain.success and dense_least_distance(robot, plain.path) < 0.0, name
            assert name not in STRAIGHT or np.array_equal(plain.path, [A, B]), name


@pytest.mark.parametrize("name", [*CROSSING, "rrt"])
def test_a_replan_certifies_around_the_spot(post, monkeypatch, name: str) -> None:  # type: ignore[no-untyped-def]
    robot, space = post
    seen = spy_certificates(monkeypatch)
    for seed in SEEDS:
        seen.clear()
        result = _plan(name, space, seed)
        # a certified path, free by the reference (not by the certifier)
        assert result.success and result.status is PlannerStatus.SOLVED, (name, seed)
        assert result.log["certified"] == 1.0
        np.testing.assert_allclose(result.path[[0, -1]], [A, B])
        assert dense_least_distance(robot, result.path) > 0.0
        # the log: the attempts and, per failed attempt, its segment and t
        attempts = int(result.log["certify_attempts"])
        assert attempts == len(seen)
        failures = result.log["certify_failures"]
        assert [f[0] for f in failures] == list(range(attempts - 1))
        for (_, segment, t), (_, cert) in zip(failures, seen, strict=False):
            assert not cert.certified
            assert (segment, t) == (cert.failed_segment, cert.failed_t)
        if name in CROSSING:  # the first path fails; no re-plan takes its failed segment
            assert not seen[0][1].certified and failures[0][0] == 0 and attempts >= 2
            assert result.log["region_certifications"] > 0
            for attempt, segment, _ in failures:
                a, b = seen[attempt][0][segment : segment + 2]
                for path, _ in seen[attempt + 1 :]:
                    assert not any(
                        np.array_equal(p, a) and np.array_equal(q, b)
                        for p, q in zip(path[:-1], path[1:])  # noqa: RUF007
                    )
        if name in STRAIGHT:  # the first path is the straight line; a re-plan never is
            assert np.array_equal(seen[0][0], [A, B]) and failures[0][:2] == (0, 0)
            assert all(not np.array_equal(p, [A, B]) for p, _ in seen[1:])


def test_the_compiled_planner_certifies_in_the_kernel(post, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # The re-plan stays in the compiled kernel (its phases are logged), which certified the
    # parts of its edges inside the failed region with the compiled certifier.
    _, space = post
    python_allows = []
    real = FailedRegions.allows

    def allows(self: FailedRegions, q0: Any, q1: Any) -> bool:
        python_allows.append(1)
        return real(self, q0, q1)

    monkeypatch.setattr(FailedRegions, "allows", allows)
    result = _plan("rrt_connect", space, 0)
    assert result.success and result.log["native"] == 1.0
    assert result.log["certify_attempts"] >= 2 and result.log["region_certifications"] > 0
    assert not python_allows


def test_replans_never_return_a_motion_uncertified_inside_a_failed_region(
    post, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    # Every edge of every re-planned path that enters a failed region is certified there
    # (checked here by the certifier on the chord, and the whole path by the reference).
    robot, space = post
    seen = spy_certificates(monkeypatch)
    for name in ["rrt_connect", "rrt_connect_python"]:
        for seed in SEEDS:
            seen.clear()
            _plan(name, space, seed)
            regions = FailedRegions(space, 1e-4)
            for attempt, (path, cert) in enumerate(seen):
                if attempt > 0:
                    for p, q in zip(path[:-1], path[1:]):  # noqa: RUF007
                        for lo, hi in regions.crossings(p, q):
                            part = space.interpolate(p, q, np.array([lo, hi]))
                            assert dense_least_distance(robot, part) > 0.0
                if not cert.certified:
                    regions.add(attempt, path, cert.failed_segment, cert.failed_t)


def test_crossings_are_the_chords_of_the_balls(post) -> None:  # type: ignore[no-untyped-def]
    _, space = post
    regions = FailedRegions(space, 1e-4)
    regions.add(0, np.stack([A, B]), 0, 0.5)  # the centre (0, -0.5)
    r = regions.radius
    assert r == pytest.approx(4 * 0.08)
    rng = np.random.default_rng(0)
    for _ in range(200):
        q0, q1 = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
        t = np.linspace(0.0, 1.0, 20001)
        inside = np.linalg.norm(space.interpolate(q0, q1, t) - [0.0, -0.5], axis=1) < r
        got = regions.crossings(q0, q1)
        if not inside.any():
            assert got == [] or got[0][1] - got[0][0] < 1e-3
            continue
        ((lo, hi),) = got
        assert lo == pytest.approx(t[inside][0], abs=1e-4)
        assert hi == pytest.approx(t[inside][-1], abs=1e-4)


def test_no_regions_no_change(tmp_path: Path) -> None:
    # Without a failed certificate the plans are those of certify=False (same seed, same
    # path): the regions change nothing on a first attempt.
    path = tmp_path / "disc.urdf"
    path.write_text(_URDF)
    space = ConfigurationSpace.from_robot(
        Robot.from_urdf(path), edge=EdgeCheckOptions(resolution=0.08)
    )
    for name in [*CROSSING, "rrt"]:
        plain = _plan(name, space, 1, certify=False)
        certified = _plan(name, space, 1)
        assert certified.log["certify_attempts"] == 1.0
        assert certified.log["certify_failures"] == []
        np.testing.assert_array_equal(plain.path, certified.path)


def test_regions_need_a_robot() -> None:
    space = ConfigurationSpace([-1.0, -1.0], [1.0, 1.0], lambda q: True)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="certify=True needs a space built on a robot"):
        FailedRegions(space, 1e-4)


@pytest.fixture(scope="module")
def wall(tmp_path_factory: pytest.TempPathFactory) -> tuple[Robot, ConfigurationSpace]:
    # The wall of test_planning_certify_all (0.01 m thick, 1 m long, for y < 0): every crossing
    # between checked points is uncertifiable, not only the one near (0, -0.5).
    path = Path(tmp_path_factory.mktemp("wall")) / "disc.urdf"
    path.write_text(_URDF)
    robot = Robot.from_urdf(path)
    robot.add_obstacle(Obstacle.box("wall", [0.01, 1.0, 0.2], [0.0, -0.5, 0.0]))
    return robot, ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.08))


@pytest.mark.parametrize("name", [*CROSSING, "rrt"])
def test_a_thin_wall_crossed_elsewhere_grows_the_region(wall, name: str) -> None:  # type: ignore[no-untyped-def]
    # RRT* and BIT* look for the shortest crossing: just outside the first ball. The balls
    # grow with each failure (4, 8 delta), so the third attempt goes around the wall.
    robot, space = wall
    for seed in SEEDS:
        result = _plan(name, space, seed)
        assert result.success and result.log["certified"] == 1.0, (name, seed)
        assert dense_least_distance(robot, result.path) > 0.0
        assert len(result.log["certify_failures"]) == result.log["certify_attempts"] - 1


def test_the_radius_doubles_after_each_failure(post) -> None:  # type: ignore[no-untyped-def]
    _, space = post
    regions = FailedRegions(space, 1e-4)
    for k in range(3):
        regions.add(k, np.stack([A, B]), 0, 0.5)
        assert regions.radius == pytest.approx(4 * 0.08 * 2**k)
    assert regions.centers.shape == (3, 2) and regions.failures[2] == (2, 0, 0.5)


@pytest.mark.parametrize("name", ["rrt_connect", "bit_star"])
def test_a_replan_without_a_path_leaves_the_result_uncertified(post, name: str) -> None:  # type: ignore[no-untyped-def]
    # A tolerance of 5 m certifies nothing: the re-plans cannot pass the failed regions, and
    # once the balls cover the start no path is left. The answer is the last path planned,
    # UNCERTIFIED (not the re-plan's ITERATION_LIMIT), with the re-plan's status in the log.
    _, space = post
    common: dict[str, Any] = {"seed": 0, "certify": True, "certify_tolerance": 5.0}
    if name == "rrt_connect":
        result = rrt_connect(space, A, B, RRTConnectOptions(max_iterations=3000, **common))
    else:
        result = bit_star(space, A, B, BITStarOptions(max_iterations=200, **common))
    assert not result.success and result.status is PlannerStatus.UNCERTIFIED
    assert result.log["stopped_by"] == "uncertified" and result.log["certified"] == 0.0
    assert result.path.shape[0] >= 2
    attempts = result.log["certify_attempts"]
    assert len(result.log["certify_failures"]) in (attempts, attempts - 1)
    if len(result.log["certify_failures"]) < attempts:
        assert result.log["replan_status"] == "iteration_limit"


def test_crossings_on_a_joint_manifold_cover_the_ball() -> None:
    # Free-flyer, spherical, revolute, prismatic and continuous joints: the part inside a ball
    # is taken at the resolution, widened by one point on each side, so it contains every
    # point of the edge nearer than the radius (checked at 50 times the resolution).
    from tests.planning.test_planning_certify_manifold import _chain_robot

    space = ConfigurationSpace.from_robot(
        _chain_robot(),
        edge=EdgeCheckOptions(resolution=0.1),
        base_lower=[-1.0, -1.0, -1.0],
        base_upper=[1.0, 1.0, 1.0],
    )
    assert not space.is_euclidean
    rng = np.random.default_rng(3)
    regions = FailedRegions(space, 1e-4)
    q0, q1 = space.sample_uniform(rng), space.sample_uniform(rng)
    regions.add(0, np.stack([q0, q1]), 0, 0.4)
    hits = 0
    for _ in range(30):
        a = space.interpolate(q0, space.sample_uniform(rng), 0.05)[0]
        b = space.interpolate(q1, space.sample_uniform(rng), 0.05)[0]
        got = regions.crossings(a, b)
        t = np.linspace(0.0, 1.0, 50 * space.segments(a, b) + 1)
        inside = t[space.distances(space.interpolate(a, b, t), regions.centers[0]) < regions.radius]
        if inside.size == 0:
            continue
        hits += 1
        ((lo, hi),) = got
        assert lo <= inside[0] and inside[-1] <= hi
    assert hits > 0
