"""HierarchySolver.solve names a bad level (its inputs were not checked before).

Before: a level's ``r`` of the wrong size or ``J`` with the wrong column count raised numpy's
bare matmul ValueError, ``C`` without ``l`` / ``u`` an AssertionError, a negative damping was
accepted (a concave level QP), a NaN in ``J`` was reported as the QP's ``H``.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
from taskspace.qp import HierarchyLevel, HierarchySolver

J = np.array([[1.0, 0.0, 0.0]])
R = np.array([1.0])


def _solve(levels, n=3, **kw):
    return HierarchySolver().solve(levels, n, **kw)


def test_valid_cascade_against_the_strict_formula() -> None:
    """x_1 = 1 by level 0, then x_1 + x_2 = 3 by level 1, then least norm: (1, 2, 0)."""
    out = _solve([HierarchyLevel("a", J, R), HierarchyLevel("b", np.array([[1.0, 1, 0]]), [3.0])])
    np.testing.assert_allclose(out.x, [1.0, 2.0, 0.0], atol=1e-9)


@pytest.mark.parametrize(
    ("levels", "kw", "error", "pattern"),
    [
        (
            [HierarchyLevel("a", J, np.array([1.0, 2.0]))],
            {},
            ShapeError,
            r"level 0 \('a'\) r must have shape \(1,\)",
        ),
        (
            [HierarchyLevel("a", J, R), HierarchyLevel("b", np.ones((1, 2)), R)],
            {},
            ShapeError,
            r"level 1 \('b'\) J must have shape \(1, 3\)",
        ),
        (
            [HierarchyLevel("a", np.array([[np.nan, 0, 0]]), R)],
            {},
            NotFiniteError,
            r"level 0 \('a'\) J",
        ),
        ([HierarchyLevel("a", J, np.array([np.inf]))], {}, NotFiniteError, r"level 0 \('a'\) r"),
        ([HierarchyLevel("a", J, R, C=np.eye(3))], {}, InvalidInputError, "C, l and u go together"),
        (
            [HierarchyLevel("a", J, R, C=np.eye(3), l=np.zeros(2), u=np.ones(3))],
            {},
            ShapeError,
            r"level 0 \('a'\) l",
        ),
        ([HierarchyLevel("a", J, R, damping=-1.0)], {}, InvalidInputError, "damping"),
        ([HierarchyLevel("a", J, R, damping=float("nan"))], {}, InvalidInputError, "damping"),
        (["not a level"], {}, InvalidInputError, r"levels\[0\] must be a HierarchyLevel"),
        ([HierarchyLevel("a", J, R)], {"lb": np.zeros(2)}, ShapeError, "lb"),
        ([HierarchyLevel("a", J, R)], {"A": np.ones((1, 3))}, InvalidInputError, "A and b"),
        ([HierarchyLevel("a", J, R)], {"A": np.ones((1, 2)), "b": R}, ShapeError, "A"),
        (
            [HierarchyLevel("a", J, R)],
            {"C": np.ones((2, 3)), "l": R, "u": np.ones(2)},
            ShapeError,
            "hard inequalities l",
        ),
    ],
)
def test_bad_inputs_are_named(levels, kw, error: type[Exception], pattern: str) -> None:
    with pytest.raises(error, match=pattern):
        _solve(levels, **kw)


def test_bad_n() -> None:
    with pytest.raises(InvalidInputError, match="n"):
        _solve([HierarchyLevel("a", J, R)], n=-1)
