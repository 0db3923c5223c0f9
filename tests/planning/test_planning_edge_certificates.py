"""Edge clearance certificates of the compiled kernel (checker "clearance", #22 items 4-5).

A sphere check returns the spheres' clearance; a per-link bound on how far a sphere centre
moves per unit of each joint (``CollisionKernel.motion_bounds``) turns it into an interval
of the edge that is free (``CollisionKernel.certify_edge``). References, independent of the
kernel's code:

* the motion bound: sphere centres placed by Pinocchio's forward kinematics at random
  configurations and displacements (single joints and all joints, small and large);
* certified edges: the kernel's sphere point checker ("spheres_only", tested against
  Pinocchio in test_planning_sphere_checker.py) at every 0.5 mm of sphere motion, and
  Pinocchio's ``computeCollisions`` on the meshes at every 2 mm;
* planned paths: Pinocchio's ``computeCollisions`` densely along the path.
"""

from __future__ import annotations

import itertools
from typing import Any

import coal
import numpy as np
import pinocchio as pin
import pytest
from _mbm import ROOT, SKIP_REASON
from _sphere_reference import mesh_collides

from taskspace._native import planning_kernel
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import CHECKERS, RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems

pytestmark = [
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
    pytest.mark.skipif(planning_kernel() is None, reason="compiled planning kernel not built"),
]

SPHERES_ONLY = 2
PROBLEM = {"bookshelf_small": 1, "box": 3, "cage": 1, "table_pick": 3}


@pytest.fixture(scope="module")
def robot() -> Any:
    return motionbenchmaker_panda()


def _space(robot: Any, scenario: str) -> tuple[Any, Any]:
    req = motionbenchmaker_problems(ROOT, scenario, [PROBLEM[scenario]])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    return req, space


def _centres(model: Any, data: Any, spheres: Any, q: np.ndarray) -> np.ndarray:
    pin.forwardKinematics(model, data, q)
    return spheres.world_centers(data)


def test_motion_bounds_hold_for_every_sphere(robot: Any) -> None:
    """|c(q + dq) - c(q)| <= sum_k mb[link, k] |dq_k| for every sphere centre c (Pinocchio's
    kinematics), and for two spheres of a self pair the change of their distance is bounded
    by the joints that move one link and not the other; the bound is not vacuous (ratios
    above 0.6 occur, so half the bound fails)."""
    _, space = _space(robot, "box")
    kernel = space.checker.sphere_kernel()
    spheres = space.checker.sphere_model()
    joints, mb = kernel.motion_bounds()
    assert mb.shape == (len(joints), robot.nq) and np.all(mb >= 0.0)
    row = {int(j): r for r, j in enumerate(joints)}
    rows = np.array([row[int(j)] for j in spheres.joints])
    model = robot.model
    data = model.createData()
    # ancestors (velocity indices) of each link's joint, from Pinocchio's model
    anc = np.zeros((len(joints), robot.nq), bool)
    for r, j in enumerate(joints):
        for k in model.supports[int(j)][1:]:
            anc[r, model.joints[k].idx_v] = True
    rng = np.random.default_rng(3)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    ratios, pair_ratios = [], []
    pick = rng.choice(len(rows), size=(400, 2))  # sphere pairs on different links
    pick = pick[rows[pick[:, 0]] != rows[pick[:, 1]]]
    ra, rb = rows[pick[:, 0]], rows[pick[:, 1]]
    only_a, only_b = anc[ra] & ~anc[rb], anc[rb] & ~anc[ra]
    for trial in range(300):
        q = rng.uniform(lo, hi)
        dq = np.zeros(robot.nq)
        scale = [1e-3, 0.1, 1.0][trial % 3]
        if trial % 2:
            dq[rng.integers(robot.nq)] = scale * rng.choice([-1.0, 1.0])
        else:
            dq = scale * rng.standard_normal(robot.nq)
        c0 = _centres(model, data, spheres, q)
        c1 = _centres(model, data, spheres, q + dq)
        bound = mb[rows] @ np.abs(dq)
        moved = np.linalg.norm(c1 - c0, axis=1)
        assert np.all(moved <= bound * (1 + 1e-9) + 1e-12), np.max(moved / bound)
        ratios.append(np.max(moved[bound > 0] / bound[bound > 0], initial=0.0))
        d0 = np.linalg.norm(c0[pick[:, 0]] - c0[pick[:, 1]], axis=1)
        d1 = np.linalg.norm(c1[pick[:, 0]] - c1[pick[:, 1]], axis=1)
        rate = (mb[ra] * only_a + mb[rb] * only_b) @ np.abs(dq)
        assert np.all(np.abs(d1 - d0) <= rate * (1 + 1e-9) + 1e-12)
        pair_ratios.append(np.max(np.abs(d1 - d0)[rate > 0] / rate[rate > 0], initial=0.0))
    assert max(ratios) > 0.6 and max(pair_ratios) > 0.6


def test_certified_radius_matches_a_reference(robot: Any) -> None:
    """The kernel's certified radius (``clearance``: the minimum over the collision pairs of
    the spheres' clearance over the pair's rate) recomputed here from Pinocchio's kinematics:
    sphere-box distances (analytic), sphere-base distances (coal, less GJK's tolerance as the
    kernel), sphere-sphere distances for the self pairs, the rates from the motion bounds
    (per link; per self pair the joints that move one link only). Equal: the kernel's culling
    drops no pair that matters (a radius too large) and adds no slack."""
    _, space = _space(robot, "cage")
    kernel = space.checker.sphere_kernel()
    spheres = space.checker.sphere_model()
    joints, mb = kernel.motion_bounds()
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    row = {int(j): r for r, j in enumerate(joints)}
    anc = np.zeros((len(joints), robot.nq), bool)
    for r, j in enumerate(joints):
        for k in model.supports[int(j)][1:]:
            anc[r, model.joints[k].idx_v] = True
    pin.updateGeometryPlacements(model, data, geom, gdata, pin.neutral(model))
    static = {}
    for g, obj in enumerate(geom.geometryObjects):
        if obj.parentJoint == 0:
            static[g] = (obj.geometry, pin.SE3(gdata.oMg[g]))
    pairs = [
        (p.first, p.second)
        for k, p in enumerate(geom.collisionPairs)
        if gdata.activeCollisionPairs[k]
    ]
    rng = np.random.default_rng(4)
    compared = touching = 0
    while compared < 40:
        q = rng.uniform(space.lower, space.upper)
        d = rng.standard_normal(robot.nq) * rng.uniform(0.05, 1.0)
        pin.forwardKinematics(model, data, q)
        centres = spheres.world_centers(data)
        rate = mb @ np.abs(d)
        ref, hit = 1.0, False
        for g1, g2 in pairs:
            if g1 in static and g2 in static:
                continue
            if g1 in static or g2 in static:
                o, m = (g1, g2) if g1 in static else (g2, g1)
                sel = spheres.geometries == m
                c, r = centres[sel], spheres.radii[sel]
                shape, placement = static[o]
                if isinstance(shape, coal.Box):
                    local = (c - placement.translation) @ placement.rotation
                    gap = np.maximum(np.abs(local) - shape.halfSide, 0.0)
                    dist = np.linalg.norm(gap, axis=1)
                else:
                    tf = coal.Transform3s(placement.rotation, placement.translation)
                    dist = np.empty(len(c))
                    for i, (ci, ri) in enumerate(zip(c, r, strict=True)):
                        res = coal.DistanceResult()
                        ball = coal.Sphere(ri)
                        at = coal.Transform3s(np.eye(3), ci)
                        coal.distance(ball, at, shape, tf, coal.DistanceRequest(), res)
                        dist[i] = res.min_distance + ri - 1e-6  # coal's, less the tolerance
                clear = dist - r
                pair_rate = rate[row[int(geom.geometryObjects[m].parentJoint)]]
            else:
                s1, s2 = spheres.geometries == g1, spheres.geometries == g2
                gap = np.linalg.norm(centres[s1][:, None] - centres[s2][None], axis=2)
                clear = (gap - spheres.radii[s1][:, None] - spheres.radii[s2][None]).ravel()
                r1 = row[int(geom.geometryObjects[g1].parentJoint)]
                r2 = row[int(geom.geometryObjects[g2].parentJoint)]
                only = mb[r1] * (anc[r1] & ~anc[r2]) + mb[r2] * (anc[r2] & ~anc[r1])
                pair_rate = only @ np.abs(d)
            hit = hit or bool(np.any(clear <= 0.0))
            if pair_rate > 0.0:
                ref = min(ref, float(np.min(clear)) / pair_rate)
        got = kernel.clearance(q, d, 1.0)
        if hit:
            touching += 1
            assert got == 0.0
            continue
        compared += 1
        assert got == pytest.approx(ref, rel=1e-9, abs=2e-6 / rate.min())
    assert touching > 0


@pytest.mark.parametrize("scenario", ["table_pick", "cage"])
def test_certified_edges_are_free(robot: Any, scenario: str) -> None:
    """Random edges from free configurations: every edge certify_edge certifies is free for
    the spheres at every 0.5 mm of sphere motion and for Pinocchio's meshes at every 2 mm;
    every edge whose dense sphere check collides is refused. Both kinds occur."""
    _, space = _space(robot, scenario)
    kernel = space.checker.sphere_kernel()
    _, mb = kernel.motion_bounds()
    collides = mesh_collides(robot)
    rng = np.random.default_rng(11)
    certified = refused = meshed = 0
    while certified < 40 or refused < 20:
        q0 = rng.uniform(space.lower, space.upper)
        if kernel.collisions_with(q0[None], SPHERES_ONLY)[0]:
            continue
        step = rng.choice([0.1, 0.3, 0.6]) * rng.standard_normal(robot.nq) / np.sqrt(robot.nq)
        q1 = np.clip(q0 + step, space.lower, space.upper)
        ok, checks = kernel.certify_edge(q0, q1, 3e-5, 0.15)
        assert checks >= 1
        reach = float(np.max(mb @ np.abs(q1 - q0)))  # most any sphere centre moves
        ts = np.linspace(0.0, 1.0, int(np.ceil(reach / 5e-4)) + 1)
        dense = kernel.collisions_with(q0 + ts[:, None] * (q1 - q0), SPHERES_ONLY)
        if ok:
            certified += 1
            assert not dense.any(), f"certified edge collides at t = {ts[np.argmax(dense)]}"
            if meshed < 6:  # the meshes (Pinocchio), fewer edges: about 0.2 ms per point
                meshed += 1
                for t in np.linspace(0.0, 1.0, int(np.ceil(reach / 2e-3)) + 1):
                    assert not collides(q0 + t * (q1 - q0))
        elif dense.any():
            refused += 1
    assert meshed == 6


def test_edges_through_a_contact_are_refused(robot: Any) -> None:
    """Edges through a configuration just inside an obstacle (10 um to 1 mm of joint motion
    past the spheres' first contact, bisected), with both ends free: never certified; the
    part of the edge before the entry point is certified in most cases."""
    _, space = _space(robot, "table_pick")
    kernel = space.checker.sphere_kernel()
    rng = np.random.default_rng(5)
    grazes = halves = 0
    while grazes < 30:
        q0 = rng.uniform(space.lower, space.upper)
        qc = rng.uniform(space.lower, space.upper)
        pair = kernel.collisions_with(np.stack([q0, qc]), SPHERES_ONLY)
        if pair[0] or not pair[1]:
            continue
        lo, hi = 0.0, 1.0  # bisect q0 -> qc to the first contact of the spheres
        while (hi - lo) * np.abs(qc - q0).max() > 1e-7:
            mid = 0.5 * (lo + hi)
            inside = kernel.collisions_with((q0 + mid * (qc - q0))[None], SPHERES_ONLY)[0]
            lo, hi = (lo, mid) if inside else (mid, hi)
        depth = 10 ** rng.uniform(-5, -3) / np.abs(qc - q0).max()
        q_in = q0 + min(1.0, hi + depth) * (qc - q0)
        if not kernel.collisions_with(q_in[None], SPHERES_ONLY)[0]:
            continue
        w = rng.standard_normal(robot.nq)
        w *= rng.uniform(0.05, 0.3) / np.linalg.norm(w)
        a, b = q_in - w, q_in + w
        if kernel.collisions_with(np.stack([a, b]), SPHERES_ONLY).any():
            continue
        grazes += 1
        assert not kernel.certify_edge(a, b, 3e-5, 0.15)[0]
        # the ray q0 -> qc up to just before the contact
        halves += kernel.certify_edge(q0, q0 + 0.999 * lo * (qc - q0), 3e-5, 0.15)[0]
    assert halves >= 15


def test_clearance_radius_is_a_lower_bound(robot: Any) -> None:
    """The certified radius at q along d: the spheres stay free for every |t| < radius (dense
    check); within 20 x the radius some configuration collides in a share of the cases (the
    bound is conservative: the first contact along the line lies 2-70 x the radius away,
    median 7, on bookshelf_small)."""
    _, space = _space(robot, "bookshelf_small")
    kernel = space.checker.sphere_kernel()
    rng = np.random.default_rng(2)
    tight = seen = 0
    while seen < 60:
        q = rng.uniform(space.lower, space.upper)
        d = rng.standard_normal(robot.nq)
        d /= np.linalg.norm(d)
        s = kernel.clearance(q, d, 1.0)
        if s <= 0.0 or s >= 1.0:
            assert s == 0.0 or s == pytest.approx(1.0) or s >= 1.0
            continue
        seen += 1
        for sign in (1.0, -1.0):
            ts = np.linspace(0.0, s, 200)[:-1]
            pts = q + sign * ts[:, None] * d
            assert not kernel.collisions_with(pts, SPHERES_ONLY).any()
        far = q + np.linspace(s, 20.0 * s, 400)[:, None] * d
        tight += bool(kernel.collisions_with(far, SPHERES_ONLY).any())
    assert tight >= 3  # the radius is not uselessly small everywhere


@pytest.mark.parametrize("scenario", ["bookshelf_small", "box"])
def test_planned_paths_are_certified(robot: Any, scenario: str) -> None:
    """checker="clearance": every returned path is free densely (Pinocchio at 0.01 rad); a
    path reported certified has every edge certified again by certify_edge. Paths are
    certified exactly when no endpoint collides for the spheres (box problem 3: the goal is
    closer to the object than the spheres' margin; its edges are checked at points)."""
    req, space = _space(robot, scenario)
    kernel = space.checker.sphere_kernel()
    collides = mesh_collides(robot)
    n_certified = 0
    for seed in range(3):
        res = rrt_connect(
            space, req.start, req.goal, RRTConnectOptions(seed=seed, checker="clearance")
        )
        assert res.success and res.log["checker"] == 3.0
        assert np.array_equal(res.path[0], req.start) and np.array_equal(res.path[-1], req.goal)
        for a, b in itertools.pairwise(res.path):
            n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.01)))
            assert not any(collides(a + t * (b - a)) for t in np.linspace(0.0, 1.0, n + 1))
        if res.log["path_certified"] == 1.0:
            n_certified += 1
            assert res.log["spheres_fallback"] == 0.0 and res.log["lazy_rejections"] == 0.0
            for a, b in itertools.pairwise(res.path):
                assert kernel.certify_edge(a, b, 3e-5, 0.15)[0]
    ends_free = not kernel.collisions_with(np.stack([req.start, req.goal]), SPHERES_ONLY).any()
    assert n_certified >= 1 if ends_free else n_certified == 0


def test_spheres_without_the_volume_certificate_certify_no_path(robot: Any) -> None:
    """Spheres set without sphere_model's volume certificate (certified_margin 0) certify the
    spheres, not the meshes: no path is reported certified (the exact re-check runs)."""
    req, space = _space(robot, "bookshelf_small")
    kernel = space.checker.sphere_kernel()
    spheres = space.checker.sphere_model()
    args = (
        spheres.centers,
        spheres.radii,
        spheres.joints.astype(np.int32),
        spheres.geometries.astype(np.int32),
    )
    opts = RRTConnectOptions(seed=0, checker="clearance")
    try:
        kernel.set_spheres(*args)  # no certificate
        res = rrt_connect(space, req.start, req.goal, opts)
        assert res.success and res.log["path_certified"] == 0.0
        assert res.log["exact_recheck_checks"] > 0.0
    finally:
        kernel.set_spheres(*args, spheres.certified_margin)
    res = rrt_connect(space, req.start, req.goal, opts)
    assert res.success and res.log["path_certified"] == 1.0
    assert res.log["exact_recheck_checks"] == 0.0


def test_bad_inputs(robot: Any) -> None:
    _, space = _space(robot, "box")
    kernel = space.checker.sphere_kernel()
    q = np.zeros(robot.nq)
    for args in (
        (q[:3], q, 1e-3, 0.1),
        (q, q, 0.0, 0.1),
        (q, q, 1e-3, 1e-4),
        (q, np.full(robot.nq, np.nan), 1e-3, 0.1),
    ):
        with pytest.raises(InvalidInputError):
            kernel.certify_edge(*args)
    with pytest.raises(InvalidInputError):
        kernel.clearance(q, q, 0.0)
    with pytest.raises(InvalidInputError):
        planning_kernel().set_clearance_tuning(0.0, 1.0)
    assert "clearance" in CHECKERS
    with pytest.raises(UnknownNameError, match="clearance"):
        rrt_connect(space, q, q, RRTConnectOptions(checker="clearence"))
