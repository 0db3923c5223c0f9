"""PathCost / PathEquality times that are not integers are named (audit 31).

PathEquality(task, 2.5) gave a bare "TypeError: 'float' object is not iterable" from
PathProblem; now an InvalidInputError naming the term.
"""

from __future__ import annotations

import numpy as np
import pytest

import taskspace.features as F
from taskspace.errors import InvalidInputError
from taskspace.tasks import Task
from taskspace.trajopt import PathEquality, PathProblem


@pytest.mark.parametrize("times", [2.5, 3.0, np.float64(2.0), "3", object()])
def test_scalar_times_that_are_not_integers_are_named(panda, times):
    q0 = panda.q_default
    task = Task(F.Position(panda, "panda_hand_tcp"), np.array([0.4, 0.1, 0.5]))
    with pytest.raises(InvalidInputError, match=r"times of 'position\(panda_hand_tcp\)'"):
        PathProblem(panda, q0, 5, equalities=[PathEquality(task, times)], velocity_weight=1.0)


@pytest.mark.parametrize("times", [3, np.int64(3), np.array(3), [3], (-3,)])
def test_integer_times_still_work(panda, times):
    q0 = panda.q_default
    task = Task(F.Position(panda, "panda_hand_tcp"), np.array([0.4, 0.1, 0.5]))
    problem = PathProblem(panda, q0, 5, equalities=[PathEquality(task, times)], velocity_weight=1.0)
    assert problem.horizon == 5
