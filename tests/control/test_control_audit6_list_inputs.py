"""Joint-space controllers called with lists, new-user sweep audit6.

Before: ``ComputedTorqueController(...)(t, list_q, list_v)`` and the JointPDController raised
Boost.Python's bare ArgumentError ("difference(Model, list, numpy.ndarray) did not match
C++ signature"), while the other controllers (state feedback, operational space, PID) take
lists. Now the same torques as for float64 arrays; reference: Pinocchio's rnea / gravity.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace.control import ComputedTorqueController, JointPDController


@pytest.fixture(scope="module")
def ur5(robot_loader: Any) -> Any:
    return robot_loader("ur5")


def test_lists_give_the_torques_of_arrays(ur5: Any) -> None:
    model, data = ur5.model, ur5.model.createData()
    target = ur5.q_default + 0.1
    q = ur5.q_default - 0.2
    v = np.linspace(-0.5, 0.5, 6)
    ct = ComputedTorqueController(ur5, target, kp=25.0, kd=10.0)
    pd = JointPDController(ur5, target, kp=30.0, kd=4.0)
    expected_ct = pin.rnea(model, data, q, v, 25.0 * (target - q) - 10.0 * v)
    expected_pd = 30.0 * (target - q) - 4.0 * v + pin.computeGeneralizedGravity(model, data, q)
    for qq, vv in ((list(q), list(v)), (tuple(q), v), (q, list(v))):
        np.testing.assert_allclose(ct(0.0, qq, vv), expected_ct, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(pd(0.0, qq, vv), expected_pd, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(
            ct.desired_acceleration(0.0, qq, vv), 25.0 * (target - q) - 10.0 * v, atol=1e-12
        )
