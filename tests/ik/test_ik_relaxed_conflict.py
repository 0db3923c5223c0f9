"""A relaxed weighted IK step's minimal conflict names the box constraints at fault only.

The QP's box is the intersection of the box constraints (one merged ``lb``, ``ub``), so a
relaxed QP's blocks could only name them all. DifferentialIK gives ``result.qp.conflict``
each box constraint as rows of its own. Reference (analytic): joint 1 of the Panda asked to
move 1 rad in one 5 ms step (a hard task) conflicts with its velocity limit (``v_max dt``
~ 0.011 rad) and not with its position range (the target lies inside it).
"""

from __future__ import annotations

import numpy as np

from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.features import JointConfiguration, Position
from taskspace.ik import DifferentialIK, IKStatus
from taskspace.model import Robot
from taskspace.tasks import Task

DT = 0.005


def test_conflict_names_the_velocity_limits_not_the_position_limits(panda: Robot) -> None:
    state = panda.state()
    target = panda.q_default.copy()
    target[0] += 1.0
    hard = Task(JointConfiguration(panda, ["panda_joint1"]), target, name="joint1 home")
    tcp = Task(Position(panda, "panda_hand_tcp"))
    tcp.set_target_from_state(state)
    limits = [JointPositionLimits(panda), JointVelocityLimits(panda)]
    # the analytic reference: out of reach in one step, inside the position range
    assert 1.0 > panda.velocity_limits[0] * DT
    assert panda.lower_limits[0] < target[0] < panda.upper_limits[0]
    ik = DifferentialIK(panda, [tcp], limits, equality_tasks=[hard])
    result = ik.solve(state, DT)
    assert result.status is IKStatus.RELAXED
    assert result.qp.conflict == ["task 'joint1 home'", "joint velocity limits"]
    # the culprits are the same here; without the separation both boxes were named
    assert result.culprits == result.qp.conflict
    assert np.isfinite(result.dq).all()
