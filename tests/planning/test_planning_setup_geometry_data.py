"""The compiled checker's own geometry data (a scene's set-up without ``geom.createData()``).

``CollisionKernel(model, data, geom, None, cache)`` builds the parts of Pinocchio's
``GeometryData`` it uses (placements, active pairs, collision requests, results and functors)
instead of the whole ``geom.createData()``, whose distance and contact-patch functors it never
calls. Reference: Pinocchio's ``computeCollisions`` on every pair with a fresh ``GeometryData``
(nothing cached, no broad phase), at random configurations and configurations bisected to
contact, for every exact mode of the kernel and the ``"spheres"`` checker; meshes and convex
hulls; obstacles of every primitive shape; the MotionBenchMaker scenes when present.
"""

from __future__ import annotations

from typing import Any

import coal
import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import planning_kernel
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import NATIVE_PAIR_CACHE, CollisionChecker
from tests.planning._mbm import ROOT, SKIP_REASON
from tests.planning._planning_worlds import pinocchio_collision_flags

MODULE = planning_kernel()
pytestmark = pytest.mark.skipif(MODULE is None, reason="compiled planning kernel not built")

KERNEL_MODES = (0, 1, 2)  # Pinocchio's tree manager, the same with fast_update, the pair list


def at(x: float, y: float, z: float) -> pin.SE3:
    """A placement at (x, y, z) [m], no rotation."""
    return pin.SE3(np.eye(3), np.array([x, y, z]))


def _touching(robot: Robot, qs: np.ndarray) -> np.ndarray:
    """Rows whose closest pair is nearer than GJK's tolerance (1e-6 m): the kernel counts such
    a contact a collision (planning_kernel.cpp, collision_distance_threshold), Pinocchio's
    default request may not."""
    model, geom = robot._model, robot._collision_model
    out = []
    for q in qs:
        gdata = geom.createData()
        pin.computeDistances(model, model.createData(), geom, gdata, q)
        out.append(min(r.min_distance for r in gdata.distanceResults) < 1e-6)
    return np.array(out, dtype=bool)


def _assert_exact(got: Any, expected: np.ndarray, touching: np.ndarray) -> None:
    """``got`` equals the reference except at touching rows, where it must say "collides"."""
    got = np.asarray(got, dtype=bool)
    np.testing.assert_array_equal(got[~touching], expected[~touching])
    assert got[touching].all()


def _kernel(robot: Robot, gdata: Any = None) -> Any:
    """A kernel on copies of the robot's models; ``gdata=None``: the kernel's own data."""
    model = robot._model.copy()
    geom = robot._collision_model.copy()
    if gdata == "full":
        gdata = geom.createData()
    return MODULE.CollisionKernel(model, model.createData(), geom, gdata, NATIVE_PAIR_CACHE)


def _scene(robot: Robot) -> None:
    """Obstacles of every primitive shape around the arm."""
    robot.clear_obstacles()
    robot.add_obstacle(Obstacle.box("front", [0.2, 1.0, 0.6], at(0.55, 0.0, 0.4)))
    robot.add_obstacle(Obstacle.sphere("ball", 0.15, at(0.1, -0.4, 0.8)))
    robot.add_obstacle(Obstacle.cylinder("post", 0.08, 1.0, at(-0.3, 0.35, 0.5)))
    robot.add_obstacle(Obstacle("bar", coal.Capsule(0.05, 0.6), at(0.0, 0.45, 0.3)))


def _configurations(robot: Robot, n: int, seed: int) -> np.ndarray:
    """``n`` random configurations and, for pairs of them with different answers, the two
    configurations of the bisection to contact (free and colliding ends 1e-9 apart)."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = rng.uniform(lo, hi, (n, robot.nq))
    flags = pinocchio_collision_flags(robot, qs)
    free, hit = qs[~flags], qs[flags]
    extra = []
    for a, b in zip(free[:15], hit[:15]):
        for _ in range(40):  # bisection on the segment a (free) - b (colliding)
            m = 0.5 * (a + b)
            if pinocchio_collision_flags(robot, m[None, :])[0]:
                b = m
            else:
                a = m
        extra += [a, b]
    return np.vstack([qs, *extra]) if extra else qs


@pytest.fixture(scope="module", params=[True, False], ids=["convex", "mesh"])
def scene(request: Any) -> tuple[Robot, np.ndarray, np.ndarray, np.ndarray]:
    robot = Robot.load("panda", convex_collision=request.param)
    _scene(robot)
    qs = _configurations(robot, 150, 11)
    return robot, qs, pinocchio_collision_flags(robot, qs), _touching(robot, qs)


@pytest.mark.parametrize("mode", KERNEL_MODES)
def test_own_geometry_data_matches_pinocchio(
    scene: tuple[Robot, np.ndarray, np.ndarray, np.ndarray], mode: int
) -> None:
    robot, qs, expected, touching = scene
    assert expected.any() and not expected.all() and touching.any()  # every case occurs
    kernel = _kernel(robot)
    kernel.mode = mode
    got = np.asarray(kernel.collisions(qs), dtype=bool)
    _assert_exact(got, expected, touching)
    # one row at a time (the pair cache then starts from the previous row's colliding pair)
    _assert_exact([bool(kernel.collisions(q[None, :])[0]) for q in qs], expected, touching)
    assert kernel.first_invalid(qs) == int(np.flatnonzero(got)[0])
    # and exactly the answers of a kernel on Pinocchio's whole GeometryData (touching rows too)
    full = _kernel(robot, "full")
    full.mode = mode
    np.testing.assert_array_equal(np.asarray(full.collisions(qs), dtype=bool), got)


def test_managers_made_after_queries(
    scene: tuple[Robot, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """Pinocchio's managers (modes 0 and 1) made when the mode is set, after queries of the
    default mode (pairs) moved the placements: the same answers."""
    robot, qs, expected, touching = scene
    kernel = _kernel(robot)
    assert kernel.mode == 2
    _assert_exact(kernel.collisions(qs[::-1]), expected[::-1], touching[::-1])
    for mode in (1, 0, 2, 0):
        kernel.mode = mode
        _assert_exact(kernel.collisions(qs), expected, touching)


def test_own_geometry_data_spheres_checker(
    scene: tuple[Robot, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """``"spheres"`` (exact narrow phase where the spheres touch) gives the exact answers."""
    robot, qs, expected, touching = scene
    checker = CollisionChecker(robot)
    kernel = checker.sphere_kernel()
    assert kernel is not None and kernel.has_spheres
    _assert_exact(kernel.collisions_with(qs, 1), expected, touching)
    _assert_exact(kernel.collisions_with(qs, 0), expected, touching)


def test_given_geometry_data_is_used(
    scene: tuple[Robot, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """A GeometryData passed to the kernel is the one it checks with (its active pairs)."""
    robot, qs, expected, touching = scene
    model = robot._model.copy()
    geom = robot._collision_model.copy()
    gdata = geom.createData()
    for p in range(len(geom.collisionPairs)):  # every pair off: the kernel finds nothing
        gdata.deactivateCollisionPair(p)
    kernel = MODULE.CollisionKernel(model, model.createData(), geom, gdata, NATIVE_PAIR_CACHE)
    assert expected.any()
    assert not np.asarray(kernel.collisions(qs), dtype=bool).any()
    _assert_exact(_kernel(robot, "full").collisions(qs), expected, touching)


def test_checker_builds_no_full_geometry_data(monkeypatch: pytest.MonkeyPatch) -> None:
    """The checker's kernel is built without ``GeometryModel.createData`` (the set-up's largest
    piece before: distance and contact-patch functors of every pair, never used)."""
    robot = Robot.load("panda", convex_collision=True)
    _scene(robot)
    calls = []
    original = pin.GeometryModel.createData

    def counting(self: Any) -> Any:
        calls.append(1)
        return original(self)

    monkeypatch.setattr(pin.GeometryModel, "createData", counting)
    checker = CollisionChecker(robot)
    assert checker.native_kernel() is not None
    checker.sphere_kernel()
    assert calls == []
    monkeypatch.undo()
    qs = _configurations(robot, 60, 5)
    _assert_exact(
        ~checker.are_valid(qs), pinocchio_collision_flags(robot, qs), _touching(robot, qs)
    )


@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
def test_motionbenchmaker_scenes() -> None:
    """Every scenario's first two problems: start, goal and random configurations."""
    from taskspace.planning.scene_loader import (
        MOTIONBENCHMAKER_SCENARIOS,
        motionbenchmaker_panda,
        motionbenchmaker_problems,
    )

    robot = motionbenchmaker_panda()
    rng = np.random.default_rng(2)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    for scen in MOTIONBENCHMAKER_SCENARIOS:
        for problem in motionbenchmaker_problems(ROOT, scen, [1, 2]):
            request = problem.apply(robot)
            qs = np.vstack([request.start, request.goal, rng.uniform(lo, hi, (40, robot.nq))])
            expected, touching = pinocchio_collision_flags(robot, qs), _touching(robot, qs)
            for mode in KERNEL_MODES:
                kernel = _kernel(robot)
                kernel.mode = mode
                _assert_exact(kernel.collisions(qs), expected, touching)
