"""Raibert's planar one-legged hopper and its three-part controller (Raibert 1986).

Model: a rigid body (mass ``M``, pitch inertia ``J``) with the hip at its center of mass and a
massless telescoping leg: a spring of stiffness ``k`` and damping ``c`` about a rest length
that the thrust actuator can lengthen. The state is ``(x, z, phi, xdot, zdot, phidot)``
(hip position [m], body pitch [rad], and their rates).

* Flight: ballistic, ``xdd = 0``, ``zdd = -g``, ``phidd = 0`` (a massless leg exerts nothing);
  the leg is held at the touchdown angle ``theta`` from the vertical (foot at
  ``hip + r0 (sin theta, -cos theta)``) and touches down when ``z = r0 cos theta``.
* Stance: the foot is pinned at ``(x_f, 0)``; with ``r = |hip - foot|``, unit leg vector ``u``
  (foot to hip) and ``n = (-u_z, u_x)``, the ground force passing through the massless leg is

      f = F u + (tau / r) n,   F = max(0, k (r_rest - r) - c rdot),

  where ``tau`` is the hip torque the body applies to the leg; the body gets ``f``, gravity and
  the reaction torque ``-tau``: ``M (xdd, zdd) = f + (0, -M g)``, ``J phidd = -tau``. Lift-off
  when ``F`` returns to zero.

Controller (the three decoupled parts):

1. Hopping height: during decompression (``rdot > 0``) the rest length is ``r0 + delta``;
   ``delta`` is adapted once per hop from the apex height error,
   ``delta <- clip(delta + k_h (h_des - h_apex), 0, delta_max)``.
2. Forward speed: the foot is placed ahead of the hip by the Raibert heuristic
   ``x_f - x = xdot T_s / 2 + k_xdot (xdot - xdot_des) + k_i sum_hops (xdot - xdot_des)``
   (``T_s`` the last stance time). The sum over past hops (``k_i = 0`` is Raibert's law)
   removes the steady-state speed error left by the asymmetry of a stance with thrust and
   damping, for which ``xdot T_s / 2`` is not exactly the neutral point.
3. Body attitude: in stance the hip servos the pitch, ``tau = k_p (phi - phi_des) + k_d phidot``.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from taskspace._validation import FloatArray, as_scalar, as_vector, check_positive
from taskspace.errors import InvalidInputError


@dataclass(frozen=True, kw_only=True)
class HopperParameters:
    """Physical parameters of the planar hopper.

    Attributes:
        body_mass: ``M`` [kg].
        body_inertia: ``J`` pitch inertia about the hip [kg m^2].
        leg_rest_length: ``r0`` [m].
        leg_stiffness: ``k`` [N/m].
        leg_damping: ``c`` [N s/m].
        max_thrust: ``delta_max``, largest rest-length extension [m].
        gravity: ``g`` [m/s^2].
    """

    body_mass: float = 10.0
    body_inertia: float = 0.5
    leg_rest_length: float = 0.5
    leg_stiffness: float = 4000.0
    leg_damping: float = 10.0
    max_thrust: float = 0.1
    gravity: float = 9.81

    def __post_init__(self) -> None:
        for name in ("body_mass", "body_inertia", "leg_rest_length", "leg_stiffness", "gravity"):
            check_positive(getattr(self, name), name)
        check_positive(self.leg_damping, "leg_damping", strict=False)
        check_positive(self.max_thrust, "max_thrust", strict=False)


@dataclass(frozen=True, kw_only=True)
class RaibertOptions:
    """Gains and targets of the Raibert controller.

    Attributes:
        hop_height: desired apex height of the hip [m].
        speed_gain: ``k_xdot`` of the foot placement [s].
        speed_integral_gain: ``k_i`` on the speed errors summed over hops [s].
        height_gain: ``k_h`` of the thrust adaptation [m/m].
        attitude_kp: ``k_p`` [N m/rad].
        attitude_kd: ``k_d`` [N m s/rad].
        pitch: desired body pitch [rad].
        max_leg_angle: bound on the touchdown leg angle [rad].
    """

    hop_height: float = 0.7
    speed_gain: float = 0.04
    speed_integral_gain: float = 0.02
    height_gain: float = 0.1
    attitude_kp: float = 300.0
    attitude_kd: float = 30.0
    pitch: float = 0.0
    max_leg_angle: float = 0.6


@dataclass(frozen=True)
class HopperResult:
    """A hopper run.

    Attributes:
        success: no fall (the body never went below the leg's reach or tumbled).
        times: (T,) sample times [s].
        states: (T, 6) ``(x, z, phi, xdot, zdot, phidot)``.
        in_stance: (T,) True where the foot was on the ground.
        apex_times: time of every flight apex [s].
        apex_heights: hip height at each apex [m].
        apex_speeds: forward speed at each apex (constant in flight) [m/s].
        desired_speeds: the commanded speed at each apex [m/s].
        stance_times: duration of each stance [s].
        thrusts: rest-length extension used at each stance [m].
        message: why the run stopped early, if it did.
        compute_time: wall time [s].
    """

    success: bool
    times: FloatArray
    states: FloatArray
    in_stance: np.ndarray
    apex_times: FloatArray
    apex_heights: FloatArray
    apex_speeds: FloatArray
    desired_speeds: FloatArray
    stance_times: FloatArray
    thrusts: FloatArray
    message: str = ""
    compute_time: float = 0.0


@dataclass
class _Log:
    t: list[FloatArray] = field(default_factory=list)
    x: list[FloatArray] = field(default_factory=list)
    stance: list[np.ndarray] = field(default_factory=list)

    def add(self, t: FloatArray, x: FloatArray, stance: bool) -> None:
        self.t.append(t)
        self.x.append(x)
        self.stance.append(np.full(t.size, stance))


def stance_dynamics(
    params: HopperParameters,
    state: FloatArray,
    foot_x: float,
    rest_length: float,
    hip_torque: float,
) -> tuple[FloatArray, float]:
    """``(xdot, F)``: the stance-phase state derivative and the leg's axial force [N]."""
    x, z, _phi, vx, vz, _w = state
    dx, dz = x - foot_x, z
    r = math.hypot(dx, dz)
    ux, uz = dx / r, dz / r
    rdot = ux * vx + uz * vz
    F = max(0.0, params.leg_stiffness * (rest_length - r) - params.leg_damping * rdot)
    T = hip_torque / r
    fx = F * ux - T * uz
    fz = F * uz + T * ux
    M = params.body_mass
    return (
        np.array(
            [vx, vz, state[5], fx / M, fz / M - params.gravity, -hip_torque / params.body_inertia]
        ),
        F,
    )


def stance_energy(params: HopperParameters, state: Any, foot_x: float, rest_length: float) -> float:
    """Kinetic + gravity + spring energy in stance [J].

    Conserved without damping, thrust or hip torque.
    """
    s = as_vector(state, 6, "state")
    r = math.hypot(s[0] - foot_x, s[1])
    M = params.body_mass
    return float(
        0.5 * M * (s[3] ** 2 + s[4] ** 2)
        + 0.5 * params.body_inertia * s[5] ** 2
        + M * params.gravity * s[1]
        + 0.5 * params.leg_stiffness * (rest_length - r) ** 2
    )


def _hip_torque(options: RaibertOptions, state: FloatArray) -> float:
    return options.attitude_kp * (state[2] - options.pitch) + options.attitude_kd * state[5]


def _rdot(state: FloatArray, foot: float) -> float:
    dx, dz = state[0] - foot, state[1]
    return float((dx * state[3] + dz * state[4]) / math.hypot(dx, dz))


def _stance_rhs(
    _t: float, state: FloatArray, p: HopperParameters, o: RaibertOptions, foot: float, rest: float
) -> FloatArray:
    return stance_dynamics(p, state, foot, rest, _hip_torque(o, state))[0]


def _bottom(
    _t: float, state: FloatArray, _p: HopperParameters, _o: RaibertOptions, foot: float, _r: float
) -> float:
    return _rdot(state, foot)


def _liftoff(
    _t: float, state: FloatArray, p: HopperParameters, _o: RaibertOptions, foot: float, rest: float
) -> float:
    r = math.hypot(state[0] - foot, state[1])
    return p.leg_stiffness * (rest - r) - p.leg_damping * _rdot(state, foot)


def _crash(
    _t: float, state: FloatArray, p: HopperParameters, _o: RaibertOptions, _f: float, _r: float
) -> float:
    return float(state[1] - 0.2 * p.leg_rest_length)


_bottom.terminal = True  # type: ignore[attr-defined]
_bottom.direction = 1.0  # type: ignore[attr-defined]
_liftoff.terminal = True  # type: ignore[attr-defined]
_liftoff.direction = -1.0  # type: ignore[attr-defined]
_crash.terminal = True  # type: ignore[attr-defined]


def _stance_phase(
    params: HopperParameters,
    options: RaibertOptions,
    log: _Log,
    t: float,
    s: FloatArray,
    foot: float,
    thrust: float,
    rtol: float,
    samples: int,
) -> tuple[float, FloatArray, bool]:
    """Compression to the bottom (rest length ``r0``), then thrust to lift-off."""
    r0 = params.leg_rest_length
    for rest, event in ((r0, _bottom), (r0 + thrust, _liftoff)):
        sol = solve_ivp(
            _stance_rhs,
            (t, t + 2.0),
            s,
            method="DOP853",
            rtol=rtol,
            atol=1e-10,
            events=(event, _crash),
            dense_output=True,
            args=(params, options, foot, rest),
        )
        if sol.status != 1 or len(sol.t_events[1]):
            return t, s, True
        t_end = float(sol.t_events[0][0])
        ts = np.linspace(t, t_end, samples)
        log.add(ts, sol.sol(ts).T, True)
        t, s = t_end, sol.y_events[0][0].copy()
    return t, s, False


def simulate_hopper(
    params: HopperParameters,
    options: RaibertOptions,
    desired_speed: float | Callable[[float], float],
    duration: float,
    *,
    initial_state: Any = None,
    samples_per_phase: int = 20,
    rtol: float = 1e-9,
) -> HopperResult:
    """Simulate the hopper under the Raibert controller.

    Args:
        params: physical parameters.
        options: controller gains and targets.
        desired_speed: forward speed command [m/s], constant or a function of time.
        duration: simulated time [s].
        initial_state: ``(x, z, phi, xdot, zdot, phidot)`` in flight (default: at rest at the
            desired apex height).
        samples_per_phase: dense samples recorded per flight or stance phase.
        rtol: relative tolerance of the stance integrator (flight is integrated exactly).
    """
    t_start = time.perf_counter()
    duration = check_positive(duration, "duration")
    if callable(desired_speed):
        command = desired_speed

        def speed(t_now: float) -> float:
            # the command's value, named when it is not a finite number (a NaN command would
            # reach scipy's integrator as a bare "y0 must be finite")
            value = command(t_now)
            try:
                return as_scalar(value, "desired_speed(t)")
            except InvalidInputError as exc:
                raise InvalidInputError(f"{exc} (at t = {t_now:.6g} s)") from None

    else:
        constant = as_scalar(desired_speed, "desired_speed")

        def speed(t_now: float) -> float:
            return constant

    if initial_state is None:
        s = np.array([0.0, options.hop_height, 0.0, 0.0, 0.0, 0.0])
    else:
        s = as_vector(initial_state, 6, "initial_state").copy()
    r0, g = params.leg_rest_length, params.gravity
    if s[1] <= r0:
        raise InvalidInputError(
            f"the hopper must start in flight: hip height {s[1]} m <= leg rest length {r0} m"
        )
    log = _Log()
    t = 0.0
    stance_time = math.pi * math.sqrt(params.body_mass / params.leg_stiffness)
    thrust = 0.0
    speed_error_sum = 0.0
    apex_t: list[float] = []
    apex_h: list[float] = []
    apex_v: list[float] = []
    apex_vd: list[float] = []
    stance_times: list[float] = []
    thrusts: list[float] = []
    message = ""
    while t < duration:
        # ---------------- flight (exact ballistic motion)
        vd = speed(t)
        if s[4] > 0:  # rising: record the apex
            t_apex = s[4] / g
            h = s[1] + s[4] ** 2 / (2 * g)
            apex_t.append(t + t_apex)
            apex_h.append(h)
            apex_v.append(s[3])
            vd = speed(t + t_apex)
            apex_vd.append(vd)
            thrust = float(
                np.clip(
                    thrust + options.height_gain * (options.hop_height - h), 0.0, params.max_thrust
                )
            )
        speed_error_sum += s[3] - vd
        offset = (
            s[3] * stance_time / 2
            + options.speed_gain * (s[3] - vd)
            + options.speed_integral_gain * speed_error_sum
        )
        theta = float(
            np.clip(
                math.asin(np.clip(offset / r0, -1, 1)),
                -options.max_leg_angle,
                options.max_leg_angle,
            )
        )
        z_td = r0 * math.cos(theta)
        disc = s[4] ** 2 + 2 * g * (s[1] - z_td)
        if disc < 0:
            message = "the hip is below the touchdown height in flight"
            break
        t_fl = (s[4] + math.sqrt(disc)) / g
        ts = np.linspace(0.0, t_fl, samples_per_phase)
        flight = np.empty((ts.size, 6))
        flight[:, 0] = s[0] + s[3] * ts
        flight[:, 1] = s[1] + s[4] * ts - 0.5 * g * ts**2
        flight[:, 2] = s[2] + s[5] * ts
        flight[:, 3] = s[3]
        flight[:, 4] = s[4] - g * ts
        flight[:, 5] = s[5]
        log.add(t + ts, flight, False)
        t += t_fl
        s = flight[-1].copy()
        if t >= duration:
            break
        # ---------------- stance
        foot = s[0] + r0 * math.sin(theta)
        t_td = t
        t, s, fell = _stance_phase(
            params, options, log, t, s, foot, thrust, rtol, samples_per_phase
        )
        if fell:
            message = "the hopper fell (the body hit the ground or the leg never extended)"
            break
        stance_times.append(t - t_td)
        thrusts.append(thrust)
        stance_time = t - t_td
        if abs(s[2]) > 1.0:
            message = "the body tumbled (pitch beyond 1 rad)"
            break
    times = np.concatenate(log.t) if log.t else np.zeros(0)
    states = np.vstack(log.x) if log.x else np.zeros((0, 6))
    return HopperResult(
        success=not message,
        times=times,
        states=states,
        in_stance=np.concatenate(log.stance) if log.stance else np.zeros(0, bool),
        apex_times=np.array(apex_t),
        apex_heights=np.array(apex_h),
        apex_speeds=np.array(apex_v),
        desired_speeds=np.array(apex_vd),
        stance_times=np.array(stance_times),
        thrusts=np.array(thrusts),
        message=message,
        compute_time=time.perf_counter() - t_start,
    )
