"""The compass gait walker: a hybrid model of passive walking down a slope.

Two rigid legs of length ``l`` joined at the hip (point mass ``m_h``), each with a point mass
``m`` at distance ``a`` from its foot (``b = l - a`` from the hip), on a slope of angle
``gamma`` (parameters of Tedrake's *Underactuated Robotics* notes and Goswami et al. 1996).

Coordinates: ``x`` forward and downhill (horizontal), ``y`` up; the stance foot is the origin.
``theta_st`` is the stance leg angle from the vertical (hip at ``l (sin, cos)(theta_st)``),
``theta_sw`` the swing leg angle (swing foot at ``hip + l (sin, -cos)(theta_sw)``); the
state is ``(theta_st, theta_sw, dtheta_st, dtheta_sw)``.

Swing phase (stance foot pinned, Lagrangian of the three point masses):

    M(q) qdd + c(q, qd) + dV/dq = 0,
    M = [[m a^2 + (m_h + m) l^2, m l b cos(theta_st + theta_sw)],
         [m l b cos(theta_st + theta_sw), m b^2]],
    c = -m l b sin(theta_st + theta_sw) (dtheta_sw^2, dtheta_st^2),
    dV/dq = g (-(m a + (m_h + m) l) sin theta_st, m b sin theta_sw).

Heel strike: the swing foot touches the slope when ``theta_st - theta_sw = 2 gamma`` with the
swing foot ahead (``theta_st + theta_sw > 0``); the other root of the foot height, the
mid-stance scuff ``theta_st + theta_sw = 0``, is ignored (the foot is assumed to clear it).
The impact is plastic and instantaneous; the legs swap roles, ``theta_st^+ = -theta_sw^-`` and
``theta_sw^+ = -theta_st^-``, and the velocities follow from conservation of the angular
momentum of the whole walker about the new stance foot and of the trailing leg about the
hip (the only impulses act at the new contact and, for the trailing leg, at the hip):

    Q^+(alpha) qd^+ = Q^-(alpha) qd^-.

Energy is conserved during the swing and lost only at impacts.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.integrate import solve_ivp

from taskspace._validation import FloatArray, as_vector, check_count, check_positive
from taskspace.errors import InvalidInputError, SolverError

MAX_WALKER_SCALE = 1e6
"""Largest mass [kg], length [m] and gravity [m/s^2] of the walker models: their squares and
products stay far from overflow (at 1e300 the integrator took ever smaller steps, forever)."""


def check_walker_scales(walker: Any, names: tuple[str, ...], slope: Any) -> None:
    """Refuse walker parameters beyond :data:`MAX_WALKER_SCALE` and slopes of 90 degrees or more."""
    for name in names:
        value = getattr(walker, name)
        if not (_is_real(value) and abs(float(value)) <= MAX_WALKER_SCALE):  # also NaN
            raise InvalidInputError(
                f"{name} must be a number in [0, {MAX_WALKER_SCALE:g}] (SI units), got {value!r}"
            )
    if not (_is_real(slope) and abs(float(slope)) < 0.5 * np.pi):
        raise InvalidInputError(f"slope must be in (-pi/2, pi/2) [rad], got {slope!r}")


def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


@dataclass(frozen=True, kw_only=True)
class CompassGait:
    """Parameters of the compass gait (defaults: Tedrake's notes).

    Attributes:
        hip_mass: ``m_h`` [kg].
        leg_mass: ``m`` [kg].
        leg_length: ``l`` [m].
        a: distance foot - leg mass [m] (``b = l - a``).
        slope: ``gamma`` [rad].
        gravity: ``g`` [m/s^2].
    """

    hip_mass: float = 10.0
    leg_mass: float = 5.0
    leg_length: float = 1.0
    a: float = 0.5
    slope: float = 0.0525
    gravity: float = 9.81

    def __post_init__(self) -> None:
        check_positive(self.hip_mass, "hip_mass", strict=False)
        check_positive(self.leg_mass, "leg_mass")
        check_positive(self.leg_length, "leg_length")
        check_positive(self.gravity, "gravity")
        check_walker_scales(
            self, ("hip_mass", "leg_mass", "leg_length", "a", "gravity"), self.slope
        )
        if not 0.0 < self.a < self.leg_length:
            raise InvalidInputError(
                f"the leg mass must sit on the leg: 0 < a < leg_length, got a = {self.a}"
            )

    @property
    def b(self) -> float:
        """Distance hip - leg mass [m]."""
        return self.leg_length - self.a

    # ----------------------------------------------------------------- kinematics
    def positions(self, q: FloatArray) -> dict[str, FloatArray]:
        """World positions of the stance mass, hip, swing mass and swing foot (stance foot at 0)."""
        st, sw = q[0], q[1]
        up = np.array([np.sin(st), np.cos(st)])
        down = np.array([np.sin(sw), -np.cos(sw)])
        hip = self.leg_length * up
        return {
            "stance_mass": self.a * up,
            "hip": hip,
            "swing_mass": hip + self.b * down,
            "swing_foot": hip + self.leg_length * down,
        }

    def mass_matrix(self, q: FloatArray) -> FloatArray:
        """``M(q)`` of the swing phase."""
        m, mh, l, a, b = self.leg_mass, self.hip_mass, self.leg_length, self.a, self.b
        c = m * l * b * np.cos(q[0] + q[1])
        return np.array([[m * a * a + (mh + m) * l * l, c], [c, m * b * b]])

    def energy(self, x: Any) -> float:
        """Total mechanical energy ``T + V`` [J] (potential measured from the stance foot)."""
        x = np.asarray(x, dtype=float)
        q, qd = x[:2], x[2:]
        kinetic = 0.5 * qd @ self.mass_matrix(q) @ qd
        p = self.positions(q)
        m, mh, g = self.leg_mass, self.hip_mass, self.gravity
        potential = g * (m * p["stance_mass"][1] + mh * p["hip"][1] + m * p["swing_mass"][1])
        return float(kinetic + potential)

    # ----------------------------------------------------------------- dynamics
    def dynamics(self, x: FloatArray) -> FloatArray:
        """``xdot = (qd, qdd)`` of the swing phase."""
        m, mh, l, a, b, g = (
            self.leg_mass,
            self.hip_mass,
            self.leg_length,
            self.a,
            self.b,
            self.gravity,
        )
        st, sw, dst, dsw = x
        s = np.sin(st + sw)
        rhs = -np.array(
            [
                -m * l * b * s * dsw * dsw - g * (m * a + (mh + m) * l) * np.sin(st),
                -m * l * b * s * dst * dst + g * m * b * np.sin(sw),
            ]
        )
        qdd = np.linalg.solve(self.mass_matrix(x[:2]), rhs)
        return np.array([dst, dsw, qdd[0], qdd[1]])

    def heel_strike(self, x: FloatArray) -> float:
        """Guard ``theta_st - theta_sw - 2 gamma`` (zero at heel strike)."""
        return float(x[0] - x[1] - 2.0 * self.slope)

    def impact(self, x: Any) -> FloatArray:
        """Post-impact state: legs swapped, velocities from angular momentum conservation."""
        x = as_vector(x, 4, "x")
        qd = x[2:]
        Qm = self._momentum_rows(x[:2], new_stance_at_swing_foot=False)
        q_new = np.array([-x[1], -x[0]])
        Qp = self._momentum_rows(q_new, new_stance_at_swing_foot=True)
        qd_new = np.linalg.solve(Qp, Qm @ qd)
        return np.array([q_new[0], q_new[1], qd_new[0], qd_new[1]])

    def _momentum_rows(self, q: FloatArray, *, new_stance_at_swing_foot: bool) -> FloatArray:
        """Rows ``(L_foot, L_hip)`` linear in ``qd``.

        Before impact (``False``): the whole walker about the swing foot (the coming contact),
        and the stance leg (which is about to leave the ground) about the hip. After impact
        (``True``, coordinates already swapped): the whole walker about the stance foot, and
        the swing leg (the trailing leg) about the hip.
        """
        p = self.positions(q)
        l, a, b = self.leg_length, self.a, self.b
        st, sw = q
        # velocity Jacobians (2 x 2) of the point masses
        J_up = np.array([[np.cos(st), 0.0], [-np.sin(st), 0.0]])
        J_down = np.array([[0.0, np.cos(sw)], [0.0, np.sin(sw)]])
        J = {
            "stance_mass": a * J_up,
            "hip": l * J_up,
            "swing_mass": l * J_up + b * J_down,
        }
        mass = {"stance_mass": self.leg_mass, "hip": self.hip_mass, "swing_mass": self.leg_mass}

        def moment(names: tuple[str, ...], about: FloatArray) -> FloatArray:
            row = np.zeros(2)
            for n in names:
                r = p[n] - about
                row += mass[n] * (r[0] * J[n][1] - r[1] * J[n][0])
            return row

        everything = ("stance_mass", "hip", "swing_mass")
        if new_stance_at_swing_foot:
            return np.vstack([moment(everything, np.zeros(2)), moment(("swing_mass",), p["hip"])])
        return np.vstack([moment(everything, p["swing_foot"]), moment(("stance_mass",), p["hip"])])


@dataclass(frozen=True)
class StepResult:
    """One step of the compass gait.

    Attributes:
        success: the swing foot struck the ground ahead (no fall).
        pre_impact: state just before heel strike.
        post_impact: state just after (the next step's start).
        duration: step time [s].
        times, states: the dense swing-phase samples (when requested).
        message: why the step failed, if it did.
    """

    success: bool
    pre_impact: FloatArray
    post_impact: FloatArray
    duration: float
    times: FloatArray
    states: FloatArray
    message: str = ""


def simulate_step(
    walker: CompassGait,
    x0: Any,
    *,
    max_time: float = 3.0,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    samples: int = 0,
) -> StepResult:
    """Integrate one swing phase from ``x0`` to heel strike and apply the impact map.

    Args:
        walker: the model.
        x0: post-impact state ``(theta_st, theta_sw, dtheta_st, dtheta_sw)``.
        max_time: give up after this time [s] (the walker stopped or fell).
        rtol, atol: tolerances of the DOP853 integrator.
        samples: number of dense output samples to return (0: none).
    """
    x0 = as_vector(x0, 4, "x0")

    def strike(_t: float, x: FloatArray) -> float:
        return walker.heel_strike(x)

    strike.terminal = True  # type: ignore[attr-defined]
    strike.direction = 1.0  # type: ignore[attr-defined]

    def fall(_t: float, x: FloatArray) -> float:
        return float(np.cos(x[0]))  # the hip reaches the height of the stance foot

    fall.terminal = True  # type: ignore[attr-defined]

    def legs_cross(_t: float, x: FloatArray) -> float:
        return float(x[0] + x[1])

    legs_cross.terminal = True  # type: ignore[attr-defined]
    legs_cross.direction = 1.0  # type: ignore[attr-defined]

    def run(t0: float, x_start: FloatArray, event: Any) -> Any:
        return solve_ivp(
            lambda _t, x: walker.dynamics(x),
            (t0, max_time),
            x_start,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            events=(event, fall),
            dense_output=samples > 0,
        )

    # stage 1: until the swing foot passes the stance foot; stage 2: until heel strike
    sols = []
    if x0[0] + x0[1] < 0.0:
        sols.append(run(0.0, x0, legs_cross))
        if sols[-1].status != 1 or not len(sols[-1].t_events[0]):
            sol = sols[-1]
            msg = "the walker fell back" if sol.status == 1 else "no step before max_time"
            return _failed(sol, samples, msg)
        sols.append(run(float(sols[-1].t_events[0][0]), sols[-1].y_events[0][0], strike))
    else:
        sols.append(run(0.0, x0, strike))
    sol = sols[-1]
    t_end = float(sol.t[-1])
    times = np.linspace(0.0, t_end, samples) if samples else np.zeros(0)
    states = np.zeros((times.size, 4))
    if samples:
        for piece in sols:
            sel = (times >= piece.t[0]) & (times <= piece.t[-1])
            states[sel] = piece.sol(times[sel]).T
    if sol.status != 1 or not len(sol.t_events[0]):
        msg = "the walker fell" if sol.status == 1 else "no heel strike before max_time"
        return StepResult(False, sol.y[:, -1], sol.y[:, -1], t_end, times, states, msg)
    pre = sol.y_events[0][0]
    return StepResult(True, pre, walker.impact(pre), float(sol.t_events[0][0]), times, states)


def _failed(sol: Any, samples: int, message: str) -> StepResult:
    t_end = float(sol.t[-1])
    times = np.linspace(0.0, t_end, samples) if samples else np.zeros(0)
    states = sol.sol(times).T if samples else np.zeros((0, 4))
    return StepResult(False, sol.y[:, -1], sol.y[:, -1], t_end, times, states, message)


def _section(walker: CompassGait, z: FloatArray) -> FloatArray:
    """Post-impact state from section coordinates ``z = (theta_st, dtheta_st, dtheta_sw)``."""
    return np.array([z[0], z[0] - 2.0 * walker.slope, z[1], z[2]])


def return_map(walker: CompassGait, z: Any, **kwargs: Any) -> FloatArray:
    """Poincare return map on the post-impact section (``theta_sw = theta_st - 2 gamma``).

    Args:
        walker: the model.
        z: ``(theta_st, dtheta_st, dtheta_sw)`` just after an impact.
        **kwargs: passed to :func:`simulate_step`.

    Raises:
        SolverError: the walker falls or stops before the next heel strike.
    """
    z = as_vector(z, 3, "z")
    step = simulate_step(walker, _section(walker, z), **kwargs)
    if not step.success:
        raise SolverError(f"return map undefined at z = {z}: {step.message}")
    x = step.post_impact
    return np.array([x[0], x[2], x[3]])


@dataclass(frozen=True, kw_only=True)
class LimitCycleOptions:
    """Settings of :func:`find_limit_cycle`.

    Attributes:
        tolerance: stop when ``|P(z) - z|_inf`` is below this.
        max_iterations: Newton iteration limit.
        fd_step: central-difference step of the Jacobian of the return map.
        rtol, atol: integrator tolerances.
    """

    tolerance: float = 1e-11
    max_iterations: int = 20
    fd_step: float = 1e-6
    rtol: float = 1e-12
    atol: float = 1e-12


@dataclass(frozen=True)
class LimitCycle:
    """A period-one gait.

    Attributes:
        success: the fixed-point residual is below the tolerance.
        fixed_point: ``z* = (theta_st, dtheta_st, dtheta_sw)`` just after impact.
        post_impact: the full post-impact state.
        residual: ``|P(z*) - z*|_inf``.
        jacobian: ``dP/dz`` at ``z*``.
        floquet_multipliers: eigenvalues of the Jacobian (stable when all ``|.| < 1``).
        period: step time [s].
        iterations: Newton iterations.
        solve_time: wall time [s].
    """

    success: bool
    fixed_point: FloatArray
    post_impact: FloatArray
    residual: float
    jacobian: FloatArray
    floquet_multipliers: npt.NDArray[np.complex128]
    period: float
    iterations: int
    solve_time: float

    @property
    def stable(self) -> bool:
        """Every Floquet multiplier inside the unit circle."""
        return bool(np.all(np.abs(self.floquet_multipliers) < 1.0))


def _central_jacobian(P: Callable[[FloatArray], FloatArray], z: FloatArray, h: float) -> FloatArray:
    """``dP/dz`` (3 x 3) by central differences of step ``h``."""
    J = np.empty((3, 3))
    for i in range(3):
        dz = np.zeros(3)
        dz[i] = h
        J[:, i] = (P(z + dz) - P(z - dz)) / (2 * h)
    return J


def _newton_limit_cycle(
    P: Callable[[FloatArray], FloatArray],
    section: Callable[[FloatArray], FloatArray],
    period: Callable[[FloatArray], float],
    initial_guess: Any,
    options: LimitCycleOptions,
) -> LimitCycle:
    """Newton on ``P(z) - z = 0`` (3-D section), the Floquet multipliers at the fixed point.

    Shared by :func:`find_limit_cycle` and the kneed walker's ``find_kneed_limit_cycle``.

    Args:
        P: return map of the section coordinates.
        section: the full post-impact state of a section point.
        period: the step duration from a section point.
        initial_guess: starting section point.
        options: tolerance, iteration cap, finite-difference step.
    """
    opts = options
    t0 = time.perf_counter()
    max_iterations = check_count(opts.max_iterations, "max_iterations")
    z = as_vector(initial_guess, 3, "initial_guess").copy()
    residual = np.inf
    iterations = 0
    for iterations in range(1, max_iterations + 1):  # noqa: B007
        F = P(z) - z
        residual = float(np.abs(F).max())
        if residual < opts.tolerance:
            break
        J = _central_jacobian(P, z, opts.fd_step)
        z = z - np.linalg.solve(J - np.eye(3), F)
    J = _central_jacobian(P, z, opts.fd_step)
    duration = period(z)
    multipliers: npt.NDArray[np.complex128] = np.linalg.eigvals(J).astype(np.complex128)
    return LimitCycle(
        success=residual < opts.tolerance,
        fixed_point=z,
        post_impact=section(z),
        residual=residual,
        jacobian=J,
        floquet_multipliers=multipliers,
        period=duration,
        iterations=iterations,
        solve_time=time.perf_counter() - t0,
    )


def find_limit_cycle(
    walker: CompassGait, initial_guess: Any, options: LimitCycleOptions | None = None
) -> LimitCycle:
    """Fixed point of the return map by Newton's method, with its Floquet multipliers.

    Solves ``P(z) - z = 0`` with ``z_{k+1} = z_k - (dP/dz - I)^-1 (P(z_k) - z_k)``, the Jacobian
    by central differences of the return map.
    """
    opts = options or LimitCycleOptions()
    kw = {"rtol": opts.rtol, "atol": opts.atol}
    return _newton_limit_cycle(
        lambda z: return_map(walker, z, **kw),
        lambda z: _section(walker, z),
        lambda z: (
            simulate_step(walker, _section(walker, z), rtol=opts.rtol, atol=opts.atol).duration
        ),
        initial_guess,
        opts,
    )
