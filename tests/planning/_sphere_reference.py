"""References for the kernel's sphere checks (test_planning_sphere_batch.py,
test_planning_sphere_pairs.py, test_planning_edge_certificates.py): the double-precision sphere
test recomputed in NumPy, and Pinocchio's exact mesh test."""

from __future__ import annotations

import warnings
from typing import Any

import coal
import numpy as np
import pinocchio as pin


class PairClearances:
    """Per active collision pair (not two static objects): the smallest clearance [m] of its
    spheres at q, from Pinocchio's kinematics: analytic distances to boxes, cylinders and balls,
    coal's distance to other shapes (the pairs in ``generic``), sphere-sphere distances for the
    self pairs. Independent of the kernel's code."""

    def __init__(self, robot: Any, spheres: Any, exact: tuple[tuple[str, str], ...] = ()) -> None:
        """``exact``: the self pairs (geometry names) the kernel tests exactly with
        "spheres_only" (``CollisionChecker.sphere_exact_pairs``): their value is then -1 where
        Pinocchio's ``computeCollision`` finds them colliding, else +1."""
        self.model, geom = robot.model, robot.collision_model
        self.data = self.model.createData()
        gdata = geom.createData()
        self.geom, self.gdata = geom, geom.createData()
        objs = geom.geometryObjects
        self.exact = {
            k
            for k, p in enumerate(geom.collisionPairs)
            if (objs[p.first].name, objs[p.second].name) in exact
        }
        pin.updateGeometryPlacements(self.model, self.data, geom, gdata, pin.neutral(self.model))
        self.spheres = spheres
        static = {g for g, o in enumerate(geom.geometryObjects) if o.parentJoint == 0}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            margins = [r.security_margin for r in gdata.collisionRequests]
        self.pairs: list[tuple[int, Any]] = []  # (pair index, test)
        self.generic: set[int] = set()
        for k, p in enumerate(geom.collisionPairs):
            if not gdata.activeCollisionPairs[k]:
                continue
            assert margins[k] <= 0.0  # these scenes: no margin to add
            g1, g2 = p.first, p.second
            if g1 in static and g2 in static:
                continue
            if g1 in static or g2 in static:
                o, m = (g1, g2) if g1 in static else (g2, g1)
                shape = geom.geometryObjects[o].geometry
                assert shape.getSweptSphereRadius() == 0.0
                if not isinstance(shape, coal.Box | coal.Cylinder | coal.Sphere):
                    self.generic.add(k)
                self.pairs.append((k, (spheres.geometries == m, shape, pin.SE3(gdata.oMg[o]))))
            else:
                self.pairs.append((k, (spheres.geometries == g1, spheres.geometries == g2)))

    def __call__(self, q: np.ndarray) -> dict[int, float]:
        pin.forwardKinematics(self.model, self.data, q)
        c = self.spheres.world_centers(self.data)
        r = self.spheres.radii
        out = {}
        if self.exact:
            pin.updateGeometryPlacements(self.model, self.data, self.geom, self.gdata, q)
        for k, test in self.pairs:
            if k in self.exact:
                out[k] = -1.0 if pin.computeCollision(self.geom, self.gdata, k) else 1.0
                continue
            if len(test) == 2:
                s1, s2 = test
                gap = np.linalg.norm(c[s1][:, None] - c[s2][None], axis=2)
                out[k] = float(np.min(gap - r[s1][:, None] - r[s2][None]))
                continue
            sel, shape, placement = test
            local = (c[sel] - placement.translation) @ placement.rotation
            if isinstance(shape, coal.Box):
                d = np.linalg.norm(np.maximum(np.abs(local) - shape.halfSide, 0.0), axis=1)
            elif isinstance(shape, coal.Cylinder):
                dr = np.maximum(np.hypot(local[:, 0], local[:, 1]) - shape.radius, 0.0)
                dz = np.maximum(np.abs(local[:, 2]) - shape.halfLength, 0.0)
                d = np.hypot(dr, dz)
            elif isinstance(shape, coal.Sphere):
                d = np.maximum(np.linalg.norm(local, axis=1) - shape.radius, 0.0)
            else:
                tf = coal.Transform3s(placement.rotation, placement.translation)
                d = np.empty(int(sel.sum()))
                for i, (ci, ri) in enumerate(zip(c[sel], r[sel], strict=True)):
                    res = coal.DistanceResult()
                    at = coal.Transform3s(np.eye(3), ci)
                    coal.distance(coal.Sphere(ri), at, shape, tf, coal.DistanceRequest(), res)
                    d[i] = res.min_distance + ri
            out[k] = float(np.min(d - r[sel]))
        return out

    def clearance(self, q: np.ndarray) -> tuple[float, float]:
        """The smallest sphere clearance [m] to the primitives and self pairs, and to the other
        shapes (coal's distance, e.g. to the robot base's hull)."""
        prim, other = np.inf, np.inf
        for k, value in self(q).items():
            if k in self.generic:
                other = min(other, value)
            else:
                prim = min(prim, value)
        return prim, other


def mesh_collides(robot: Any) -> Any:
    """Pinocchio's exact test of every pair at q (no GJK warm start, EPA on), as a function."""
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for request in gdata.collisionRequests:
            request.enable_cached_gjk_guess = False
            request.gjk_initial_guess = coal.GJKInitialGuess.DefaultGuess
            request.enable_contact = True

    def collides(q: np.ndarray) -> bool:
        return bool(pin.computeCollisions(model, data, geom, gdata, q, True))

    return collides


def first_sphere_contacts(kernel: Any, qs: np.ndarray, rng: Any, count: int) -> np.ndarray:
    """Configurations bisected (kernel, filter off, double precision) to within 1e-12 of the
    first sphere contact on segments free -> colliding: the colliding ends. ``qs`` must hold
    both free and colliding rows for the spheres (checker 2)."""
    off, trusted, spheres_only = 0, 2, 2  # set_sphere_filter modes; the kernel's checker code
    kernel.set_sphere_filter(off)
    try:
        flags = kernel.collisions_with(qs, spheres_only).astype(bool)
        free, hit = qs[~flags], qs[flags]
        assert len(free) and len(hit)
        out = []
        for k in range(count):
            a, b = free[k % len(free)], hit[rng.integers(len(hit))]
            lo, hi = 0.0, 1.0
            while hi - lo > 1e-12:
                mid = 0.5 * (lo + hi)
                if kernel.collisions_with((a + mid * (b - a))[None], spheres_only)[0]:
                    hi = mid
                else:
                    lo = mid
            out.append(a + hi * (b - a))
        return np.array(out)
    finally:
        kernel.set_sphere_filter(trusted)


def last_step_pairs(kernel: Any, free: np.ndarray, hit: np.ndarray, count: int) -> np.ndarray:
    """For k < count, the segment free[k] -> hit[k] bisected (the kernel's "spheres only"
    answers, checker 2) to the last representable step before sphere contact: its two ends,
    one row each (the free one first)."""
    edge = []
    for k in range(count):
        a, b = free[k], hit[k]
        lo, hi = 0.0, 1.0
        while np.nextafter(lo, 1.0) < hi and (mid := 0.5 * (lo + hi)) not in (lo, hi):
            if kernel.collisions_with((a + mid * (b - a))[None], 2)[0]:
                hi = mid
            else:
                lo = mid
        edge += [a + lo * (b - a), a + hi * (b - a)]
    return np.array(edge)
