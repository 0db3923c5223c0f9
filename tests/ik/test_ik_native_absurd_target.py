"""The compiled weighted IK step hands a step at its "unbounded" box sentinel to the Python path.

Before (audit5): a position target of 1e150 m came back SOLVED from the compiled step with
|dq| = 1e20, the sentinel of the unbounded box (kInf), not the QP's answer; the Python path
refuses such a problem. Now both refuse it; a large but representable step is still solved
by the kernel, and agrees with the Python path (quadprog).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace._native import ik_kernel
from taskspace.errors import InvalidInputError
from taskspace.features import JointConfiguration, Position
from taskspace.ik import DifferentialIK, DifferentialIKOptions
from taskspace.model import Robot
from taskspace.qp import QPSolverOptions
from taskspace.tasks import Task

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason="compiled IK kernel not built")


def _ik(robot: Robot, target: list[float], native: bool) -> DifferentialIK:
    tasks = [
        Task(Position(robot, "panda_hand"), target),
        Task(JointConfiguration(robot), robot.q_default, weight=1e-3),
    ]
    options = None
    if not native:
        options = DifferentialIKOptions(native=False, solver=QPSolverOptions(backend="quadprog"))
    return DifferentialIK(robot, tasks, options=options)


@pytest.mark.parametrize("x", [1e150, 1e300])
def test_absurd_target_is_refused_on_both_paths(panda: Robot, x: float) -> None:
    state = panda.state(panda.q_default)
    for native in (True, False):
        ik = _ik(panda, [x, 0.0, 0.0], native)
        assert ik.native is native
        with pytest.raises(InvalidInputError):
            ik.solve(state, 0.01)


def test_large_representable_step_is_the_kernels(panda: Robot) -> None:
    state = panda.state(panda.q_default)
    a = _ik(panda, [1e6, 0.0, 0.0], True).solve(state, 0.01)
    b = _ik(panda, [1e6, 0.0, 0.0], False).solve(state, 0.01)
    assert a.success and a.qp.backend == "native"
    np.testing.assert_allclose(a.dq, b.dq, rtol=1e-6)
