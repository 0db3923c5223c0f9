"""No answer of taskspace's Python collision queries depends on an earlier query.

Pinocchio's ``GeometryData`` requests keep coal's cached GJK guess by default. On
MotionBenchMaker bookshelf_small problem 1, configuration ``b`` puts ``panda_link5`` 1.3 cm
inside ``shelf_bottom``; after a narrow-phase call of that pair at configuration ``a``, a
data with the cached guess reports ``b`` free. Reference: a fresh ``GeometryData`` per query
(nothing cached) and coal's distance (-1.3 cm).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from _mbm import ROOT, SKIP_REASON

from taskspace.model.collision_requests import without_cached_guess
from taskspace.model.state import State
from taskspace.planning.collision_checker import CollisionChecker, CollisionCheckerOptions
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

pytestmark = pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
PAIR = ("panda_link5_0", "shelf_bottom")
OPTIONS = {
    "kernel": CollisionCheckerOptions(),
    "broadphase_pool": CollisionCheckerOptions(native=False),
    "geometry_pool": CollisionCheckerOptions(native=False, broadphase=False),
}


@pytest.fixture(scope="module")
def scene() -> tuple[Any, np.ndarray, np.ndarray]:
    robot = motionbenchmaker_panda()
    motionbenchmaker_problems(ROOT, "bookshelf_small", [1])[0].apply(robot)
    rng = np.random.default_rng(0)
    lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    qs = rng.uniform(lo, hi, (1000, robot.nq))
    return robot, qs[192], qs[837]


def _fresh_pairs(robot: Any, q: np.ndarray) -> list[tuple[str, str]]:
    """Colliding pairs from a new GeometryData (nothing cached from earlier calls)."""
    model, geom = robot.model, robot.collision_model
    gdata = geom.createData()
    pin.computeCollisions(model, model.createData(), geom, gdata, q, False)
    objs = geom.geometryObjects
    return [
        (objs[p.first].name, objs[p.second].name)
        for k, p in enumerate(geom.collisionPairs)
        if gdata.collisionResults[k].isCollision()
    ]


def test_the_reproducer_is_a_penetration_pinocchio_defaults_miss(scene: Any) -> None:
    robot, a, b = scene
    assert _fresh_pairs(robot, b) == [PAIR]
    assert _fresh_pairs(robot, a) == []
    model, geom = robot.model, robot.collision_model
    pair = next(
        k
        for k, p in enumerate(geom.collisionPairs)
        if (geom.geometryObjects[p.first].name, geom.geometryObjects[p.second].name) == PAIR
    )
    gdata, data = geom.createData(), model.createData()  # Pinocchio's defaults: cached guess
    for q in (a, b):
        pin.updateGeometryPlacements(model, data, geom, gdata, q)
        hit = pin.computeCollision(geom, gdata, pair)
    assert not hit  # the stale answer the fix avoids (if coal changes, this test says so)
    without_cached_guess(gdata)
    assert pin.computeCollision(geom, gdata, pair)
    pin.computeDistance(geom, gdata, pair)
    assert gdata.distanceResults[pair].min_distance < -0.01


@pytest.mark.parametrize("name", list(OPTIONS))
def test_collision_checker_answers_do_not_depend_on_earlier_queries(scene: Any, name: str) -> None:
    robot, a, b = scene
    checker = CollisionChecker(robot, OPTIONS[name])
    for q in (a, b):
        valid = checker.is_valid(q)
    assert not valid
    checker.are_valid(a[None])
    assert not checker.are_valid(b[None])[0]
    checker.first_invalid(a[None])
    assert checker.first_invalid(np.stack([a, b])) == 1
    checker.colliding_pairs(a)
    assert checker.colliding_pairs(b) == _fresh_pairs(robot, b)
    checker.distance(a)
    dist, pair = checker.distance(b)
    assert pair == PAIR and dist < -0.01


def test_robot_queries_do_not_depend_on_earlier_queries(scene: Any) -> None:
    robot, a, b = scene
    robot.is_collision_free(a)
    assert not robot.is_collision_free(b)
    robot.colliding_pairs(a)
    assert robot.colliding_pairs(b) == _fresh_pairs(robot, b)


def test_every_geometry_data_taskspace_makes_has_no_cached_guess(scene: Any) -> None:
    robot = scene[0]
    robot.is_collision_free(scene[1])  # the robot turns it off at its first query
    state = State(robot, scene[1])
    state.compute_distances()  # the state turns the guess off at its first distance query
    datas = [robot.collision_data, state.collision_data]
    for options in OPTIONS.values():
        checker = CollisionChecker(robot, options)
        checker.colliding_pairs(scene[1])  # turned off at the first Python-side query
        datas.append(checker._geom_data)
        pool = checker._pool if checker._pool is not None else checker._geometry_pool
        datas.extend(pool.getGeometryDatas())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for gdata in datas:
            requests = list(gdata.collisionRequests) + list(gdata.distanceRequests)
            assert requests
            assert not any(r.enable_cached_gjk_guess for r in requests)
