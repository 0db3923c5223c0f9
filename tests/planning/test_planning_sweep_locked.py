"""Locked joints, metric weights and MechanicalWork on a locked-joint space (sweep 35).

A bool value was locked at 1.0 rad, text raised NumPy's bare ValueError; MechanicalWork given
the full robot on a locked-joint (Euclidean) space said only that the sizes differ.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.planning import ConfigurationSpace, MechanicalWork


@pytest.fixture(scope="module")
def ur5() -> Robot:
    return Robot.load("ur5")


@pytest.mark.parametrize("value", [True, "0.3", None, [0.1, 0.2]])
def test_locked_value_must_be_the_joints_numbers(ur5: Robot, value: object) -> None:
    with pytest.raises(InvalidInputError, match="shoulder_lift_joint"):
        ConfigurationSpace.from_robot(ur5, locked_joints={"shoulder_lift_joint": value})


def test_locked_value_numpy_scalar_is_locked_exactly(ur5: Robot) -> None:
    space = ConfigurationSpace.from_robot(
        ur5, locked_joints={"shoulder_lift_joint": np.float32(0.25)}
    )
    full = space.full_configurations(np.zeros((1, 5)))
    assert full.shape == (1, 6) and full[0, 1] == float(np.float32(0.25))


def test_mechanical_work_on_a_locked_space_names_the_reduced_model(ur5: Robot) -> None:
    space = ConfigurationSpace.from_robot(ur5, locked_joints={"shoulder_lift_joint": -1.0})
    q0, q1 = np.zeros(5), np.full(5, 0.4)
    with pytest.raises(InvalidInputError, match="planning_model"):
        MechanicalWork(ur5).motion_cost(q0, q1)
    # the reduced model's work equals the full model's with the joint held (same gravity)
    reduced = MechanicalWork(space.planning_model, resolution=np.inf).motion_cost(q0, q1)
    full0, full1 = space.full_configurations(np.stack([q0, q1]))
    tau = pin.computeGeneralizedGravity(ur5.model, ur5.model.createData(), (full0 + full1) / 2)
    assert reduced == pytest.approx(abs(float(tau @ (full1 - full0))), rel=1e-10)


def test_metric_weights_whose_distances_overflow_are_refused(ur5: Robot) -> None:
    # the space was built, then every distance was inf: planners failed with errors about
    # the motions (or, before the sweep, NumPy's / math's bare errors)
    with pytest.raises(InvalidInputError, match="weights are too large"):
        ConfigurationSpace.from_robot(ur5, weights=[1e300] * 6)
    space = ConfigurationSpace.from_robot(ur5, weights=[2.0, 1, 1, 1, 1, 1])
    assert space.distance(np.zeros(6), np.array([0.5, 0, 0, 0, 0, 0])) == pytest.approx(1.0)
