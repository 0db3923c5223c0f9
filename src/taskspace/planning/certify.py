"""Certified paths: collision-free everywhere along each segment, not only at its samples.

A straight segment ``q(t) = q0 (+) t (q1 (-) q0)``, ``t in [0, 1]`` (``(+)``, ``(-)``:
Pinocchio's ``integrate`` and ``difference``, so a continuous joint turns the short way), is
certified by conservative advancement (Schwarzer, Saha and Latombe 2005): at ``q(t)`` the
least distance ``d`` between
the robot and the obstacles (and ``d_s`` between checked robot links) is computed with coal;
no point of any link moves farther than ``B |dt|`` while ``t`` changes by ``dt``, where::

    B = sum_j (|v_j| + R_j |omega_j|),

``(v_j, omega_j)`` the linear and angular parts of joint ``j``'s share of
``q1 (-) q0`` (a free-flyer, planar, spherical, revolute, continuous or prismatic joint moves
with a constant body velocity along the segment) and ``R_j`` bounding the distance from joint
``j``'s origin to any point of a link moved by it (the joint offsets along the chain, the
reach of the prismatic joints crossed, plus the farthest corner of the geometry's bounding
box); see :class:`MotionBound`. Each pair is advanced on its own rate: an obstacle pair's
``B`` sums the joints above its robot body, a self pair's only the joints between its two
bodies (a common ancestor, e.g. the floating base, moves both rigidly). So ``t`` may advance
by ``min_p d_p / B_p`` over the pairs with no contact
possible, and the segment is free when ``t`` reaches 1. A distance below ``tolerance`` stops
the advancement: the segment is then reported uncertified (touching, or closer than the
tolerance), never "free".

Compiled certifier: for robots of revolute and prismatic joints about x, y or z (the
compiled kernel's robots), :func:`certify_path` runs the same advancement in C++
(``taskspace/_native/certify_kernel.hpp``), pair by pair along the whole path: each pair is
evaluated again only where the motion since its last evaluation could have used up its
distance, with cheap lower bounds first (the bounding sphere of each robot geometry, then the
robot's sphere model when it carries its volume certificate) and coal's distance where those
do not prove enough. Same answer's meaning: a certified path is free everywhere and every
distance evaluated is at least ``tolerance``; an uncertified one reports the first segment
(and ``t``) where an exact distance fell below ``tolerance``. Other robots, or
``native=False``, use the Python advancement below.

Thread safety: :class:`MotionBound` and :class:`PathCertificate` are immutable values; the
functions build their own Pinocchio data per call and may run from several threads (one robot may
be shared as long as its model, limits and world are not changed meanwhile; the compiled
certifier of a robot serves one thread at a time).
"""

from __future__ import annotations

import dataclasses
import math
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import check_count, check_finite, check_positive
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.model.collision_requests import without_cached_guess
from taskspace.planning.configuration_space import as_path

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
        timed_out: the advancement stopped at ``deadline`` (not certified, nothing found
            against the path).
    """

    certified: bool
    min_distance: float
    failed_segment: int
    failed_t: float
    distance_queries: int
    timed_out: bool = False


_REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned",
             "JointModelRUBX", "JointModelRUBY", "JointModelRUBZ",
             "JointModelRevoluteUnboundedUnaligned", "JointModelSphericalZYX")  # fmt: skip
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned",
              "JointModelTranslation")  # fmt: skip
_HELICAL = ("JointModelHX", "JointModelHY", "JointModelHZ", "JointModelHelicalUnaligned")
_CERTIFIABLE = (*_REVOLUTE, *_PRISMATIC, *_HELICAL, "JointModelPlanar", "JointModelSpherical",
                "JointModelFreeFlyer")  # fmt: skip


@dataclass(frozen=True)
class MotionBound:
    """A bound on how far any point of any link moves along a segment of joint motion.

    For the segment ``q(t) = q0 (+) t delta``, ``t in [0, 1]`` (``delta = q1 (-) q0``, size
    ``nv``), every joint ``j`` moves with a constant body velocity ``delta_j`` (the exponential
    of its Lie group), so a point ``p`` of a link below it moves, because of ``j``, at most at
    ``|v_j| + |omega_j| |p - o_j|`` (``v_j``, ``omega_j``: the linear and angular parts of
    ``delta_j``, ``o_j`` the joint's origin). Summed down the tree::

        B(delta) = sum_g w_g |delta[g]|,

    over groups ``g`` of velocity coordinates: the translation of a free-flyer, planar or
    translation joint and a prismatic coordinate with ``w = 1``; the rotation vector of a
    free-flyer or spherical joint, the angle of a planar, revolute or continuous joint with
    ``w = R_j``, the farthest any collision geometry below ``j`` can be from ``o_j`` (joint
    offsets along the chain, plus the reach of every prismatic joint crossed, plus the
    farthest corner of the geometry's bounding box); a helical joint ``R_j + |pitch|``; each
    Euler rate of a ``SphericalZYX`` joint ``R_j`` (``|omega| <= sum |rates|``).

    The reach of a prismatic joint comes from its position limits (unless the bound was made
    for a given path), so a bound kept across :meth:`~taskspace.model.Robot.set_limits` may
    under-estimate the motion: :meth:`check` raises once the robot's limits changed.

    Attributes:
        groups: per group, the indices of its velocity coordinates.
        weights: ``w_g`` [m per rad, or 1 for translations].
        joints: the Pinocchio joint index of each group.
        model_version: the :attr:`~taskspace.model.Robot.version` whose limits the bound
            was made from (``None``: made for a path, independent of the limits).
    """

    groups: tuple[tuple[int, ...], ...]
    weights: tuple[float, ...]
    joints: tuple[int, ...] = ()
    model_version: int | None = None

    def check(self, robot: Robot) -> None:
        """Raise :class:`~taskspace.errors.StaleModelError` if the limits changed.

        The bound was made from ``robot``'s limits of another version: make a new one with
        :func:`motion_bound`.
        """
        if self.model_version is not None:
            robot.check_version(self.model_version, "MotionBound")

    def group_rates(self, delta: FloatArray) -> FloatArray:
        """``w_g |delta[g]|`` per group [m]: the share of ``B(delta)`` of each group."""
        return np.array(
            [w * float(np.linalg.norm(delta[list(g)])) for g, w in zip(self.groups, self.weights)]
        )

    def __call__(self, delta: FloatArray) -> float:
        """``B(delta)`` [m]: no link point moves farther along the segment."""
        return float(
            sum(
                w * float(np.linalg.norm(delta[list(g)])) for g, w in zip(self.groups, self.weights)
            )
        )

    def per_coordinate(self, nv: int) -> FloatArray:
        """``w`` of each velocity coordinate's group (``B <= sum_i w_i |delta_i|``), (nv,)."""
        out = np.zeros(nv)
        for g, w in zip(self.groups, self.weights):
            out[list(g)] = w
        return out


def _robot(robot: Any, who: str) -> Robot:
    """``robot`` if it is a :class:`Robot`, else a clear error (a space, a Pinocchio model...).

    Raises:
        InvalidInputError: not a Robot; for a planning space, the message says which robot
            and configurations to give instead.
    """
    if isinstance(robot, Robot):
        return robot
    hint = ""
    if hasattr(robot, "full_configurations") and hasattr(robot, "checker"):  # a space
        hint = (
            ": give the robot the space was built on (ConfigurationSpace.from_robot(robot)), "
            "with the robot's configurations (space.full_configurations(path) for a space "
            "with locked joints)"
        )
    elif isinstance(robot, pin.Model):
        hint = ": it needs the collision geometry and obstacles of a taskspace Robot"
    raise InvalidInputError(f"{who} takes a taskspace Robot, got {type(robot).__name__}{hint}")


def motion_bound(robot: Robot, path: Any = None) -> MotionBound:
    """The :class:`MotionBound` of ``robot``.

    Args:
        robot: the robot and its collision geometries.
        path: waypoints ``(m, nq)`` the bound will be used on: the reach of each prismatic
            joint is the largest ``|q|`` along it (the segments move prismatic coordinates
            linearly). Without it, the largest ``|limit|``.

    Raises:
        InvalidInputError: a joint type whose motion cannot be bounded (composite, mimic),
            or a prismatic joint without finite limits and no ``path``; ``robot`` is not a
            :class:`Robot`.
    """
    robot = _robot(robot, "motion_bound")
    model = robot._model
    gm = robot._collision_model
    extent = np.zeros(model.njoints)  # how far a prismatic joint can displace its child
    for j in range(1, model.njoints):
        joint = model.joints[j]
        short = joint.shortname()
        if short not in _CERTIFIABLE:
            raise InvalidInputError(
                f"certify_path cannot bound the motion of joint '{model.names[j]}' of type "
                f"{short}; supported: {', '.join(_CERTIFIABLE)} (lock it, e.g. "
                "pinocchio.buildReducedModel)"
            )
        if short in _PRISMATIC:
            sl = slice(joint.idx_q, joint.idx_q + joint.nq)
            if path is not None:
                values = np.abs(np.asarray(path, dtype=np.float64)[:, sl])
                extent[j] = float(np.max(np.linalg.norm(values, axis=1)))
            else:
                lim = np.maximum(
                    np.abs(model.lowerPositionLimit[sl]), np.abs(model.upperPositionLimit[sl])
                )
                if not np.all(np.isfinite(lim)):
                    raise InvalidInputError(
                        f"prismatic joint '{model.names[j]}' has no finite limits: give the "
                        "path to motion_bound so its reach can be taken from it"
                    )
                extent[j] = float(np.linalg.norm(lim))
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
        offset = far
        while joint > 0:
            reach[joint] = max(reach[joint], offset)
            # From the parent's origin to this joint's moving frame: the fixed placement
            # plus the prismatic displacement.
            offset += float(np.linalg.norm(model.jointPlacements[joint].translation))
            offset += extent[joint]
            joint = model.parents[joint]
    groups: list[tuple[int, ...]] = []
    weights: list[float] = []
    owners: list[int] = []
    for j in range(1, model.njoints):
        joint = model.joints[j]
        short, i = joint.shortname(), joint.idx_v
        before = len(groups)
        if short == "JointModelFreeFlyer":
            groups += [(i, i + 1, i + 2), (i + 3, i + 4, i + 5)]
            weights += [1.0, reach[j]]
        elif short == "JointModelPlanar":
            groups += [(i, i + 1), (i + 2,)]
            weights += [1.0, reach[j]]
        elif short == "JointModelSpherical":
            groups.append((i, i + 1, i + 2))
            weights.append(reach[j])
        elif short == "JointModelTranslation":
            groups.append((i, i + 1, i + 2))
            weights.append(1.0)
        elif short in _PRISMATIC:
            groups.append((i,))
            weights.append(1.0)
        elif short in _HELICAL:
            groups.append((i,))
            weights.append(reach[j] + abs(float(joint.pitch)))
        else:  # revolute, continuous, the three Euler rates of SphericalZYX
            for k in range(joint.nv):
                groups.append((i + k,))
                weights.append(reach[j])
        owners += [j] * (len(groups) - before)
    return MotionBound(
        tuple(groups),
        tuple(float(w) for w in weights),
        tuple(owners),
        None if path is not None else robot.version,
    )


def motion_bounds(robot: Robot) -> FloatArray:
    """``R_j`` per velocity coordinate [m per rad, or 1 for translations].

    ``sum_i R_i |delta_i|`` bounds how far any link point moves along a segment of joint
    motion ``delta`` (it is never below :class:`MotionBound`'s ``B(delta)``, which takes
    norms of the translation and rotation vectors of multi-DoF joints instead).

    Raises:
        InvalidInputError: see :func:`motion_bound`.
    """
    return motion_bound(robot).per_coordinate(robot._model.nv)


_NATIVE_JOINTS = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelPX", "JointModelPY",
                  "JointModelPZ")  # fmt: skip
_NATIVE_NEAR = 0.005
"""[m] the compiled certifier takes a sphere lower bound from this distance on (else coal's)."""
_NATIVE_FAR = 0.02
"""[m] the same for the bounding sphere of a robot geometry."""
_NATIVE_CERTIFIERS: weakref.WeakKeyDictionary[Robot, tuple[tuple[Any, ...], Any, Any]] = (
    weakref.WeakKeyDictionary()
)
"""Per robot: (what the certifier was built from, the compiled certifier, its spheres)."""


def native_certifier(robot: Robot, spheres: Any = None) -> Any:
    """The compiled certifier of ``robot`` (cached), or ``None`` when it cannot serve it.

    ``None`` when the kernel is not built or a joint is not revolute or prismatic about x, y
    or z. ``spheres``: the robot's :class:`~taskspace.planning.sphere_model.SphereModel`
    (used when it carries its volume certificate), a function returning it or ``None``
    (called when the certifier is built), or ``None`` (the cached certifier as it is, else one
    with bounding spheres and coal's distances only). Rebuilt when the robot's model, limits,
    world or geometry changed, or for other spheres.
    """
    model, gm = robot._model, robot._collision_model
    world = robot._world
    key = (model, gm, world, world._version, robot._version, robot._geometry_edits, gm.ngeoms)
    cached = _NATIVE_CERTIFIERS.get(robot)
    if cached is not None:
        old, used = cached[0], cached[2]
        same = all(a is b if i < 3 else a == b for i, (a, b) in enumerate(zip(old, key)))
        if same and (
            spheres is None or spheres is used or (callable(spheres) and used is not None)
        ):
            return cached[1]
    from taskspace._native import planning_kernel

    if model.nq != model.nv or any(
        model.joints[j].shortname() not in _NATIVE_JOINTS for j in range(1, model.njoints)
    ):
        return None
    module = planning_kernel()
    if module is None or not hasattr(module, "PathCertifier"):
        return None
    if callable(spheres):
        spheres = spheres()
    if spheres is not None and spheres.certified_margin > 0.0:
        centers = np.ascontiguousarray(spheres.centers, dtype=np.float64)
        radii = np.asarray(spheres.radii, dtype=np.float64)
        geometries = np.asarray(spheres.geometries, dtype=np.int32)
        margin = float(spheres.certified_margin)
    else:
        centers, radii = np.zeros((0, 3)), np.zeros(0)
        geometries, margin = np.zeros(0, np.int32), 0.0
    certifier = module.PathCertifier(
        model, gm, centers, radii, geometries, margin, robot.robot_geometry_count
    )
    _NATIVE_CERTIFIERS[robot] = (key, certifier, spheres)
    return certifier


def certify_path(
    robot: Robot,
    path: object,
    *,
    tolerance: float = 1e-4,
    max_queries: int = 100_000,
    deadline: float = math.inf,
    native: bool = True,
    spheres: Any = None,
) -> PathCertificate:
    """Prove each segment of ``path`` collision-free by conservative advancement.

    Robot pairs of two geometries on the same body (one parent joint) keep their distance
    along any motion: they are checked once, at the first waypoint (distance > 0), and take
    no part in the advancement. Any joint :func:`motion_bound` accepts may move, floating and
    planar bases included.

    Args:
        robot: the robot with its collision pairs and obstacles (convex hulls make the
            distance queries fast).
        path: waypoints ``(m, nq)`` (a 1-D array as
            :func:`~taskspace.planning.configuration_space.as_path` reads it).
        tolerance: the least distance [m] still counted as free.
        max_queries: a cap on distance evaluations over the whole path.
        deadline: a ``time.perf_counter()`` value [s]: the clock is read before each
            distance evaluation and none starts after it (then ``timed_out``, not
            certified); ``math.inf`` (default): no deadline.
        native: use the compiled certifier when it serves the robot (:func:`native_certifier`;
            ``distance_queries`` then counts its evaluation points).
        spheres: the robot's sphere model for the compiled certifier's lower bounds, or a
            function returning it (see :func:`native_certifier`).
    """
    robot = _robot(robot, "certify_path")
    arr = as_path(path, robot.nq)
    if isinstance(tolerance, (bool, np.bool_)):
        raise InvalidInputError(f"tolerance must be a distance > 0 [m], got {tolerance!r}")
    check_positive(tolerance, "tolerance")
    max_queries = check_count(max_queries, "max_queries", minimum=1)
    model, gm = robot._model, robot._collision_model
    # (the compiled certifier's joints have no quaternion or (cos, sin) pair to normalize)
    compiled = native_certifier(robot, spheres) if native else None
    if compiled is not None:
        left = deadline - time.perf_counter() if math.isfinite(deadline) else math.inf
        certified, least, segment, t, queries, timed_out, _, _ = compiled.certify(
            arr, float(tolerance), max_queries, left, _NATIVE_NEAR, _NATIVE_FAR
        )
        return PathCertificate(
            bool(certified), float(least), int(segment), float(t), int(queries), bool(timed_out)
        )
    normalized = np.array([pin.normalize(model, q) for q in arr])
    if np.max(np.abs(normalized - arr)) > 1e-6:
        raise InvalidInputError(
            "path has configurations whose quaternions or (cos, sin) pairs are not of unit "
            "norm; normalize them (pinocchio.normalize) before certifying"
        )
    bound = motion_bound(robot, arr)
    data, gd = model.createData(), without_cached_guess(gm.createData())
    n_robot = robot.robot_geometry_count
    pairs = gm.collisionPairs
    self_pair = np.array([p.first < n_robot and p.second < n_robot for p in pairs], dtype=bool)
    parent = [obj.parentJoint for obj in gm.geometryObjects]
    # Two geometries on one joint's body never move relative to each other: their distance
    # is checked once (> 0), not advanced on (tiago's finger links sit 2e-5 m apart).
    rigid = self_pair & np.array([parent[p.first] == parent[p.second] for p in pairs], dtype=bool)

    def ancestors(joint: int) -> set[int]:
        out = set()
        while joint > 0:
            out.add(joint)
            joint = model.parents[joint]
        return out

    # Which groups of joint motion can change each pair's distance: the joints above the
    # robot geometry for an obstacle pair; for a self pair only the joints between the two
    # bodies (a common ancestor moves both rigidly, which keeps their distance).
    owners = np.array(bound.joints)
    pair_groups = np.zeros((len(pairs), len(owners)))
    for k, p in enumerate(pairs):
        a = ancestors(parent[p.first]) if p.first < n_robot else set()
        b = ancestors(parent[p.second]) if p.second < n_robot else set()
        pair_groups[k] = np.isin(owners, sorted(a ^ b))
    active = ~rigid

    queries = 0
    least = math.inf
    timed = math.isfinite(deadline)
    if rigid.any():
        if timed and time.perf_counter() > deadline:
            return PathCertificate(False, least, 0, 0.0, queries, timed_out=True)
        pin.computeDistances(model, data, gm, gd, arr[0])
        queries += 1
        least = float(np.array([r.min_distance for r in gd.distanceResults])[rigid].min())
        if least <= 0.0:
            return PathCertificate(False, least, 0, 0.0, queries)
    for s in range(arr.shape[0] - 1 if arr.shape[0] > 1 else 1):
        # the robot's interpolation (interpolate_configurations): from normalized ends, whose
        # SO(2) difference Pinocchio gets right
        q0 = pin.normalize(model, arr[s])
        q1 = pin.normalize(model, arr[s + 1] if arr.shape[0] > 1 else arr[s])
        delta = pin.difference(model, q0, q1)  # (nv,): joint motions, continuous joints too
        rates = pair_groups @ bound.group_rates(delta)  # [m] per unit t, per pair
        moving = active & (rates > 0.0)
        t = 0.0
        while True:
            if timed and time.perf_counter() > deadline:
                return PathCertificate(False, least, s, t, queries, timed_out=True)
            pin.computeDistances(model, data, gm, gd, pin.integrate(model, q0, t * delta))
            queries += 1
            d = np.array([r.min_distance for r in gd.distanceResults])
            least = min(least, float(d[active].min()) if active.any() else math.inf)
            if (active.any() and d[active].min() < tolerance) or queries >= max_queries:
                return PathCertificate(False, least, s, t, queries)
            if not moving.any() or t >= 1.0:
                break
            step = float(np.min(d[moving] / rates[moving]))
            t = min(1.0, t + step)
    return PathCertificate(True, least, -1, 1.0, queries)


_Made = TypeVar("_Made")


def certify_keeping(
    space: Any,
    plan: Callable[[int, float], tuple[Any, _Made]],
    options: Any,
    *,
    time_limit_s: float,
) -> tuple[Any, _Made]:
    """:func:`certify_planned` for planners that also return what they built (a roadmap).

    ``plan(attempt, time_left)`` returns ``(result, product)``; the product of the last
    attempt is returned with the result. Without ``options.certify`` one plan runs with
    ``time_limit_s`` [s]; with it, ``options.certify_retries`` and ``options.certify_tolerance``
    as in :func:`certify_planned`.
    """
    made: list[_Made] = []

    def attempt(k: int, left: float) -> Any:
        result, product = plan(k, left)
        made.append(product)
        return result

    if not options.certify:
        return attempt(0, time_limit_s), made[-1]
    result = certify_planned(
        space,
        attempt,
        time_limit_s=time_limit_s,
        retries=options.certify_retries,
        tolerance=options.certify_tolerance,
    )
    return result, made[-1]


_certify_segment = certify_path
"""The certifier of :class:`FailedRegions` (a test that replaces :func:`certify_path` to see
the certified paths does not see the parts of edges certified during a re-plan)."""

_REGION_RESOLUTIONS = 4.0
"""Radius of a failed region, in units of the edge checks' spacing (the space's
:attr:`~taskspace.planning.ConfigurationSpace.edge_resolution`, in its metric)."""


class FailedRegions:
    """Where the certificates of earlier paths failed: a re-plan must prove its motions there.

    A certificate that fails at ``q(t)`` of segment ``s`` met a configuration closer to contact
    than the tolerance (or in contact) which the planner's edge check, a test of points
    ``delta`` apart in the space's metric (its ``edge_resolution``: ``edge.resolution``, scaled
    down by metric weights below 1), let through; a re-plan with another seed would let it through
    again: the same straight start-goal line, the same shortcut, or another edge across the
    same thin spot. Each failure adds a ball (in the space's metric) around ``q(t)``; all
    balls have the radius ``radius = 4 delta 2^(k - 1)`` after ``k`` failures: a failure
    again, after the first, says that the thin spot extends beyond the balls (a thin wall
    crossed elsewhere, which an optimizing planner seeks out: the shortest crossing just
    outside the ball), so the region where motions must be proven grows. A re-plan accepts
    an edge only if its part inside every ball it crosses is certified free
    (:func:`certify_path` on that part, within the plan's deadline); edges that cross no
    ball are checked as before, at no extra cost. The balls are not
    obstacles: a passage with a certifiable way through them stays open, and the returned
    path is still certified whole (:func:`certify_planned`); the balls only keep the re-plan
    from returning a motion already known to fail.

    The part inside a ball: the exact chord in a box space; on a joint manifold, between the
    points (at the resolution) nearer than ``radius`` plus half a step, widened by one point
    on each side (so it holds every point of the edge nearer than ``radius``, an edge that
    grazes a ball between two of its points included).

    Attributes:
        centers: the configurations ``q(t)`` where certificates failed, ``(k, d)``.
        base_radius: the balls' radius after one failure [rad or m].
        failures: ``(attempt, segment, t)`` of each failed certificate.
        certifications: edge parts certified during re-plans (inside a ball).
        rejections: those that could not be certified (the edge was refused).
    """

    def __init__(self, space: Any, tolerance: float) -> None:
        self.space = space
        self.robot, self.locked, self._checker = _certified_robot(space)
        self.tolerance = tolerance
        self.deadline = math.inf
        # The spacing of the edge checks in the metric of the balls: edge.resolution scaled
        # by metric weights below 1 (with edge.resolution itself, weights of 0.05 made balls
        # 20 checks wider, up to the whole space: every re-planned edge certified).
        self.base_radius = _REGION_RESOLUTIONS * float(space.edge_resolution)
        self.centers: FloatArray = np.empty((0, space.dim))
        self.failures: list[tuple[int, int, float]] = []
        self.certifications = 0
        self.rejections = 0

    @property
    def radius(self) -> float:
        """The balls' radius [rad or m]: ``base_radius`` doubled at each failure after the first."""
        return float(self.base_radius * 2.0 ** max(0, len(self.failures) - 1))

    def add(self, attempt: int, path: FloatArray, segment: int, t: float) -> None:
        """Record the failure of ``path`` (the planner's coordinates) at ``segment``, ``t``.

        Raises:
            InvalidInputError: ``path`` or ``t`` is not finite (a NaN centre would be no
                ball: every edge would pass it unproven).
        """
        check_finite(np.asarray(path, dtype=np.float64), "failed path")
        if not math.isfinite(t):
            raise InvalidInputError(f"the failed certificate's t must be finite, got {t!r}")
        self.failures.append((attempt, segment, t))
        if not 0 <= segment < path.shape[0] - 1:  # a one-point path (the start in a region)
            q = path[min(max(segment, 0), path.shape[0] - 1)]
        else:
            q = self.space.interpolate(path[segment], path[segment + 1], t)[0]
        self.centers = np.vstack([self.centers, q[None, :]])

    def crossings(self, q0: FloatArray, q1: FloatArray) -> list[tuple[float, float]]:
        """The intervals ``[t_in, t_out]`` of the edge ``q0 -> q1`` inside a ball.

        Raises:
            InvalidInputError: ``q0`` or ``q1`` is not finite (no ball would be found).
        """
        check_finite(q0, "edge start")
        check_finite(q1, "edge end")
        out: list[tuple[float, float]] = []
        r2 = self.radius * self.radius
        if self.space.is_euclidean:
            b = q1 - q0
            bb = float(b @ b)
            if bb <= 0.0:
                return out
            tc = (self.centers - q0) @ b / bb  # closest points of the line
            e2 = np.sum((q0 + tc[:, None] * b - self.centers) ** 2, axis=1)
            for k in np.flatnonzero(e2 < r2):
                h = math.sqrt((r2 - float(e2[k])) / bb)
                lo, hi = max(0.0, float(tc[k]) - h), min(1.0, float(tc[k]) + h)
                if lo <= hi:
                    out.append((lo, hi))
            return out
        n = self.space.segments(q0, q1)
        ts = np.arange(n + 1) / n
        points = self.space.interpolate(q0, q1, ts)
        # A point of the edge nearer than the radius is at most half a step from a sample,
        # which is then nearer than radius + step / 2: an edge grazing a ball between two
        # samples is caught too (with the radius alone, such a chord went unproven).
        near = self.radius + 0.5 * self.space.distance(q0, q1) / n
        for c in self.centers:
            inside = np.flatnonzero(self.space.distances(points, c) < near)
            if inside.size:
                out.append((float(ts[max(inside[0] - 1, 0)]), float(ts[min(inside[-1] + 1, n)])))
        return out

    def allows(self, q0: FloatArray, q1: FloatArray) -> bool:
        """Whether the edge ``q0 -> q1`` is certified free inside every ball it crosses."""
        for lo, hi in self.crossings(q0, q1):
            part = self.space.interpolate(q0, q1, np.array([lo, hi]))
            if self.locked is not None:
                part = self.locked.lift(part)
            self.certifications += 1
            cert = _certify_segment(
                self.robot,
                part,
                tolerance=self.tolerance,
                deadline=self.deadline,
                spheres=lambda: _built_spheres(self._checker),
            )
            if not cert.certified:
                self.rejections += 1
                return False
        return True

    def edge_case(self, found: tuple[FloatArray, Any]) -> tuple[FloatArray, Any]:
        """:func:`~taskspace.planning.limits.edge_case`'s answer, its straight line allowed.

        A straight start-goal line (``max_iterations=0``) that :meth:`allows` refuses is no
        path: ``ITERATION_LIMIT``, as when no line is free.
        """
        from taskspace.planning.planner_result import PlannerStatus

        path, status = found
        if status is PlannerStatus.SOLVED and path.shape[0] == 2 and not self.allows(*path):
            return np.empty((0, self.space.dim)), PlannerStatus.ITERATION_LIMIT
        return found

    def kernel_regions(self) -> tuple[Any, ...] | None:
        """The compiled RRT-Connect's ``regions`` argument, or ``None`` if it cannot take them.

        ``(centers, radius, certifier, tolerance, near, far)``: the compiled certifier
        (:func:`native_certifier`) certifies the parts inside the balls in the kernel. ``None``
        for a space of locked joints (its kernel plans the reduced model) or a robot the
        compiled certifier does not serve: the Python planner then runs.
        """
        if self.locked is not None:
            return None
        certifier = native_certifier(self.robot, lambda: _built_spheres(self._checker))
        if certifier is None:
            return None
        return (
            np.ascontiguousarray(self.centers),
            self.radius,
            certifier,
            float(self.tolerance),
            _NATIVE_NEAR,
            _NATIVE_FAR,
        )


def _certified_robot(space: Any) -> tuple[Robot, Any, Any]:
    """``(robot, locked joints or None, checker)`` of a space certify=True can serve.

    Raises:
        InvalidInputError: the space has no robot to certify against.
    """
    from taskspace.planning.collision_checker import CollisionChecker

    checker = getattr(space, "checker", None)
    locked = getattr(space, "locked", None)
    if locked is not None:  # a space of free joints: certify the robot's full configurations
        checker = getattr(checker, "checker", None)
    if not isinstance(checker, CollisionChecker):
        raise InvalidInputError(
            "certify=True needs a space built on a robot (ConfigurationSpace.from_robot): "
            f"the space's checker is a {type(checker).__name__}, which has no geometry to "
            "measure distances on; use certify=False"
        )
    return checker.robot, locked, checker


def certify_planned(
    space: Any,
    plan: Callable[[int, float], Any],
    *,
    time_limit_s: float,
    retries: int,
    tolerance: float = 1e-4,
    regions: FailedRegions | None = None,
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
        regions: filled with each failure (:class:`FailedRegions`, read by the re-plans of
            ``plan``), its deadline set to the budget's end.

    Returns:
        The first certified result (``log["certified"] = 1.0``, ``log["min_distance"]``,
        ``log["certify_attempts"]``, and ``log["certify_failures"]``: ``(attempt, segment,
        t)`` of every earlier path whose certificate failed; with ``regions``,
        ``log["region_certifications"]`` and ``log["region_rejections"]``, the edge parts
        the re-plans certified inside the failed regions and refused there); when none could
        be certified (with ``regions``: also when a re-plan found no path within its limits,
        the time limit included, ``log["replan_status"]`` its status), the last path with
        ``success=False``, status ``UNCERTIFIED`` and ``log["uncertified_segment"]`` /
        ``log["uncertified_t"]`` (where along it the proof stopped). The certification
        reads the clock before each distance evaluation: when the time runs out in it, the
        result has ``success=False``, status ``TIME_LIMIT`` and ``log["stopped_by"]`` is
        ``"time"`` (the path is not certified, nothing was found against it).

    Raises:
        InvalidInputError: the space has no robot to certify against.
    """
    from taskspace.planning.planner_result import PlannerStatus

    robot, locked, checker = _certified_robot(space)
    retries = check_count(retries, "certify_retries")
    if isinstance(tolerance, (bool, np.bool_)):
        raise InvalidInputError(f"certify_tolerance must be a distance > 0 [m], got {tolerance!r}")
    check_positive(tolerance, "certify_tolerance")
    t0 = time.perf_counter()
    if regions is not None:
        regions.deadline = t0 + time_limit_s
    failures: list[tuple[int, int, float]] = []
    result: Any = None
    uncertified: Any = None  # the last planned path whose certificate failed
    for attempt in range(retries + 1):
        left = max(0.0, time_limit_s - (time.perf_counter() - t0))
        result = plan(attempt, left)
        result.log["certify_attempts"] = float(attempt + 1)
        result.log["certify_failures"] = list(failures)
        if regions is not None:
            result.log["region_certifications"] = float(regions.certifications)
            result.log["region_rejections"] = float(regions.rejections)
        if not result.success:
            if uncertified is None or regions is None:
                return result
            # no path that is certified inside the failed regions (or avoids them) within the
            # limits, time included: the uncertified path found before is the answer,
            # UNCERTIFIED (the re-plan's own status in log["replan_status"])
            uncertified.log.update(
                {k: v for k, v in result.log.items() if k.startswith(("certify_", "region_"))}
            )
            uncertified.log["replan_status"] = result.status.value
            result = uncertified
            break
        path = result.path if locked is None else locked.lift(result.path)
        cert = certify_path(
            robot,
            path,
            tolerance=tolerance,
            deadline=t0 + time_limit_s,
            spheres=lambda: _built_spheres(checker),
        )
        result.log["min_distance"] = cert.min_distance
        if cert.certified:
            result.log["certified"] = 1.0
            result.time_s = time.perf_counter() - t0
            return result
        result.log["certified"] = 0.0
        result.log["uncertified_segment"] = float(cert.failed_segment)
        result.log["uncertified_t"] = cert.failed_t
        if not cert.timed_out:
            uncertified = result
            failures.append((attempt, cert.failed_segment, cert.failed_t))
            result.log["certify_failures"] = list(failures)
            if regions is not None:
                regions.add(attempt, result.path, cert.failed_segment, cert.failed_t)
        if cert.timed_out:
            result.success = False
            result.status = PlannerStatus.TIME_LIMIT
            result.log["stopped_by"] = "time"
            result.time_s = time.perf_counter() - t0
            return result
        if time.perf_counter() - t0 >= time_limit_s:
            break
    result.success = False
    result.status = PlannerStatus.UNCERTIFIED
    result.log["stopped_by"] = "uncertified"
    result.time_s = time.perf_counter() - t0
    return result


def _built_spheres(checker: Any) -> Any:
    """The checker's sphere model if it was built already (building one takes about 1 s)."""
    from taskspace.planning.collision_checker import _SPHERE_CACHE

    return checker.sphere_model() if checker.robot in _SPHERE_CACHE else None


def plan_certified(
    space: Any, options: Any, run: Callable[[Any, FailedRegions | None], Any]
) -> Any:
    """:func:`certify_planned` for a planner whose options carry the common fields.

    Attempt ``k`` runs ``run(options, regions)`` with ``seed + k`` and the time left as its
    limit; ``regions`` is ``None`` on the first attempt, then the :class:`FailedRegions` of
    the earlier attempts, which the planner's edge checks must honour (``regions.allows``).
    ``options`` has ``seed``, ``max_iterations``, ``time_limit_s``, ``certify_retries`` and
    ``certify_tolerance`` (RRT, RRT-Connect, RRT*, BIT*; PRM, Lazy PRM and PRM* call
    :func:`certify_planned` with their own re-plan, which drops the failed edge).
    """
    from taskspace._validation import check_seed
    from taskspace.planning.limits import planner_limits

    _, limit = planner_limits(options.max_iterations, options.time_limit_s)
    seed = check_seed(options.seed)
    regions = FailedRegions(space, options.certify_tolerance)

    def plan(attempt: int, left: float) -> Any:
        again = dataclasses.replace(
            options, seed=seed + attempt, time_limit_s=left if math.isfinite(left) else None
        )
        return run(again, regions if regions.failures else None)

    return certify_planned(
        space,
        plan,
        time_limit_s=limit,
        retries=options.certify_retries,
        tolerance=options.certify_tolerance,
        regions=regions,
    )
