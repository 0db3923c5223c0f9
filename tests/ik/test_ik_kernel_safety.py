"""The compiled IK kernel checks its own numeric arguments (issue #15).

Direct calls of ``WeightedIKKernel`` (no Python validation in front): a NaN, negative or
infinite damping, a negative iteration cap, a non-finite ``q``, weight, bound or target give
a :class:`TaskspaceError` instead of a NaN step or a bare C++ exception.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import ik_kernel, status
from taskspace.errors import InvalidInputError, SolverError, TaskspaceError
from taskspace.model import Robot

pytestmark = pytest.mark.skipif(ik_kernel() is None, reason=f"native kernel: {status()}")


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda")


def _kernel(robot: Robot) -> tuple[Any, dict[str, Any]]:
    module = ik_kernel()
    kernel = module.WeightedIKKernel(robot.nv, robot.nq)
    frame = robot.model.getFrameId("panda_hand_tcp")
    kernel.add_pose(robot.model, frame)
    kernel.set_scaling(np.ones(6), -np.ones(6))
    q = robot.q_default.copy()
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    pin.computeJointJacobians(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    target = data.oMf[frame].copy()
    target.translation[0] += 0.05
    args = {
        "model": robot.model,
        "data": data,
        "q": q,
        "targets": [target],
        "hard": [],
        "soft": [],
        "damping": 1e-6,
        "out": np.zeros(robot.nv),
        "max_iter": 50,
    }
    return kernel, args


def _solve(kernel: Any, a: dict[str, Any]) -> Any:
    return kernel.solve_boxes(
        a["model"],
        a["data"],
        a["q"],
        a["targets"],
        a["hard"],
        a["soft"],
        a["damping"],
        a["out"],
        a["max_iter"],
    )


def test_valid_call_gives_a_finite_step(panda: Robot) -> None:
    kernel, args = _kernel(panda)
    _solve(kernel, args)
    assert np.isfinite(args["out"]).all() and np.linalg.norm(args["out"]) > 0


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"damping": math.nan}, "damping must be finite and >= 0"),
        ({"damping": -1.0}, "damping must be finite and >= 0"),
        ({"damping": math.inf}, "damping must be finite and >= 0"),
        ({"max_iter": -1}, "max_iter must be >= 0"),
        ({"q": "nan_q"}, "q must be finite"),
        ({"hard": "nan_box"}, "bounds are NaN"),
        ({"targets": "nan_target"}, "step is not finite"),
    ],
)
def test_bad_numbers_raise_a_taskspace_error(
    panda: Robot, change: dict[str, Any], match: str
) -> None:
    kernel, args = _kernel(panda)
    nv = panda.nv
    for key, value in change.items():
        if value == "nan_q":
            value = args["q"].copy()
            value[2] = math.nan
        elif value == "nan_box":
            value = [(np.full(nv, -1.0), np.full(nv, math.nan))]
        elif value == "nan_target":
            bad = args["targets"][0].copy()
            bad.translation = np.array([math.nan, 0.0, 0.0])
            value = [bad]
        args[key] = value
    with pytest.raises(InvalidInputError, match=match):
        _solve(kernel, args)


def test_non_finite_weights_are_refused(panda: Robot) -> None:
    kernel, _ = _kernel(panda)
    with pytest.raises(InvalidInputError, match="weights and gains must be finite"):
        kernel.set_scaling(np.full(6, math.nan), -np.ones(6))


def test_singular_hessian_is_a_solver_error(panda: Robot) -> None:
    """Damping 0 and a 6-row task on 7 joints: H = J^T J is singular (rank 6)."""
    kernel, args = _kernel(panda)
    args["damping"] = 0.0
    with pytest.raises(SolverError, match="not positive definite"):
        _solve(kernel, args)


def test_size_errors_are_taskspace_errors(panda: Robot) -> None:
    kernel, args = _kernel(panda)
    args["out"] = np.zeros(3)
    with pytest.raises(TaskspaceError, match="vector size mismatch"):
        _solve(kernel, args)
    with pytest.raises(TaskspaceError, match="nv and nq must be positive"):
        ik_kernel().WeightedIKKernel(0, 0)
