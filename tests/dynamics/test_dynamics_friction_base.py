"""JointFriction acts on the joints, never on the base: free-flyer (6) or planar (3) velocities.

A planar base (``base="planar"``) took the friction as a joint: a scalar damping damped the
base's x, y and yaw, and a vector needed nv entries (base included). The reference is
Pinocchio's ABA with the friction torque written out here.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.dynamics import ForwardDynamics, JointFriction
from taskspace.errors import ShapeError
from taskspace.model import Robot


def _robot(base: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("ur5", base=base, geometry=False)


@pytest.mark.parametrize(("base", "n_base"), [("fixed", 0), ("planar", 3), ("free_flyer", 6)])
def test_friction_skips_the_base_against_aba(base: str, n_base: int) -> None:
    robot = _robot(base)
    rng = np.random.default_rng(3)
    q = robot.random_configuration(rng)
    v = rng.uniform(-1.0, 1.0, robot.nv)
    tau = rng.uniform(-5.0, 5.0, robot.nv)
    damping = np.linspace(0.1, 0.6, robot.nv - n_base)
    friction = JointFriction(damping=tuple(damping), coulomb=0.3, coulomb_smoothing=0.05)
    dyn = ForwardDynamics(robot, friction)
    tau_f = np.zeros(robot.nv)
    vj = v[n_base:]
    tau_f[n_base:] = -damping * vj - 0.3 * np.tanh(vj / 0.05)
    model = robot.model
    ref = pin.aba(model, model.createData(), q, v, tau + tau_f)
    np.testing.assert_allclose(dyn.friction_torque(v), tau_f, rtol=0, atol=1e-15)
    np.testing.assert_allclose(dyn.acceleration(q, v, tau), ref, rtol=1e-10, atol=1e-10)


def test_planar_base_vector_of_nv_entries_is_refused_with_the_count() -> None:
    robot = _robot("planar")
    with pytest.raises(ShapeError, match="after the 3-dof base"):
        ForwardDynamics(robot, JointFriction(damping=tuple([0.1] * robot.nv)))
