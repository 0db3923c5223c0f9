"""Targets far away with joint limits: both IK paths agree, and a returned step respects the box.

Before (loose3's sweep): a position target 1e20 m away came back FAILED from the Python path
with ``|dq| ~ 1e13`` (proxsuite's last iterate, far outside the velocity box) while the
compiled kernel answered SOLVED with a box-corner step that meets the KKT conditions; from
1e31 m the Python path refused the QP (gradient beyond ``MAX_QP_MAGNITUDE``) while the kernel
still answered SOLVED. The reference here is the KKT conditions of the box QP, evaluated on
the QP the Python path builds (stationarity on the free components, the sign of the
recovered bound multipliers), not another solver path.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace._native import ik_kernel
from taskspace.constraints import JointPositionLimits, JointVelocityLimits
from taskspace.errors import InvalidInputError
from taskspace.features import JointConfiguration, Position
from taskspace.ik import DifferentialIK, DifferentialIKOptions, IKStatus
from taskspace.model import Robot
from taskspace.qp import QPSolverOptions
from taskspace.tasks import Task
from tests.conftest import load_robot

FRAMES = {"panda": "panda_hand", "ur5": "tool0"}


@pytest.fixture(scope="module", params=sorted(FRAMES))
def robot(request: pytest.FixtureRequest) -> Robot:
    return load_robot(request.param)


def _ik(robot: Robot, x: float, options: DifferentialIKOptions) -> DifferentialIK:
    tasks = [
        Task(Position(robot, FRAMES[robot.name]), [x, 0.0, 0.0]),
        Task(JointConfiguration(robot), robot.q_default, weight=1e-3),
    ]
    limits = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    return DifferentialIK(robot, tasks, limits, options=options)


def _check_box_kkt(ik: DifferentialIK, state: object, dq: np.ndarray, dt: float) -> None:
    """``dq`` in the box, ``H dq + g`` zero on the free components (relative to its scale),
    and of the sign that pushes into the bound on the held ones (the multipliers' sign)."""
    p = ik.build(state, dt)  # type: ignore[arg-type]
    assert np.all(dq >= p.lb) and np.all(dq <= p.ub)
    grad = p.H @ dq + p.g
    scale = max(np.abs(p.g).max(), np.abs(p.H @ dq).max())
    at_lb, at_ub = dq <= p.lb + 1e-12, dq >= p.ub - 1e-12
    free = ~(at_lb | at_ub)
    assert np.all(np.abs(grad[free]) <= 1e-9 + 1e-9 * scale)
    assert np.all(grad[at_lb] >= -1e-9 * scale)  # moving up would increase the objective
    assert np.all(grad[at_ub] <= 1e-9 * scale)


@pytest.mark.parametrize("x", [1e20, 1e25, 1e29])
def test_python_path_solves_far_targets_within_the_box(robot: Robot, x: float) -> None:
    state = robot.state(robot.q_default)
    python = _ik(robot, x, DifferentialIKOptions(native=False))
    r = python.solve(state, 0.01)
    assert r.status is IKStatus.SOLVED and r.success
    _check_box_kkt(python, state, r.dq, 0.01)
    assert r.qp.kkt.within(1e-9, 1e-9)
    if ik_kernel() is not None:  # the kernel's step: the same status and KKT point
        native = _ik(robot, x, DifferentialIKOptions(native_residuals=True))
        n = native.solve(state, 0.01)
        assert n.status is IKStatus.SOLVED and n.qp.backend == "native"
        assert n.qp.kkt.within(1e-9, 1e-9)
        _check_box_kkt(python, state, n.dq, 0.01)
        p = python.build(state, 0.01)
        f = [0.5 * d @ p.H @ d + p.g @ d for d in (r.dq, n.dq)]
        assert f[0] == pytest.approx(f[1], rel=1e-9)


@pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")
@pytest.mark.parametrize("x", [1e31, 1e100, 1e300])
def test_both_paths_refuse_targets_beyond_the_qp_range(robot: Robot, x: float) -> None:
    state = robot.state(robot.q_default)
    for native in (True, False):
        ik = _ik(robot, x, DifferentialIKOptions(native=native))
        assert ik.native is native
        with pytest.raises(InvalidInputError, match="beyond 1e"):
            ik.solve(state, 0.01)
        with pytest.raises(InvalidInputError, match="beyond 1e"):
            ik.advance(robot.state(robot.q_default), 0.01)


@pytest.mark.parametrize("x", [1e20, 1.0])
def test_failed_step_respects_the_box(robot: Robot, x: float) -> None:
    # a QP solver stopped after one iteration without fallback fails; its iterate was
    # returned as the step (|dq| ~ 2.5e18 for the 1e20 m target; 3.5e-7 outside the velocity
    # box for the 1 m one)
    state = robot.state(robot.q_default)
    solver = QPSolverOptions(max_iter=1, fallbacks=(), max_polish_iter=1, refine=False)
    ik = _ik(robot, x, DifferentialIKOptions(native=False, solver=solver))
    r = ik.solve(state, 0.01)
    p = ik.build(state, 0.01)
    assert np.all(r.dq >= p.lb) and np.all(r.dq <= p.ub)
    assert r.qp.x is r.dq
    if robot.name == "panda":  # (the ur5's 1e20 m QP, scaled, is solved in one iteration)
        assert r.status is IKStatus.FAILED and not r.success
    if r.success:
        _check_box_kkt(ik, state, r.dq, 0.01)
