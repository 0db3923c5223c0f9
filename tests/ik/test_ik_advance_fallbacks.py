"""DifferentialIK.advance's armed paths fall back to the Python path when H is not PD.

The armed (compiled) steps of ``advance`` raise SolverError when ``H = M^T M + mu I`` has no
Cholesky factor; each of the three armed paths then takes the Python path (its three
``except SolverError`` clauses had no test). The trigger: planar_2link (links of 1 m about
z) with damping 0, armed at q = (0.3, 0.6), then moved to q = (0, 0): the tip Jacobian's
columns are (0, 2, 0) and (0, 1, 0), ``H = [[4, 2], [2, 1]]`` exactly, whose Cholesky
pivot 1 - 1 = 0 fails in floating point too. The paths:

- the armed C function of ``arm_advance`` (constant boxes, the default);
- the armed kernel step (``_lean_step``) when that C function is not there (a kernel built
  before ``arm_advance``) or the lock is held: here ``_lean_fast`` is cleared;
- the kernel's ``advance`` with boxes re-read at every step (a JointAccelerationLimits box
  reads the state's velocity, so nothing is armed beyond ``dt``; limits of 1e6 rad/s^2 keep
  it inactive).

The reference is the least-squares optimality of the step, from Pinocchio's Jacobian:
``J^T (J dq - e) = 0`` with ``e`` the tip error (gain 1), the boxes inactive.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from taskspace.constraints import JointAccelerationLimits
from taskspace.features import Position
from taskspace.ik import DifferentialIK
from taskspace.ik.differential_ik import DifferentialIKOptions
from taskspace.model import Robot
from taskspace.tasks import Task

TARGET = np.array([1.5, 0.8, 0.0])
DT = 0.01


@pytest.fixture(scope="module")
def robot() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("planar_2link", geometry=False)


def _armed(robot: Robot, path: str):  # type: ignore[no-untyped-def]
    reads_state = path == "boxes_read_state"
    constraints = [JointAccelerationLimits(robot, [1e6, 1e6])] if reads_state else []
    task = Task(Position(robot, "ee"), TARGET)
    ik = DifferentialIK(robot, [task], constraints, options=DifferentialIKOptions(damping=0.0))
    state = robot.state(np.array([0.3, 0.6]), np.zeros(2))
    for _ in range(3):
        result = ik.advance(state, DT)
        assert result.native_declined == ""  # the compiled step answered
    assert ik._lean_dt == DT  # armed
    if path == "arm_advance":
        assert ik._lean_fast is not None
    elif path == "lean_step":
        assert ik._lean_step is not None
        ik._lean_fast = None  # as a kernel without arm_advance
    else:
        assert ik._lean_step is None and ik._lean_fast is None
    return ik, state


@pytest.mark.parametrize("path", ["arm_advance", "lean_step", "boxes_read_state"])
def test_singular_hessian_on_an_armed_path_takes_the_python_path(robot: Robot, path: str) -> None:
    ik, state = _armed(robot, path)
    q_b = np.zeros(2)
    state.update(q_b, np.zeros(2))
    result = ik.advance(state, DT)
    assert result.success
    assert "not positive definite" in result.native_declined  # the kernel raised, Python ran
    dq = result.dq
    np.testing.assert_array_equal(state.q, q_b + dq)  # the state moved by the step
    # least-squares optimality from Pinocchio (independent of the IK's own QP)
    model = robot.model
    data = model.createData()
    fid = model.getFrameId("ee")
    pin.computeJointJacobians(model, data, q_b)
    pin.updateFramePlacements(model, data)
    J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
    e = TARGET - data.oMf[fid].translation
    np.testing.assert_allclose(J, [[0, 0], [2, 1], [0, 0]], atol=1e-15)
    np.testing.assert_allclose(J.T @ (J @ dq - e), 0.0, atol=1e-6)
    assert np.all(np.abs(dq) < 3.0)  # the boxes (|q| <= 3, |dq| <= 100) are inactive
    # the next step, away from the singularity, is the compiled one again
    again = ik.advance(state, DT)
    assert again.success and again.native_declined == ""
