"""The passive dynamic walker with knees: a hybrid model of walking down a slope.

McGeer's kneed walker (McGeer 1990, "Passive walking with knees") in the point-foot form of
Hsu Chen's thesis (V. F. Hsu Chen, "Passive dynamic walking with knees: a point foot model",
MIT 2007, ch. 3, used by Tedrake's *Underactuated Robotics* notes). Each leg is a thigh of
length ``l_t = a2 + b2`` (hip to knee, point mass ``m_t`` at ``b2`` below the hip) and a shank of
length ``l_s = a1 + b1`` (knee to foot, point mass ``m_s`` at ``b1`` below the knee, ``a1`` above
the foot); the hip carries ``m_H``; ``L = l_t + l_s``.

Coordinates as in :mod:`~taskspace.locomotion.compass_gait`: ``x`` forward and downhill
(horizontal), ``y`` up, the stance foot at the origin. Absolute angles from the vertical:
``theta_st`` of the stance leg (hip at ``L (sin, cos)(theta_st)``), ``theta_th`` of the swing
thigh (knee at ``hip + l_t (sin, -cos)(theta_th)``), ``theta_sh`` of the swing shank (foot at
``knee + l_s (sin, -cos)(theta_sh)``). The state is always the 6-vector
``x = (theta_st, theta_th, theta_sh, dtheta_st, dtheta_th, dtheta_sh)``; Hsu Chen's angles
are ``(q1, q2, q3) = (-theta_st, theta_th, theta_sh)``. The stance knee is locked throughout;
:meth:`KneedWalker.knee_lock_torques` tells whether a stop suffices or a latch is needed.

The equations of motion come from Pinocchio models of the walker (revolute joints about ``z``,
point-mass bodies): the 3-DOF chain stance leg - hip - swing thigh - knee - swing shank for the
unlocked phase, the 2-DOF chain with a straight swing leg for the locked phase; ABA gives

    M(q) qdd + c(q, qd) + dV/dq = 0

in Pinocchio's relative joint angles ``phi = T^-1 theta`` (``theta = T phi``).

One step, starting just after heel strike with both knees straight:

1. unlocked swing (3 DOF) until the swing knee reaches full extension,
   ``theta_sh - theta_th = 0`` from below (knee strike);
2. knee strike: the knee locks in a plastic impact, the generalized momentum jump
   ``M (qd+ - qd-) = J_k^T lambda`` with ``J_k qd+ = 0`` (``J_k``: the knee's relative rate),
   which conserves the angular momentum of the whole walker about the stance foot and of the
   swing leg about the hip;
3. locked swing (2 DOF, a compass gait with two masses per leg) until heel strike,
   ``theta_st - theta_sw - 2 gamma = 0`` with the swing foot ahead;
4. heel strike: a plastic impact at the swing foot on the 4-DOF floating model (stance foot
   free in the plane, knees locked), ``M (v+ - v-) = J_f^T lambda`` with ``J_f v+ = 0``
   (``J_f``: the swing foot's linear velocity), which conserves the angular momentum of the
   whole walker about the new stance foot and of the trailing leg about the hip (Hsu Chen's
   eq. 3.5); the legs swap roles and the new swing leg leaves the impact straight,
   ``dtheta_sh+ = dtheta_th+``.

Both impacts are solved by :func:`pinocchio.impulseDynamics`. Energy is conserved in each
continuous phase; each impact loses ``1/2 (qd+ - qd-)^T M (qd+ - qd-)`` (Carnot).
The swing foot touching the slope before the knee locks ends the step as a failure (the model
has no contact there); with the knee locked, only heel strike ahead of the stance foot counts.

Thread safety: a :class:`KneedWalker` is immutable and its Pinocchio data are per thread (see
there), so one walker may be evaluated and simulated from several threads;
:class:`KneedStepResult` is immutable.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

from taskspace._validation import FloatArray, as_vector, check_count, check_positive
from taskspace.errors import InvalidInputError, SolverError
from taskspace.locomotion.compass_gait import (
    LimitCycle,
    LimitCycleOptions,
    _newton_limit_cycle,
    check_walker_scales,
)

POINTS = (
    "stance_shank_mass",
    "stance_thigh_mass",
    "hip",
    "swing_thigh_mass",
    "knee",
    "swing_shank_mass",
    "swing_foot",
)
"""Names of the points returned by :meth:`KneedWalker.positions`."""

# theta = T phi: absolute angles from Pinocchio's relative joint angles (stance joint turns
# counterclockwise, theta_st clockwise)
_T3 = np.array([[-1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 1.0, 1.0]])
_T3_INV = np.linalg.inv(_T3)
_T2 = np.array([[-1.0, 0.0], [1.0, 1.0]])
_T2_INV = np.linalg.inv(_T2)


def _point_masses(*masses: tuple[float, float]) -> pin.Inertia:
    """Inertia of point masses ``(m, y)`` on a body's ``y`` axis."""
    inertia = pin.Inertia.Zero()
    for m, y in masses:
        if m > 0.0:
            inertia += pin.Inertia(m, np.array([0.0, y, 0.0]), np.zeros((3, 3)))
    return inertia


def _at(y: float) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array([0.0, y, 0.0]))


@dataclass(frozen=True)
class _Models:
    """The walker's Pinocchio models; their ``pin.Data`` are per thread (made on first use).

    A method evaluates and then reads its data (``framesForwardKinematics`` then ``oMf``,
    ``impulseDynamics`` then ``impulse_c``): with one data shared by threads, another thread's
    evaluation in between gave a silently wrong answer.
    """

    unlocked: pin.Model
    locked: pin.Model
    floating: pin.Model
    frames: dict[str, int]
    floating_foot: int
    jointed: pin.Model
    _local: threading.local = field(default_factory=threading.local, repr=False, compare=False)

    def _data(self, name: str) -> pin.Data:
        data = self._local.__dict__.get(name)
        if data is None:
            data = self._local.__dict__[name] = getattr(self, name).createData()
        return data

    @property
    def unlocked_data(self) -> pin.Data:
        return self._data("unlocked")

    @property
    def locked_data(self) -> pin.Data:
        return self._data("locked")

    @property
    def floating_data(self) -> pin.Data:
        return self._data("floating")

    @property
    def jointed_data(self) -> pin.Data:
        return self._data("jointed")


@dataclass(frozen=True, kw_only=True)
class KneedWalker:
    """Parameters of the kneed walker (defaults: Hsu Chen 2007, Table 3.1).

    Attributes:
        hip_mass: ``m_H`` [kg].
        thigh_mass: ``m_t`` [kg].
        shank_mass: ``m_s`` [kg].
        a1: distance foot - shank mass [m].
        b1: distance shank mass - knee [m].
        a2: distance knee - thigh mass [m].
        b2: distance thigh mass - hip [m].
        slope: ``gamma`` [rad].
        gravity: ``g`` [m/s^2].

    Thread safety: a walker is an immutable set of parameters; its Pinocchio data are per
    thread, so one walker may be evaluated and simulated from several threads at once.
    """

    hip_mass: float = 0.5
    thigh_mass: float = 0.5
    shank_mass: float = 0.05
    a1: float = 0.375
    b1: float = 0.125
    a2: float = 0.175
    b2: float = 0.325
    slope: float = 0.0504
    gravity: float = 9.81

    def __post_init__(self) -> None:
        check_positive(self.hip_mass, "hip_mass", strict=False)
        check_positive(self.thigh_mass, "thigh_mass")
        check_positive(self.shank_mass, "shank_mass")
        for name in ("a1", "b1", "a2", "b2"):
            check_positive(getattr(self, name), name, strict=False)
        if self.b1 <= 0.0 or self.b2 <= 0.0:
            raise InvalidInputError(
                "the swing leg's point masses must sit below their joints: b1 > 0 and b2 > 0, "
                f"got b1 = {self.b1}, b2 = {self.b2}"
            )
        check_positive(self.gravity, "gravity")
        if not np.isfinite(self.slope):
            raise InvalidInputError(f"slope must be finite, got {self.slope!r}")
        names = ("hip_mass", "thigh_mass", "shank_mass", "a1", "b1", "a2", "b2", "gravity")
        check_walker_scales(self, names, self.slope)

    @property
    def thigh_length(self) -> float:
        """``l_t = a2 + b2`` [m]."""
        return self.a2 + self.b2

    @property
    def shank_length(self) -> float:
        """``l_s = a1 + b1`` [m]."""
        return self.a1 + self.b1

    @property
    def leg_length(self) -> float:
        """``L = l_t + l_s`` [m]."""
        return self.thigh_length + self.shank_length

    # ----------------------------------------------------------------- Pinocchio models
    @cached_property
    def models(self) -> _Models:
        """The Pinocchio models: unlocked (3 DOF), locked (2 DOF), floating (4 DOF, locked)."""
        mh, mt, ms = self.hip_mass, self.thigh_mass, self.shank_mass
        ls, lt, L = self.shank_length, self.thigh_length, self.leg_length
        gravity = pin.Motion(np.array([0.0, -self.gravity, 0.0]), np.zeros(3))
        stance_body = _point_masses((ms, self.a1), (mt, ls + self.a2), (mh, L))

        def chain(*, locked: bool, floating: bool) -> pin.Model:
            model = pin.Model()
            model.gravity = gravity
            parent = 0
            if floating:
                parent = model.addJoint(parent, pin.JointModelPX(), pin.SE3.Identity(), "x")
                parent = model.addJoint(parent, pin.JointModelPY(), pin.SE3.Identity(), "y")
            stance = model.addJoint(parent, pin.JointModelRZ(), pin.SE3.Identity(), "stance")
            model.appendBodyToJoint(stance, stance_body, pin.SE3.Identity())
            hip = model.addJoint(stance, pin.JointModelRZ(), _at(L), "hip")
            if locked:
                thigh = _point_masses((mt, -self.b2), (ms, -(lt + self.b1)))
                model.appendBodyToJoint(hip, thigh, pin.SE3.Identity())
                model.addFrame(pin.Frame("swing_foot", hip, _at(-L), pin.FrameType.OP_FRAME))
                return model
            model.appendBodyToJoint(hip, _point_masses((mt, -self.b2)), pin.SE3.Identity())
            knee = model.addJoint(hip, pin.JointModelRZ(), _at(-lt), "knee")
            model.appendBodyToJoint(knee, _point_masses((ms, -self.b1)), pin.SE3.Identity())
            points = {
                "stance_shank_mass": (stance, self.a1),
                "stance_thigh_mass": (stance, ls + self.a2),
                "hip": (hip, 0.0),
                "swing_thigh_mass": (hip, -self.b2),
                "knee": (knee, 0.0),
                "swing_shank_mass": (knee, -self.b1),
                "swing_foot": (knee, -ls),
            }
            for name, (joint, y) in points.items():
                model.addFrame(pin.Frame(name, joint, _at(y), pin.FrameType.OP_FRAME))
            return model

        # the unlocked chain with a stance knee joint too, for the locks' torques (RNEA)
        jointed = pin.Model()
        jointed.gravity = gravity
        foot = jointed.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "stance_foot")
        jointed.appendBodyToJoint(foot, _point_masses((ms, self.a1)), pin.SE3.Identity())
        knee = jointed.addJoint(foot, pin.JointModelRZ(), _at(ls), "stance_knee")
        stance_thigh = _point_masses((mt, self.a2), (mh, lt))
        jointed.appendBodyToJoint(knee, stance_thigh, pin.SE3.Identity())
        hip = jointed.addJoint(knee, pin.JointModelRZ(), _at(lt), "hip")
        jointed.appendBodyToJoint(hip, _point_masses((mt, -self.b2)), pin.SE3.Identity())
        knee = jointed.addJoint(hip, pin.JointModelRZ(), _at(-lt), "swing_knee")
        jointed.appendBodyToJoint(knee, _point_masses((ms, -self.b1)), pin.SE3.Identity())
        unlocked = chain(locked=False, floating=False)
        locked = chain(locked=True, floating=False)
        floating = chain(locked=True, floating=True)
        return _Models(
            unlocked=unlocked,
            locked=locked,
            floating=floating,
            frames={n: unlocked.getFrameId(n) for n in POINTS},
            floating_foot=floating.getFrameId("swing_foot"),
            jointed=jointed,
        )

    # ----------------------------------------------------------------- kinematics
    def positions(self, q: Any) -> dict[str, FloatArray]:
        """World ``(x, y)`` of the point masses, hip, knee and swing foot (stance foot at 0).

        Args:
            q: ``(theta_st, theta_th, theta_sh)`` [rad].
        """
        q = as_vector(q, 3, "q")
        m = self.models
        pin.framesForwardKinematics(m.unlocked, m.unlocked_data, _T3_INV @ q)
        return {n: m.unlocked_data.oMf[f].translation[:2].copy() for n, f in m.frames.items()}

    def mass_matrix(self, q: Any) -> FloatArray:
        """``M(q)`` of the unlocked phase in the absolute angles (``T^-T M_phi T^-1``, CRBA)."""
        q = as_vector(q, 3, "q")
        m = self.models
        M = pin.crba(m.unlocked, m.unlocked_data, _T3_INV @ q)
        M = np.triu(M) + np.triu(M, 1).T
        return np.asarray(_T3_INV.T @ M @ _T3_INV)

    def energy(self, x: Any) -> float:
        """Total mechanical energy ``T + V`` [J] (potential measured from the stance foot)."""
        x = as_vector(x, 6, "x")
        m = self.models
        phi, dphi = _T3_INV @ x[:3], _T3_INV @ x[3:]
        kinetic = pin.computeKineticEnergy(m.unlocked, m.unlocked_data, phi, dphi)
        potential = pin.computePotentialEnergy(m.unlocked, m.unlocked_data, phi)
        return float(kinetic + potential)

    def swing_foot_height(self, x: Any) -> float:
        """Distance of the swing foot above the slope [m] (normal to it; negative below)."""
        st, th, sh = x[0], x[1], x[2]
        lt, ls, L = self.thigh_length, self.shank_length, self.leg_length
        fx = L * np.sin(st) + lt * np.sin(th) + ls * np.sin(sh)
        fy = L * np.cos(st) - lt * np.cos(th) - ls * np.cos(sh)
        return float(fy * np.cos(self.slope) + fx * np.sin(self.slope))

    def knee_flexion(self, x: Any) -> float:
        """``theta_th - theta_sh`` [rad]: positive while the swing knee is bent."""
        return float(x[1] - x[2])

    # ----------------------------------------------------------------- dynamics
    def unlocked_dynamics(self, x: FloatArray) -> FloatArray:
        """``xdot`` of the unlocked phase (3 DOF), state ``x`` of size 6 (ABA)."""
        m = self.models
        ddphi = pin.aba(m.unlocked, m.unlocked_data, _T3_INV @ x[:3], _T3_INV @ x[3:], _ZERO3)
        return np.concatenate((x[3:], _T3 @ ddphi))

    def locked_dynamics(self, x: FloatArray) -> FloatArray:
        """``xdot`` of the locked phase (2 DOF).

        The state is ``(theta_st, theta_sw, dtheta_st, dtheta_sw)``; ``theta_sw`` is the
        straight swing leg's angle (``theta_th = theta_sh``).
        """
        m = self.models
        ddphi = pin.aba(m.locked, m.locked_data, _T2_INV @ x[:2], _T2_INV @ x[2:], _ZERO2)
        return np.concatenate((x[2:], _T2 @ ddphi))

    def heel_strike(self, x: FloatArray) -> float:
        """Guard ``theta_st - theta_sw - 2 gamma`` of the locked phase (zero at heel strike)."""
        return float(x[0] - x[1] - 2.0 * self.slope)

    # ----------------------------------------------------------------- impacts
    def knee_strike_impact(self, x: Any) -> tuple[FloatArray, float]:
        """Knee lock: ``M (qd+ - qd-) = J_k^T lambda``, ``J_k qd+ = 0`` (impulseDynamics).

        Returns:
            The post-impact state (``dtheta_sh+ = dtheta_th+``) and the knee's impulsive
            torque ``lambda`` [N m s].
        """
        x = as_vector(x, 6, "x")
        m = self.models
        J = np.array([[0.0, 0.0, 1.0]])  # the knee's relative rate dphi_3
        dphi = pin.impulseDynamics(
            m.unlocked, m.unlocked_data, _T3_INV @ x[:3], _T3_INV @ x[3:], J, 0.0, 0.0
        )
        qd = _T3 @ dphi
        qd[2] = qd[1]  # J_k qd+ = 0 holds to rounding; make it exact
        return np.concatenate((x[:3], qd)), float(m.unlocked_data.impulse_c[0])

    def heel_strike_impact(self, x: Any) -> tuple[FloatArray, FloatArray]:
        """Heel strike on the floating locked model; the legs swap roles.

        ``M (v+ - v-) = J_f^T lambda`` with ``J_f v+ = 0``, ``v = (xd, yd, dphi_1, dphi_2)``
        (the stance foot free in the plane, at rest before the impact).

        Args:
            x: pre-impact state with the swing knee locked (``theta_sh = theta_th``).

        Returns:
            The post-impact state in the swapped coordinates, and the ground impulse on the
            new stance foot ``(lambda_x, lambda_y)`` [N s].
        """
        x = as_vector(x, 6, "x")
        m = self.models
        phi = np.concatenate((np.zeros(2), _T2_INV @ x[:2]))
        v = np.concatenate((np.zeros(2), _T2_INV @ x[3:5]))
        pin.computeJointJacobians(m.floating, m.floating_data, phi)
        pin.updateFramePlacements(m.floating, m.floating_data)
        J = pin.getFrameJacobian(
            m.floating, m.floating_data, m.floating_foot, pin.LOCAL_WORLD_ALIGNED
        )[:2]
        v_after = pin.impulseDynamics(m.floating, m.floating_data, phi, v, J, 0.0, 0.0)
        omega_old_stance = v_after[2]  # counterclockwise rates of the two legs
        omega_old_swing = v_after[2] + v_after[3]
        st, sw = -x[1], -x[0]
        d_st, d_sw = -omega_old_swing, omega_old_stance
        post = np.array([st, sw, sw, d_st, d_sw, d_sw])
        return post, np.asarray(m.floating_data.impulse_c[:2]).copy()

    def knee_lock_torques(self, x: Any, *, swing_knee_locked: bool) -> FloatArray:
        """Torques the knee locks must supply, by RNEA on a model with a stance knee joint.

        The accelerations are those of the phase (the stance knee, and in the locked phase the
        swing knee, do not move); ``tau = RNEA(q, qd, qdd)`` then holds the locks' torques at
        the knee joints and zero at the passive foot and hip. Signs: positive when the lock
        pushes against hyperextension (a stop holds it), negative when it must pull against
        flexion (only a latch holds it; without one the knee would buckle).

        Args:
            x: the 6-state.
            swing_knee_locked: the locked phase (else the unlocked phase: the swing knee is
                free and its torque is zero).

        Returns:
            ``(stance knee, swing knee, stance foot, hip)`` torques [N m]; the last two are
            zero up to rounding (a consistency check).
        """
        x = as_vector(x, 6, "x")
        if swing_knee_locked:
            xdot = self.locked_dynamics(x[[0, 1, 3, 4]])
            qdd = np.array([xdot[2], xdot[3], xdot[3]])
        else:
            qdd = self.unlocked_dynamics(x)[3:]

        def jointed(theta: FloatArray) -> FloatArray:
            phi = _T3_INV @ theta  # (stance leg, hip, swing knee) -> add a straight stance knee
            return np.array([phi[0], 0.0, phi[1], phi[2]])

        m = self.models
        tau = pin.rnea(m.jointed, m.jointed_data, jointed(x[:3]), jointed(x[3:]), jointed(qdd))
        # stance knee: its relative angle grows with flexion; swing knee: it shrinks
        return np.array([tau[1], -tau[3], tau[0], tau[2]])

    def impact(self, x: Any) -> FloatArray:
        """Post-heel-strike state (see :meth:`heel_strike_impact`)."""
        return self.heel_strike_impact(x)[0]


_ZERO3 = np.zeros(3)
_ZERO2 = np.zeros(2)


@dataclass(frozen=True)
class KneedStepResult:
    """One step of the kneed walker.

    Attributes:
        success: the knee locked and the swing foot struck the ground ahead (no fall).
        pre_impact: state just before heel strike.
        post_impact: state just after (the next step's start).
        duration: step time [s].
        knee_strike_time: time of the knee strike [s] (0 when the knee never bent).
        pre_knee_strike: state just before the knee strike.
        post_knee_strike: state just after it.
        knee_impulse: the knee's impulsive torque at the knee strike [N m s].
        heel_impulse: ground impulse ``(lambda_x, lambda_y)`` at heel strike [N s].
        times: dense sample times [s] (when requested).
        states: dense states, one row of 6 per sample (when requested).
        message: why the step failed, if it did.
    """

    success: bool
    pre_impact: FloatArray
    post_impact: FloatArray
    duration: float
    knee_strike_time: float
    pre_knee_strike: FloatArray
    post_knee_strike: FloatArray
    knee_impulse: float
    heel_impulse: FloatArray
    times: FloatArray
    states: FloatArray
    message: str = ""


def _event(fn: Any, *, direction: float = 0.0) -> Any:
    fn.terminal = True
    fn.direction = direction
    return fn


def simulate_kneed_step(
    walker: KneedWalker,
    x0: Any,
    *,
    max_time: float = 3.0,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    samples: int = 0,
) -> KneedStepResult:
    """Integrate one step from ``x0``: unlocked swing, knee strike, locked swing, heel strike.

    Events are located by the integrator's root finder on its dense output.

    Args:
        walker: the model.
        x0: post-heel-strike state ``(theta_st, theta_th, theta_sh, dtheta_st, dtheta_th,
            dtheta_sh)`` with the swing knee straight.
        max_time: give up after this time [s] (the walker stopped or fell).
        rtol, atol: tolerances of the DOP853 integrator.
        samples: number of dense output samples to return (0: none).
    """
    x0 = as_vector(x0, 6, "x0")
    samples = check_count(samples, "samples")
    max_time = check_positive(max_time, "max_time")
    if abs(walker.knee_flexion(x0)) > 1e-9 or abs(x0[4] - x0[5]) > 1e-9:
        raise InvalidInputError(
            "a step starts just after heel strike with the swing knee straight and locked: "
            f"theta_th = theta_sh and dtheta_th = dtheta_sh, got x0 = {x0}"
        )

    fall3 = _event(lambda _t, x: float(np.cos(x[0])))  # hip at the stance foot's height
    knee = _event(lambda _t, x: float(x[2] - x[1]), direction=1.0)
    scuff = _event(lambda _t, x: walker.swing_foot_height(x), direction=-1.0)

    def solve(fun: Any, t0: float, x_start: FloatArray, events: tuple[Any, ...]) -> Any:
        return solve_ivp(
            lambda _t, x: fun(x),
            (t0, max_time),
            x_start,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            events=events,
            dense_output=samples > 0,
        )

    pieces: list[tuple[Any, bool]] = []  # (solution, locked)
    t_knee, pre_knee, post_knee, knee_impulse = 0.0, x0, x0, 0.0
    # the knee bends only if the free shank falls behind the thigh (else it stays locked)
    xdot0 = walker.unlocked_dynamics(x0)
    if xdot0[5] - xdot0[4] < 0.0:
        sol = solve(walker.unlocked_dynamics, 0.0, x0, (knee, fall3, scuff))
        pieces.append((sol, False))
        if sol.status != 1 or not len(sol.t_events[0]):
            msg = "no knee strike before max_time"
            if sol.status == 1:
                msg = "the walker fell before its knee locked"
                if len(sol.t_events[2]):
                    msg = "the swing foot hit the slope before its knee locked"
            return _failed(pieces, samples, msg)
        t_knee, pre_knee = float(sol.t_events[0][0]), sol.y_events[0][0]
        post_knee, knee_impulse = walker.knee_strike_impact(pre_knee)

    heel = _event(lambda _t, x: walker.heel_strike(x), direction=1.0)
    fall2 = _event(lambda _t, x: float(np.cos(x[0])))
    x_locked = post_knee[[0, 1, 3, 4]]
    sol = solve(walker.locked_dynamics, t_knee, x_locked, (heel, fall2))
    pieces.append((sol, True))
    if sol.status != 1 or not len(sol.t_events[0]):
        msg = "the walker fell" if sol.status == 1 else "no heel strike before max_time"
        return _failed(pieces, samples, msg)
    y = sol.y_events[0][0]
    if y[0] + y[1] <= 0.0:
        return _failed(pieces, samples, "the swing foot struck the ground behind the stance foot")
    pre = np.array([y[0], y[1], y[1], y[2], y[3], y[3]])
    post, heel_impulse = walker.heel_strike_impact(pre)
    t_end = float(sol.t_events[0][0])
    times, states = _samples(pieces, samples, t_end)
    return KneedStepResult(
        True,
        pre,
        post,
        t_end,
        t_knee,
        pre_knee,
        post_knee,
        knee_impulse,
        heel_impulse,
        times,
        states,
    )


def _expand(y: FloatArray, locked: bool) -> FloatArray:
    """Rows of 6-states from rows of phase states."""
    if not locked:
        return y
    return np.column_stack((y[:, 0], y[:, 1], y[:, 1], y[:, 2], y[:, 3], y[:, 3]))


def _samples(pieces: list[tuple[Any, bool]], samples: int, t_end: float) -> tuple[Any, Any]:
    times = np.linspace(0.0, t_end, samples) if samples else np.zeros(0)
    states = np.zeros((times.size, 6))
    for sol, locked in pieces:
        if samples:
            sel = (times >= sol.t[0]) & (times <= sol.t[-1])
            states[sel] = _expand(sol.sol(times[sel]).T, locked)
    return times, states


def _failed(pieces: list[tuple[Any, bool]], samples: int, message: str) -> KneedStepResult:
    sol, locked = pieces[-1]
    t_end = float(sol.t[-1])
    last = _expand(sol.y[:, -1:].T, locked)[0]
    times, states = _samples(pieces, samples, t_end)
    nan = np.full(6, np.nan)
    return KneedStepResult(
        False,
        last,
        last,
        t_end,
        np.nan,
        nan,
        nan,
        np.nan,
        np.full(2, np.nan),
        times,
        states,
        message,
    )


def _section(walker: KneedWalker, z: FloatArray) -> FloatArray:
    """Post-heel-strike state from ``z = (theta_st, dtheta_st, dtheta_sw)``."""
    sw = z[0] - 2.0 * walker.slope
    return np.array([z[0], sw, sw, z[1], z[2], z[2]])


def kneed_return_map(walker: KneedWalker, z: Any, **kwargs: Any) -> FloatArray:
    """Poincare return map on the post-heel-strike section.

    The section: ``theta_th = theta_sh = theta_st - 2 gamma``, ``dtheta_th = dtheta_sh``.

    Args:
        walker: the model.
        z: ``(theta_st, dtheta_st, dtheta_sw)`` just after heel strike.
        **kwargs: passed to :func:`simulate_kneed_step`.

    Raises:
        SolverError: the walker falls or stops before the next heel strike.
    """
    z = as_vector(z, 3, "z")
    step = simulate_kneed_step(walker, _section(walker, z), **kwargs)
    if not step.success:
        raise SolverError(f"return map undefined at z = {z}: {step.message}")
    x = step.post_impact
    return np.array([x[0], x[3], x[4]])


def find_kneed_limit_cycle(
    walker: KneedWalker, initial_guess: Any, options: LimitCycleOptions | None = None
) -> LimitCycle:
    """Fixed point of the kneed walker's return map by Newton's method, with its multipliers.

    Solves ``P(z) - z = 0`` with ``z_{k+1} = z_k - (dP/dz - I)^-1 (P(z_k) - z_k)``, the Jacobian
    by central differences of the return map; the Floquet multipliers are the eigenvalues of
    ``dP/dz`` at the fixed point. ``post_impact`` of the result is the 6-state.
    """
    opts = options or LimitCycleOptions()
    kw = {"rtol": opts.rtol, "atol": opts.atol}
    return _newton_limit_cycle(
        lambda z: kneed_return_map(walker, z, **kw),
        lambda z: _section(walker, z),
        lambda z: (
            simulate_kneed_step(
                walker, _section(walker, z), rtol=opts.rtol, atol=opts.atol
            ).duration
        ),
        initial_guess,
        opts,
    )
