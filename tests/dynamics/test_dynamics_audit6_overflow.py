"""Dynamics of finite inputs whose answer overflows float64, new-user sweep audit6.

Before: on ur5, ``inverse_dynamics(q, v=1e300, 0)``, ``nonlinear_effects``,
``coriolis_torque(v=1e200)``, ``inverse_dynamics(a=1e308)``, ``forward_dynamics(v=1e300)``,
``kinetic_energy(v=1e300)`` and ``linearize(v_eq=1e300)`` returned NaN silently (inf - inf in
the recursions). Now InvalidInputError naming the overflow. Ordinary large inputs keep
Pinocchio's answers (rnea, aba, computeKineticEnergy as the reference).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace import dynamics as D
from taskspace.control import linearize
from taskspace.errors import InvalidInputError


@pytest.fixture(scope="module")
def ur5(robot_loader: Any) -> Any:
    return robot_loader("ur5")


CASES: dict[str, Callable[[Any, Any, Any], Any]] = {
    "inverse_dynamics v": lambda r, q, z: D.inverse_dynamics(r, q, np.full(6, 1e300), z),
    "inverse_dynamics a": lambda r, q, z: D.inverse_dynamics(r, q, z, np.full(6, 1e308)),
    "nonlinear_effects": lambda r, q, z: D.nonlinear_effects(r, q, np.full(6, 1e300)),
    "coriolis_torque": lambda r, q, z: D.coriolis_torque(r, q, np.full(6, 1e200)),
    "forward_dynamics": lambda r, q, z: D.forward_dynamics(r, q, np.full(6, 1e300), z),
    "kinetic_energy": lambda r, q, z: D.kinetic_energy(r, q, np.full(6, 1e300)),
    "mechanical_energy": lambda r, q, z: D.mechanical_energy(r, q, np.full(6, 1e300)),
    "linearize": lambda r, q, z: linearize(r, q, np.full(6, 1e300)),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_an_overflowing_answer_is_an_error_not_nan(ur5: Any, name: str) -> None:
    with pytest.raises(InvalidInputError, match="overflow"):
        CASES[name](ur5, ur5.q_default, np.zeros(6))


def test_large_but_representable_inputs_keep_pinocchios_answers(ur5: Any) -> None:
    model, data = ur5.model, ur5.model.createData()
    q = ur5.q_default
    v = np.linspace(-1e10, 1e10, 6)
    a = np.linspace(1e12, -1e12, 6)
    np.testing.assert_array_equal(D.inverse_dynamics(ur5, q, v, a), pin.rnea(model, data, q, v, a))
    tau = np.full(6, 1e9)
    np.testing.assert_array_equal(
        D.forward_dynamics(ur5, q, v, tau), pin.aba(model, data, q, v, tau)
    )
    assert D.kinetic_energy(ur5, q, v) == pin.computeKineticEnergy(model, data, q, v)
