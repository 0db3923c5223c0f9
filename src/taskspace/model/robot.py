"""``Robot``: a Pinocchio model, its coal collision geometry and an obstacle world."""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector, check_finite
from taskspace.errors import (
    InvalidInputError,
    LimitError,
    ModelLoadError,
    ShapeError,
    UnknownNameError,
)
from taskspace.model.registry import RobotSpec, robot_spec
from taskspace.model.world import Obstacle, World

if TYPE_CHECKING:
    from taskspace.model.state import State

logger = logging.getLogger(__name__)

_F64 = np.dtype(np.float64)

QUATERNION_TOLERANCE = 1e-6
"""Largest accepted deviation of a quaternion's (or unit complex's) norm from 1."""


class Robot:
    """A robot: kinematic/dynamic model, collision and visual geometry, obstacle world.

    Create with :meth:`load` (registry name) or :meth:`from_urdf`. The Pinocchio objects are
    exposed as ``model``, ``collision_model`` and ``visual_model``; never modify them in
    place, use the methods of this class (obstacles, collision pairs).

    Attributes:
        name: robot name.
        model: the ``pin.Model``.
        collision_model: ``pin.GeometryModel`` of robot collision geometry plus obstacles.
        visual_model: ``pin.GeometryModel`` for display.
        end_effectors: names of the end-effector frames.
        world: the obstacles (also present in ``collision_model``).
    """

    def __init__(
        self,
        model: pin.Model,
        collision_model: pin.GeometryModel,
        visual_model: pin.GeometryModel,
        *,
        name: str,
        end_effectors: Sequence[str] = (),
        default_configuration: FloatArray | None = None,
        srdf_path: str | None = None,
        description: str = "",
    ) -> None:
        self.name = name
        self.description = description
        self.model = model
        self.visual_model = visual_model
        self.collision_model = collision_model
        self.srdf_path = srdf_path
        self.world = World()
        self._robot_geometry_count = collision_model.ngeoms
        self._frame_ids = {f.name: i for i, f in enumerate(model.frames)}
        self._joint_ids = {n: i for i, n in enumerate(model.names) if i > 0}
        for ee in end_effectors:
            self.frame_id(ee)
        self.end_effectors = tuple(end_effectors)
        self._nq = int(model.nq)
        self._nv = int(model.nv)
        self._q_shape = (self._nq,)
        self._v_shape = (self._nv,)
        self.data = model.createData()
        self.collision_data = collision_model.createData()
        self._setup_joint_structure()
        if default_configuration is None:
            default_configuration = pin.neutral(model)
        self._q_default = self.check_configuration(default_configuration, "default_configuration")
        self._q_default.flags.writeable = False

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(
        cls,
        name: str,
        *,
        convex_collision: bool = False,
        locked_values: dict[str, float] | None = None,
    ) -> Robot:
        """Load a robot of the registry ``robots/registry.yaml``.

        Args:
            name: registry name (``panda``, ``ur5``, ``talos``, ``g1``, ``solo12``,
                ``planar_2link``, ``planar_3link``, ``pendulum``, ``cartpole``...).
            convex_collision: replace collision meshes by their convex hulls (distance
                queries become ~30x cheaper; needed for distance-based features).
            locked_values: values [rad or m] at which the registry's locked joints are held
                (e.g. ``{"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}``);
                default their default-posture values.

        Raises:
            UnknownNameError: ``name`` is not in the registry (the message lists the names).
            ModelLoadError: the description files cannot be read.
        """
        spec = robot_spec(name)
        if spec.source == "example-robot-data":
            urdf, package_dirs, srdf = _erd_paths(spec)
        else:
            if spec.urdf is None:
                raise ModelLoadError(f"registry entry '{name}' has no urdf path")
            urdf, package_dirs, srdf = str(spec.urdf), [str(spec.urdf.parent)], None
        robot = cls.from_urdf(
            urdf,
            free_flyer=spec.free_flyer,
            package_dirs=package_dirs,
            srdf=srdf,
            locked_joints=spec.locked_joints,
            name=name,
            end_effectors=spec.end_effectors,
            convex_collision=convex_collision,
            locked_values=locked_values,
            _posture=spec,
        )
        robot.description = spec.description
        return robot

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        *,
        free_flyer: bool = False,
        package_dirs: Sequence[str] | None = None,
        srdf: str | Path | None = None,
        locked_joints: Sequence[str] = (),
        name: str | None = None,
        end_effectors: Sequence[str] = (),
        default_configuration: Any = None,
        convex_collision: bool = False,
        locked_values: dict[str, float] | None = None,
        _posture: RobotSpec | None = None,
    ) -> Robot:
        """Load any URDF.

        Args:
            path: URDF file.
            free_flyer: add a floating base (free-flyer root joint).
            package_dirs: directories searched for ``package://`` mesh paths.
            srdf: SRDF file: disabled collision pairs and reference configurations.
            locked_joints: joints removed from the model, held at their default value.
            name: robot name (default: the URDF file stem).
            end_effectors: names of end-effector frames.
            default_configuration: default posture (size of the unreduced model's nq).
            convex_collision: replace collision meshes by their convex hulls.
            locked_values: values [rad or m] of locked joints (default: their default value).

        Raises:
            ModelLoadError: missing or malformed URDF/SRDF, unknown locked joint.
        """
        path = Path(path)
        if not path.is_file():
            raise ModelLoadError(f"URDF file not found: {path}")
        dirs = list(package_dirs) if package_dirs is not None else [str(path.parent)]
        root = pin.JointModelFreeFlyer() if free_flyer else None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if root is None:
                    model = pin.buildModelFromUrdf(str(path))
                else:
                    model = pin.buildModelFromUrdf(str(path), root)
                collision = pin.buildGeomFromUrdf(model, str(path), pin.COLLISION, dirs)
                visual = pin.buildGeomFromUrdf(model, str(path), pin.VISUAL, dirs)
        except Exception as exc:  # pinocchio raises ValueError/RuntimeError with C++ text
            raise ModelLoadError(f"cannot load URDF {path}: {exc}") from exc

        # Default posture on the full model.
        q_full = pin.neutral(model)
        if srdf is not None:
            if not Path(srdf).is_file():
                raise ModelLoadError(f"SRDF file not found: {srdf}")
            try:
                pin.loadReferenceConfigurations(model, str(srdf), False)
            except Exception as exc:
                raise ModelLoadError(f"cannot read SRDF {srdf}: {exc}") from exc
        if _posture is not None:
            q_full = _posture_from_spec(model, _posture, q_full)
        elif default_configuration is not None:
            q_full = as_vector(default_configuration, model.nq, "default_configuration")

        for jname, value in (locked_values or {}).items():
            if jname not in locked_joints:
                raise UnknownNameError("locked joint", jname, locked_joints)
            jid = model.getJointId(jname)
            q_full[model.joints[jid].idx_q] = float(value)
        if locked_joints:
            names = {n: i for i, n in enumerate(model.names) if i > 0}
            ids = []
            for j in locked_joints:
                if j not in names:
                    raise UnknownNameError("joint", j, names)
                ids.append(names[j])
            model_r, (collision, visual) = pin.buildReducedModel(
                model, [collision, visual], ids, q_full
            )
            keep = [
                model.joints[i].idx_q + k
                for i in range(1, model.njoints)
                if i not in ids
                for k in range(model.joints[i].nq)
            ]
            q_full = q_full[keep]
            model = model_r

        if convex_collision:
            _convexify(collision)
        collision.addAllCollisionPairs()
        if srdf is not None:
            try:
                pin.removeCollisionPairs(model, collision, str(srdf), False)
            except Exception as exc:
                raise ModelLoadError(f"cannot read collision pairs of SRDF {srdf}: {exc}") from exc
        else:
            _remove_adjacent_pairs(model, collision, q_full)
        if free_flyer:
            # Unlimited floating base (Pinocchio stores +-max float; keep it explicit).
            lower = model.lowerPositionLimit.copy()
            upper = model.upperPositionLimit.copy()
            lower[:7] = -np.inf
            upper[:7] = np.inf
            model.lowerPositionLimit = lower
            model.upperPositionLimit = upper
        return cls(
            model,
            collision,
            visual,
            name=name or path.stem,
            end_effectors=end_effectors,
            default_configuration=q_full,
            srdf_path=str(srdf) if srdf is not None else None,
        )

    # ------------------------------------------------------------------ structure
    def _setup_joint_structure(self) -> None:
        model = self.model
        self._normalized_blocks: list[tuple[int, int, str]] = []  # (idx_q, size, joint name)
        scalar_q: list[int] = []
        scalar_v: list[int] = []
        for jid in range(1, model.njoints):
            joint = model.joints[jid]
            short = joint.shortname()
            if "FreeFlyer" in short:
                self._normalized_blocks.append((joint.idx_q + 3, 4, model.names[jid]))
            elif "Spherical" in short and "ZYX" not in short:
                self._normalized_blocks.append((joint.idx_q, 4, model.names[jid]))
            elif "Unbounded" in short or "Planar" in short:
                offset = 2 if "Planar" in short else 0
                self._normalized_blocks.append((joint.idx_q + offset, 2, model.names[jid]))
            elif joint.nq == 1 and joint.nv == 1:
                scalar_q.append(joint.idx_q)
                scalar_v.append(joint.idx_v)
        self.is_floating = model.njoints > 1 and "FreeFlyer" in model.joints[1].shortname()
        lower = model.lowerPositionLimit[scalar_q]
        upper = model.upperPositionLimit[scalar_q]
        finite = np.isfinite(lower) & np.isfinite(upper) & (upper > lower) & (upper - lower < 1e10)
        self._limited_q = np.asarray(scalar_q, dtype=int)[finite]
        self._limited_v = np.asarray(scalar_v, dtype=int)[finite]

    @property
    def nq(self) -> int:
        """Size of the configuration vector."""
        return int(self.model.nq)

    @property
    def nv(self) -> int:
        """Size of the velocity (tangent) vector."""
        return int(self.model.nv)

    @property
    def frame_names(self) -> list[str]:
        """Names of all frames."""
        return list(self._frame_ids)

    @property
    def joint_names(self) -> list[str]:
        """Names of all joints except the universe."""
        return list(self._joint_ids)

    def frame_id(self, name: str) -> int:
        """Index of the frame called ``name``; the error lists the valid frames."""
        try:
            return self._frame_ids[name]
        except KeyError:
            raise UnknownNameError("frame", name, self._frame_ids) from None

    def joint_id(self, name: str) -> int:
        """Index of the joint called ``name``; the error lists the valid joints."""
        try:
            return self._joint_ids[name]
        except KeyError:
            raise UnknownNameError("joint", name, self._joint_ids) from None

    def joint_v_index(self, name: str) -> int:
        """First index of joint ``name`` in the velocity vector."""
        return int(self.model.joints[self.joint_id(name)].idx_v)

    @property
    def limited_joints_q(self) -> np.ndarray:
        """Configuration indices of the 1-DoF joints with finite position limits."""
        return self._limited_q

    @property
    def limited_joints_v(self) -> np.ndarray:
        """Velocity indices matching :attr:`limited_joints_q`."""
        return self._limited_v

    @property
    def lower_limits(self) -> FloatArray:
        """Lower position limits (size nq) [rad or m]; -inf where unlimited."""
        return np.asarray(self.model.lowerPositionLimit)

    @property
    def upper_limits(self) -> FloatArray:
        """Upper position limits (size nq) [rad or m]; +inf where unlimited."""
        return np.asarray(self.model.upperPositionLimit)

    @property
    def velocity_limits(self) -> FloatArray:
        """Velocity limits (size nv) [rad/s or m/s]; inf where unlimited (floating base)."""
        lim = np.asarray(self.model.velocityLimit, dtype=float).copy()
        if self.is_floating:
            lim[:6] = np.inf
        lim[lim <= 0] = np.inf
        return lim

    @property
    def effort_limits(self) -> FloatArray:
        """Torque/force limits (size nv) [N m or N]; 0 on the unactuated floating base."""
        lim = np.asarray(self.model.effortLimit, dtype=float).copy()
        if self.is_floating:
            lim[:6] = 0.0
        return lim

    @property
    def q_default(self) -> FloatArray:
        """Default posture (read-only)."""
        return self._q_default

    @property
    def mass(self) -> float:
        """Total mass [kg]."""
        return float(pin.computeTotalMass(self.model))

    # ------------------------------------------------------------------ configurations
    def check_configuration(self, q: Any, name: str = "q") -> FloatArray:
        """Validate a configuration: shape (nq,), finite, unit quaternions.

        Returns:
            A float64 copy of ``q``.

        Raises:
            ShapeError, NotFiniteError: wrong shape or NaN/inf.
            InvalidInputError: a quaternion (or unit complex of a continuous joint) is not
                normalized; use :meth:`normalize`.
        """
        if type(q) is np.ndarray and q.dtype is _F64 and q.shape == self._q_shape:
            arr = q.copy()  # fast path for the common case
            if not math.isfinite(arr.dot(arr)):
                check_finite(arr, name)
        else:
            arr = as_vector(q, self._nq, name)
            arr = arr.copy() if arr is q else arr
        for idx, size, joint in self._normalized_blocks:
            block = arr[idx : idx + size]
            norm = math.sqrt(block.dot(block))
            if abs(norm - 1.0) > QUATERNION_TOLERANCE:
                kind = "quaternion" if size == 4 else "unit complex (cos, sin)"
                raise InvalidInputError(
                    f"{name}[{idx}:{idx + size}] is the {kind} of joint '{joint}' and must have "
                    f"unit norm, got {norm:.9g}; call robot.normalize(q)"
                )
        return arr

    def check_velocity(self, v: Any, name: str = "v") -> FloatArray:
        """Validate a tangent vector: shape (nv,), finite. Returns a float64 copy."""
        if type(v) is np.ndarray and v.dtype is _F64 and v.shape == self._v_shape:
            arr = v.copy()
            if not math.isfinite(arr.dot(arr)):
                check_finite(arr, name)
            return arr
        arr = as_vector(v, self._nv, name)
        return arr.copy() if arr is v else arr

    def check_limits(self, q: Any, *, tolerance: float = 0.0, name: str = "q") -> FloatArray:
        """Validate ``q`` and raise :class:`LimitError` if a joint is outside its limits."""
        arr = self.check_configuration(q, name)
        idx = self._limited_q
        lo = self.model.lowerPositionLimit[idx] - tolerance
        hi = self.model.upperPositionLimit[idx] + tolerance
        bad = np.flatnonzero((arr[idx] < lo) | (arr[idx] > hi))
        if bad.size:
            qi = idx[bad]
            names = [self._joint_name_at_q(int(i)) for i in qi]
            details = ", ".join(
                f"{n}={arr[i]:.4g} not in [{self.model.lowerPositionLimit[i]:.4g}, "
                f"{self.model.upperPositionLimit[i]:.4g}]"
                for n, i in zip(names, qi)
            )
            raise LimitError(
                f"{name} is outside the joint limits: {details}",
                [int(i) for i in qi],
                arr[qi],
                self.model.lowerPositionLimit[qi],
                self.model.upperPositionLimit[qi],
            )
        return arr

    def _joint_name_at_q(self, idx_q: int) -> str:
        for jid in range(1, self.model.njoints):
            joint = self.model.joints[jid]
            if joint.idx_q <= idx_q < joint.idx_q + joint.nq:
                return str(self.model.names[jid])
        return f"q[{idx_q}]"

    def normalize(self, q: Any) -> FloatArray:
        """Return ``q`` with its quaternions normalized."""
        arr = as_vector(q, self.model.nq, "q")
        return np.asarray(pin.normalize(self.model, arr))

    def neutral(self) -> FloatArray:
        """The neutral configuration (zero joint angles, identity base)."""
        return np.asarray(pin.neutral(self.model))

    def random_configuration(
        self, rng: np.random.Generator, *, base_box: float = 1.0
    ) -> FloatArray:
        """Uniform random configuration within the joint limits.

        Args:
            rng: random generator.
            base_box: floating-base positions are drawn in ``[-base_box, base_box]^3`` [m];
                orientations uniformly on SO(3).
        """
        q = np.empty(self.model.nq)
        lo = self.model.lowerPositionLimit
        hi = self.model.upperPositionLimit
        idx = self._limited_q
        q[:] = pin.neutral(self.model)
        q[idx] = rng.uniform(lo[idx], hi[idx])
        for start, size, _ in self._normalized_blocks:
            x = rng.normal(size=size)
            q[start : start + size] = x / np.linalg.norm(x)
        if self.is_floating:
            q[:3] = rng.uniform(-base_box, base_box, 3)
        return q

    def integrate(self, q: Any, v: Any, dt: float = 1.0) -> FloatArray:
        """Configuration reached from ``q`` moving with velocity ``v`` for ``dt`` [s]."""
        qa = self.check_configuration(q)
        va = self.check_velocity(v)
        return np.asarray(pin.integrate(self.model, qa, va * dt))

    def difference(self, q0: Any, q1: Any) -> FloatArray:
        """Tangent vector ``v`` such that ``integrate(q0, v) = q1``."""
        a = self.check_configuration(q0, "q0")
        b = self.check_configuration(q1, "q1")
        return np.asarray(pin.difference(self.model, a, b))

    def state(self, q: Any = None, v: Any = None) -> State:
        """A :class:`~taskspace.model.state.State` at ``q`` (default posture if omitted)."""
        from taskspace.model.state import State

        return State(self, self._q_default if q is None else q, v)

    # ------------------------------------------------------------------ kinematics helpers
    def frame_placement(self, q: Any, frame: str) -> pin.SE3:
        """Pose of ``frame`` in the world at configuration ``q``."""
        fid = self.frame_id(frame)
        qa = self.check_configuration(q)
        pin.framesForwardKinematics(self.model, self.data, qa)
        return self.data.oMf[fid].copy()

    # ------------------------------------------------------------------ world and collisions
    @property
    def robot_geometry_count(self) -> int:
        """Number of robot geometries (the first entries of ``collision_model``)."""
        return self._robot_geometry_count

    def add_obstacle(self, obstacle: Obstacle) -> None:
        """Add a fixed obstacle; it is checked against every robot geometry."""
        self.world.add(obstacle)
        geom = pin.GeometryObject(obstacle.name, 0, 0, obstacle.placement, obstacle.geometry)
        geom.meshColor = np.asarray(obstacle.color, dtype=float)
        gid = self.collision_model.addGeometryObject(geom)
        for rid in range(self._robot_geometry_count):
            if self.collision_model.geometryObjects[rid].parentJoint != 0:
                self.collision_model.addCollisionPair(pin.CollisionPair(rid, gid))
        self.collision_data = self.collision_model.createData()

    def add_obstacles(self, obstacles: Iterable[Obstacle]) -> None:
        """Add several obstacles."""
        for obstacle in obstacles:
            self.add_obstacle(obstacle)

    def clear_obstacles(self) -> None:
        """Remove every obstacle."""
        for obstacle in list(self.world):
            self.collision_model.removeGeometryObject(obstacle.name)
            self.world.remove(obstacle.name)
        self.collision_data = self.collision_model.createData()

    @property
    def collision_pairs(self) -> list[tuple[str, str]]:
        """Checked collision pairs as (geometry name, geometry name)."""
        objs = self.collision_model.geometryObjects
        return [
            (objs[p.first].name, objs[p.second].name) for p in self.collision_model.collisionPairs
        ]

    def is_collision_free(self, q: Any) -> bool:
        """True if no checked pair (self or world) collides at ``q``; stops at the first hit."""
        qa = self.check_configuration(q)
        return not pin.computeCollisions(
            self.model, self.data, self.collision_model, self.collision_data, qa, True
        )

    def colliding_pairs(self, q: Any) -> list[tuple[str, str]]:
        """Names of all colliding pairs at ``q``."""
        qa = self.check_configuration(q)
        pin.computeCollisions(
            self.model, self.data, self.collision_model, self.collision_data, qa, False
        )
        objs = self.collision_model.geometryObjects
        out = []
        for k, pair in enumerate(self.collision_model.collisionPairs):
            if self.collision_data.collisionResults[k].isCollision():
                out.append((objs[pair.first].name, objs[pair.second].name))
        return out

    def __repr__(self) -> str:
        return (
            f"Robot('{self.name}', nq={self.nq}, nv={self.nv}, floating={self.is_floating}, "
            f"geometries={self.collision_model.ngeoms}, "
            f"pairs={len(self.collision_model.collisionPairs)}, obstacles={len(self.world)})"
        )


# ---------------------------------------------------------------------- helpers
def _erd_paths(spec: RobotSpec) -> tuple[str, list[str], str | None]:
    try:
        from example_robot_data.robots_loader import ROBOTS
    except ImportError as exc:  # pragma: no cover - dependency missing
        raise ModelLoadError(
            "example_robot_data is not installed: pip install example-robot-data-loaders"
        ) from exc
    if spec.erd_name not in ROBOTS:
        raise UnknownNameError("example-robot-data robot", str(spec.erd_name), ROBOTS)
    loader_cls = ROBOTS[spec.erd_name]
    from os.path import join

    from example_robot_data.robots_loader import getModelPath

    df_path = join(loader_cls.path, loader_cls.urdf_subpath, loader_cls.urdf_filename)
    model_path = loader_cls.model_path or getModelPath(df_path)
    urdf = join(model_path, df_path)
    srdf = None
    if loader_cls.srdf_filename:
        srdf = join(model_path, loader_cls.path, loader_cls.srdf_subpath, loader_cls.srdf_filename)
    return urdf, [join(model_path, "../.."), model_path], srdf


def _posture_from_spec(model: pin.Model, spec: RobotSpec, q: FloatArray) -> FloatArray:
    q = q.copy()
    posture = spec.default_posture
    if "srdf" in posture:
        ref = posture["srdf"]
        names = [k for k in model.referenceConfigurations]
        names = [str(k.key()) if hasattr(k, "key") else str(k) for k in names]
        try:
            q = np.asarray(model.referenceConfigurations[ref]).copy()
        except Exception:
            raise UnknownNameError("reference configuration", ref, names) from None
    joints = posture.get("joints", {}) or {}
    names_map = {n: i for i, n in enumerate(model.names)}
    for jname, value in joints.items():
        if jname not in names_map:
            raise ModelLoadError(
                f"registry entry '{spec.name}': default posture names unknown joint '{jname}'"
            )
        q[model.joints[names_map[jname]].idx_q] = float(value)
    if "base" in posture:
        q[:3] = np.asarray(posture["base"], dtype=float)
    check_finite(q, "default posture")
    return q


def _remove_adjacent_pairs(
    model: pin.Model, collision: pin.GeometryModel, q_default: FloatArray
) -> None:
    """Without an SRDF, drop pairs that are always or usually in contact.

    Pairs on the same or adjacent joints, and pairs touching at the default posture (what
    MoveIt's setup assistant disables as "adjacent" and "default").
    """
    objs = collision.geometryObjects
    parents = model.parents
    drop = []
    for pair in collision.collisionPairs:
        ja, jb = objs[pair.first].parentJoint, objs[pair.second].parentJoint
        if ja == jb or parents[ja] == jb or parents[jb] == ja:
            drop.append((int(pair.first), int(pair.second)))
    for first, second in drop:
        collision.removeCollisionPair(pin.CollisionPair(first, second))
    data = model.createData()
    geom_data = collision.createData()
    pin.computeCollisions(model, data, collision, geom_data, q_default, False)
    touching = [
        (int(p.first), int(p.second))
        for k, p in enumerate(collision.collisionPairs)
        if geom_data.collisionResults[k].isCollision()
    ]
    for first, second in touching:
        collision.removeCollisionPair(pin.CollisionPair(first, second))
    if drop or touching:
        logger.info(
            "no SRDF: disabled %d adjacent and %d default-posture collision pairs",
            len(drop),
            len(touching),
        )


def _convexify(geometry_model: pin.GeometryModel) -> None:
    """Replace BVH mesh geometries by their convex hulls, in place."""
    for obj in geometry_model.geometryObjects:
        geom = obj.geometry
        if hasattr(geom, "buildConvexRepresentation"):
            geom.buildConvexRepresentation(False)
            obj.geometry = geom.convex


def configuration_from_joint_values(robot: Robot, values: dict[str, float]) -> FloatArray:
    """Default posture with the named 1-DoF joints set to ``values`` [rad or m]."""
    q = robot.q_default.copy()
    for name, value in values.items():
        jid = robot.joint_id(name)
        joint = robot.model.joints[jid]
        if joint.nq != 1:
            raise ShapeError(f"joint '{name}' value", (joint.nq,), (1,))
        q[joint.idx_q] = float(value)
    return q
