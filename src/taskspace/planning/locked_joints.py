"""Locked joints: plan in the sub-space of the other joints, check in the full configuration.

A robot's configuration ``q`` (size ``nq``) is split into the coordinates of the locked joints,
held at given values, and those of the free joints, which the planner moves. The planning
space holds only the free coordinates ``q_f`` (in the order of ``q``); a configuration is
*lifted* to the robot's ``q = L(q_f)`` by writing ``q_f`` into a copy of the reference
configuration whose locked coordinates are the given values, and *reduced* back by taking
the free coordinates. ``L`` copies the locked values, so every lifted configuration holds them
exactly, and the collision checker sees ``L(q_f)``: the locked links are checked where they
are held.

Any joint can be locked: a floating base (its 7 coordinates, a unit quaternion), a continuous
joint (its ``(cos, sin)`` pair, or an angle), a planar joint, or a joint type the planners
cannot move. The free joints' Lie-group operations (metric, interpolation, sampling) come from
the reduced Pinocchio model (``pinocchio.buildReducedModel``), whose configuration is the free
coordinates in the same order.

Thread safety: :class:`LockedJoints` is immutable after construction; a
:class:`LockedJointChecker` is a wrapper around a :class:`CollisionChecker` and, as it, one per
thread.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import as_float_array
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.planning.collision_checker import NATIVE_PAIR_CACHE, BoolArray, CollisionChecker

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

_CIRCLE = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ",
           "JointModelRevoluteUnboundedUnaligned")  # fmt: skip


class LockedJoints:
    """Which joints are held, at which values, and the free coordinates of ``q`` and ``v``.

    Args:
        model: the full Pinocchio model.
        values: joint name -> value: a number for a one-coordinate joint, an angle [rad] or a
            ``(cos, sin)`` pair for a continuous joint, the joint's ``nq`` coordinates
            otherwise (a floating base: ``x, y, z, qx, qy, qz, qw``).
        reference: a configuration of the model (size ``nq``) whose free coordinates are
            irrelevant (the model's neutral configuration by default).

    Attributes:
        names: the locked joints' names, in the model's order.
        joint_ids: their Pinocchio joint indices.
        free_q: indices of the free coordinates in ``q`` (ascending).
        free_v: indices of the free coordinates in ``v`` (ascending).
        locked_q: indices of the locked coordinates in ``q``.
        q_locked: the full configuration with the locked values (read-only).

    Raises:
        UnknownNameError: a name that is not a joint of the model (the valid names listed).
        InvalidInputError: a value of the wrong size, not finite, outside the joint's
            limits, a quaternion or ``(cos, sin)`` pair not of unit norm, or every joint
            locked.
    """

    def __init__(self, model: pin.Model, values: Mapping[str, Any], reference: Any = None) -> None:
        if not isinstance(values, Mapping) or not values:
            raise InvalidInputError(
                f"locked_joints must be a non-empty mapping joint name -> value, got {values!r}"
            )
        joints = [str(model.names[j]) for j in range(1, model.njoints)]
        q = np.array(pin.neutral(model) if reference is None else reference, dtype=np.float64)
        if q.shape != (model.nq,):
            raise InvalidInputError(f"reference must have size nq = {model.nq}, got {q.shape}")
        locked_q = np.zeros(model.nq, dtype=bool)
        locked_v = np.zeros(model.nv, dtype=bool)
        ids = []
        for name, value in values.items():
            if name not in joints:
                raise UnknownNameError("joint", str(name), joints)
            jid = int(model.getJointId(name))
            joint = model.joints[jid]
            sl = slice(joint.idx_q, joint.idx_q + joint.nq)
            q[sl] = _joint_value(model, joint, name, value)
            locked_q[sl] = True
            locked_v[joint.idx_v : joint.idx_v + joint.nv] = True
            ids.append(jid)
        if locked_v.all():
            raise InvalidInputError("locked_joints holds every joint: nothing is left to plan with")
        order = np.argsort(ids)
        self.joint_ids = tuple(int(ids[i]) for i in order)
        self.names = tuple(str(model.names[j]) for j in self.joint_ids)
        self._slices = tuple(
            slice(model.joints[j].idx_q, model.joints[j].idx_q + model.joints[j].nq)
            for j in self.joint_ids
        )
        self.free_q = np.flatnonzero(~locked_q).astype(np.int64)
        self.free_v = np.flatnonzero(~locked_v).astype(np.int64)
        self.locked_q = np.flatnonzero(locked_q).astype(np.int64)
        self.nq, self.nv = int(model.nq), int(model.nv)
        for arr in (self.free_q, self.free_v, self.locked_q):
            arr.flags.writeable = False
        q.flags.writeable = False
        self.q_locked = q

    def reduced_model(self, model: pin.Model) -> pin.Model:
        """The model of the free joints (the locked ones welded at their values).

        Its configuration is :meth:`reduce` of the full one (same joints, same order) and
        its limits are the full model's current limits of the free coordinates.
        """
        reduced = pin.buildReducedModel(
            _with_joint_frames(model), list(self.joint_ids), self.q_locked
        )
        self._check_layout(reduced)
        return reduced

    def reduced_models(
        self, model: pin.Model, geometry: pin.GeometryModel
    ) -> tuple[pin.Model, pin.GeometryModel]:
        """:meth:`reduced_model` and the geometry model on it (the same objects and pairs).

        Each geometry object of a locked joint's subtree is re-attached to the nearest free
        ancestor joint (or the world) with its placement composed through the locked joints
        at their values (``pinocchio.buildReducedModel`` with a geometry model); objects,
        their order and the collision pairs are unchanged.
        """
        reduced, reduced_geometry = pin.buildReducedModel(
            _with_joint_frames(model), geometry, list(self.joint_ids), self.q_locked
        )
        self._check_layout(reduced)
        if reduced_geometry.ngeoms != geometry.ngeoms or len(
            reduced_geometry.collisionPairs
        ) != len(geometry.collisionPairs):
            raise InvalidInputError(  # pragma: no cover - Pinocchio's contract
                "pinocchio.buildReducedModel changed the geometry objects or collision pairs"
            )
        return reduced, reduced_geometry

    def _check_layout(self, reduced: pin.Model) -> None:
        if reduced.nq != self.free_q.size or reduced.nv != self.free_v.size:
            raise InvalidInputError(  # pragma: no cover - Pinocchio's layout contract
                "pinocchio.buildReducedModel returned a model of another size "
                f"(nq {reduced.nq}, nv {reduced.nv}; expected {self.free_q.size}, "
                f"{self.free_v.size})"
            )

    def lift(self, configurations: Any) -> FloatArray:
        """Full configurations ``L(q_f)`` of free-coordinate rows (shape (n, nq) or (nq,))."""
        arr = np.asarray(configurations, dtype=np.float64)
        if arr.shape[-1:] != self.free_q.shape or arr.ndim > 2:
            raise InvalidInputError(
                f"configurations of the free joints have {self.free_q.size} coordinates, got "
                f"shape {arr.shape}"
            )
        if arr.ndim == 1:
            out = self.q_locked.copy()
            out[self.free_q] = arr
            return out
        out = np.empty((arr.shape[0], self.nq))
        out[:] = self.q_locked
        out[:, self.free_q] = arr
        return out

    def reduce(self, configurations: Any) -> FloatArray:
        """The free coordinates of full configurations (rows or one vector)."""
        arr = np.asarray(configurations, dtype=np.float64)
        return np.ascontiguousarray(arr[..., self.free_q])

    def mismatch(self, q: FloatArray, tolerance: float = 1e-9) -> str:
        """Which locked joints of the full configuration ``q`` differ from their values ("")."""
        diff = np.abs(q[self.locked_q] - self.q_locked[self.locked_q]) > tolerance
        if not diff.any():
            return ""
        parts = []
        for name, sl in zip(self.names, self._slices, strict=True):
            if np.any(np.abs(q[sl] - self.q_locked[sl]) > tolerance):
                parts.append(
                    f"{name}={np.round(q[sl], 6).tolist()} (locked at "
                    f"{np.round(self.q_locked[sl], 6).tolist()})"
                )
        return ", ".join(parts)


def _with_joint_frames(model: pin.Model) -> pin.Model:
    """``model``, or a copy with a JOINT frame for every joint that has none.

    ``pinocchio.buildReducedModel`` reads each joint's JOINT frame and crashes (segmentation
    fault) on a model built without them (``addJoint`` alone); the configuration layout of
    the copy is the same.
    """
    framed = {f.parentJoint for f in model.frames if f.type == pin.FrameType.JOINT}
    missing = sorted(set(range(1, model.njoints)) - framed)
    if not missing:
        return model
    model = model.copy()
    for j in missing:
        model.addJointFrame(j)
    return model


def _joint_value(model: pin.Model, joint: Any, name: str, value: Any) -> FloatArray:
    """The ``nq`` coordinates of a locked joint's value, validated."""
    short = joint.shortname()
    # (numbers only: a bool was taken as 1.0, text raised NumPy's bare ValueError)
    arr = np.atleast_1d(as_float_array(value, f"locked joint '{name}'"))
    if short in _CIRCLE and arr.size == 1:
        arr = np.array([math.cos(arr[0]), math.sin(arr[0])])
    if arr.shape != (joint.nq,):
        raise InvalidInputError(
            f"locked joint '{name}' ({short}) has {joint.nq} coordinates, got a value of "
            f"shape {arr.shape}" + (" (an angle or a (cos, sin) pair)" if short in _CIRCLE else "")
        )
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"locked joint '{name}': the value is not finite: {arr}")
    unit = {"JointModelFreeFlyer": slice(3, 7), "JointModelSpherical": slice(0, 4),
            "JointModelPlanar": slice(2, 4)}.get(short)  # fmt: skip
    if short in _CIRCLE:
        unit = slice(0, 2)
    if unit is not None:
        norm = float(np.linalg.norm(arr[unit]))
        if abs(norm - 1.0) > 1e-9:
            raise InvalidInputError(
                f"locked joint '{name}' ({short}): the quaternion or (cos, sin) pair must "
                f"have unit norm, got norm {norm:.6g}"
            )
        return arr
    lo = np.asarray(model.lowerPositionLimit[joint.idx_q : joint.idx_q + joint.nq])
    hi = np.asarray(model.upperPositionLimit[joint.idx_q : joint.idx_q + joint.nq])
    if short != "JointModelFreeFlyer" and np.any((arr < lo) | (arr > hi)):
        raise InvalidInputError(
            f"locked joint '{name}': value {arr.tolist()} is outside its limits "
            f"[{lo.tolist()}, {hi.tolist()}]"
        )
    return arr


class LockedJointChecker:
    """A :class:`ValidityChecker` on free coordinates: lifts each row and asks the full checker.

    Args:
        checker: the robot's collision checker (full configurations).
        locked: the locked joints.

    Attributes:
        checker: the wrapped checker (certification and the compiled planners use the full
            robot through it).
        locked: the locked joints.
    """

    def __init__(self, checker: CollisionChecker, locked: LockedJoints) -> None:
        self.checker = checker
        self.locked = locked
        self._kernel: Any = None
        self._kernel_key: tuple[Any, ...] = ()

    def native_kernel(self) -> Any:
        """The compiled checker of the free joints, or ``None`` (not built, or not plain).

        A ``CollisionKernel`` on the reduced model and geometry
        (:meth:`LockedJoints.reduced_models`): its configurations are the free coordinates,
        the locked links are held at their values (re-attached to a free ancestor or the
        world) and every collision pair of the robot is kept, so the compiled RRT-Connect
        plans the space directly. Rebuilt when the robot's world, collision pairs or limits
        change (checked at each call, as :meth:`CollisionChecker.native_kernel` does);
        ``None`` when the kernel is not built, the broad phase is off or the free joints are
        not plain vectors (``nq != nv``: a free floating base or continuous joint).
        """
        base = self.checker
        base._sync()
        robot = base.robot
        if not base.options.broadphase or self.locked.free_q.size != self.locked.free_v.size:
            return None
        # what the kernel's copies were made from: the checker's world (rebuilt by
        # _sync on any change: a new world version) and the robot's model and limits
        key = (base._world_version, base._geometry_model, robot._version)
        old = self._kernel_key
        if self._kernel is not None and key[0] == old[0] and key[1] is old[1] and key[2] == old[2]:
            return self._kernel
        from taskspace._native import planning_kernel

        module = planning_kernel()
        if module is None:
            return None
        model, geometry = self.locked.reduced_models(robot._model, robot._collision_model)
        if model.nq != model.nv:  # pragma: no cover - free_q and free_v sizes agree
            return None
        self._kernel = module.CollisionKernel(
            model, model.createData(), geometry, geometry.createData(), NATIVE_PAIR_CACHE
        )
        self._kernel_key = key
        return self._kernel

    @property
    def checks(self) -> int:
        """Configurations evaluated by the wrapped checker."""
        return int(self.checker.checks)

    @checks.setter
    def checks(self, value: int) -> None:
        self.checker.checks = value

    @property
    def robot(self) -> Any:
        """The robot of the wrapped checker."""
        return self.checker.robot

    @property
    def world_version(self) -> int:
        """:attr:`CollisionChecker.world_version` of the wrapped checker."""
        return int(self.checker.world_version)

    def first_invalid(self, configurations: FloatArray) -> int:
        """Index of the first row whose lifted configuration is not free, or -1."""
        return self.checker.first_invalid(self.locked.lift(np.atleast_2d(configurations)))

    def are_valid(self, configurations: FloatArray) -> BoolArray:
        """Validity of every row's lifted configuration."""
        return self.checker.are_valid(self.locked.lift(np.atleast_2d(configurations)))

    def explain(self, q: FloatArray) -> str:
        """Why the lifted configuration of ``q`` is invalid."""
        return self.checker.explain(self.locked.lift(np.asarray(q, dtype=np.float64)))
