"""Model-reference adaptive control of a pendulum (or point mass) with an unknown mass.

Plant (slide 5:22): ``m (l^2 theta'' + g l sin theta) = u`` with the mass ``m`` unknown; the
torque is linear in it, ``u = Y m`` with the regressor ``Y = l^2 theta'' + g l sin theta``.
``g = 0`` and ``l = 1`` give the point mass ``m x'' = u``.

Reference model: a critically damped (or any) second-order filter of the command ``r``,
``theta_m'' = w^2 (r - theta_m) - 2 zeta w theta_m'``, whose output the plant must follow.

Controller (Slotine-Li adaptive computed torque): with ``e = theta - theta_m``, the sliding
variable ``s = e' + lambda e``, the reference velocity ``theta_r' = theta_m' - lambda e`` and
``Y_r = l^2 theta_r'' + g l sin theta``,

``u = m_hat Y_r - k s``,  ``m_hat' = -gamma Y_r s``.

Lyapunov argument: the closed loop is ``m l^2 s' = (m_hat - m) Y_r - k s``; with
``V = 1/2 m l^2 s^2 + 1/(2 gamma) (m_hat - m)^2``,
``V' = s ((m_hat - m) Y_r - k s) + (m_hat - m) m_hat' / gamma = -k s^2 <= 0``.
So ``V`` never increases, ``s`` is square integrable and bounded, and by Barbalat's lemma
``s -> 0``, hence ``e -> 0`` (``e`` is ``s`` filtered by ``1 / (p + lambda)``). The mass estimate
converges to ``m`` only if ``Y_r`` is persistently exciting.

Thread safety: :class:`ReferenceModel` and :class:`AdaptiveOptions` are immutable;
:class:`AdaptivePendulumController` keeps only its constants (the parameter estimate is part of the
simulated state passed to its methods), so it may be shared by threads;
:func:`simulate_adaptive_pendulum` keeps its state local to the call; an
:class:`AdaptiveSimulation` is plain result data (arrays), not locked: do not modify it while
another thread reads it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from taskspace._validation import FloatArray, as_scalar, as_vector, check_positive
from taskspace.dynamics.pendulum import STANDARD_GRAVITY
from taskspace.dynamics.simulation import MAX_RECORD_BYTES, memory_budget
from taskspace.errors import InvalidInputError, SolverError, TaskspaceError


@dataclass(frozen=True, kw_only=True)
class ReferenceModel:
    """Second-order reference model ``theta_m'' = w^2 (r - theta_m) - 2 zeta w theta_m'``.

    Attributes:
        natural_frequency: ``w`` [rad/s].
        damping_ratio: ``zeta`` (1: critically damped, no overshoot).
    """

    natural_frequency: float = 2.0
    damping_ratio: float = 1.0

    def acceleration(self, position: float, velocity: float, command: float) -> float:
        """``theta_m''`` [rad/s^2] for the model state and the command ``r`` [rad]."""
        w = self.natural_frequency
        return w * w * (command - position) - 2.0 * self.damping_ratio * w * velocity


@dataclass(frozen=True, kw_only=True)
class AdaptiveOptions:
    """Gains of :class:`AdaptivePendulumController`.

    Attributes:
        slope: ``lambda`` of the sliding variable ``s = e' + lambda e`` [1/s].
        feedback_gain: ``k`` [N m s/rad].
        adaptation_rate: ``gamma`` [kg^2 s / (N m rad)], larger adapts faster.
    """

    slope: float = 4.0
    feedback_gain: float = 5.0
    adaptation_rate: float = 2.0


class AdaptivePendulumController:
    """Adaptive computed torque for ``m (l^2 theta'' + g l sin theta) = u`` with unknown ``m``.

    Args:
        length: known distance hinge-mass ``l`` [m].
        gravity: ``g`` [m/s^2] (0 for a horizontal point mass).
        options: gains, see :class:`AdaptiveOptions`.
    """

    def __init__(
        self,
        length: float = 1.0,
        gravity: float = STANDARD_GRAVITY,
        options: AdaptiveOptions | None = None,
    ) -> None:
        self.length = check_positive(length, "length [m]")
        self.gravity = check_positive(gravity, "gravity [m/s^2]", strict=False)
        self.options = options or AdaptiveOptions()
        check_positive(self.options.slope, "slope [1/s]")
        check_positive(self.options.feedback_gain, "feedback_gain")
        check_positive(self.options.adaptation_rate, "adaptation_rate")

    def sliding_variable(
        self, theta: float, theta_dot: float, reference: tuple[float, float, float]
    ) -> float:
        """``s = e' + lambda e`` with ``e = theta - theta_m`` [rad/s]."""
        pos, vel, _ = reference
        return (theta_dot - vel) + self.options.slope * (theta - pos)

    def regressor(
        self, theta: float, theta_dot: float, reference: tuple[float, float, float]
    ) -> float:
        """``Y_r = l^2 theta_r'' + g l sin theta`` with ``theta_r'' = theta_m'' - lambda e'``."""
        _, vel, acc = reference
        ddq_r = acc - self.options.slope * (theta_dot - vel)
        return self.length**2 * ddq_r + self.gravity * self.length * float(np.sin(theta))

    def torque(
        self,
        theta: float,
        theta_dot: float,
        reference: tuple[float, float, float],
        mass_estimate: float,
    ) -> tuple[float, float]:
        """Torque ``u = m_hat Y_r - k s`` [N m] and the adaptation ``m_hat' = -gamma Y_r s``.

        Args:
            theta, theta_dot: plant state [rad, rad/s].
            reference: reference model position, velocity, acceleration.
            mass_estimate: current ``m_hat`` [kg].
        """
        s = self.sliding_variable(theta, theta_dot, reference)
        y = self.regressor(theta, theta_dot, reference)
        u = mass_estimate * y - self.options.feedback_gain * s
        return u, -self.options.adaptation_rate * y * s

    def lyapunov(
        self,
        theta: float,
        theta_dot: float,
        reference: tuple[float, float, float],
        mass_estimate: float,
        true_mass: float,
    ) -> float:
        """``V = 1/2 m l^2 s^2 + 1/(2 gamma) (m_hat - m)^2`` (needs the true mass)."""
        s = self.sliding_variable(theta, theta_dot, reference)
        err = mass_estimate - true_mass
        return 0.5 * true_mass * self.length**2 * s * s + 0.5 * err * err / (
            self.options.adaptation_rate
        )


@dataclass
class AdaptiveSimulation:
    """Closed-loop trajectory of :func:`simulate_adaptive_pendulum` (``K`` samples).

    Attributes:
        time: sample times [s] (K,).
        theta, theta_dot: plant state [rad, rad/s] (K,).
        reference: reference model position, velocity, acceleration (K x 3).
        mass_estimate: ``m_hat`` [kg] (K,).
        torque: applied torque [N m] (K,).
        lyapunov: ``V`` along the trajectory (K,).
        tracking_error: ``theta - theta_m`` [rad] (K,).
    """

    time: FloatArray
    theta: FloatArray
    theta_dot: FloatArray
    reference: FloatArray
    mass_estimate: FloatArray
    torque: FloatArray
    lyapunov: FloatArray
    tracking_error: FloatArray


def simulate_adaptive_pendulum(
    controller: AdaptivePendulumController,
    *,
    true_mass: float,
    command: Callable[[float], float],
    duration: float,
    dt: float = 1e-3,
    reference_model: ReferenceModel | None = None,
    initial_state: tuple[float, float] = (0.0, 0.0),
    initial_mass_estimate: float = 0.5,
) -> AdaptiveSimulation:
    """Integrate plant, reference model and adaptation law together with RK4.

    State ``z = [theta, theta', theta_m, theta_m', m_hat]``; the plant is the forward dynamics of
    :func:`taskspace.dynamics.pendulum.pendulum_acceleration` with the true mass.

    Args:
        controller: the adaptive controller (its ``length`` and ``gravity`` are the plant's).
        true_mass: the plant's mass ``m`` [kg], unknown to the controller.
        command: ``r(t)`` [rad].
        duration: simulated time [s].
        dt: RK4 step [s].
        reference_model: see :class:`ReferenceModel`.
        initial_state: plant ``(theta, theta')`` [rad, rad/s]; the model starts at rest at 0.
        initial_mass_estimate: ``m_hat(0)`` [kg].

    Raises:
        InvalidInputError: bad arguments, a record larger than half the available memory, a
            ``command`` that raises or returns a non-finite or non-scalar value.
        SolverError: the closed loop diverges (non-finite state).
    """
    if not isinstance(controller, AdaptivePendulumController):
        raise InvalidInputError(
            f"controller must be an AdaptivePendulumController, got {type(controller).__name__}"
        )
    if not callable(command):
        raise InvalidInputError(f"command must be a function r(t) [rad], got {command!r}")
    true_mass = check_positive(true_mass, "true_mass [kg]")
    duration = check_positive(duration, "duration [s]")
    dt = check_positive(dt, "dt [s]")
    if dt > duration:  # one step of dt was taken: the record covered dt, not duration
        raise InvalidInputError(f"dt = {dt:g} s must be <= duration = {duration:g} s")
    initial_mass_estimate = as_scalar(initial_mass_estimate, "initial_mass_estimate")
    theta0, theta_dot0 = as_vector(initial_state, 2, "initial_state")
    model = reference_model or ReferenceModel()
    if not isinstance(model, ReferenceModel):
        raise InvalidInputError(f"reference_model must be a ReferenceModel, got {model!r}")
    check_positive(model.natural_frequency, "ReferenceModel.natural_frequency [rad/s]")
    check_positive(model.damping_ratio, "ReferenceModel.damping_ratio")
    samples = duration / dt + 1.0
    needed = 8 * 12 * samples  # rows (5), times, torques, refs (3), lyapunov, error
    budget = memory_budget(MAX_RECORD_BYTES)
    if not needed <= budget:
        raise InvalidInputError(
            f"simulate_adaptive_pendulum(duration={duration:g}, dt={dt:g}) would record "
            f"{samples:.3g} samples ({needed / 1e9:.3g} GB) but the budget is "
            f"{budget / 1e9:.3g} GB (half the available memory): use a larger dt or a shorter "
            "duration"
        )
    length, gravity = controller.length, controller.gravity

    def command_at(t: float) -> float:
        try:
            value = command(t)
        except TaskspaceError:
            raise
        except Exception as exc:
            raise InvalidInputError(
                f"the user function command raised {type(exc).__name__} at t = {t:g} s: {exc}"
            ) from exc
        r = as_scalar(value, f"command({t:g})")  # NaN made the whole run NaN, silently
        return r

    def ref(z: FloatArray, t: float) -> tuple[float, float, float]:
        return (
            float(z[2]),
            float(z[3]),
            model.acceleration(float(z[2]), float(z[3]), command_at(t)),
        )

    def f(z: FloatArray, t: float) -> tuple[FloatArray, float]:
        r = ref(z, t)
        u, dm = controller.torque(float(z[0]), float(z[1]), r, float(z[4]))
        # pendulum_acceleration's closed form, inlined (it validates its inputs each call).
        ddq = (u - true_mass * gravity * length * float(np.sin(z[0]))) / (true_mass * length**2)
        return np.array([z[1], ddq, z[3], r[2], dm]), u

    steps = int(np.ceil(duration / dt))
    z = np.array([theta0, theta_dot0, 0.0, 0.0, initial_mass_estimate], dtype=float)
    rows = np.empty((steps + 1, 5))
    times = np.arange(steps + 1, dtype=np.float64) * float(dt)
    torques = np.empty(steps + 1)
    for k in range(steps + 1):
        rows[k] = z
        t = float(times[k])
        k1, torques[k] = f(z, t)
        if k == steps:
            break
        k2, _ = f(z + 0.5 * dt * k1, t + 0.5 * dt)
        k3, _ = f(z + 0.5 * dt * k2, t + 0.5 * dt)
        k4, _ = f(z + dt * k3, t + dt)
        with np.errstate(over="ignore", invalid="ignore"):
            z = z + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(z)):  # a diverging loop returned NaN trajectories
            raise SolverError(
                f"the closed loop diverged (non-finite state at t = {t + dt:g} s): reduce dt "
                "(RK4 stability: dt * feedback_gain / (m l^2) must stay small) or the gains"
            )
    refs = np.array([ref(rows[k], float(times[k])) for k in range(steps + 1)])
    V = np.array(
        [
            controller.lyapunov(rows[k, 0], rows[k, 1], tuple(refs[k]), rows[k, 4], true_mass)
            for k in range(steps + 1)
        ]
    )
    return AdaptiveSimulation(
        time=times,
        theta=rows[:, 0].copy(),
        theta_dot=rows[:, 1].copy(),
        reference=refs,
        mass_estimate=rows[:, 4].copy(),
        torque=torques,
        lyapunov=V,
        tracking_error=rows[:, 0] - rows[:, 2],
    )
