"""The compiled IK step of a box-only stack calls the kernel's ``solve_boxes`` (issue #15).

Since the collision dampers, ``WeightedIKKernel.solve`` has two overloads (9 arguments, and
11 with the collision model and data); Boost.Python tried the 11-argument one first and the
arity mismatch cost ~0.4 us per call. A stack without inequality rows now calls
``solve_boxes`` (one signature). Checked here: it is the one bound, it gives the same step as
the 11-argument ``solve`` with ``(None, None)``, and on a moving Panda trajectory the compiled
steps equal the Python path's solved with quadprog (the independent reference).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from taskspace import features as F
from taskspace._native import ik_kernel, status
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.ik._native_stack import MAX_ACTIVE_SET_ITERATIONS
from taskspace.model import Robot
from taskspace.qp import QPSolverOptions
from taskspace.tasks import Task

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason=f"native kernel: {status()}")


def _ik(robot: Robot, native: bool) -> tuple[DifferentialIK, Task]:
    s = robot.state(robot.q_default)
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"))
    offset = pin.SE3(np.eye(3), np.array([0.1, 0.1, 0.1]))
    tcp.set_target(s.frame_placement(robot.frame_id("panda_hand_tcp")) * offset)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    options = (
        DifferentialIKOptions()
        if native
        else DifferentialIKOptions(native=False, solver=QPSolverOptions(backend="quadprog"))
    )
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    return DifferentialIK(robot, [tcp, posture], limits, options=options), tcp


def test_box_stack_binds_solve_boxes_and_matches_quadprog() -> None:
    robot = Robot.load("panda")
    ik, _ = _ik(robot, True)
    reference, _ = _ik(robot, False)
    state = robot.state(robot.q_default)
    q = robot.q_default.copy()
    constrained = 0
    for _ in range(40):  # the velocity limits are active in the first steps
        state.update(q)
        step = ik.solve(state, 0.01)
        assert step.qp.backend == "native"
        ref = reference.solve(state, 0.01)
        assert ref.success
        np.testing.assert_allclose(step.dq, ref.dq, atol=1e-8, rtol=0)
        constrained += step.qp.status.name != "UNCONSTRAINED"
        q = pin.integrate(robot.model, q, step.dq)
    assert constrained > 0  # the active-set path ran, not only the unconstrained one
    native = ik._native
    assert native is not None and not native.has_rows
    assert native._kernel_solve.__name__ == "solve_boxes"


def test_solve_boxes_equals_the_11_argument_solve() -> None:
    robot = Robot.load("panda")
    ik, _ = _ik(robot, True)
    state = robot.state(robot.q_default)
    ik.solve(state, 0.01)
    native = ik._native
    assert native is not None
    kernel = native.kernel
    targets = [t._target for t in native.tasks]
    hard = [b for c in native._hard if (b := c.bounds(state, 0.01)) is not None]
    soft = [b for c in native._soft if (b := c.bounds(state, 0.01)) is not None]
    outs = [np.zeros(robot.nv), np.zeros(robot.nv)]
    common = (robot.model, state._data, state.q, targets, hard, soft, 1e-6)
    a = kernel.solve_boxes(*common, outs[0], MAX_ACTIVE_SET_ITERATIONS)
    b = kernel.solve(*common, outs[1], MAX_ACTIVE_SET_ITERATIONS, None, None)
    assert a[:3] == b[:3]  # status, iterations, objective
    assert np.array_equal(outs[0], outs[1]) and np.linalg.norm(outs[0]) > 0
