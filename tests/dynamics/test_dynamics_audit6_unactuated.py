"""simulate with a controller that pushes unactuated coordinates, new-user sweep audit6.

Before: a torque on the cart-pole's passive hinge or on a floating base (effort limit 0:
no motor) was applied silently, e.g. gravity compensation held a quadruped in the air by
its base. Now simulate warns once per run (TaskspaceWarning naming the joints), since the
torque acts as an external force; ``clip_torque=True`` drops it (effort limit 0).
Reference: the cart-pole under a hinge torque follows Pinocchio's ABA with that torque.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.dynamics import SimulationOptions, gravity_torque, simulate
from taskspace.errors import TaskspaceWarning


def test_a_torque_on_a_passive_joint_is_reported(robot_loader: Any) -> None:
    cartpole = robot_loader("cartpole")
    x0 = (np.zeros(2), np.zeros(2))
    with pytest.warns(TaskspaceWarning, match="hinge") as caught:
        sim = simulate(cartpole, lambda t, q, v: np.array([0.0, 0.5]), x0, 0.01, 1e-3)
    assert sum(issubclass(w.category, TaskspaceWarning) for w in caught) == 1  # once per run
    # the torque is still applied, as the equation of motion says
    a0 = pin.aba(cartpole.model, cartpole.model.createData(), x0[0], x0[1], np.array([0.0, 0.5]))
    np.testing.assert_allclose(sim.a[0], a0, rtol=1e-12)


def test_actuated_or_clipped_torques_are_silent(robot_loader: Any) -> None:
    cartpole = robot_loader("cartpole")
    x0 = (np.zeros(2), np.zeros(2))
    with warnings.catch_warnings():
        warnings.simplefilter("error", TaskspaceWarning)
        simulate(cartpole, lambda t, q, v: np.array([3.0, 0.0]), x0, 0.01, 1e-3)
        sim = simulate(
            cartpole,
            lambda t, q, v: np.array([3.0, 0.5]),
            x0,
            0.01,
            1e-3,
            SimulationOptions(clip_torque=True),
        )
    assert np.all(sim.tau[:, 1] == 0.0)


def test_a_floating_base_held_by_torques_is_reported(robot_loader: Any) -> None:
    solo = robot_loader("solo12")
    with pytest.warns(TaskspaceWarning, match="floating base"):
        simulate(
            solo,
            lambda t, q, v: gravity_torque(solo, q),
            (solo.q_default, np.zeros(solo.nv)),
            0.01,
            1e-3,
        )
