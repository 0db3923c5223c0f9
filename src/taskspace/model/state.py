"""``State``: a configuration, a velocity, and the kinematics computed for them once."""

from __future__ import annotations

import operator
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray
from taskspace.errors import InvalidInputError
from taskspace.model.collision_requests import without_cached_guess

if TYPE_CHECKING:
    from taskspace.model.robot import Robot

_compute_joint_jacobians = pin.computeJointJacobians
_forward_kinematics = pin.forwardKinematics
_update_frame_placements = pin.updateFramePlacements
_get_frame_jacobian = pin.getFrameJacobian
_get_frame_acceleration = pin.getFrameAcceleration
_get_frame_classical_acceleration = pin.getFrameClassicalAcceleration

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
LOCAL = pin.ReferenceFrame.LOCAL
WORLD = pin.ReferenceFrame.WORLD


ADOPT_RESETS = (
    ("_com", "_com_jacobian", "_com_drift"),
    ("_cache_lwa", "_cache_local"),
    ("_distances_done",),
)
"""What :meth:`State._adopt` does besides recording ``q``, ``v`` and the velocity flag: the
slots it sets to None, the dicts it empties, the slots it sets to False. A compiled kernel that
records a configuration itself (``DifferentialIK.advance``'s armed step, through the slots'
member descriptors) does the same from this list: keep both in step (a test compares them)."""


class State:
    """Configuration ``q``, velocity ``v`` and their kinematics, computed in one pass.

    :meth:`update` runs Pinocchio once (``computeJointJacobians`` and frame placements, plus
    ``forwardKinematics`` with ``a = 0`` when a velocity is given, for the drift terms
    ``Jdot v``). Every feature then reads from it; per-frame Jacobians are cached until the
    next update.

    Invariants (by construction): ``q``, ``v``, ``robot`` and ``data`` are read-only;
    ``collision_data`` accepts only a data of the robot's collision model. ``q`` and ``v``
    are private copies whose buffers cannot be made writable again, so the kinematics always
    belong to the ``q`` and ``v`` the state reports: the only ways to change them are
    :meth:`update`, which recomputes everything, and
    :meth:`DifferentialIK.advance <taskspace.ik.DifferentialIK.advance>`, whose compiled
    kernel writes the kinematics of the new configuration into ``data`` exactly as
    :meth:`update` would and then records it (``_adopt``, the one place both go through).
    ``data`` is the ``pin.Data`` of ``robot.model`` made by this state; it cannot be
    replaced (a ``Data`` of another model would make Pinocchio and the compiled kernels write
    out of bounds). The collision data follow the robot's obstacle world by its
    :attr:`~taskspace.model.World.version`.

    Thread safety: a state is a workspace and is not thread-safe; use one state per thread
    (reading the same state from several threads without updating it is safe).

    Args:
        robot: the robot.
        q: configuration (size nq), validated (shape, finite, unit quaternions).
        v: velocity (size nv) [rad/s, m/s]; zero if omitted.
    """

    __slots__ = (
        "__weakref__",
        "_a0",
        "_cache_local",
        "_cache_lwa",
        "_collision_data",
        "_collision_version",
        "_com",
        "_com_drift",
        "_com_jacobian",
        "_com_ref",
        "_data",
        "_distance_handles",
        "_distances_done",
        "_guess_reset",
        "_has_velocity",
        "_model",
        "_nframes",
        "_njoints",
        "_placements",
        "_q",
        "_robot",
        "_v",
    )

    def __init__(self, robot: Robot, q: Any, v: Any = None) -> None:
        self._robot = robot
        self._model = robot._model
        self._nframes = int(robot._model.nframes)
        self._njoints = int(robot._model.njoints)
        self._com: FloatArray | None = None
        self._com_jacobian: FloatArray | None = None
        self._com_drift: FloatArray | None = None
        self._data = robot._model.createData()
        # References into ``data`` (Pinocchio returns views that follow every update); taking
        # them once saves building a new Python object at each access.
        self._com_ref: FloatArray = self._data.com[0]
        self._placements: dict[int, pin.SE3] = {}
        # made at the first distance query or read (a GeometryData costs about 2 us per
        # collision pair: most states never query distances)
        self._collision_data: Any = None
        self._guess_reset: Any = None  # the data whose cached GJK guess is off (lazily)
        self._collision_version = robot.world.version
        self._distance_handles: tuple[Any, list[Any]] | None = None
        self._a0 = _frozen(np.zeros(robot.nv))  # also serves as the zero velocity
        self._cache_lwa: dict[int, FloatArray] = {}
        self._cache_local: dict[int, FloatArray] = {}
        self.update(q, v)
        robot._states.add(self)  # re-evaluated by Robot.edit_model

    # Read-only attributes: C-level getters (``attrgetter``), as fast as they come.
    robot = property(
        operator.attrgetter("_robot"),
        lambda self, value: _read_only("robot"),
        doc="The robot whose model made this state (read-only).",
    )
    data = property(
        operator.attrgetter("_data"),
        lambda self, value: _read_only("data"),
        doc="The ``pin.Data`` of ``robot.model`` holding the kinematics (read-only; do not "
        "pass it to Pinocchio functions that modify it).",
    )

    def _set_collision_data(self, value: Any) -> None:
        geom = self._robot._collision_model
        if (
            not isinstance(value, pin.GeometryData)
            or len(value.oMg) != geom.ngeoms
            or len(value.distanceResults) != len(geom.collisionPairs)
        ):
            raise InvalidInputError(
                "State.collision_data must be a pin.GeometryData of this robot's collision "
                f"model ({geom.ngeoms} geometries, {len(geom.collisionPairs)} pairs): use "
                "robot.collision_model.createData()"
            )
        self._collision_data = value
        self._collision_version = self._robot.world.version
        self._distances_done = False

    def _get_collision_data(self) -> Any:
        data = self._collision_data
        version = self._robot.world._version
        if data is None or version != self._collision_version:
            # not made yet, or made for an earlier world: made for the current one (as the
            # distance queries would)
            data = self._collision_data = self._robot._collision_model.createData()
            self._collision_version = version
            self._distances_done = False
        return data

    collision_data = property(
        _get_collision_data,
        _set_collision_data,
        doc="The ``pin.GeometryData`` of ``robot.collision_model`` used by the distance "
        "queries (made at the first use, and again after a change of the robot's world); it "
        "may be replaced only by another data of the same collision model.",
    )

    # ------------------------------------------------------------------ update
    def update(self, q: Any, v: Any = None, *, validate: bool = True) -> None:
        """Recompute the kinematics for a new configuration (and velocity).

        Args:
            q: configuration (size nq).
            v: velocity (size nv); zero if omitted.
            validate: check shapes, finiteness and quaternion norms (turn off only for
                vectors produced by taskspace itself in a hot loop).
        """
        if validate:
            robot = self._robot
            q = robot.check_configuration(q)
            if v is not None:
                v = robot.check_velocity(v)
        else:
            q = np.array(q, dtype=float)
            if v is not None:
                v = np.array(v, dtype=float)
        data = self._data
        model = self._model
        if v is None:
            _compute_joint_jacobians(model, data, q)
        else:
            _forward_kinematics(model, data, q, v, self._a0)
            _compute_joint_jacobians(model, data)
        _update_frame_placements(model, data)
        self._adopt(q, v)

    def _refresh(self) -> None:
        """Recompute the kinematics of the current ``q`` and ``v`` (the model's values changed).

        Called by :meth:`Robot.edit_model` on every live state of the robot: a state never
        holds kinematics of values the model no longer has.
        """
        self.update(self._q, self._v if self._has_velocity else None, validate=False)

    def _adopt(self, q: FloatArray, v: FloatArray | None, locked: bool = False) -> None:
        """Make ``q`` and ``v`` the state's, the kinematics of ``data`` being already theirs.

        The one place that records a new configuration: :meth:`update` calls it after
        Pinocchio, and a compiled kernel that has just written the kinematics of ``q`` (and
        ``v``) into this state's data (``DifferentialIK.advance``) calls it after its call.
        Everything derived from the previous kinematics (cached Jacobians, center of mass,
        collision distances) is marked stale here.

        ``q`` and ``v`` must be private copies (nobody else holds them): they are made
        read-only for good (the buffer is locked and only a view of it is kept; numpy refuses
        to make a view of a locked buffer writable). ``v`` None: no velocity (zero).
        ``locked``: ``q`` and ``v`` are already such views (a compiled kernel made them so).
        The compiled armed step does what this does from :data:`ADOPT_RESETS`.
        """
        if locked:
            self._q = q
        else:
            q.setflags(write=False)
            self._q = q.view()
        if v is None:
            self._has_velocity = False
            self._v = self._a0
        else:
            self._has_velocity = True
            if not locked:
                v.setflags(write=False)
                v = v.view()
            self._v = v
        if self._cache_lwa:
            self._cache_lwa.clear()
        if self._cache_local:
            self._cache_local.clear()
        self._com = self._com_jacobian = self._com_drift = None
        self._distances_done = False

    # ------------------------------------------------------------------ accessors
    @property
    def q(self) -> FloatArray:
        """Configuration (read-only)."""
        return self._q

    @property
    def v(self) -> FloatArray:
        """Velocity (read-only)."""
        return self._v

    @property
    def has_velocity(self) -> bool:
        """Whether a velocity was given (drift terms need it)."""
        return self._has_velocity

    def frame_placement(self, frame_id: int) -> pin.SE3:
        """World pose of a frame (a reference into the state's data; do not modify).

        The object follows the state: after :meth:`update` it holds the new pose.
        """
        try:
            M = self._placements.get(frame_id)
        except TypeError:  # unhashable: not an index (the check below says so)
            M = None
        if M is None:
            frame_id = self._frame_index(frame_id)
            M = self._placements[frame_id] = self._data.oMf[frame_id]
        return M

    def frame_jacobian(self, frame_id: int) -> FloatArray:
        """6 x nv Jacobian of a frame, LOCAL_WORLD_ALIGNED: rows (linear, angular) [m, rad].

        The linear rows give the velocity of the frame origin in world coordinates.
        """
        try:
            J = self._cache_lwa.get(frame_id)
        except TypeError:  # unhashable: not an index (the check below says so)
            J = None
        if J is None:
            frame_id = self._frame_index(frame_id)
            J = _get_frame_jacobian(self._model, self._data, frame_id, LWA)
            self._cache_lwa[frame_id] = J
        return J

    def frame_jacobian_local(self, frame_id: int) -> FloatArray:
        """6 x nv Jacobian of a frame in its LOCAL coordinates (body twist)."""
        try:
            J = self._cache_local.get(frame_id)
        except TypeError:  # unhashable: not an index (the check below says so)
            J = None
        if J is None:
            frame_id = self._frame_index(frame_id)
            J = _get_frame_jacobian(self._model, self._data, frame_id, LOCAL)
            self._cache_local[frame_id] = J
        return J

    def joint_jacobian_world(self, joint_id: int) -> FloatArray:
        """6 x nv spatial Jacobian of a joint in WORLD coordinates.

        The velocity of a point ``p`` (world coordinates) attached to the joint is
        ``(J[:3] - [p]x J[3:]) v``.
        """
        joint_id = self._index(joint_id, self._njoints, "joint", "robot.joint_id(name)")
        return pin.getJointJacobian(self._model, self._data, joint_id, WORLD)

    def _frame_index(self, frame_id: Any) -> int:
        return self._index(frame_id, self._nframes, "frame", "robot.frame_id(name)")

    def _index(self, index: Any, count: int, kind: str, hint: str) -> int:
        """``index`` as an int in ``[0, count)``, else an error giving the valid range."""
        if type(index) is int and 0 <= index < count:
            return index
        if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
            raise InvalidInputError(
                f"{kind} index must be an integer in [0, {count - 1}], got "
                f"{type(index).__name__} {index!r}; use {hint} to get it from a name"
            )
        if not 0 <= int(index) < count:
            raise InvalidInputError(
                f"{kind} index {int(index)} is out of range: robot '{self._robot.name}' has "
                f"{count} {kind}s, valid indices are 0..{count - 1}; use {hint} to get it "
                "from a name"
            )
        return int(index)

    def _require_velocity(self, what: str) -> None:
        if not self._has_velocity:
            raise InvalidInputError(
                f"{what} needs the velocity: create the state with v (robot.state(q, v)) or "
                "call state.update(q, v)"
            )

    def frame_drift(self, frame_id: int) -> FloatArray:
        """Classical acceleration of a frame at zero joint acceleration, ``Jdot v``.

        Returns the 6-vector (linear [m/s^2], angular [rad/s^2]) in LOCAL_WORLD_ALIGNED
        coordinates, the drift of :meth:`frame_jacobian`.
        """
        if not self._has_velocity:
            self._require_velocity("the drift Jdot v")
        if type(frame_id) is not int or not 0 <= frame_id < self._nframes:
            frame_id = self._frame_index(frame_id)
        acc = _get_frame_classical_acceleration(self._model, self._data, frame_id, LWA)
        return np.asarray(acc.vector)

    def frame_drift_local(self, frame_id: int) -> FloatArray:
        """Spatial acceleration of a frame at zero joint acceleration, LOCAL coordinates.

        The drift of :meth:`frame_jacobian_local` (the body twist ``J_local v``).
        """
        if not self._has_velocity:
            self._require_velocity("the drift Jdot v")
        if type(frame_id) is not int or not 0 <= frame_id < self._nframes:
            frame_id = self._frame_index(frame_id)
        acc = _get_frame_acceleration(self._model, self._data, frame_id, LOCAL)
        return np.asarray(acc.vector)

    def frame_velocity(self, frame_id: int) -> FloatArray:
        """6-vector velocity (linear, angular) of a frame, LOCAL_WORLD_ALIGNED [m/s, rad/s]."""
        return self.frame_jacobian(frame_id) @ self._v

    # ------------------------------------------------------------------ center of mass
    def com(self) -> FloatArray:
        """Center of mass in the world [m]."""
        if self._com is None:
            self.com_jacobian()
        com = self._com
        if com is None:  # pragma: no cover - set by com_jacobian
            raise RuntimeError("center of mass not computed")
        return com

    def com_jacobian(self) -> FloatArray:
        """3 x nv Jacobian of the center of mass."""
        J = self._com_jacobian
        if J is None:
            J = pin.jacobianCenterOfMass(self._model, self._data, True)
            self._com_jacobian = J
            self._com = self._com_ref  # a view into data: valid until the next update
        return J

    def com_drift(self) -> FloatArray:
        """Acceleration of the center of mass at zero joint acceleration [m/s^2]."""
        self._require_velocity("the center-of-mass drift")
        drift = self._com_drift
        if drift is None:
            pin.centerOfMass(self._model, self._data, pin.KinematicLevel.ACCELERATION, True)
            drift = np.asarray(self._data.acom[0]).copy()
            self._com_drift = drift
        return drift

    # ------------------------------------------------------------------ collisions
    def compute_distances(self) -> None:
        """Run coal distance queries for every collision pair (once per update and world).

        Also after a change of the robot's world (obstacles, collision pairs,
        :meth:`Robot.edit_collision_model`) since the last queries, without an update: the
        world's version is compared first.
        """
        robot = self._robot
        version = robot.world._version  # the property costs more than the check itself
        if self._distances_done and version == self._collision_version:
            return
        geom = robot._collision_model
        if (
            self._collision_data is None
            or version != self._collision_version
            or len(self._collision_data.oMg) != geom.ngeoms
            or len(self._collision_data.distanceResults) != len(geom.collisionPairs)
        ):
            # the world (obstacles or collision pairs) changed since the data were made
            self._collision_data = geom.createData()
            self._collision_version = version
        if self._guess_reset is not self._collision_data:  # once per data, here: ~0.5 ms
            self._guess_reset = without_cached_guess(self._collision_data)
        pin.updateGeometryPlacements(self._model, self._data, geom, self._collision_data)
        pin.computeDistances(geom, self._collision_data)
        self._distances_done = True

    def distance_results(self) -> list[Any]:
        """Distance results (coal) of every collision pair, queries run once per update.

        Handles into :attr:`collision_data`, taken once: building a Python object per pair at
        every access costs about 1 us each, more than the distance queries of convex shapes.
        They follow every later update (read them, do not modify them); a replaced
        :attr:`collision_data` gets new handles.
        """
        self.compute_distances()
        cached = self._distance_handles
        if cached is not None and cached[0] is self._collision_data:
            return cached[1]
        handles = list(self._collision_data.distanceResults)
        self._distance_handles = (self._collision_data, handles)
        return handles


def _frozen(array: FloatArray) -> FloatArray:
    """A read-only view of ``array`` whose buffer is locked (cannot be made writable)."""
    array.setflags(write=False)
    return array.view()


def _read_only(name: str) -> NoReturn:
    raise InvalidInputError(
        f"State.{name} is read-only: a state owns its kinematics; call state.update(q, v) "
        "for a new configuration or robot.state(q) for a new state"
    )
