"""The stacking layer's rules on hand-computed cases (taskspace.qp.rows)."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.constraints import Constraint
from taskspace.errors import ShapeError
from taskspace.features import JointConfiguration
from taskspace.features.rows import INF, Box, InequalityRows
from taskspace.qp.rows import InequalityStack, TaskRowStack, combine_boxes
from taskspace.tasks import Task
from tests.conftest import load_robot


def test_combine_boxes_rules_by_hand() -> None:
    # joint 0: plain intersection; 1: soft above hard -> hard upper; 2: soft below hard ->
    # hard lower; 3: empty soft box inside the hard one -> its midpoint; 4: hard boxes in
    # conflict -> midpoint of the gap (the soft box then follows it)
    hard = [
        Box(np.array([-1.0, -1.0, -1.0, -1.0, 0.0]), np.array([1.0, 1.0, 1.0, 1.0, 1.0])),
        Box(np.full(5, -INF), np.array([INF, INF, INF, INF, -1.0])),
    ]
    soft = [Box(np.array([-0.5, 2.0, -3.0, 0.4, -5.0]), np.array([0.5, 3.0, -2.0, 0.2, 5.0]))]
    lb, ub = combine_boxes(hard, soft, 5)
    np.testing.assert_allclose(lb, [-0.5, 1.0, -1.0, 0.3, -0.5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(ub, [0.5, 1.0, -1.0, 0.3, -0.5], rtol=0, atol=1e-15)
    lb, ub = combine_boxes([], soft, 5)  # an empty soft box alone: its midpoint
    assert lb[3] == ub[3] == pytest.approx(0.3)
    # an empty soft box reaching past both sides of the hard box: its midpoint, clipped
    # (not the hard lower bound, which an early version returned)
    wide = [Box(np.array([5.0, 9.0]), np.array([-5.0, 2.0]))]
    lb, ub = combine_boxes([Box(np.array([-1.0, -1.0]), np.array([1.0, 1.0]))], wide, 2)
    np.testing.assert_array_equal(lb, [0.0, 1.0])
    np.testing.assert_array_equal(ub, [0.0, 1.0])
    lb, ub = combine_boxes([], [], 2)
    np.testing.assert_array_equal(lb, [-INF, -INF])
    np.testing.assert_array_equal(ub, [INF, INF])


class Rows(Constraint):
    """A constraint with a changing number of rows (as collision dampers have)."""

    def __init__(self, robot, name: str) -> None:  # type: ignore[no-untyped-def]
        super().__init__(robot, name)
        self.k = 0

    def inequalities(self, state, dt):  # type: ignore[no-untyped-def]
        n = self.robot.nv
        return InequalityRows(
            np.full((self.k, n), self.k), np.full(self.k, -self.k), np.ones(self.k)
        )


def test_inequality_stack_grows_and_names_blocks() -> None:
    robot = load_robot("ur5")
    a, b = Rows(robot, "a"), Rows(robot, "b")
    stack = InequalityStack([a, b], robot.nv)
    state = robot.state()
    for ka, kb in [(0, 0), (2, 1), (5, 3), (1, 0)]:
        a.k, b.k = ka, kb
        (C, l, _), blocks = stack.fill(state, 0.01)
        assert C.shape == (ka + kb, robot.nv)
        np.testing.assert_array_equal(C[:ka], ka)
        np.testing.assert_array_equal(C[ka:], kb)
        np.testing.assert_array_equal(l, [-ka] * ka + [-kb] * kb)
        assert [(blk.name, blk.start, blk.stop) for blk in blocks] == [
            (name, start, stop)
            for name, start, stop in (("a", 0, ka), ("b", ka, ka + kb))
            if stop > start
        ]


def test_task_row_stack_checks_its_buffers() -> None:
    robot = load_robot("ur5")
    task = Task(JointConfiguration(robot), robot.q_default)
    with pytest.raises(ShapeError, match="task row buffer J"):
        TaskRowStack([task], robot.nv, J=np.zeros((3, robot.nv)))
    with pytest.raises(ShapeError, match="task row buffer rhs"):
        TaskRowStack([task], robot.nv, rhs=np.zeros(3))
