"""QPProblem.copy: independent arrays and blocks; objective=False keeps only the constraints."""

from __future__ import annotations

import numpy as np

from taskspace.qp import QPProblem, QPSolver, QPStatus
from taskspace.qp.problem import RowBlock


def _problem() -> QPProblem:
    return QPProblem(
        np.eye(2),
        np.array([1.0, -1.0]),
        np.array([[1.0, 1.0]]),
        np.array([1.0]),
        np.array([[1.0, -1.0]]),
        np.array([-1.0]),
        np.array([1.0]),
        np.array([-2.0, -2.0]),
        np.array([2.0, 2.0]),
        [RowBlock("sum", 0, 1)],
        [RowBlock("gap", 0, 1)],
        [RowBlock("box", 0, 2)],
    )


def test_copy_is_independent_of_later_in_place_builds() -> None:
    p = _problem()
    c = p.copy()
    for name in ("H", "g", "A", "b", "C", "l", "u", "lb", "ub"):
        np.testing.assert_array_equal(getattr(c, name), getattr(p, name))
        getattr(p, name)[...] = 7.0
        assert not np.array_equal(getattr(c, name), getattr(p, name)), name
    p.eq_blocks[0].name = "changed"
    assert c.eq_blocks[0].name == "sum"
    assert [b.name for b in c.in_blocks + c.box_blocks] == ["gap", "box"]


def test_constraints_only_copy_has_the_same_feasible_set() -> None:
    p = _problem()
    c = p.copy(objective=False)
    assert c.H.shape == (0, 0) and np.array_equal(c.g, np.zeros(2))
    x = QPSolver().solve(p).x
    assert p.is_feasible(x) and c.is_feasible(x)
    assert QPSolver().solve(p).status is QPStatus.SOLVED
