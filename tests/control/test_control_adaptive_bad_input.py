"""Bad inputs to the adaptive pendulum simulation (issue #15): a right answer or a
TaskspaceError, never a bare exception, a NaN trajectory or a 3.5 PiB allocation.

Reference: with the true mass known from the start and the plant starting on the reference
model, the adaptive law keeps ``m_hat = m`` and the tracking error at 0 (``s = 0``, ``Y_r s = 0``).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.control import (
    AdaptiveOptions,
    AdaptivePendulumController,
    ReferenceModel,
    simulate_adaptive_pendulum,
)
from taskspace.errors import InvalidInputError, SolverError

CONTROLLER = AdaptivePendulumController()


def run(**kw: object):  # type: ignore[no-untyped-def]
    args: dict[str, object] = {
        "true_mass": 1.0,
        "command": lambda t: 0.0,
        "duration": 0.5,
        "dt": 0.01,
    }
    args.update(kw)
    controller = args.pop("controller", CONTROLLER)
    return simulate_adaptive_pendulum(controller, **args)  # type: ignore[arg-type]


def test_reference_equilibrium() -> None:
    sim = run(initial_mass_estimate=1.0)
    np.testing.assert_allclose(sim.tracking_error, 0.0, atol=1e-15)
    np.testing.assert_allclose(sim.mass_estimate, 1.0, atol=1e-15)


@pytest.mark.parametrize(
    "kw",
    [
        {"duration": 1e12},  # bare MemoryError (3.5 PiB)
        {"dt": 1e-15},  # bare MemoryError
        {"dt": 10.0},  # one 10 s step recorded for a 0.5 s run
        {"command": lambda t: np.nan},  # NaN trajectory
        {"command": lambda t: 1 / 0},  # bare ZeroDivisionError
        {"command": lambda t: "a"},  # bare TypeError
        {"command": None},
        {"command": lambda t: np.array([1.0, 2.0])},  # bare ValueError
        {"initial_state": (np.nan, 0.0)},  # NaN trajectory
        {"initial_state": "ab"},
        {"initial_state": (0.0, 0.0, 1.0)},  # third entry ignored
        {"initial_mass_estimate": "a"},
        {"initial_mass_estimate": 1j},
        {"reference_model": ReferenceModel(natural_frequency=np.nan)},  # NaN trajectory
        {"reference_model": ReferenceModel(natural_frequency=-2.0)},  # unstable model
        {"controller": None},  # bare AttributeError
    ],
)
def test_bad_arguments_are_refused(kw: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        run(**kw)


def test_divergence_is_an_error_not_a_nan_trajectory() -> None:
    stiff = AdaptivePendulumController(options=AdaptiveOptions(feedback_gain=1e12))
    with pytest.raises(SolverError, match="diverged"):
        run(controller=stiff, dt=0.1, duration=5.0, command=lambda t: 1.0)
