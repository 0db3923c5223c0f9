from __future__ import annotations

import numpy as np
import pytest

from taskspace.control import (
    AdaptiveOptions,
    AdaptivePendulumController,
    ReferenceModel,
    simulate_adaptive_pendulum,
)
from taskspace.dynamics.pendulum import pendulum_torque
from taskspace.errors import InvalidInputError


def _command(t: float) -> float:
    return float(np.sin(1.3 * t) + 0.5 * np.sin(2.9 * t))


@pytest.mark.parametrize(
    ("mass", "gravity", "rate"), [(2.0, 9.81, 2.0), (0.4, 9.81, 2.0), (3.0, 0.0, 20.0)]
)
def test_lyapunov_non_increasing_and_tracking(mass: float, gravity: float, rate: float) -> None:
    # gravity = 0: the point mass m x'' = u (weaker excitation, faster adaptation).
    ctrl = AdaptivePendulumController(
        length=0.8, gravity=gravity, options=AdaptiveOptions(adaptation_rate=rate)
    )
    sim = simulate_adaptive_pendulum(
        ctrl,
        true_mass=mass,
        command=_command,
        duration=10.0,
        dt=5e-3,
        initial_state=(0.3, -0.5),
        initial_mass_estimate=1.0,
    )
    V = sim.lyapunov
    # V' = -k s^2 <= 0 along exact trajectories; RK4 error is far below this slack.
    assert np.all(np.diff(V) <= 1e-9 * V[0])
    assert V[-1] < 1e-4 * V[0]
    assert np.abs(sim.tracking_error[-200:]).max() < 1e-3
    # With a persistently exciting command the mass estimate converges.
    assert abs(sim.mass_estimate[-1] - mass) < 1e-2 * mass


def test_closed_loop_matches_the_lyapunov_derivative() -> None:
    # dV/dt = -k s^2 (finite differences of V against the formula).
    ctrl = AdaptivePendulumController(options=AdaptiveOptions(feedback_gain=3.0))
    sim = simulate_adaptive_pendulum(
        ctrl, true_mass=1.5, command=_command, duration=2.0, dt=1e-3, initial_state=(0.5, 0.0)
    )
    s = np.array(
        [
            ctrl.sliding_variable(sim.theta[k], sim.theta_dot[k], tuple(sim.reference[k]))
            for k in range(sim.time.size)
        ]
    )
    dV = np.gradient(sim.lyapunov, sim.time)
    assert np.allclose(dV[5:-5], -3.0 * s[5:-5] ** 2, atol=1e-4 * abs(dV).max())


def test_torque_uses_the_pendulum_model_with_a_known_mass() -> None:
    # With the true mass and zero tracking error the torque is the inverse dynamics.
    ctrl = AdaptivePendulumController(length=0.7)
    ref = (0.4, 0.2, -1.1)
    u, dm = ctrl.torque(0.4, 0.2, ref, 2.5)
    assert u == pytest.approx(float(pendulum_torque(0.4, -1.1, mass=2.5, length=0.7)))
    assert dm == 0.0


def test_without_adaptation_a_wrong_mass_leaves_an_error() -> None:
    # Mutation check: the adaptation law is what removes the error.
    ctrl = AdaptivePendulumController(options=AdaptiveOptions(adaptation_rate=1e-9))
    sim = simulate_adaptive_pendulum(
        ctrl,
        true_mass=3.0,
        command=_command,
        duration=10.0,
        dt=5e-3,
        reference_model=ReferenceModel(natural_frequency=3.0),
        initial_mass_estimate=1.0,
    )
    assert np.abs(sim.tracking_error[-200:]).max() > 1e-2


def test_errors() -> None:
    with pytest.raises(InvalidInputError):
        AdaptivePendulumController(length=-1.0)
    with pytest.raises(InvalidInputError):
        simulate_adaptive_pendulum(
            AdaptivePendulumController(), true_mass=0.0, command=_command, duration=1.0
        )
