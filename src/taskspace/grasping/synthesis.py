"""Grasp synthesis for parallel-jaw grippers: antipodal sampling, scoring, hand placement.

1. Sample points on the object's surface; from each, cast a ray into the object inside the
   friction cone of the inward normal; where it leaves the object is the second contact.
   The pair is antipodal when the line between the contacts lies inside both friction cones
   (the force-closure condition of two soft fingers; the cones inscribed in the linearized
   pyramids are used, so the pyramids agree), and graspable when its width fits the gripper.
2. Score every antipodal pair by the Ferrari-Canny epsilon (L1) of its two soft-finger
   contacts (one convex hull each).
3. Place the hand: for the best pairs and several approach directions about the closing axis,
   solve IK for the tool frame (the fingers closing along its ``closing_axis`` onto the two
   contacts) and keep the configurations that reach it and are collision-free with the object
   (coal, through the robot's collision model).

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace import features as F
from taskspace._validation import check_count
from taskspace.errors import InvalidInputError
from taskspace.grasping.contact import (
    ContactType,
    GraspContact,
    check_edges,
    nonnegative,
)
from taskspace.grasping.epsilon import grasp_epsilon_batch
from taskspace.grasping.object_mesh import TriangleMesh
from taskspace.ik import SolveIKOptions, solve_ik
from taskspace.model import Obstacle, Robot
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.tasks import Task

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class AntipodalOptions:
    """Settings of :func:`sample_antipodal_grasps`.

    Attributes:
        samples: surface points sampled (each gives at most one candidate).
        mu: friction coefficient of the finger pads.
        torsion: soft-finger torsional coefficient [m].
        min_width: narrowest graspable width [m].
        max_width: the gripper's opening [m] (Panda: 0.08).
        edges: edges of each linearized friction cone for the epsilon metric.
    """

    samples: int = 500
    mu: float = 0.5
    torsion: float = 0.005
    min_width: float = 0.002
    max_width: float = 0.08
    edges: int = 8

    def __post_init__(self) -> None:
        object.__setattr__(self, "samples", check_count(self.samples, "samples", minimum=1))
        for name in ("mu", "torsion", "min_width", "max_width"):
            object.__setattr__(self, name, nonnegative(getattr(self, name), name))
        object.__setattr__(self, "edges", check_edges(self.edges))
        if self.max_width <= self.min_width:
            raise InvalidInputError("max_width must be larger than min_width")


@dataclass(frozen=True)
class GraspCandidates:
    """Antipodal contact pairs in the object's frame, best first.

    Attributes:
        p1, p2: contact points ``(N, 3)`` [m].
        n1, n2: inward unit normals ``(N, 3)``.
        width: distance between the contacts ``(N,)`` [m].
        epsilon: Ferrari-Canny epsilon (L1) of the two soft-finger contacts ``(N,)``, torques
            about the mesh's center of mass (:attr:`TriangleMesh.centroid`).
        options: the sampling settings.
    """

    p1: FloatArray
    p2: FloatArray
    n1: FloatArray
    n2: FloatArray
    width: FloatArray
    epsilon: FloatArray
    options: AntipodalOptions

    def __len__(self) -> int:
        return len(self.width)

    def contacts(self, i: int) -> list[GraspContact]:
        """The two soft-finger contacts of candidate ``i``."""
        o = self.options
        return [
            GraspContact(p, n, type=ContactType.SOFT_FINGER, mu=o.mu, torsion=o.torsion)
            for p, n in ((self.p1[i], self.n1[i]), (self.p2[i], self.n2[i]))
        ]


def _cone_directions(axis: FloatArray, half_angle: float, rng: np.random.Generator) -> FloatArray:
    """Unit directions uniform in solid angle within ``half_angle`` of each ``axis`` row."""
    n = len(axis)
    cos_t = 1 - rng.random(n) * (1 - np.cos(half_angle))
    sin_t = np.sqrt(1 - cos_t**2)
    phi = 2 * np.pi * rng.random(n)
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t1 = np.cross(helper, axis)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(axis, t1)
    return (
        cos_t[:, None] * axis
        + (sin_t * np.cos(phi))[:, None] * t1
        + (sin_t * np.sin(phi))[:, None] * t2
    )


def sample_antipodal_grasps(
    mesh: TriangleMesh, rng: np.random.Generator, options: AntipodalOptions | None = None
) -> GraspCandidates:
    """Antipodal contact pairs on ``mesh``, scored and sorted by epsilon (best first)."""
    o = options or AntipodalOptions()
    # The cone inscribed in the linearized (m-edge) friction pyramid: pairs inside it are in
    # closure for the pyramid too, so every candidate has a positive epsilon.
    half = float(np.arctan(o.mu * np.cos(np.pi / o.edges)))
    points, outward, _ = mesh.sample_surface(o.samples, rng)
    directions = _cone_directions(-outward, half * 0.999, rng)
    t, face = mesh.ray_exit(points + 1e-9 * directions, directions)
    hit = np.isfinite(t)
    p1, n1, d, t, face = points[hit], -outward[hit], directions[hit], t[hit], face[hit]
    p2 = p1 + t[:, None] * d
    n2 = -mesh.face_normals[face]
    cos_limit = np.cos(half)
    keep = (
        (np.einsum("ij,ij->i", -d, n2) > cos_limit)  # the line is inside the second cone
        & (t >= o.min_width)
        & (t <= o.max_width)
    )
    p1, p2, n1, n2, width = p1[keep], p2[keep], n1[keep], n2[keep], t[keep]
    epsilon = (
        grasp_epsilon_batch(
            np.stack([p1, p2], axis=1),
            np.stack([n1, n2], axis=1),
            mu=o.mu,
            edges=o.edges,
            torsion=o.torsion,
            center=mesh.centroid,
        )
        if len(width)
        else np.zeros(0)
    )
    order = np.argsort(-epsilon, kind="stable")
    return GraspCandidates(
        p1[order], p2[order], n1[order], n2[order], width[order], epsilon[order], o
    )


@dataclass(frozen=True)
class PlacedGrasp:
    """A candidate grasp reached by the robot.

    Attributes:
        candidate: index into the :class:`GraspCandidates`.
        approach: rotation of the approach direction about the closing axis [rad].
        tool_pose: the tool frame's pose in the world.
        q: the robot configuration (the IK result).
        reached: IK reached the pose within tolerance.
        collision_free: the configuration does not collide (robot with itself, the object
            and the rest of the world).
        epsilon: the candidate's epsilon metric.
    """

    candidate: int
    approach: float
    tool_pose: pin.SE3
    q: FloatArray
    reached: bool
    collision_free: bool
    epsilon: float
    extra: dict[str, float] = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        """Reached and collision-free."""
        return self.reached and self.collision_free


def grasp_tool_pose(
    p1: FloatArray, p2: FloatArray, approach: float, closing_axis: int = 1
) -> pin.SE3:
    """Tool pose (object frame) with the closing axis along ``p2 - p1`` at their midpoint.

    The approach axis (the tool's z when the closing axis is y) is the one perpendicular to
    the closing axis, turned by ``approach`` [rad] about it.
    """
    y = (p2 - p1) / np.linalg.norm(p2 - p1)
    helper = np.array([0.0, 0.0, 1.0]) if abs(y[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    z = np.cross(helper, y)
    z /= np.linalg.norm(z)
    z = pin.exp3(approach * y) @ z
    x = np.cross(y, z)
    axes = [x, y, z]
    if closing_axis != 1:
        axes[1], axes[closing_axis] = axes[closing_axis], axes[1]
        axes[0] = np.cross(axes[1], axes[2])
    return pin.SE3(np.column_stack(axes), (p1 + p2) / 2)


def place_grasps(
    robot: Robot,
    mesh: TriangleMesh,
    object_pose: pin.SE3,
    candidates: GraspCandidates,
    rng: np.random.Generator,
    *,
    tool_frame: str = "panda_hand_tcp",
    closing_axis: int = 1,
    top: int = 10,
    approaches: int = 8,
    want: int = 3,
) -> list[PlacedGrasp]:
    """Reach the best candidates with the robot; return the tried placements, feasible first.

    The object is added to the robot's world as an obstacle named ``"grasped_object"`` for
    the collision checks and removed afterwards. The robot's gripper must be open (e.g.
    ``Robot.load("panda", locked_values={"panda_finger_joint1": 0.04,
    "panda_finger_joint2": 0.04})``).

    Args:
        robot: the arm with its hand.
        mesh: the object, in its own frame.
        object_pose: the object's pose in the world.
        candidates: from :func:`sample_antipodal_grasps`.
        rng: random generator (IK restarts).
        tool_frame: the frame between the fingertips.
        closing_axis: the tool axis along which the fingers close (0, 1 or 2).
        top: how many of the best candidates are tried.
        approaches: approach directions tried per candidate.
        want: stop after this many feasible grasps.
    """
    task = Task(F.FramePose(robot, tool_frame))
    obstacle = Obstacle("grasped_object", mesh.collision_geometry(), object_pose)
    robot.add_obstacle(obstacle)
    placed: list[PlacedGrasp] = []
    try:
        checker = CollisionChecker(robot)
        found = 0
        for i in range(min(top, len(candidates))):
            for a in np.linspace(0, 2 * np.pi, approaches, endpoint=False):
                pose = object_pose * grasp_tool_pose(
                    candidates.p1[i], candidates.p2[i], float(a), closing_axis
                )
                task.set_target(pose)
                result = solve_ik(robot, [task], options=SolveIKOptions(restarts=2), rng=rng)
                free = bool(result.success and checker.is_valid(result.q))
                placed.append(
                    PlacedGrasp(
                        i,
                        float(a),
                        pose,
                        result.q,
                        result.success,
                        free,
                        float(candidates.epsilon[i]),
                    )
                )
                found += free
                if free:
                    break
            if found >= want:
                break
    finally:
        robot.remove_obstacle("grasped_object")
    placed.sort(key=lambda g: (not g.feasible, -g.epsilon))
    return placed
