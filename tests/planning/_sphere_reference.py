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

    def __init__(self, robot: Any, spheres: Any) -> None:
        self.model, geom = robot.model, robot.collision_model
        self.data = self.model.createData()
        gdata = geom.createData()
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
        for k, test in self.pairs:
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
