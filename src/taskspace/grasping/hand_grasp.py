"""Multi-finger hand placement by approach and close-until-contact (GraspIt-style).

A grasp of a multi-finger hand is found in the hand's own frame, as a planner for a hand on
an arm would: the object is placed in front of the palm, moved along the approach axis until
it touches the hand, and every finger is then closed until its links touch the object. Each
joint of a finger stops when a link it carries touches (the distal joints go on closing, so
the finger wraps around the object), or at its closing limit. The contacts of the closed hand
are evaluated for force closure and quality (:mod:`taskspace.grasping.closure`,
:mod:`taskspace.grasping.quality`).

Nothing ever penetrates: every motion is a conservative advancement. A translation by ``delta``
moves every point of the object by ``|delta|``; turning joint ``j`` by ``dtheta`` moves a
point of a link it carries by at most ``|dtheta| r_j``, with ``r_j`` the distance from the
joint's origin to the farthest point of that link's collision geometry (the bound of
:func:`taskspace.planning.certify_path` for one chain). A step never exceeds the current
distance (from coal) less half the contact tolerance divided by that bound.

Distances and nearest points come from coal on the robot's collision geometry and the
object's triangle mesh; the contact normal is the mesh face normal at the nearest point.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import coal
import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_float_array
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.grasping.closure import ClosureResult, force_closure
from taskspace.grasping.contact import ContactType, GraspContact
from taskspace.grasping.object_mesh import TriangleMesh
from taskspace.grasping.quality import grasp_quality
from taskspace.model.robot import Robot


class StartsInCollisionError(InvalidInputError):
    """The object's initial placement intersects the open hand."""


MAX_REACH = 100.0
"""Largest distance [m] of an object from the palm that :func:`close_hand` accepts."""

MAX_STEPS = 400
"""Advancement steps per phase (approach, closing of one finger) before giving up."""


@dataclass(frozen=True)
class Finger:
    """One finger: its joints from proximal to distal, and how each closes.

    Attributes:
        name: a name for reports.
        joints: joint names, proximal first.
        closed: joint angle at which each joint stops closing [rad].
    """

    name: str
    joints: tuple[str, ...]
    closed: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.joints) == 0 or len(self.joints) != len(self.closed):
            raise InvalidInputError(
                f"finger {self.name!r}: joints and closed angles must be non-empty and of the "
                f"same length, got {len(self.joints)} and {len(self.closed)}"
            )


@dataclass(frozen=True)
class Hand:
    """A multi-finger hand with a fixed palm.

    Attributes:
        robot: the hand (a fixed-base model whose root is the palm).
        palm_frame: frame in which approach directions and object poses are expressed.
        approach: unit direction [palm frame] from the palm toward a grasped object.
        preshape: the open configuration ``(nq,)`` the fingers close from.
        fingers: the fingers.
        center: where objects are presented [m, palm frame]: their origin starts at
            ``center + (standoff + radius) approach``.
    """

    robot: Robot
    palm_frame: str
    approach: FloatArray
    preshape: FloatArray
    fingers: tuple[Finger, ...]
    center: FloatArray = field(default_factory=lambda: np.zeros(3))
    _joint_index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        robot = self.robot
        if robot._model.njoints > 1 and robot._model.joints[1].shortname() == "JointModelFreeFlyer":
            raise InvalidInputError("the hand must be a fixed-base model rooted at its palm")
        robot.frame_id(self.palm_frame)  # UnknownNameError lists the frames
        a = as_float_array(self.approach, "approach").reshape(-1)
        if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) < 1e-9:
            raise InvalidInputError(f"approach must be a non-zero 3-vector, got {self.approach!r}")
        q = robot.check_configuration(self.preshape, "preshape")
        names = [robot._model.names[j] for j in range(1, robot._model.njoints)]
        index = {}
        for finger in self.fingers:
            for joint, closed in zip(finger.joints, finger.closed):
                if joint not in names:
                    raise UnknownNameError("joint", joint, names)
                jid = robot._model.getJointId(joint)
                if robot._model.nqs[jid] != 1:
                    raise InvalidInputError(f"finger joint {joint!r} must have one coordinate")
                k = robot._model.idx_qs[jid]
                if not robot.lower_limits[k] <= closed <= robot.upper_limits[k]:
                    raise InvalidInputError(
                        f"closed angle {closed} of {joint!r} outside its limits "
                        f"[{robot.lower_limits[k]}, {robot.upper_limits[k]}]"
                    )
                index[joint] = jid
        object.__setattr__(self, "approach", a / np.linalg.norm(a))
        object.__setattr__(self, "preshape", np.array(q, dtype=float))
        c = as_float_array(self.center, "center").reshape(-1)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise InvalidInputError(f"center must be a finite 3-vector, got {self.center!r}")
        object.__setattr__(self, "center", c.copy())
        object.__setattr__(self, "_joint_index", index)

    @classmethod
    def allegro(cls, robot: Robot | None = None, *, closing: float = 0.9) -> Hand:
        """The Allegro hand of example-robot-data (``allegro_right_hand``).

        The palm faces ``+x`` of ``palm_link``; the thumb is opposed (``joint_12.0`` at 1.2 rad)
        and every flexion joint closes to ``closing`` times its upper limit.
        """
        if robot is None:
            robot = Robot.load("allegro_right_hand")
        q = np.array(robot.q_default, dtype=float)
        k12 = robot._model.idx_qs[robot._model.getJointId("joint_12.0")]
        q[k12] = 1.2
        fingers = []
        for name, first in (("index", 0), ("middle", 4), ("ring", 8), ("thumb", 12)):
            joints = [f"joint_{j}.0" for j in range(first, first + 4)]
            if name == "thumb":
                joints = joints[1:]  # the opposition joint stays at its preshape
            else:
                joints = joints[1:]  # abduction stays at 0
            closed = []
            for joint in joints:
                k = robot._model.idx_qs[robot._model.getJointId(joint)]
                closed.append(float(closing * robot.upper_limits[k]))
            fingers.append(Finger(name, tuple(joints), tuple(closed)))
        center = np.array([0.0, 0.0, 0.03])
        return cls(robot, "palm_link", np.array([1.0, 0.0, 0.0]), q, tuple(fingers), center)


@dataclass(frozen=True)
class HandGrasp:
    """A grasp found by :func:`close_hand`.

    Attributes:
        q: hand configuration ``(nq,)``.
        object_pose: placement of the object in the palm frame.
        contacts: contacts in the object's frame (``frame`` is the touching link's geometry).
        closure: force-closure test of the contacts (LP, with certificate).
        epsilon: Ferrari-Canny epsilon (L1) of the contacts (0 when not in closure), torques
            about the object's center of mass (:attr:`TriangleMesh.centroid`, uniform
            density), as :func:`sample_antipodal_grasps` scores them.
        min_distance: smallest hand-object distance at the end [m] (>= 0: no penetration).
        touching: names of the fingers with at least one contact.
        self_collision: whether two hand links collide at ``q``.
    """

    q: FloatArray
    object_pose: pin.SE3
    contacts: list[GraspContact]
    closure: ClosureResult
    epsilon: float
    min_distance: float
    touching: tuple[str, ...]
    self_collision: bool

    @property
    def success(self) -> bool:
        """In force closure, without self-collision."""
        return bool(self.closure.closure) and not self.self_collision


class _Scene:
    """The hand's collision geometries and the object, with distances from coal."""

    def __init__(self, hand: Hand, mesh: TriangleMesh) -> None:
        self.hand = hand
        self.robot = hand.robot
        self.gmodel = self.robot._collision_model
        self.gdata = self.gmodel.createData()
        self.data = self.robot._model.createData()
        self.mesh = mesh
        self.object = mesh.collision_geometry()
        self.normals = mesh.face_normals
        self.request = coal.DistanceRequest()
        self.radius = float(np.max(np.linalg.norm(mesh.vertices, axis=1)))
        palm = self.robot.frame_id(hand.palm_frame)
        self.q = hand.preshape.copy()
        pin.framesForwardKinematics(self.robot._model, self.data, self.q)
        self.palm = self.data.oMf[palm].copy()
        self.half_extent = [self._half_extent(g.geometry) for g in self.gmodel.geometryObjects]
        self.partners: dict[int, list[int]] = {}
        for pair in self.gmodel.collisionPairs:
            self.partners.setdefault(int(pair.first), []).append(int(pair.second))
            self.partners.setdefault(int(pair.second), []).append(int(pair.first))

    @staticmethod
    def _half_extent(geometry: coal.CollisionGeometry) -> float:
        geometry.computeLocalAABB()
        box = geometry.aabb_local
        center = 0.5 * (np.asarray(box.min_) + np.asarray(box.max_))
        return float(np.linalg.norm(np.asarray(box.max_) - center) + np.linalg.norm(center))

    def update(self, q: FloatArray) -> None:
        self.q = q
        pin.updateGeometryPlacements(self.robot._model, self.data, self.gmodel, self.gdata, q)

    def distance(self, g: int, pose: pin.SE3) -> coal.DistanceResult:
        result = coal.DistanceResult()
        M = self.gdata.oMg[g]
        coal.distance(
            self.gmodel.geometryObjects[g].geometry,
            coal.Transform3s(M.rotation, M.translation),
            self.object,
            coal.Transform3s(pose.rotation, pose.translation),
            self.request,
            result,
        )
        return result

    def distances(self, pose: pin.SE3, geoms: Sequence[int]) -> FloatArray:
        return np.array([self.distance(g, pose).min_distance for g in geoms])

    def link_distance(self, a: int, b: int) -> float:
        """Distance between two of the hand's collision geometries [m]."""
        result = coal.DistanceResult()
        Ma, Mb = self.gdata.oMg[a], self.gdata.oMg[b]
        coal.distance(
            self.gmodel.geometryObjects[a].geometry,
            coal.Transform3s(Ma.rotation, Ma.translation),
            self.gmodel.geometryObjects[b].geometry,
            coal.Transform3s(Mb.rotation, Mb.translation),
            self.request,
            result,
        )
        return float(result.min_distance)

    def clearance(self, pose: pin.SE3, g: int, fixed: set[int]) -> float:
        """Distance from geometry ``g`` to the object and to its ``fixed`` collision partners."""
        d = self.distance(g, pose).min_distance
        for h in self.partners.get(g, ()):
            if h in fixed:
                d = min(d, self.link_distance(g, h))
        return float(d)

    def joint_radius(self, jid: int, g: int) -> float:
        """Bound on ``|p - o_j|`` over the points ``p`` of geometry ``g`` (world frame) [m]."""
        origin = self.data.oMi[jid].translation
        center = self.gdata.oMg[g].translation
        return float(np.linalg.norm(center - origin)) + self.half_extent[g]

    def surface_normal(self, point_world: FloatArray, pose: pin.SE3) -> FloatArray:
        """Outward normal (object frame) of the mesh face nearest to ``point_world``."""
        p = pose.actInv(point_world)
        tri = self.mesh.triangles
        d = np.abs(np.einsum("fi,fi->f", self.normals, p[None, :] - tri[:, 0]))
        centroid = tri.mean(axis=1)
        # among faces whose plane passes through p, the one whose centroid is nearest
        near = d <= d.min() + 1e-6
        candidates = np.flatnonzero(near)
        best = candidates[np.argmin(np.linalg.norm(centroid[candidates] - p, axis=1))]
        return np.asarray(self.normals[best], dtype=float)


def _geoms_by_joint(scene: _Scene) -> dict[int, list[int]]:
    """Collision geometries attached to each joint (by the joint carrying their frame)."""
    out: dict[int, list[int]] = {}
    for g, obj in enumerate(scene.gmodel.geometryObjects):
        out.setdefault(int(obj.parentJoint), []).append(g)
    return out


def _subtree_geoms(scene: _Scene, jid: int, by_joint: dict[int, list[int]]) -> list[int]:
    model = scene.robot._model
    return [g for j in model.subtrees[jid] for g in by_joint.get(int(j), [])]


def _approach(scene: _Scene, pose: pin.SE3, tolerance: float) -> pin.SE3 | None:
    """Move the object toward the palm (along ``-approach``) until it touches the hand."""
    geoms = list(range(len(scene.gmodel.geometryObjects)))
    direction = -(scene.palm.rotation @ scene.hand.approach)
    pose = pose.copy()
    for _ in range(MAX_STEPS):
        d = float(scene.distances(pose, geoms).min())
        if d <= 0.0:
            raise StartsInCollisionError(
                "the object starts in collision with the open hand; place it farther away"
            )
        if d <= tolerance:
            return pose
        pose.translation = pose.translation + (d - 0.5 * tolerance) * direction
        if np.linalg.norm(pose.translation - scene.palm.translation) > 10.0 * scene.radius + 1.0:
            return None
    return None


def _close_finger(
    scene: _Scene, finger: Finger, pose: pin.SE3, tolerance: float, by_joint: dict[int, list[int]]
) -> None:
    """Close one finger until each of its joints is stopped by a contact or its limit."""
    model = scene.robot._model
    hand = scene.hand
    jids = [hand._joint_index[j] for j in finger.joints]
    ks = [model.idx_qs[j] for j in jids]
    start = np.array([scene.q[k] for k in ks])
    goal = np.array(finger.closed)
    span = goal - start
    s = np.zeros(len(jids))
    active = np.abs(span) > 1e-12
    # geometries moved by each joint (its subtree) and by the finger's last joints
    moved = [_subtree_geoms(scene, j, by_joint) for j in jids]
    # the rest of the hand stands still while this finger closes: its links stop on them too
    fixed = set(range(len(scene.gmodel.geometryObjects))) - set(moved[0])
    for _ in range(MAX_STEPS):
        if not active.any():
            return
        geoms = sorted({g for i in range(len(jids)) if active[i] for g in moved[i]})
        if not geoms:
            return
        d = np.array([scene.clearance(pose, g, fixed) for g in geoms])
        for g, dist in zip(geoms, d):
            if dist <= tolerance:
                # a touching link stops every joint that carries it
                for i in range(len(jids)):
                    if g in moved[i]:
                        active[i] = False
        if not active.any():
            return
        geoms = sorted({g for i in range(len(jids)) if active[i] for g in moved[i]})
        d = np.array([scene.clearance(pose, g, fixed) for g in geoms])
        # conservative step: a point of geometry g moves by at most
        # sum_i |span_i| ds r_i(g) over the active joints i that carry g
        step = math.inf
        for g, dist in zip(geoms, d):
            rate = sum(
                abs(span[i]) * scene.joint_radius(jids[i], g)
                for i in range(len(jids))
                if active[i] and g in moved[i]
            )
            if rate > 0:
                step = min(step, (dist - 0.5 * tolerance) / rate)
        step = min(step, float(np.min(1.0 - s[active])))
        if step <= 0:
            return
        s[active] += step
        q = scene.q.copy()
        for i, k in enumerate(ks):
            q[k] = start[i] + s[i] * span[i]
        scene.update(q)
        pin.forwardKinematics(model, scene.data, q)
        for i in range(len(jids)):
            if s[i] >= 1.0 - 1e-12:
                active[i] = False


def close_hand(
    hand: Hand,
    mesh: TriangleMesh,
    object_pose: pin.SE3,
    *,
    mu: float = 0.5,
    tolerance: float = 1e-3,
    edges: int = 8,
    approach: bool = True,
) -> HandGrasp | None:
    """Approach the object and close the fingers on it (close-until-contact).

    Args:
        hand: the hand.
        mesh: the object, in its own frame (moments are taken about its center of mass,
            :attr:`TriangleMesh.centroid`, wherever the frame's origin is).
        object_pose: initial placement of the object in the palm frame (away from the hand
            when ``approach``).
        mu: friction coefficient of the point contacts.
        tolerance: distance at which a link counts as touching [m].
        edges: edges of the linearized friction cones.
        approach: move the object toward the palm first (else close where it is).

    Returns:
        The grasp, or ``None`` when the object passes the hand without touching it.
    """
    if not (isinstance(tolerance, (int, float)) and 0 < tolerance < 0.05):
        raise InvalidInputError(f"tolerance must be in (0, 0.05) m, got {tolerance!r}")
    if not isinstance(object_pose, pin.SE3):
        raise InvalidInputError("object_pose must be a pinocchio.SE3 (palm frame)")
    pose_matrix = np.asarray(object_pose.homogeneous)
    if not np.all(np.isfinite(pose_matrix)) or np.linalg.norm(pose_matrix[:3, 3]) > MAX_REACH:
        raise InvalidInputError(
            f"object_pose must be finite and within {MAX_REACH} m of the palm, got translation "
            f"{pose_matrix[:3, 3]}"
        )
    scene = _Scene(hand, mesh)
    scene.update(hand.preshape.copy())
    pin.forwardKinematics(hand.robot._model, scene.data, scene.q)
    pose = scene.palm * object_pose
    if approach:
        found = _approach(scene, pose, tolerance)
        if found is None:
            return None
        pose = found
    by_joint = _geoms_by_joint(scene)
    for finger in hand.fingers:
        _close_finger(scene, finger, pose, tolerance, by_joint)
    return _evaluate(scene, pose, mu, tolerance, edges)


def _evaluate(scene: _Scene, pose: pin.SE3, mu: float, tolerance: float, edges: int) -> HandGrasp:
    geoms = range(len(scene.gmodel.geometryObjects))
    contacts = []
    touching = set()
    joint_finger = {
        scene.hand._joint_index[j]: f.name for f in scene.hand.fingers for j in f.joints
    }
    model = scene.robot._model
    distances = []
    for g in geoms:
        result = scene.distance(g, pose)
        distances.append(result.min_distance)
        if result.min_distance > tolerance:
            continue
        point = np.asarray(result.getNearestPoint2(), dtype=float)
        outward = scene.surface_normal(point, pose)
        contacts.append(
            GraspContact(
                pose.actInv(point),
                -outward,
                ContactType.POINT_FRICTION,
                mu=mu,
                frame=scene.gmodel.geometryObjects[g].name,
            )
        )
        jid = int(scene.gmodel.geometryObjects[g].parentJoint)
        while jid > 0 and jid not in joint_finger:
            jid = int(model.parents[jid])
        touching.add(joint_finger.get(jid, "palm"))
    if contacts:
        closure = force_closure(contacts, edges=edges)
        epsilon = (
            # torques about the center of mass, not the mesh frame's origin: the epsilon of
            # the same grasp changed with where the mesh file put its origin
            grasp_quality(contacts, edges=edges, center=scene.mesh.centroid, linf=False).epsilon_l1
            if closure.closure
            else 0.0
        )
    else:
        closure = ClosureResult(closure=False, certificate=None, margin=0.0, method="lp", rank=0)
        epsilon = 0.0
    return HandGrasp(
        q=scene.q.copy(),
        object_pose=scene.palm.actInv(pose),
        contacts=contacts,
        closure=closure,
        epsilon=float(epsilon),
        min_distance=float(min(distances)),
        touching=tuple(sorted(touching)),
        self_collision=_self_collision(scene),
    )


def _self_collision(scene: _Scene) -> bool:
    gmodel = scene.gmodel
    request = coal.CollisionRequest()
    for pair in gmodel.collisionPairs:
        a, b = pair.first, pair.second
        Ma, Mb = scene.gdata.oMg[a], scene.gdata.oMg[b]
        result = coal.CollisionResult()
        coal.collide(
            gmodel.geometryObjects[a].geometry,
            coal.Transform3s(Ma.rotation, Ma.translation),
            gmodel.geometryObjects[b].geometry,
            coal.Transform3s(Mb.rotation, Mb.translation),
            request,
            result,
        )
        if result.isCollision():
            return True
    return False


def sample_hand_grasps(
    hand: Hand,
    mesh: TriangleMesh,
    n: int,
    *,
    rng: np.random.Generator | None = None,
    standoff: float = 0.05,
    lateral: float = 0.02,
    mu: float = 0.5,
    tolerance: float = 1e-3,
) -> list[HandGrasp]:
    """Close the hand on ``n`` random placements of the object; best first.

    Placements that start in collision with the open hand are skipped. Each placement turns
    the object by a uniform random rotation and puts its origin
    ``standoff`` plus its bounding radius beyond ``hand.center`` along the approach axis,
    shifted sideways by up to ``lateral`` [m]. The grasps are sorted by success, then
    by epsilon.
    """
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
        raise InvalidInputError(f"n must be a positive integer, got {n!r}")
    rng = np.random.default_rng() if rng is None else rng
    radius = float(np.max(np.linalg.norm(mesh.vertices, axis=1)))
    a = hand.approach
    grasps = []
    for _ in range(int(n)):
        rotation = pin.Quaternion(*_unit_quaternion(rng)).toRotationMatrix()
        offset = rng.uniform(-lateral, lateral, 3)
        offset -= a * float(a @ offset)
        center = hand.center + a * (radius + standoff) + offset
        try:
            grasp = close_hand(hand, mesh, pin.SE3(rotation, center), mu=mu, tolerance=tolerance)
        except StartsInCollisionError:
            continue
        if grasp is not None:
            grasps.append(grasp)
    grasps.sort(key=lambda g: (not g.success, -g.epsilon))
    return grasps


def _unit_quaternion(rng: np.random.Generator) -> tuple[float, float, float, float]:
    u1, u2, u3 = rng.random(3)
    w = math.sqrt(1 - u1) * math.sin(2 * math.pi * u2)
    x = math.sqrt(1 - u1) * math.cos(2 * math.pi * u2)
    y = math.sqrt(u1) * math.sin(2 * math.pi * u3)
    z = math.sqrt(u1) * math.cos(2 * math.pi * u3)
    return (w, x, y, z)
