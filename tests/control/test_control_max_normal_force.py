"""Maximum normal force per contact in InverseDynamicsQP (issue #16, item 5)."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace import features as F
from taskspace.constraints import Contact6D, PointContact
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.errors import TaskspaceError
from taskspace.tasks import Task
from tests.conftest import load_robot

FEET = ["left_ankle_roll_link", "right_ankle_roll_link"]


def _controller(max_force: float | None, hierarchical: bool = False):  # type: ignore[no-untyped-def]
    robot = load_robot("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [
        Contact6D(robot, f, half_length=0.1, half_width=0.03, max_force=max_force) for f in FEET
    ]
    com = Task(F.CenterOfMass(robot), kp=400.0, priority=0)
    com.set_target_from_state(s)
    com.set_target(com.target + np.array([0.0, 0.02, 0.0]))  # a sideways push: loads one foot
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=1)
    options = InverseDynamicsOptions(hierarchical=hierarchical)
    return InverseDynamicsQP(robot, [com, posture], contacts, options), s


@pytest.mark.parametrize("hierarchical", [False, True])
def test_normal_force_stays_below_its_maximum(hierarchical: bool) -> None:
    free, s = _controller(None, hierarchical)
    res_free = free.solve(s)
    normal = [res_free.forces[name][2] for name in FEET]
    heavy, light = (0, 1) if normal[0] > normal[1] else (1, 0)
    limit = 0.5 * (normal[0] + normal[1]) + 0.25 * abs(normal[0] - normal[1])
    assert normal[heavy] > limit + 1.0  # the limit binds on the loaded foot
    limited, s = _controller(limit, hierarchical)
    res = limited.solve(s)
    assert res.success, res.status
    for name in FEET:
        assert res.forces[name][2] <= limit + 1e-6
    assert res.forces[FEET[heavy]][2] == pytest.approx(limit, abs=1e-5)  # active
    assert res.forces[FEET[light]][2] > normal[light] + 1.0  # the other foot takes more
    qps = res.level_results if hierarchical else [res.qp]
    for qp in qps:
        assert qp is not None and qp.kkt.within(1e-9, 1e-6), qp.kkt


def test_cone_row_and_errors() -> None:
    robot = load_robot("g1")
    c = Contact6D(robot, FEET[0], max_force=300.0)
    K, k = c.cone()
    f = np.array([0.0, 0.0, 301.0, 0, 0, 0])
    assert K[-1] @ f < k[-1]  # violated above the maximum
    f[2] = 299.0
    assert np.all(K @ f >= k)
    assert Contact6D(robot, FEET[0]).cone()[0].shape[0] == K.shape[0] - 1
    solo = load_robot("solo12")
    p = PointContact(solo, "FL_FOOT", max_force=50.0)
    K, k = p.cone()
    assert K[-1] @ np.array([0.0, 0.0, 51.0]) < k[-1]
    with pytest.raises(TaskspaceError, match="max_force"):
        Contact6D(robot, FEET[0], min_force=10.0, max_force=5.0)
    with pytest.raises(TaskspaceError, match="max_force"):
        Contact6D(robot, FEET[0], max_force=float("nan"))
    with pytest.raises(TaskspaceError, match="max_force"):
        PointContact(solo, "FL_FOOT", max_force=-1.0)


def test_contact_gains_are_validated_and_cone_parameters_fixed() -> None:
    robot = load_robot("g1")
    c = Contact6D(robot, FEET[0], max_force=300.0)
    c.kd = 5.0
    c.kp = 1.0
    for bad in (float("nan"), -1.0, np.inf, "x"):
        with pytest.raises(TaskspaceError, match="kd of contact"):
            c.kd = bad  # type: ignore[assignment]
    assert c.kd == 5.0
    for name in ("friction", "min_force", "max_force", "half_width"):
        with pytest.raises(TaskspaceError, match="fixed at construction"):
            setattr(c, name, 1.0)
    with pytest.raises(TaskspaceError, match="kp"):
        Contact6D(robot, FEET[0], kp=-1.0)


@pytest.mark.parametrize(
    "field", ["acceleration_regularization", "force_regularization", "limits_horizon"]
)
def test_inverse_dynamics_options_are_validated(field: str) -> None:
    for bad in (float("nan"), -1.0):
        with pytest.raises(TaskspaceError, match=field):
            InverseDynamicsOptions(**{field: bad})
