"""Task weights are bounded by MAX_WEIGHT = 1e20, refused at the task naming it and the weight.

Weights up to 1e100 were accepted; from ~1e30 on the QP's magnitude check refused the Hessian
``rho J^T J`` later, in the solver, with a message about "QP H rows" that named no task.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.features import Position
from taskspace.ik import DifferentialIK
from taskspace.model import Robot
from taskspace.tasks import MAX_WEIGHT, Task


@pytest.fixture(scope="module")
def robot() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Robot.load("ur5", geometry=False)


@pytest.mark.parametrize("weight", [1e21, 1e40, 1e100, [1.0, 1e25, 1.0]])
def test_weight_beyond_the_bound_is_refused_naming_task_and_weight(
    robot: Robot, weight: object
) -> None:
    with pytest.raises(InvalidInputError, match=r"weight of task 'reach' must be <= 1e\+20"):
        Task(Position(robot, "tool0"), [0.4, 0.1, 0.4], weight=weight, name="reach")
    task = Task(Position(robot, "tool0"), [0.4, 0.1, 0.4], name="reach")
    with pytest.raises(InvalidInputError, match="task 'reach'"):
        task.weight = weight
    assert task.weight == 1.0  # unchanged


def test_sqrt_weight_beyond_the_bound_is_refused(robot: Robot) -> None:
    task = Task(Position(robot, "tool0"), [0.4, 0.1, 0.4], name="reach")
    with pytest.raises(InvalidInputError, match=r"sqrt_weight of task 'reach' must be <= 1e\+10"):
        task.sqrt_weight = 1e11


def test_weight_at_the_bound_solves(robot: Robot) -> None:
    # the bound itself: the QP takes its Hessian (entries ~1e20 |J|^2 < 1e30) and the step
    # moves the tool toward the target (first-order: the weighted least-squares step)
    assert MAX_WEIGHT == 1e20
    state = robot.state(robot.q_default)
    p0 = np.asarray(robot.frame_placement(robot.q_default, "tool0").translation)
    target = p0 + np.array([0.01, 0.0, 0.0])
    task = Task(Position(robot, "tool0"), target, weight=MAX_WEIGHT, name="reach")
    q, result = DifferentialIK(robot, [task]).step(state, 0.01)
    assert result.success
    p1 = np.asarray(robot.frame_placement(q, "tool0").translation)
    assert np.linalg.norm(p1 - target) < 0.5 * np.linalg.norm(p0 - target)
