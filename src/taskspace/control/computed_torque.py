"""Joint-space computed-torque (inverse-dynamics) tracking control (slides 5:28-5:30).

``q''* = q''_ref + Kp (q_ref - q) + Kd (q'_ref - q')``  (slide 5:30)

``u = M(q) q''* + C(q, q') q' + G(q) = NE(q, q', q''*)``  (slide 5:29, via ``pin.rnea``)

With an exact model every joint error then obeys ``e'' + Kd e' + Kp e = 0``: "all joints
behave exactly like a 1D point particle around the reference trajectory" (unit mass; the
gains can be given as wavelength and damping ratio, slide 5:14). Fixed-base robots only: a
floating base is not actuated (use the inverse-dynamics QP for humanoids and quadrupeds).

Thread safety: the controllers keep their gains and reference fixed after construction and evaluate
each call in one Pinocchio call on their own data, whose result is copied out (the bindings hold
the GIL during the call), so one controller may be called from several threads, with a reference
that is itself safe to share (those of :mod:`taskspace.control.reference` are). Do not reassign
``kp``, ``kd`` or ``reference`` while other threads call it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_vector,
    check_finite,
    check_positive,
)
from taskspace.control.reference import ConstantReference, JointReference, ReferencePoint
from taskspace.errors import InvalidInputError, ShapeError

if TYPE_CHECKING:
    from taskspace.model.robot import Robot


def _gain(value: Any, n: int, name: str) -> FloatArray:
    arr = as_float_array(value, name)  # "x" / complex: bare ValueError / TypeError before
    if arr.ndim == 0:
        check_positive(float(arr), name, strict=False)
        return np.full(n, float(arr))
    arr = as_vector(arr, n, name)
    if np.any(arr < 0):
        raise InvalidInputError(f"{name} must be >= 0, got {value!r}")
    return arr


def _as_arrays(model: pin.Model, q: Any, v: Any) -> tuple[FloatArray, FloatArray] | None:
    """``q`` and ``v`` as float64 arrays after a failed call, ``None`` if they were already.

    Raises the error naming a bad ``q`` or ``v``; lists (Boost's bare ArgumentError before)
    come back as arrays for one more try.
    """
    qa = as_vector(q, model.nq, "q")
    va = as_vector(v, model.nv, "v")
    return None if qa is q and va is v else (qa, va)


def _diagnose(model: pin.Model, q: Any, v: Any) -> None:
    """Raise the taskspace error naming a bad ``q`` or ``v``.

    Called only after a failure or a non-finite (or complex) torque, so the common path pays
    nothing: NaN gave NaN torques, text a bare Boost error, complex v complex torques.
    """
    as_vector(q, model.nq, "q")
    as_vector(v, model.nv, "v")


def _finite_torque(model: pin.Model, tau: FloatArray, q: Any, v: Any) -> FloatArray:
    if tau.dtype != np.float64 or (
        not math.isfinite(float(np.vdot(tau, tau))) and not np.isfinite(tau).all()
    ):
        _diagnose(model, q, v)
        check_finite(tau, "torque (from finite q, v: overflow of gains or reference)")
    return tau


def _joint_reference(robot: Robot, reference: Any) -> JointReference:
    """A callable reference as given, or a fixed target configuration checked as one.

    The target is held with a zero velocity and acceleration of size ``nv``: a robot with a
    continuous joint (``(cos, sin)``) has ``nv < nq`` (sizes ``nq`` raised numpy's bare
    broadcast error at every call), and its unit complex numbers must be normalized.
    """
    if callable(reference):
        return reference  # type: ignore[no-any-return]
    try:
        q = robot.check_configuration(reference, "reference")
    except InvalidInputError as exc:
        raise InvalidInputError(
            "reference must be callable as reference(t) -> ReferencePoint or a target "
            f"configuration of size nq = {robot.nq}: {exc}"
        ) from exc
    return ConstantReference(q, velocity_size=robot.nv)


def _reference_at(reference: JointReference, t: float, nq: int, nv: int) -> ReferencePoint:
    """``reference(t)``, its ``q`` of size ``nq`` and ``v``, ``a`` of size ``nv``.

    Raises:
        ShapeError: a wrong size (``v`` or ``a`` of size ``nq`` on a robot with continuous
            joints raised numpy's bare broadcast error).
        InvalidInputError: not a :class:`ReferencePoint`-like ``(q, v, a)``, or not finite.
    """
    ref = reference(t)
    try:
        if ref.q.shape == (nq,) and ref.v.shape == (nv,) and ref.a.shape == (nv,):
            return ref
    except AttributeError:
        pass
    if not all(hasattr(ref, name) for name in ("q", "v", "a")):
        raise InvalidInputError(
            f"reference(t) must return a ReferencePoint (q, v, a), got {type(ref).__name__}"
        )
    for name, size in (("q", nq), ("v", nv), ("a", nv)):
        shape = np.shape(getattr(ref, name))
        if shape != (size,):
            raise ShapeError(f"reference(t).{name} at t={t:.6g}", (size,), shape)
    return ReferencePoint(
        as_vector(ref.q, nq, "reference(t).q"),
        as_vector(ref.v, nv, "reference(t).v"),
        as_vector(ref.a, nv, "reference(t).a"),
    )


def _require_fixed_base(robot: Robot, what: str) -> None:
    """Refuse a floating base or passive joints: the controller's torque acts on every joint.

    A passive joint (:attr:`Robot.passive_joints`, effort limit 0) got a torque silently: the
    cart-pole's hinge was "tracked" in simulation by a motor it does not have.
    """
    if robot.is_floating:
        raise InvalidInputError(
            f"{what} needs a fixed-base robot (every joint actuated); '{robot.name}' has a "
            "floating base: use taskspace.control.inverse_dynamics_qp with contacts"
        )
    if robot.passive_joints:
        raise InvalidInputError(
            f"{what} needs every joint actuated; '{robot.name}' has passive joints "
            f"{list(robot.passive_joints)} (effort limit 0): use taskspace.control."
            "inverse_dynamics_qp (unactuated rows), or LQR on linearize(robot, q_eq) (its "
            "inputs are the actuated joints)"
        )


def gains_from_wavelength(wavelength: float, damping_ratio: float) -> tuple[float, float]:
    """Unit-mass gains ``(Kp, Kd) = (1 / lambda^2, 2 xi / lambda)`` of the error dynamics.

    Args:
        wavelength: ``lambda`` [s] (> 0).
        damping_ratio: ``xi`` (>= 0).
    """
    lam = check_positive(wavelength, "wavelength [s]")
    xi = check_positive(damping_ratio, "damping_ratio", strict=False)
    kp, kd = (1.0 / lam) / lam, 2.0 * xi / lam  # lam**2 raised OverflowError / ZeroDivision
    if not (math.isfinite(kp) and math.isfinite(kd) and kp > 0.0):
        raise InvalidInputError(
            f"wavelength {lam!r} s gives gains kp = {kp:g}, kd = {kd:g} outside the floats; "
            "use a wavelength between about 1e-150 and 1e150 s"
        )
    return kp, kd


class ComputedTorqueController:
    """``u = NE(q, q', q''_ref + Kp (q_ref - q) + Kd (q'_ref - q'))`` (slides 5:29-5:30).

    Args:
        robot: a fixed-base robot (the model used for the inverse dynamics).
        reference: ``reference(t) -> ReferencePoint`` (``q`` of size nq, ``v`` and ``a`` of
            size nv) or a fixed target configuration (nq).
        kp: stiffness of the error dynamics, scalar or per joint [1/s^2].
        kd: damping of the error dynamics, scalar or per joint [1/s]; default
            ``2 sqrt(kp)`` (critical damping).

    Raises:
        InvalidInputError: floating-base robot, negative gains, bad reference.
    """

    def __init__(self, robot: Robot, reference: Any, kp: Any = 100.0, kd: Any = None) -> None:
        _require_fixed_base(robot, "computed-torque control")
        self.robot = robot
        nv = robot.nv
        self.reference: JointReference = _joint_reference(robot, reference)
        self.kp = _gain(kp, nv, "kp [1/s^2]")
        self.kd = 2.0 * np.sqrt(self.kp) if kd is None else _gain(kd, nv, "kd [1/s]")
        self._model = robot._model
        self._data = robot._model.createData()
        self._nq, self._nv = robot.nq, nv

    @staticmethod
    def from_wavelength(
        robot: Robot, reference: Any, wavelength: float, damping_ratio: float = 1.0
    ) -> ComputedTorqueController:
        """Gains ``Kp = 1/lambda^2``, ``Kd = 2 xi/lambda`` for the unit-mass error (slide 5:14)."""
        kp, kd = gains_from_wavelength(wavelength, damping_ratio)
        return ComputedTorqueController(robot, reference, kp, kd)

    def desired_acceleration(self, t: float, q: FloatArray, v: FloatArray) -> FloatArray:
        """``q''* = q''_ref + Kp (q_ref (-) q) + Kd (q'_ref - q')`` [rad/s^2] (slide 5:30).

        Raises:
            ShapeError, NotFiniteError, InvalidInputError: ``q``, ``v`` of the wrong size,
                not finite or not numbers (NaN gave NaN torques, text a bare Boost error).
        """
        try:
            out = self._desired_acceleration(t, q, v)
        except (TypeError, ValueError, RuntimeError):  # Boost ArgumentError is a TypeError
            arrays = _as_arrays(self._model, q, v)
            if arrays is None:
                raise
            return self.desired_acceleration(t, *arrays)
        return _finite_torque(self._model, out, q, v)

    def _desired_acceleration(self, t: float, q: FloatArray, v: FloatArray) -> FloatArray:
        ref = _reference_at(self.reference, t, self._nq, self._nv)
        error = pin.difference(self._model, q, ref.q)
        return ref.a + self.kp * error + self.kd * (ref.v - v)

    def __call__(self, t: float, q: FloatArray, v: FloatArray) -> FloatArray:
        """Torques ``u = M q''* + C q' + G`` [N m] at time ``t`` [s]."""
        try:
            a_star = self._desired_acceleration(t, q, v)
            tau = np.asarray(pin.rnea(self._model, self._data, q, v, a_star))
        except (TypeError, ValueError, RuntimeError):
            arrays = _as_arrays(self._model, q, v)
            if arrays is None:
                raise
            return self(t, *arrays)
        return _finite_torque(self._model, tau, q, v)


class JointPDController:
    """Naive independent-joint PD, optionally with gravity compensation (slide 5:27).

    ``u = Kp (q_ref - q) + Kd (q'_ref - q') [+ G(q)]``: each joint is treated as a separate
    point mass and the dynamic coupling between joints is ignored ("poor solution: apply
    very high gains separately in each joint").

    Args:
        robot: a fixed-base robot.
        reference: ``reference(t) -> ReferencePoint`` (``q`` of size nq, ``v`` and ``a`` of
            size nv) or a fixed target configuration (nq).
        kp: joint stiffness, scalar or per joint [N m/rad].
        kd: joint damping, scalar or per joint [N m s/rad]; default ``2 sqrt(kp)``.
        gravity_compensation: add ``G(q) = NE(q, 0, 0)``.
    """

    def __init__(
        self,
        robot: Robot,
        reference: Any,
        kp: Any = 100.0,
        kd: Any = None,
        *,
        gravity_compensation: bool = True,
    ) -> None:
        _require_fixed_base(robot, "joint PD control")
        self.robot = robot
        nv = robot.nv
        self.reference: JointReference = _joint_reference(robot, reference)
        self.kp = _gain(kp, nv, "kp [N m/rad]")
        self.kd = 2.0 * np.sqrt(self.kp) if kd is None else _gain(kd, nv, "kd [N m s/rad]")
        self.gravity_compensation = bool(gravity_compensation)
        self._model = robot._model
        self._data = robot._model.createData()
        self._nq, self._nv = robot.nq, nv

    def __call__(self, t: float, q: FloatArray, v: FloatArray) -> FloatArray:
        """Torques [N m] at time ``t`` [s] (``q``, ``v`` checked as by the computed torque)."""
        try:
            ref = _reference_at(self.reference, t, self._nq, self._nv)
            tau = self.kp * pin.difference(self._model, q, ref.q) + self.kd * (ref.v - v)
            if self.gravity_compensation:
                tau = tau + np.asarray(pin.computeGeneralizedGravity(self._model, self._data, q))
        except (TypeError, ValueError, RuntimeError):
            arrays = _as_arrays(self._model, q, v)
            if arrays is None:
                raise
            return self(t, *arrays)
        return _finite_torque(self._model, np.asarray(tau), q, v)


def tracking_error(
    times: Any, q: Any, reference: JointReference, robot: Robot | None = None
) -> FloatArray:
    """Joint-space tracking error ``|q_ref(t_k) (-) q_k|_inf`` per sample [rad, m].

    ``(-)`` is Pinocchio's ``difference`` (the tangent-space error, ``nv`` entries), as the
    controllers' own error: a continuous joint's error is its angle difference, not the
    difference of its ``(cos, sin)`` entries, and a floating base's is its twist, not the
    difference of its quaternions.

    Args:
        times: sample times (K,) [s].
        q: configurations (K, nq), one row per time.
        reference: the joint reference tracked.
        robot: the robot whose configurations ``q`` are; needed when its configuration and
            velocity sizes differ (continuous joints, a floating base). ``None``: the entries
            of ``q`` are compared directly (vector joints only).

    Raises:
        InvalidInputError: ``q`` has not one row per time, or the reference's position and
            velocity sizes differ (configuration entries that are not coordinates) and no
            ``robot`` is given.
    """
    ts = np.asarray(times, dtype=float)
    qs = np.asarray(q, dtype=float)
    if qs.ndim != 2 or qs.shape[0] != ts.size:
        raise InvalidInputError(f"q must have one row per time ({ts.size}), got shape {qs.shape}")
    if robot is not None and qs.shape[1] != robot.nq:
        raise InvalidInputError(
            f"q must have {robot.nq} columns (robot {robot.name!r}'s nq), got shape {qs.shape}"
        )
    out = np.empty(ts.size)
    for k, t in enumerate(ts):
        ref = reference(float(t))
        if robot is not None:
            err = pin.difference(robot.model, qs[k], as_vector(ref.q, robot.nq, "reference q"))
        elif ref.v.size != ref.q.size:
            raise InvalidInputError(
                f"the reference has {ref.q.size} position but {ref.v.size} velocity entries "
                "(continuous joints or a floating base): pass robot= so that the error is "
                "Pinocchio's difference, not a difference of (cos, sin) or quaternion entries"
            )
        else:
            err = ref.q - qs[k]
        out[k] = float(np.max(np.abs(err))) if np.size(err) else 0.0
    return out
