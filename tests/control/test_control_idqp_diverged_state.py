"""A diverged state (v = 1e20 rad/s) is refused naming the joint, not "a lower bound of +inf".

The joint-limit acceleration bounds ``(v_max - v) / T`` of such a state lie beyond ``INF``
(1e20): the QP refused "lower bound entries [1] are +inf ... use -inf for no bound", which
says nothing of the state. The reference is Pinocchio's joint table (``idx_v``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace import features as F
from taskspace.control import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import InvalidInputError
from taskspace.model import Robot
from taskspace.tasks import Task


@pytest.mark.parametrize("hierarchical", [False, True])
def test_diverged_velocity_names_the_joint(hierarchical: bool) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.load("ur5", geometry=False)
    model = robot._model
    name = next(model.names[j] for j in range(1, model.njoints) if model.joints[j].idx_v == 1)
    v = np.zeros(robot.nv)
    v[1] = 1e20
    posture = Task(F.JointConfiguration(robot), robot.q_default, kp=10.0)
    ctrl = InverseDynamicsQP(
        robot, [posture], options=InverseDynamicsOptions(hierarchical=hierarchical)
    )
    with pytest.raises(InvalidInputError, match=rf"acceleration bounds of \['{name}'\]"):
        ctrl.solve(robot.state(robot.q_default, v))
    # a normal state afterwards is answered
    assert ctrl.solve(robot.state(robot.q_default, np.zeros(robot.nv))).success
