"""Forward simulation of a robot under a controller: ``simulate(robot, controller, x0, T, dt)``.

At each step ``k`` (time ``t_k = k dt``) the controller is called with ``(t_k, q_k, v_k)``;
its torque is held constant over ``[t_k, t_k + dt)`` (zero-order hold, the default) or, with
``hold_control=False``, the controller is evaluated at every integrator stage (a
continuous-time control law; only for stateless controllers). The forward dynamics
``q'' = M^-1 (u + tau_friction - F)`` (slide 5:29) come from ``pin.aba``; the integrators are
in :mod:`taskspace.dynamics.integrators`. Every sample records the kinetic and potential
energies (slide 5:25).

Thread safety: :func:`simulate` builds its own dynamics and Pinocchio data per call, so calls
may run from several threads (with a torque callback that is itself safe to call from them).
:class:`SimulationOptions` and :class:`SimulationStatus` are immutable; a
:class:`SimulationTrajectory` is plain result data (arrays), not locked: do not modify it while
another thread reads it.
"""

from __future__ import annotations

import enum
import logging
import math
import os
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector, check_finite, check_positive
from taskspace.dynamics.forward_dynamics import ForwardDynamics, JointFriction
from taskspace.dynamics.integrators import STEPPERS, Integrator
from taskspace.errors import InvalidInputError, ShapeError, TaskspaceError, TaskspaceWarning

if TYPE_CHECKING:
    from taskspace.model.robot import Robot

logger = logging.getLogger(__name__)

MAX_RECORD_BYTES = 1 << 36
"""Largest record :func:`simulate` allocates [bytes] (64 GiB), below half the free memory."""

Controller = Callable[[float, FloatArray, FloatArray], Any]
"""Controller protocol: ``tau = controller(t, q, v)``, torques of size nv [N m, N]."""


class SimulationDivergedError(TaskspaceError):
    """A simulated state blew up: not finite, or a velocity beyond the stated bound.

    Raised by simulations that return a full record only (e.g.
    :func:`~taskspace.control.inverse_dynamics_qp_rollout.simulate_with_contacts`); the
    record up to the last finite sample is attached, never a NaN trajectory.

    Attributes:
        time: simulated time of the first diverged sample [s].
        step: its step index.
        quantity: what diverged (``"q"``, ``"v"``, ``"a"``, a contact force...).
        value: the offending magnitude (``|.|_inf``; NaN or inf when not finite).
        bound: the bound it exceeded (inf for a finiteness test).
        record: the partial record (samples ``0..step-1``), or ``None``.
    """

    def __init__(
        self,
        quantity: str,
        time: float,
        step: int,
        value: float,
        bound: float,
        record: Any = None,
        hint: str = "",
    ) -> None:
        what = (
            f"{quantity} is not finite"
            if not math.isfinite(value)
            else f"|{quantity}|_inf = {value:.3g} exceeds {bound:.3g}"
        )
        super().__init__(
            f"the simulation diverged at t = {time:.6g} s (step {step}): {what}"
            + (f"; {hint}" if hint else "")
        )
        self.time = time
        self.step = step
        self.quantity = quantity
        self.value = value
        self.bound = bound
        self.record = record


class SimulationStatus(enum.Enum):
    """Outcome of :func:`simulate`."""

    COMPLETED = "completed"
    """All steps were integrated."""
    DIVERGED = "diverged"
    """The state became non-finite or exceeded ``SimulationOptions.max_velocity``."""


@dataclass(frozen=True, kw_only=True)
class SimulationOptions:
    """Settings of :func:`simulate`.

    Attributes:
        integrator: ``"rk4"`` (default) or ``"semi_implicit_euler"``.
        friction: joint friction (viscous damping, smoothed Coulomb); none by default.
        hold_control: zero-order hold of the controller output over each step (``True``), or
            evaluation of the controller at every integrator stage (``False``: a
            continuous-time law; the controller must then be stateless).
        clip_torque: clip the controller output to the robot's effort limits (0 on the
            floating base and passive joints). Without clipping, a torque there is applied
            as an external force and reported once per run (TaskspaceWarning).
        record_energy: compute the kinetic and potential energies at every sample.
        progress: show a tqdm progress bar; ``None`` shows it only when stderr is a TTY and
            the run has at least ``progress_min_steps`` steps.
        progress_min_steps: threshold of the automatic progress bar.
        max_velocity: a state with ``|v|_inf`` above this is declared diverged [rad/s, m/s].
    """

    integrator: Integrator | str = Integrator.RK4
    friction: JointFriction = field(default_factory=JointFriction)
    hold_control: bool = True
    clip_torque: bool = False
    record_energy: bool = True
    progress: bool | None = None
    progress_min_steps: int = 20_000
    max_velocity: float = 1e6


@dataclass
class SimulationTrajectory:
    """Record of a simulation, one row per sample ``t_k = k dt``.

    Attributes:
        success: the run completed.
        status: see :class:`SimulationStatus`.
        t: sample times (N+1,) [s].
        q: configurations (N+1, nq).
        v: velocities (N+1, nv) [rad/s, m/s].
        a: accelerations at the samples (N+1, nv) [rad/s^2, m/s^2] (for the last sample the
            acceleration under the controller's last output).
        tau: controller torques at the samples (N+1, nv) [N m, N] (after clipping).
        kinetic_energy: ``1/2 v^T M v`` per sample (N+1,) [J] (NaN if not recorded).
        potential_energy: gravitational energy per sample (N+1,) [J].
        dt: time step [s].
        integrator: the integration scheme.
        steps: integrated steps.
        wall_time: duration of the run [s].
        message: human-readable outcome.
    """

    success: bool
    status: SimulationStatus
    t: FloatArray
    q: FloatArray
    v: FloatArray
    a: FloatArray
    tau: FloatArray
    kinetic_energy: FloatArray
    potential_energy: FloatArray
    dt: float
    integrator: Integrator
    steps: int
    wall_time: float
    message: str = ""

    @property
    def total_energy(self) -> FloatArray:
        """``T + U`` per sample [J]."""
        return self.kinetic_energy + self.potential_energy

    @property
    def energy_drift(self) -> float:
        """``max_k |E_k - E_0|`` [J]: the energy error of a passive, frictionless run."""
        e = self.total_energy
        return float(np.max(np.abs(e - e[0])))

    @property
    def final_q(self) -> FloatArray:
        """Last configuration."""
        return self.q[-1]

    @property
    def final_v(self) -> FloatArray:
        """Last velocity [rad/s, m/s]."""
        return self.v[-1]


def _initial_state(robot: Robot, x0: Any) -> tuple[FloatArray, FloatArray]:
    nq, nv = robot.nq, robot.nv
    if isinstance(x0, tuple | list) and len(x0) == 2:
        q0 = robot.check_configuration(x0[0], "x0[0] (q0)")
        v0 = robot.check_velocity(x0[1], "x0[1] (v0)")
        return q0, v0
    x = as_vector(x0, nq + nv, "x0 (q0 and v0 concatenated)")
    return robot.check_configuration(x[:nq], "q0"), robot.check_velocity(x[nq:], "v0")


def _integrator(value: Integrator | str) -> Integrator:
    if isinstance(value, Integrator):
        return value
    try:
        return Integrator(value)
    except ValueError:
        valid = ", ".join(i.value for i in Integrator)
        raise InvalidInputError(
            f"unknown integrator {value!r}; valid integrators are: {valid}"
        ) from None


def available_memory_bytes() -> int | None:
    """Memory the process may still allocate [bytes], ``None`` when the platform does not tell.

    ``MemAvailable`` of ``/proc/meminfo`` (else ``sysconf``), capped by a cgroup v2
    ``memory.max``.
    """
    available: int | None = None
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        available = None
    if available is None:
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, OSError, ValueError):
            return None
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as f:
            limit = f.read().strip()
        with open("/sys/fs/cgroup/memory.current", encoding="ascii") as f:
            used = int(f.read().strip())
        if limit != "max":
            available = min(available, max(0, int(limit) - used))
    except (OSError, ValueError):
        pass
    return available


def memory_budget(cap: int) -> int:
    """Bytes a table or record may take: ``cap``, or half the available memory when less."""
    available = available_memory_bytes()
    return cap if available is None else min(cap, available // 2)


def check_record_size(
    n_steps: int, nq: int, nv: int, T: float, dt: float, *, name: str = "simulate", extra: int = 0
) -> None:
    """Raise before allocating a record that would not fit in half the available memory.

    Args:
        n_steps: steps of the run (``n_steps + 1`` samples).
        nq, nv: sizes of the configuration and the velocity.
        T, dt: duration and time step [s] (for the message).
        name: the simulating function (for the message).
        extra: further floats per sample (contact forces...).
    """
    row = 8 * (nq + 3 * nv + 3 + extra)  # t, q, v, a, tau, kinetic and potential energy
    needed = (n_steps + 1) * row
    budget = memory_budget(MAX_RECORD_BYTES)
    if needed > budget:
        raise InvalidInputError(
            f"{name}(T={T:g}, dt={dt:g}) would record {_count(n_steps + 1)} samples "
            f"({needed / 1e9:.3g} GB) but the budget is {budget / 1e9:.3g} GB (half the "
            "available memory, at most "
            f"{MAX_RECORD_BYTES / 2**30:g} GiB); shorten T, increase dt, or run several shorter "
            "simulations from the last state"
        )


def _count(n: int) -> str:
    """``n`` with thousands separators, or as ``1.23e+300`` beyond 15 digits."""
    return f"{n:,}" if n < 10**15 else f"{float(n):.3g}"


def _warn_unactuated(robot: Robot, tau: FloatArray, unactuated: Any, t: float) -> None:
    """Warn that the controller pushes coordinates without a motor (effort limit 0)."""
    pushed = [int(i) for i in unactuated if tau[i] != 0.0]
    base = [i for i in pushed if robot.is_floating and i < 6]
    model = robot._model
    joints = sorted(
        {
            str(model.names[j])
            for j in range(1, model.njoints)
            for i in pushed
            if i not in base
            and model.joints[j].idx_v <= i < model.joints[j].idx_v + model.joints[j].nv
        }
    )
    what = (["the floating base"] if base else []) + [f"joint '{j}'" for j in joints]
    warnings.warn(
        f"simulate({robot.name}): the controller applies torque on {', '.join(what)} at "
        f"t={t:.6g} s, which has no motor (effort limit 0); the simulation applies it as an "
        "external force. Use SimulationOptions(clip_torque=True) to drop it.",
        TaskspaceWarning,
        stacklevel=4,
    )


def _show_progress(options: SimulationOptions, steps: int) -> bool:
    if options.progress is not None:
        return bool(options.progress)
    return steps >= options.progress_min_steps and sys.stderr.isatty()


def simulate(
    robot: Robot,
    controller: Controller | None,
    x0: Any,
    T: float,
    dt: float,
    options: SimulationOptions | None = None,
) -> SimulationTrajectory:
    """Simulate ``M(q) q'' + C(q, v) v + G(q) = u + tau_friction(v)`` from ``x0`` for ``T``.

    Args:
        robot: the robot (fixed or floating base; no contacts).
        controller: ``tau = controller(t, q, v)`` returning nv torques [N m, N]; ``None`` for
            a passive run (zero torque).
        x0: initial state, ``(q0, v0)`` or the concatenated vector of size nq + nv.
        T: duration [s] (> 0, finite); the run has ``N = round(T / dt)`` steps.
        dt: time step [s] (> 0, <= T).
        options: see :class:`SimulationOptions`.

    Returns:
        The :class:`SimulationTrajectory` (truncated at the last finite sample if the state
        diverged: ``success=False``, ``status=DIVERGED``).

    Raises:
        InvalidInputError: bad ``T``, ``dt``, controller, options, integrator or initial state; a
            record (``N + 1`` rows of ``t, q, v, a, tau`` and energies) that would need more
            than half the available memory (checked before allocating).
        KeyboardInterrupt: Ctrl-C stops a long run between two steps.
        ShapeError, NotFiniteError: the controller returned a wrong-size or non-finite torque.
    """
    options = SimulationOptions() if options is None else options
    if not isinstance(options, SimulationOptions):  # a dict raised a bare AttributeError
        raise InvalidInputError(
            f"options must be a SimulationOptions, got {type(options).__name__}"
        )
    integrator = _integrator(options.integrator)
    T = check_positive(T, "T (duration [s])")
    dt = check_positive(dt, "dt (time step [s])")
    if dt > T:
        raise InvalidInputError(f"dt must not exceed T, got dt={dt} > T={T}")
    if controller is not None and not callable(controller):
        raise InvalidInputError(
            f"controller must be callable as controller(t, q, v) -> tau, got {controller!r}"
        )
    check_positive(options.max_velocity, "max_velocity")
    q, v = _initial_state(robot, x0)
    n_steps = max(1, round(T / dt))
    nq, nv = robot.nq, robot.nv
    check_record_size(n_steps, nq, nv, T, dt)
    model = robot._model
    dynamics = ForwardDynamics(robot, options.friction)
    energy_data = model.createData()
    step = STEPPERS[integrator]
    zero = np.zeros(nv)
    lo = -robot.effort_limits
    hi = robot.effort_limits
    # coordinates without a motor (floating base, passive joints): a torque there is an
    # external force, applied as the equation says but reported once (it was silent)
    unactuated = np.flatnonzero(hi == 0.0) if not options.clip_torque else np.zeros(0, int)
    warned = [not unactuated.size]

    def control(t: float, qk: FloatArray, vk: FloatArray) -> FloatArray:
        if controller is None:
            return zero
        raw = controller(t, qk, vk)
        if type(raw) is np.ndarray and raw.dtype == np.float64 and raw.shape == (nv,):
            tau = raw
        else:
            try:
                tau = np.asarray(raw, dtype=float)
            except (TypeError, ValueError) as exc:
                raise InvalidInputError(
                    f"controller returned {type(raw).__name__}, not an array of numbers"
                ) from exc
            if tau.shape != (nv,):
                raise ShapeError(f"controller torque at t={t:.6g}", (nv,), tau.shape)
        if not math.isfinite(float(np.vdot(tau, tau))):
            check_finite(tau, f"controller torque at t={t:.6g}")
        if options.clip_torque:
            tau = np.clip(tau, lo, hi)
        elif not warned[0] and np.any(tau[unactuated]):
            warned[0] = True
            _warn_unactuated(robot, tau, unactuated, t)
        return tau

    ts = np.arange(n_steps + 1, dtype=np.float64) * dt
    Q = np.empty((n_steps + 1, nq))
    V = np.empty((n_steps + 1, nv))
    A = np.empty((n_steps + 1, nv))
    TAU = np.empty((n_steps + 1, nv))
    KE = np.full(n_steps + 1, np.nan)
    PE = np.full(n_steps + 1, np.nan)
    Q[0], V[0] = q, v

    show = _show_progress(options, n_steps)
    bar: Any = None
    if show:
        from tqdm import tqdm

        bar = tqdm(total=n_steps, desc=f"simulate {robot.name}", unit="step", leave=False)
    report_every = max(1, n_steps // 200)
    status = SimulationStatus.COMPLETED
    message = f"{n_steps} steps of {integrator.value} with dt={dt:g} s"
    last = n_steps
    t0 = time.perf_counter()
    try:
        for k in range(n_steps):
            t = float(ts[k])
            tau = control(t, q, v)
            TAU[k] = tau
            if options.record_energy:
                KE[k] = pin.computeKineticEnergy(model, energy_data, q, v)
                PE[k] = pin.computePotentialEnergy(model, energy_data, q)
            if options.hold_control:
                q, v, a = step(dynamics, q, v, dt, tau, t)
            else:
                q, v, a = step(dynamics, q, v, dt, control, t)
            A[k] = a
            Q[k + 1], V[k + 1] = q, v
            vmax = float(np.max(np.abs(v))) if nv else 0.0
            if not (math.isfinite(vmax) and vmax <= options.max_velocity) or not np.all(
                np.isfinite(q)
            ):
                status = SimulationStatus.DIVERGED
                last = k
                message = (
                    f"state diverged at t={ts[k + 1]:.6g} s (|v|_inf={vmax:.3g}); "
                    "reduce dt or check the controller"
                )
                logger.warning("simulate(%s): %s", robot.name, message)
                break
            if bar is not None and (k + 1) % report_every == 0:
                bar.update(report_every)
        if status is SimulationStatus.COMPLETED:
            t = float(ts[n_steps])
            tau = control(t, q, v)
            TAU[n_steps] = tau
            A[n_steps] = dynamics.acceleration(q, v, tau)
            if options.record_energy:
                KE[n_steps] = pin.computeKineticEnergy(model, energy_data, q, v)
                PE[n_steps] = pin.computePotentialEnergy(model, energy_data, q)
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    end = last + 1
    return SimulationTrajectory(
        success=status is SimulationStatus.COMPLETED,
        status=status,
        t=ts[:end],
        q=Q[:end],
        v=V[:end],
        a=A[:end],
        tau=TAU[:end],
        kinetic_energy=KE[:end],
        potential_energy=PE[:end],
        dt=dt,
        integrator=integrator,
        steps=last,
        wall_time=wall,
        message=message,
    )
