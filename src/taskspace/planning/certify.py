"""Certified paths: collision-free everywhere along each segment, not only at its samples.

A straight segment ``q(t) = q0 (+) t (q1 (-) q0)``, ``t in [0, 1]`` (``(+)``, ``(-)``:
Pinocchio's ``integrate`` and ``difference``, so a continuous joint turns the short way), is
certified by conservative advancement (Schwarzer, Saha and Latombe 2005): at ``q(t)`` the
least distance ``d`` between
the robot and the obstacles (and ``d_s`` between checked robot links) is computed with coal;
no point of any link moves farther than ``B |dt|`` while ``t`` changes by ``dt``, where

    B = sum_j R_j |(q1 (-) q0)_j|,

``R_j`` bounding the distance from joint ``j``'s axis to any point of a link moved by it (the
joint offsets along the chain plus the farthest corner of the geometry's bounding box; 1 for a
prismatic joint). So ``t`` may advance by ``min(d / B, d_s / (2 B))`` with no contact
possible, and the segment is free when ``t`` reaches 1. A distance below ``tolerance`` stops
the advancement: the segment is then reported uncertified (touching, or closer than the
tolerance), never "free".
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import as_float_array, check_count, check_positive
from taskspace.errors import InvalidInputError
from taskspace.model import Robot

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PathCertificate:
    """The result of :func:`certify_path`.

    Attributes:
        certified: every segment was proven collision-free.
        min_distance: the least distance met along the path [m] (<= 0 in collision).
        failed_segment: index of the first segment not certified (-1 when certified).
        failed_t: where along it the advancement stopped (``t`` in [0, 1]).
        distance_queries: distance evaluations made.
    """

    certified: bool
    min_distance: float
    failed_segment: int
    failed_t: float
    distance_queries: int


def motion_bounds(robot: Robot) -> FloatArray:
    """``R_j`` per velocity coordinate [m per rad, or 1 for prismatic joints].

    Raises:
        InvalidInputError: the robot has joints of more than one degree of freedom (floating
            base, spherical, planar): certify the arm with the base fixed instead.
    """
    model = robot.model
    gm = robot.collision_model
    bounds = np.zeros(model.nv)
    reach = np.zeros(model.njoints)  # farthest geometry point from each joint's origin
    for k in range(robot.robot_geometry_count):
        obj = gm.geometryObjects[k]
        geometry = obj.geometry
        geometry.computeLocalAABB()
        lo, hi = geometry.aabb_local.min_, geometry.aabb_local.max_
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
        far = float(
            np.max(
                np.linalg.norm(
                    corners @ obj.placement.rotation.T + obj.placement.translation, axis=1
                )
            )
        )
        joint = obj.parentJoint
        offset = 0.0
        while joint > 0:
            reach[joint] = max(reach[joint], far + offset)
            offset += float(np.linalg.norm(model.jointPlacements[joint].translation))
            joint = model.parents[joint]
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nv != 1:
            raise InvalidInputError(
                f"certify_path handles joints of one degree of freedom; joint "
                f"'{model.names[j]}' has {joint.nv}; certify the arm with the base fixed "
                f"(a fixed-base model, e.g. pinocchio.buildReducedModel) instead"
            )
        prismatic = "Prismatic" in joint.shortname()
        bounds[joint.idx_v] = 1.0 if prismatic else reach[j]
    return bounds


def certify_path(
    robot: Robot,
    path: object,
    *,
    tolerance: float = 1e-4,
    max_queries: int = 100_000,
) -> PathCertificate:
    """Prove each segment of ``path`` collision-free by conservative advancement.

    Args:
        robot: the robot with its collision pairs and obstacles (convex hulls make the
            distance queries fast).
        path: waypoints ``(m, nq)``.
        tolerance: the least distance [m] still counted as free.
        max_queries: a cap on distance evaluations over the whole path.
    """
    arr = as_float_array(path, "path")
    if arr.ndim != 2 or arr.shape[1] != robot.nq or arr.shape[0] == 0:
        raise InvalidInputError(f"path must have shape (m, {robot.nq}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError("path must be finite")
    if isinstance(tolerance, (bool, np.bool_)):
        raise InvalidInputError(f"tolerance must be a distance > 0 [m], got {tolerance!r}")
    check_positive(tolerance, "tolerance")
    max_queries = check_count(max_queries, "max_queries", minimum=1)
    R = motion_bounds(robot)
    model, gm = robot.model, robot.collision_model
    data, gd = model.createData(), gm.createData()
    n_robot = robot.robot_geometry_count
    pairs = gm.collisionPairs
    self_pair = np.array([p.first < n_robot and p.second < n_robot for p in pairs])

    def distances(q: FloatArray) -> tuple[float, float]:
        pin.computeDistances(model, data, gm, gd, q)
        d = np.array([r.min_distance for r in gd.distanceResults])
        d_obstacle = float(d[~self_pair].min()) if (~self_pair).any() else math.inf
        d_self = float(d[self_pair].min()) if self_pair.any() else math.inf
        return d_obstacle, d_self

    queries = 0
    least = math.inf
    for s in range(arr.shape[0] - 1 if arr.shape[0] > 1 else 1):
        q0 = arr[s]
        q1 = arr[s + 1] if arr.shape[0] > 1 else arr[s]
        delta = pin.difference(model, q0, q1)  # (nv,): joint motions, continuous joints too
        rate = float(R @ np.abs(delta))
        t = 0.0
        while True:
            d_obs, d_self = distances(pin.integrate(model, q0, t * delta))
            queries += 1
            d = min(d_obs, d_self)
            least = min(least, d)
            if d < tolerance or queries >= max_queries:
                return PathCertificate(False, least, s, t, queries)
            if rate == 0.0 or t >= 1.0:
                break
            step = min(d_obs / rate, d_self / (2.0 * rate))
            t = min(1.0, t + step)
    return PathCertificate(True, least, -1, 1.0, queries)


def certify_planned(
    space: Any,
    plan: Callable[[int, float], Any],
    *,
    time_limit_s: float,
    retries: int,
    tolerance: float = 1e-4,
) -> Any:
    """Plan, certify the path (:func:`certify_path`) and re-plan while it is not certified.

    Args:
        space: the planner's :class:`~taskspace.planning.ConfigurationSpace`; its checker
            must be a :class:`~taskspace.planning.CollisionChecker` (a robot).
        plan: ``plan(attempt, time_left_s) -> PlannerResult`` (attempt 0, 1, ...: the
            planner with a different seed for each attempt).
        time_limit_s: the whole budget [s] (``math.inf``: none).
        retries: re-plans after an uncertified path (an integer >= 0).
        tolerance: the least distance [m] still counted as free.

    Returns:
        The first certified result (``log["certified"] = 1.0``, ``log["min_distance"]``,
        ``log["certify_attempts"]``); when none could be certified, the last path with
        ``success=False``, status ``UNCERTIFIED`` and ``log["uncertified_segment"]`` /
        ``log["uncertified_t"]`` (where along it the proof stopped).

    Raises:
        InvalidInputError: the space has no robot to certify against.
    """
    from taskspace.planning.collision_checker import CollisionChecker
    from taskspace.planning.planner_result import PlannerStatus

    checker = getattr(space, "checker", None)
    if not isinstance(checker, CollisionChecker):
        raise InvalidInputError(
            "certify=True needs a space built on a robot (ConfigurationSpace.from_robot): "
            f"the space's checker is a {type(checker).__name__}, which has no geometry to "
            "measure distances on; use certify=False"
        )
    retries = check_count(retries, "certify_retries")
    if isinstance(tolerance, (bool, np.bool_)):
        raise InvalidInputError(f"certify_tolerance must be a distance > 0 [m], got {tolerance!r}")
    check_positive(tolerance, "certify_tolerance")
    t0 = time.perf_counter()
    result: Any = None
    for attempt in range(retries + 1):
        left = max(0.0, time_limit_s - (time.perf_counter() - t0))
        result = plan(attempt, left)
        result.log["certify_attempts"] = float(attempt + 1)
        if not result.success:
            return result
        cert = certify_path(checker.robot, result.path, tolerance=tolerance)
        result.log["min_distance"] = cert.min_distance
        if cert.certified:
            result.log["certified"] = 1.0
            result.time_s = time.perf_counter() - t0
            return result
        result.log["certified"] = 0.0
        result.log["uncertified_segment"] = float(cert.failed_segment)
        result.log["uncertified_t"] = cert.failed_t
        if time.perf_counter() - t0 >= time_limit_s:
            break
    result.success = False
    result.status = PlannerStatus.UNCERTIFIED
    result.time_s = time.perf_counter() - t0
    return result
