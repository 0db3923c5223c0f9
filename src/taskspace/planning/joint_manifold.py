"""The configuration manifold of a robot with any joint type, for sampling-based planning.

A Pinocchio configuration ``q`` (size ``nq``) is a point of a product of Lie groups, one per
joint: ``R`` for revolute and prismatic joints, the circle ``S^1`` for continuous (unbounded
revolute) joints stored as ``(cos theta, sin theta)``, ``SE(2)`` for planar joints
``(x, y, cos theta, sin theta)``, ``SO(3)`` for spherical joints (a unit quaternion) and
``SE(3)`` for a floating base (position and unit quaternion ``x, y, z, w``). Planning on it
uses Pinocchio's own operations:

* difference ``q1 (-) q0 = log(q0^-1 q1)`` (``pinocchio.difference``, size ``nv``): the joint
  motion from ``q0`` to ``q1``, the short way round for continuous joints;
* metric ``d(q0, q1) = |W (q1 (-) q0)|`` with per-velocity-coordinate weights ``W = diag(w)``
  (e.g. metres against radians of a floating base); it is symmetric because
  ``log(g^-1) = -log(g)``;
* interpolation ``q(t) = q0 (+) t (q1 (-) q0)`` (``pinocchio.integrate`` of ``t
  pinocchio.difference``, :func:`~taskspace.model.robot.interpolate_configurations`), the
  geodesic of each joint's group (a screw motion for a floating base), whose length in the
  metric is ``t d(q0, q1)``;
* uniform sampling: bounded coordinates uniform within their limits, angles of continuous and
  planar joints uniform on the circle, rotations uniform on SO(3) (a normalized Gaussian
  quaternion), the translation of a planar or floating base uniform in a box given by the user.

:meth:`JointManifold.difference` is vectorized over rows in NumPy (closed-form logarithms of
SO(2), SE(2), SO(3) and SE(3)) and agrees with ``pinocchio.difference``; interpolation is
the robot's own (:meth:`~taskspace.model.Robot.interpolate`), which equals
``pinocchio.interpolate`` except where Pinocchio's is wrong (opposite angles of a continuous
joint, unit complexes not normalized to rounding).

Thread safety: a :class:`JointManifold` only reads its limits, which it derives again (in the
calling thread) after :meth:`~taskspace.model.Robot.set_limits`; threads may share one, each
sampling with its own generator, as long as the robot's limits are not changed while they use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace._validation import as_vector
from taskspace.errors import InvalidInputError, StaleModelError
from taskspace.model.robot import Robot, interpolate_configurations
from taskspace.model.versioning import ModelFollower

FloatArray = npt.NDArray[np.float64]

_SCALAR = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelPX", "JointModelPY",
           "JointModelPZ", "JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned",
           "JointModelHX", "JointModelHY", "JointModelHZ", "JointModelHelicalUnaligned",
           "JointModelTranslation", "JointModelSphericalZYX")  # fmt: skip
_CIRCLE = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ",
           "JointModelRevoluteUnboundedUnaligned")  # fmt: skip
_KINDS = ("vector", "circle", "planar", "spherical", "free_flyer")


@dataclass(frozen=True)
class JointBlock:
    """One joint's coordinates: kind, ``q`` slice start/size, ``v`` slice start/size, name."""

    kind: str
    idx_q: int
    nq: int
    idx_v: int
    nv: int
    name: str


def _quat_mul(a: FloatArray, b: FloatArray) -> FloatArray:
    """Hamilton product of quaternions stored ``(x, y, z, w)``, rows."""
    ax, ay, az, aw = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bx, by, bz, bw = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=1,
    )


def _quat_log(q0: FloatArray, q1: FloatArray) -> FloatArray:
    """``log3(R0^T R1)`` from unit quaternions (rows, ``x y z w``): rotation vectors (n, 3)."""
    conj = q0 * np.array([-1.0, -1.0, -1.0, 1.0])
    rel = _quat_mul(conj, q1)
    rel = np.where(rel[:, 3:4] < 0, -rel, rel)  # the short way: theta in [0, pi]
    vec = rel[:, :3]
    s = np.linalg.norm(vec, axis=1)
    theta = 2.0 * np.arctan2(s, rel[:, 3])
    scale = np.where(s > 1e-12, theta / np.maximum(s, 1e-300), 2.0)  # theta / sin(theta/2)
    return np.asarray(vec * scale[:, None], dtype=np.float64)


def _quat_rotate_inverse(q: FloatArray, p: FloatArray) -> FloatArray:
    """``R(q)^T p`` for rows."""
    u = -q[:, :3]
    w = q[:, 3:4]
    t = 2.0 * np.cross(u, p)
    return np.asarray(p + w * t + np.cross(u, t), dtype=np.float64)


def _se3_v_inverse(omega: FloatArray, p: FloatArray) -> FloatArray:
    """``V(omega)^-1 p`` (the translation part of log6), rows."""
    theta = np.linalg.norm(omega, axis=1)
    small = theta < 1e-6
    th = np.where(small, 1.0, theta)
    alpha = np.where(
        small,
        1.0 / 12.0 + theta**2 / 720.0,
        (1.0 - th * np.sin(th) / (2.0 * (1.0 - np.cos(th)))) / th**2,
    )
    wxp = np.cross(omega, p)
    return np.asarray(p - 0.5 * wxp + alpha[:, None] * np.cross(omega, wxp), dtype=np.float64)


class JointManifold:
    """Vectorized Lie-group operations on a Pinocchio model's configurations.

    Args:
        model: the robot (its limits are followed: after :meth:`Robot.set_limits` the bounds
            and samples use the new ones), or a bare Pinocchio model (its limits are copied
            now; a Pinocchio model has no version, so a later change of its limits makes
            :meth:`sample`, :attr:`lower` and :attr:`upper` raise
            :class:`~taskspace.errors.StaleModelError`).
        weights: per-velocity-coordinate metric weights ``w > 0`` (size ``nv``; default 1).
        base_lower: lower corner of the translation box of a planar (x, y) or floating
            (x, y, z) root joint [m]; required when the model has one.
        base_upper: upper corner of that box [m].

    Raises:
        InvalidInputError: a joint type that cannot be planned on (composite, mimic), a
            planar or floating joint without its translation box, bad weights.
    """

    def __init__(
        self,
        model: pin.Model | Robot,
        *,
        weights: Any = None,
        base_lower: Any = None,
        base_upper: Any = None,
    ) -> None:
        robot = model if isinstance(model, Robot) else None
        model = model._model if isinstance(model, Robot) else model
        self._model = model  # a robot's own model: never handed out (see ``model``)
        self._robot = robot
        self.nq, self.nv = int(model.nq), int(model.nv)
        blocks = []
        for j in range(1, model.njoints):
            joint = model.joints[j]
            short = joint.shortname()
            name = str(model.names[j])
            if short in _SCALAR:
                kind = "vector"
            elif short in _CIRCLE:
                kind = "circle"
            elif short == "JointModelPlanar":
                kind = "planar"
            elif short == "JointModelSpherical":
                kind = "spherical"
            elif short == "JointModelFreeFlyer":
                kind = "free_flyer"
            else:
                raise InvalidInputError(
                    f"joint '{name}' of type {short} cannot be planned on; supported: "
                    f"{', '.join(_SCALAR + _CIRCLE)}, JointModelPlanar, JointModelSpherical, "
                    "JointModelFreeFlyer (lock it: ConfigurationSpace.from_robot(..., "
                    "locked_joints={name: value}))"
                )
            blocks.append(JointBlock(kind, joint.idx_q, joint.nq, joint.idx_v, joint.nv, name))
        self.blocks = tuple(blocks)
        w = np.ones(self.nv) if weights is None else as_vector(weights, self.nv, "weights")
        if np.any(w <= 0):
            raise InvalidInputError(f"weights must all be > 0, got {w.tolist()}")
        self.weights = w
        based = [b for b in self.blocks if b.kind in ("planar", "free_flyer")]
        self._base: tuple[FloatArray, FloatArray] | None = None
        if based:
            if base_lower is None or base_upper is None:
                names = ", ".join(f"'{b.name}'" for b in based)
                raise InvalidInputError(
                    f"joint {names} moves the base: give its translation box "
                    "base_lower/base_upper [m] (x, y for a planar joint, x, y, z for a "
                    "floating base) so that it can be sampled"
                )
            n_t = 2 if based[0].kind == "planar" else 3
            lo = as_vector(base_lower, n_t, "base_lower")
            hi = as_vector(base_upper, n_t, "base_upper")
            if np.any(hi <= lo):
                raise InvalidInputError("base_upper must be > base_lower in every coordinate")
            self._base = (lo, hi)
        elif base_lower is not None or base_upper is not None:
            raise InvalidInputError(
                "base_lower/base_upper bound a planar or floating base's translation, but the "
                "model has no JointModelPlanar or JointModelFreeFlyer joint (a fixed-base "
                "model; give the base joint when building the model to plan for a mobile base)"
            )
        self.is_euclidean = all(b.kind == "vector" for b in self.blocks)
        self._unit = [b for b in self.blocks if b.kind != "vector"]
        # difference() in a few array operations: the vector joints' coordinates (nq = nv)
        # and the continuous joints' (cos, sin) pairs gathered once
        vec = [b for b in self.blocks if b.kind == "vector"]
        circ = [b for b in self.blocks if b.kind == "circle"]
        self._vec_q = np.array([b.idx_q + k for b in vec for k in range(b.nq)], dtype=np.int64)
        self._vec_v = np.array([b.idx_v + k for b in vec for k in range(b.nv)], dtype=np.int64)
        self._circ_q = np.array([b.idx_q for b in circ], dtype=np.int64)
        self._circ_v = np.array([b.idx_v for b in circ], dtype=np.int64)
        self._lie = [b for b in self.blocks if b.kind not in ("vector", "circle")]
        self._snapshot: tuple[FloatArray, FloatArray] | None = None
        self._follower = (
            None if robot is None else ModelFollower(robot, "JointManifold", self._derive)
        )
        if robot is None:
            self._derive()

    def _derive(self) -> None:
        """The sampling box from the model's current limits (again after set_limits)."""
        model = self._model
        model_lower = np.array(model.lowerPositionLimit, dtype=np.float64)
        model_upper = np.array(model.upperPositionLimit, dtype=np.float64)
        lower, upper = model_lower.copy(), model_upper.copy()
        for b in self.blocks:
            if b.kind in ("circle", "spherical"):
                lower[b.idx_q : b.idx_q + b.nq] = -1.0
                upper[b.idx_q : b.idx_q + b.nq] = 1.0
            elif b.kind in ("planar", "free_flyer"):
                assert self._base is not None
                n_t = 2 if b.kind == "planar" else 3
                lower[b.idx_q : b.idx_q + n_t], upper[b.idx_q : b.idx_q + n_t] = self._base
                lower[b.idx_q + n_t : b.idx_q + b.nq] = -1.0
                upper[b.idx_q + n_t : b.idx_q + b.nq] = 1.0
            else:
                sl = slice(b.idx_q, b.idx_q + b.nq)
                with np.errstate(over="ignore", invalid="ignore"):
                    span = upper[sl] - lower[sl]
                # (a range that overflows: Pinocchio's default limits of a joint added to a
                # bare model are -+1.8e308, and sampling them raised numpy's OverflowError)
                if not np.all(np.isfinite(span)):
                    raise InvalidInputError(
                        f"joint '{b.name}' has no finite position limits (lower = "
                        f"{lower[sl].tolist()}, upper = {upper[sl].tolist()}: their range "
                        "overflows a float; Pinocchio's default for a joint added to a bare "
                        "model); give the model limits (Robot.set_limits, or "
                        "model.lowerPositionLimit / upperPositionLimit of a bare model) to "
                        "plan with it"
                    )
                if not np.all(upper[sl] > lower[sl]):
                    # URDF's default range [0, 0] ("no limit" for the robot: its random
                    # configurations cover the circle) has no box to sample for the planner
                    raise InvalidInputError(
                        f"joint '{b.name}' has no position range (lower = {lower[sl].tolist()}, "
                        f"upper = {upper[sl].tolist()}: a description without limits; the "
                        "robot treats it as unbounded); give it limits (Robot.set_limits) or "
                        "lock it (locked_joints=...) to plan with it"
                    )
        lower.flags.writeable = False
        upper.flags.writeable = False
        self._lower, self._upper = lower, upper
        self._snapshot = (model_lower, model_upper)

    def _sync(self) -> None:
        """Follow the robot's version, or refuse a bare model whose limits changed."""
        if self._follower is not None:
            self._follower.sync()
            return
        assert self._snapshot is not None
        lo, hi = self._snapshot
        model = self._model
        if not (
            np.array_equal(lo, model.lowerPositionLimit)
            and np.array_equal(hi, model.upperPositionLimit)
        ):
            raise StaleModelError(
                "JointManifold was built from a bare Pinocchio model whose position limits "
                "have changed since; build JointManifold(robot) to follow Robot.set_limits, "
                "or a new JointManifold(model)",
                0,
                0,
            )

    @property
    def lower(self) -> FloatArray:
        """Lower corner of the sampling box (size nq, read-only) [rad or m].

        The joints' limits, -1 for unit-norm parts, ``base_lower`` for a base's translation.
        """
        self._sync()
        return self._lower

    @property
    def upper(self) -> FloatArray:
        """Upper corner of the sampling box (size nq, read-only) [rad or m]."""
        self._sync()
        return self._upper

    @property
    def model(self) -> pin.Model:
        """The Pinocchio model: ``robot.model`` (the robot's read-only copy) for a robot.

        Edit a robot through :meth:`Robot.edit_model`; the manifold follows its version.
        """
        return self._model if self._robot is None else self._robot.model

    @property
    def model_version(self) -> int | None:
        """The robot version the bounds are for (``None`` for a bare Pinocchio model)."""
        if self._follower is None:
            return None
        self._follower.sync()
        return self._follower.version

    # ------------------------------------------------------------------ operations
    def difference(self, q0: Any, q1: Any) -> FloatArray:
        """``q1 (-) q0`` row by row (``pinocchio.difference``), shape (n, nv).

        A (cos, sin) pair or quaternion off the unit circle or sphere is read as its
        direction, as Pinocchio does (the base's rotation scaled the translation part).
        """
        a, b = np.broadcast_arrays(np.atleast_2d(q0), np.atleast_2d(q1))
        out = np.empty((a.shape[0], self.nv))
        if self._vec_q.size:
            out[:, self._vec_v] = b[:, self._vec_q] - a[:, self._vec_q]
        if self._circ_q.size:
            c = self._circ_q
            out[:, self._circ_v] = _angle(a[:, c], a[:, c + 1], b[:, c], b[:, c + 1])
        for blk in self._lie:
            qa = a[:, blk.idx_q : blk.idx_q + blk.nq]
            qb = b[:, blk.idx_q : blk.idx_q + blk.nq]
            v = slice(blk.idx_v, blk.idx_v + blk.nv)
            if blk.kind == "planar":
                th = _angle(qa[:, 2], qa[:, 3], qb[:, 2], qb[:, 3])
                norm = np.hypot(qa[:, 2], qa[:, 3])
                c, s = qa[:, 2] / norm, qa[:, 3] / norm
                dx, dy = qb[:, 0] - qa[:, 0], qb[:, 1] - qa[:, 1]
                lx, ly = c * dx + s * dy, -s * dx + c * dy  # R0^T dp
                small = np.abs(th) < 1e-9
                t = np.where(small, 1.0, th)
                A = np.where(small, 1.0 - th**2 / 6.0, np.sin(t) / t)
                B = np.where(small, th / 2.0, (1.0 - np.cos(t)) / t)
                det = A * A + B * B
                out[:, v] = np.stack([(A * lx + B * ly) / det, (-B * lx + A * ly) / det, th], 1)
            elif blk.kind == "spherical":
                out[:, v] = _quat_log(qa, qb)
            else:  # free flyer: log6(M0^-1 M1) = (v, omega)
                omega = _quat_log(qa[:, 3:], qb[:, 3:])
                unit = qa[:, 3:] / np.linalg.norm(qa[:, 3:], axis=1)[:, None]
                p = _quat_rotate_inverse(unit, qb[:, :3] - qa[:, :3])
                out[:, blk.idx_v : blk.idx_v + 3] = _se3_v_inverse(omega, p)
                out[:, blk.idx_v + 3 : blk.idx_v + 6] = omega
        return out

    def distances(self, q0: Any, q1: Any) -> FloatArray:
        """``d(q0_i, q1_i) = |W (q1_i (-) q0_i)|`` row by row, shape (n,)."""
        diff = self.difference(q0, q1) * self.weights
        return np.sqrt(np.einsum("ij,ij->i", diff, diff))

    def interpolate(self, q0: FloatArray, q1: FloatArray, t: Any) -> FloatArray:
        """``q0 (+) t_k (q1 (-) q0)`` for each ``t_k``, shape (len(t), nq).

        :func:`~taskspace.model.robot.interpolate_configurations`, as
        :meth:`Robot.interpolate <taskspace.model.Robot.interpolate>` (``q0 + t (q1 - q0)``,
        the same arithmetic, when every joint is a vector joint).
        """
        ts = np.atleast_1d(np.asarray(t, dtype=np.float64))
        if self.is_euclidean:
            return np.asarray(q0 + ts[:, None] * (q1 - q0), dtype=np.float64)
        return interpolate_configurations(self._model, q0, q1, ts, (self._circ_q, self._circ_v))

    def sample(self, rng: np.random.Generator, n: int) -> FloatArray:
        """``n`` uniform samples (see the module docstring), shape (n, nq)."""
        self._sync()
        q = rng.uniform(self._lower, self._upper, size=(n, self.nq))
        for blk in self._unit:
            i = blk.idx_q
            if blk.kind in ("circle", "planar"):
                k = i if blk.kind == "circle" else i + 2
                th = rng.uniform(-math.pi, math.pi, n)
                q[:, k], q[:, k + 1] = np.cos(th), np.sin(th)
            else:
                k = i if blk.kind == "spherical" else i + 3
                quat = rng.standard_normal((n, 4))
                q[:, k : k + 4] = quat / np.linalg.norm(quat, axis=1)[:, None]
        return q

    def unit_error(self, q: FloatArray) -> float:
        """Largest ``| |u| - 1 |`` over the unit-norm parts of ``q`` (0 for a vector space)."""
        worst = 0.0
        for blk in self._unit:
            i = blk.idx_q
            sl = {
                "circle": slice(i, i + 2),
                "planar": slice(i + 2, i + 4),
                "spherical": slice(i, i + 4),
                "free_flyer": slice(i + 3, i + 7),
            }[blk.kind]
            worst = max(worst, abs(float(np.linalg.norm(q[sl])) - 1.0))
        return worst

    def bounded_mask(self) -> npt.NDArray[np.bool_]:
        """Coordinates of ``q`` that carry box bounds (False for unit-norm parts)."""
        mask = np.ones(self.nq, dtype=bool)
        for blk in self._unit:
            i = blk.idx_q
            start = {"circle": i, "planar": i + 2, "spherical": i, "free_flyer": i + 3}[blk.kind]
            mask[start : i + blk.nq] = False
        return mask


def _angle(c0: FloatArray, s0: FloatArray, c1: FloatArray, s1: FloatArray) -> FloatArray:
    """Signed angle from ``(c0, s0)`` to ``(c1, s1)`` in (-pi, pi]."""
    return np.asarray(np.arctan2(c0 * s1 - s0 * c1, c0 * c1 + s0 * s1), dtype=np.float64)
