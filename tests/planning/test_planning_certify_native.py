"""The compiled certifier (``certify_kernel.hpp``) against Python's and dense coal distances.

``certify_path`` runs in C++ for robots of revolute and prismatic joints about x, y or z
(:func:`~taskspace.planning.certify.native_certifier`), else in Python. The references are
independent of both advancements: Pinocchio/coal ``computeDistances`` at dense points of every
segment. On each path the compiled answer must be the Python one where the dense check
decides it (every segment clear by 1 cm: both certified; a first segment that enters an
obstacle: both uncertified at that segment), and a certified path must be free at every
dense point. A certifier whose motion bound is halved (``set_weight_factor(0.5)`` on the
disc, 0.25 at a Panda fingertip) certifies paths through thin walls: these tests, and those
of test_planning_certify_all, fail with W halved in the C++ source.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from taskspace.model import Obstacle, Robot
from taskspace.planning import certify as certify_module
from taskspace.planning.certify import certify_path, native_certifier
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from tests.planning._mbm import ROOT, SKIP_REASON

TOL = 1e-4
CLEAR = 0.01  # a segment whose dense distances all exceed this is certified by both

_LINK = """  <link name="{name}">
    <collision><origin xyz="{xyz}"/><geometry><box size="{size}"/></geometry></collision>
    <inertial><mass value="1"/>
      <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
"""


def _arm_urdf(second_axis: str, second_type: str = "revolute") -> str:
    """A lift (prismatic z), a shoulder (revolute z) and an elbow, box links."""
    links = "".join(
        _LINK.format(name=n, xyz=x, size=s)
        for n, x, s in (
            ("column", "0 0 0.1", "0.08 0.08 0.2"),
            ("arm", "0.2 0 0", "0.4 0.06 0.06"),
            ("forearm", "0.15 0 0", "0.3 0.05 0.05"),
        )
    )
    limit = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
    return f"""<?xml version="1.0"?>
<robot name="lift_arm">
  <link name="world"/>
{links}  <joint name="lift" type="prismatic"><parent link="world"/><child link="column"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="0.4" effort="1" velocity="1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="column"/><child link="arm"/>
    <origin xyz="0 0 0.25"/><axis xyz="0 0 1"/>{limit}</joint>
  <joint name="elbow" type="{second_type}"><parent link="arm"/><child link="forearm"/>
    <origin xyz="0.4 0 0"/><axis xyz="{second_axis}"/>{limit}</joint>
</robot>
"""


def _robot_from(tmp_path: Path, name: str, text: str) -> Robot:
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    return Robot.from_urdf(path)


@pytest.fixture(scope="module")
def panda() -> Robot:
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.box("block", [0.1, 0.4, 0.3], [0.45, 0.0, 0.35]))
    return robot


@pytest.fixture(scope="module")
def lift_arm(tmp_path_factory: pytest.TempPathFactory) -> Robot:
    robot = _robot_from(tmp_path_factory.mktemp("arm"), "arm", _arm_urdf("0 1 0"))
    robot.add_obstacle(Obstacle.box("post", [0.1, 0.1, 1.0], [0.5, 0.3, 0.5]))
    robot.add_obstacle(Obstacle.sphere("ball", 0.08, [-0.4, -0.2, 0.5]))
    return robot


def segment_least(robot: Robot, a: np.ndarray, b: np.ndarray, n: int = 400) -> float:
    """Least Pinocchio/coal distance at n + 1 evenly spaced points of the segment a -> b."""
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    least = math.inf
    for t in np.arange(n + 1) / n:
        pin.computeDistances(model, data, gm, gd, a + t * (b - a))
        least = min(least, min(r.min_distance for r in gd.distanceResults))
    return least


def check_against_references(
    robot: Robot, paths: list[np.ndarray], spheres: object = None
) -> dict[str, int]:
    """Compare the compiled and Python certificates with the dense check, path by path."""
    seen = {"certified": 0, "refused": 0, "undecided": 0}
    for path in paths:
        native = certify_path(robot, path, tolerance=TOL, spheres=spheres)
        python = certify_path(robot, path, tolerance=TOL, native=False)
        dense = [segment_least(robot, a, b) for a, b in itertools.pairwise(path)]
        if native.certified:
            assert min(dense) > 0.0
            assert native.min_distance >= TOL
            assert native.failed_segment == -1
        if python.certified:
            assert min(dense) > 0.0
        if min(dense) > CLEAR:
            assert native.certified and python.certified
            seen["certified"] += 1
            continue
        first_in = next((k for k, d in enumerate(dense) if d < 0.0), None)
        if first_in is not None and all(d > CLEAR for d in dense[:first_in]):
            assert not native.certified and not python.certified
            assert native.failed_segment == python.failed_segment == first_in
            assert native.min_distance < TOL
            seen["refused"] += 1
        else:
            seen["undecided"] += 1
    return seen


def random_paths(
    robot: Robot, rng: np.random.Generator, count: int, scale: float
) -> list[np.ndarray]:
    paths = []
    for _ in range(count):
        q0 = robot.random_configuration(rng)
        rows = [q0]
        for _ in range(2):
            step = scale * (robot.random_configuration(rng) - rows[-1])
            rows.append(rows[-1] + step)
        paths.append(np.array(rows))
    return paths


def test_the_compiled_certifier_serves_the_kernel_robots_and_others_fall_back(
    panda: Robot, tmp_path: Path
) -> None:
    assert native_certifier(panda) is not None
    unaligned = _robot_from(tmp_path, "unaligned", _arm_urdf("0.6 0.8 0"))
    continuous = _robot_from(tmp_path, "continuous", _arm_urdf("0 1 0", "continuous"))
    for robot in (unaligned, continuous):
        assert native_certifier(robot) is None
        robot.add_obstacle(Obstacle.box("post", [0.1, 0.1, 1.0], [0.5, 0.3, 0.5]))
        rng = np.random.default_rng(3)
        path = np.array([robot.random_configuration(rng) for _ in range(3)])
        a = certify_path(robot, path)
        b = certify_path(robot, path, native=False)
        assert a == b  # the same (Python) computation


def test_panda_compiled_certificates_agree_with_python_and_dense_distances(panda: Robot) -> None:
    seen = check_against_references(panda, random_paths(panda, np.random.default_rng(11), 14, 0.5))
    assert seen["certified"] >= 2 and seen["refused"] >= 2, seen


def test_prismatic_and_revolute_arm_agrees_with_python_and_dense_distances(lift_arm: Robot) -> None:
    assert native_certifier(lift_arm) is not None
    seen = check_against_references(
        lift_arm, random_paths(lift_arm, np.random.default_rng(5), 24, 0.6)
    )
    assert seen["certified"] >= 2 and seen["refused"] >= 2, seen


def _disc(tmp_path: Path) -> Robot:
    urdf = Path(__file__).with_name("test_planning_certify_all.py").read_text()
    text = urdf.split('_URDF = """', 1)[1].split('"""', 1)[0]
    robot = _robot_from(tmp_path, "disc", text)
    robot.add_obstacle(Obstacle.box("wall", [0.01, 1.0, 0.2], [0.0, -0.5, 0.0]))
    return robot


def _panda_through_a_plate() -> tuple[Robot, np.ndarray]:
    """The stretched Panda turning about its first joint through a small plate at a fingertip."""
    robot = Robot.load("panda", convex_collision=True)
    q = np.array([0.0, 1.3, 0.0, -0.4, 0.0, 1.7, 0.8])
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    pin.updateGeometryPlacements(model, data, gm, gd, q)
    tip = gm.getGeometryId("panda_leftfinger_3")
    center = gd.oMg[tip].translation
    robot.add_obstacle(Obstacle.box("plate", [0.02, 0.005, 0.02], list(center)))
    a, b = q.copy(), q.copy()
    a[0], b[0] = -0.6, 0.6
    return robot, np.array([a, b])


def test_paths_through_thin_walls_are_refused_and_a_weaker_bound_would_certify_them(
    tmp_path: Path,
) -> None:
    disc = _disc(tmp_path)
    disc_path = np.array([[-0.3, -0.3], [0.3, -0.3]])
    panda, panda_path = _panda_through_a_plate()
    # the disc's bound is tight along an axis: half of it certifies the wall; the Panda's
    # global bound has slack at the fingertip: a quarter of it certifies the plate
    for robot, path, factor in ((disc, disc_path, 0.5), (panda, panda_path, 0.25)):
        assert segment_least(robot, path[0], path[1]) < 0.0  # through the wall
        assert segment_least(robot, path[0], path[0]) > 0.05  # the ends are free
        assert segment_least(robot, path[1], path[1]) > 0.05
        cert = certify_path(robot, path)
        assert not cert.certified and cert.failed_segment == 0
        assert not certify_path(robot, path, native=False).certified
        certifier = native_certifier(robot)
        certifier.set_weight_factor(factor)  # the mutant: a fraction of the motion bound
        try:
            mutant = certify_path(robot, path)
        finally:
            certifier.set_weight_factor(1.0)
        assert mutant.certified  # what the tests above would catch


def test_motion_bound_holds_for_hull_points_of_every_link(lift_arm: Robot, panda: Robot) -> None:
    """W[l][k] (distance to axis k of any point of link l's hull, any configuration)."""
    rng = np.random.default_rng(2)
    for robot in (panda, lift_arm):
        certifier = native_certifier(robot)
        joints, W = certifier.weights(np.zeros((0, robot.nq)))
        model, gm = robot.model, robot.collision_model
        for _ in range(30):
            q = robot.random_configuration(rng)
            k = int(rng.integers(robot.nv))
            dq = np.zeros(robot.nv)
            dq[k] = 1e-6
            da, db = model.createData(), model.createData()
            gda, gdb = gm.createData(), gm.createData()
            pin.updateGeometryPlacements(model, da, gm, gda, q)
            pin.updateGeometryPlacements(model, db, gm, gdb, q + dq)
            for i in range(robot.robot_geometry_count):
                obj = gm.geometryObjects[i]
                if obj.parentJoint == 0:
                    continue
                geometry = obj.geometry
                points = np.asarray(geometry.points()) if hasattr(geometry, "points") else None
                if points is None or points.ndim != 2:
                    geometry.computeLocalAABB()
                    lo, hi = geometry.aabb_local.min_, geometry.aabb_local.max_
                    points = np.array(list(itertools.product(*zip(lo, hi))))
                pa = points @ gda.oMg[i].rotation.T + gda.oMg[i].translation
                pb = points @ gdb.oMg[i].rotation.T + gdb.oMg[i].translation
                speed = float(np.max(np.linalg.norm(pb - pa, axis=1))) / 1e-6
                row = list(joints).index(obj.parentJoint)
                assert speed <= W[row, k] * (1 + 1e-6) + 1e-9


def test_deadline_and_query_cap(panda: Robot) -> None:
    path = random_paths(panda, np.random.default_rng(1), 1, 0.3)[0]
    late = certify_path(panda, path, deadline=time.perf_counter() - 1.0)
    assert late.timed_out and not late.certified and late.failed_segment == 0
    capped = certify_path(panda, path, max_queries=1)
    assert not capped.certified and not capped.timed_out and capped.distance_queries == 1


def test_a_new_obstacle_is_seen(tmp_path: Path) -> None:
    robot = _disc(tmp_path)
    path = np.array([[-0.3, 0.3], [0.3, 0.3]])  # above the wall
    assert certify_path(robot, path).certified
    robot.add_obstacle(Obstacle.box("lid", [0.01, 0.2, 0.2], [0.0, 0.3, 0.0]))
    assert not certify_path(robot, path).certified


@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
@pytest.mark.parametrize(
    ("scenario", "index"), [("table_pick", 6), ("bookshelf_thin", 3), ("box", 6)]
)
def test_motionbenchmaker_paths_with_spheres(
    scenario: str, index: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Planned paths, and paths built through a colliding configuration, on MBM scenes.

    With the robot's certified spheres as lower bounds the answers are Python's (and the
    dense check's); certify=True plans use the compiled certifier and return free paths.
    """
    from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

    robot = motionbenchmaker_panda()
    problem = motionbenchmaker_problems(ROOT, scenario, [index])[0]
    request = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    space.checker.sphere_kernel()
    spheres = space.checker.sphere_model()
    assert native_certifier(robot, spheres).has_spheres
    options = RRTConnectOptions(
        step_size=0.5, coarse_resolution=0.15, local_sampling=0.5, trapped_priority=0.75,
        time_limit_s=1.0, seed=0, checker="spheres_only", validator="spheres",
    )  # fmt: skip
    planned = rrt_connect(space, request.start, request.goal, options)
    assert planned.success
    rng = np.random.default_rng(index)
    colliding = None
    while colliding is None:
        q = robot.random_configuration(rng)
        if not space.checker.is_valid(q) and segment_least(robot, q, q, 1) < -0.005:
            colliding = q
    built = np.array([request.start, colliding, request.goal])
    seen = check_against_references(robot, [planned.path, built], spheres)
    assert seen["refused"] >= 1

    calls = []
    original = certify_module.native_certifier

    def counted(*args: object) -> object:
        calls.append(1)
        return original(*args)

    monkeypatch.setattr(certify_module, "native_certifier", counted)
    result = rrt_connect(
        space, request.start, request.goal, dataclasses.replace(options, certify=True)
    )
    assert calls
    if result.success:
        assert result.log["certified"] == 1.0
        assert (
            min(segment_least(robot, a, b, 200) for a, b in itertools.pairwise(result.path)) > 0.0
        )
