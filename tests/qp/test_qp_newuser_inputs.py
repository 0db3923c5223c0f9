"""A new user's inputs to QPSolver and HierarchySolver (lists, dtypes, NaN, bad shapes, n = 0).

Before: a NaN in a hierarchy's hard ``C``, bounds or a level's ``l`` was ignored (the result
UNCONSTRAINED, a success); inconsistent hard equalities ``A x = b`` gave a success at their
least-squares point; lists for the hard data raised a bare AttributeError or a ShapeError
"must have shape (2,), got (2,)"; QPSolver met a list ``H``, a 2-D ``g``, a ``C`` of the wrong
width, a complex or object ``H`` and a QP without variables with bare NumPy / LAPACK errors.
References: the analytic solutions of these small problems.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
from taskspace.qp import INF, HierarchyLevel, HierarchySolver, QPProblem, QPSolver, QPStatus


def _qp(**kw):  # type: ignore[no-untyped-def]
    n = 3
    data = {
        "H": np.eye(n),
        "g": -np.ones(n),
        "A": np.zeros((0, n)),
        "b": np.zeros(0),
        "C": np.zeros((0, n)),
        "l": np.zeros(0),
        "u": np.zeros(0),
        "lb": np.full(n, -INF),
        "ub": np.full(n, INF),
    }
    data.update(kw)
    return QPProblem(**data)


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"H": np.eye(3).tolist()}, InvalidInputError, "QP H must be a numpy array"),
        ({"g": -np.ones((3, 1))}, ShapeError, "QP g"),
        ({"C": np.eye(2), "l": -np.ones(2), "u": np.ones(2)}, ShapeError, "QP C"),
        ({"H": np.eye(3, dtype=complex)}, InvalidInputError, "real numbers"),
        ({"H": np.eye(3).astype(object)}, InvalidInputError, "real numbers"),
        ({"lb": -np.ones(2)}, ShapeError, "QP lb"),
    ],
)
def test_qp_solver_refuses_malformed_arrays(change: dict, error: type, match: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(error, match=match):
        QPSolver().solve(_qp(**change))


def test_qp_solver_accepts_other_real_dtypes_and_layouts() -> None:
    # min 1/2 |x|^2 - sum x  ->  x = 1, clipped by the box to 0.5
    for H in (np.eye(3, dtype=np.float32), np.eye(3, dtype=int), np.asfortranarray(np.eye(3))):
        result = QPSolver().solve(_qp(H=H, ub=np.full(6, 0.5)[::2]))
        assert result.success
        np.testing.assert_allclose(result.x, 0.5, atol=1e-9)


def test_qp_without_variables() -> None:
    empty = {"H": np.zeros((0, 0)), "g": np.zeros(0), "lb": np.zeros(0), "ub": np.zeros(0)}
    p = _qp(**empty, A=np.zeros((0, 0)), C=np.zeros((1, 0)), l=-np.ones(1), u=np.ones(1))
    result = QPSolver().solve(p)
    assert result.success and result.x.shape == (0,)
    # 0 = 1 cannot hold: relaxed, naming the block
    p = _qp(**empty, A=np.zeros((1, 0)), b=np.ones(1), C=np.zeros((0, 0)))
    result = QPSolver().solve(p)
    assert result.status is QPStatus.RELAXED and result.culprits == ["equality"]


def _level() -> list[HierarchyLevel]:
    return [HierarchyLevel("a", np.eye(2), np.array([3.0, 1.0]))]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"lb": np.array([np.nan, -1.0]), "ub": np.ones(2)}, "lb"),
        ({"C": np.array([[np.nan, 0.0], [0.0, 1.0]]), "l": -np.ones(2), "u": np.ones(2)}, "C"),
        ({"C": np.eye(2), "l": np.array([-1.0, np.nan]), "u": np.ones(2)}, "l"),
        ({"A": np.array([[np.inf, 0.0]]), "b": np.zeros(1)}, "A"),
    ],
)
def test_hierarchy_refuses_nan_hard_data(kwargs: dict, match: str) -> None:  # type: ignore[type-arg]
    # before: the NaN row or bound was ignored and the result was a success
    with pytest.raises(NotFiniteError, match=match):
        HierarchySolver().solve(_level(), 2, **kwargs)


def test_hierarchy_refuses_nan_in_a_level_inequality() -> None:
    level = HierarchyLevel("a", np.eye(2), [3.0, 1.0], C=np.eye(2), l=[np.nan, 0.0], u=[1, 1])
    with pytest.raises(NotFiniteError, match="level 0"):
        HierarchySolver().solve([level], 2)


def test_hierarchy_inconsistent_hard_equalities_are_not_a_success() -> None:
    # x0 = 0 and x0 = 1: the least-squares point x0 = 1/2, reported RELAXED
    A = np.array([[1.0, 0.0], [1.0, 0.0]])
    b = np.array([0.0, 1.0])
    result = HierarchySolver().solve(_level(), 2, A=A, b=b)
    assert not result.success and result.status is QPStatus.RELAXED
    assert result.culprits[0] == "hard equalities"
    np.testing.assert_allclose(result.x, [0.5, 1.0], atol=1e-9)
    # consistent ones stay a success
    ok = HierarchySolver().solve(_level(), 2, A=A[:1], b=b[:1])
    assert ok.success and ok.culprits == []
    np.testing.assert_allclose(ok.x, [0.0, 1.0], atol=1e-9)


def test_hierarchy_accepts_lists_for_the_hard_data() -> None:
    # argmin |x - (3, 1)| on x0 + x1 = 0.5 is (1.25, -0.75); the box x0 <= 1 makes it (1, -0.5)
    result = HierarchySolver().solve(
        _level(), 2, lb=[-1, -1], ub=[1, 1], A=[[1, 1]], b=[0.5], C=[[0, 1]], l=[-2], u=[2]
    )
    assert result.success
    np.testing.assert_allclose(result.x, [1.0, -0.5], atol=1e-7)


_BOOL_CHANGES = [
    {"H": np.eye(3, dtype=bool)},
    {"g": np.array([True, False, True])},
    {"A": np.array([[True, False, False]]), "b": np.ones(1)},
    {"A": np.array([[1.0, 0.0, 0.0]]), "b": np.array([True])},
    {"C": np.eye(3, dtype=bool), "l": -np.ones(3), "u": np.ones(3)},
    {"C": np.eye(3), "l": np.zeros(3, dtype=bool), "u": np.ones(3)},
    {"C": np.eye(3), "l": -np.ones(3), "u": np.ones(3, dtype=bool)},
    {"lb": np.zeros(3, dtype=bool)},
    {"ub": np.array([True, True, False])},
]


@pytest.mark.parametrize("change", _BOOL_CHANGES, ids=lambda c: "+".join(c))
@pytest.mark.parametrize("entry", ["solve", "solve_relaxed", "check_problem_data"])
def test_qp_boolean_arrays_are_refused_naming_the_array(change: dict, entry: str) -> None:  # type: ignore[type-arg]
    # before: a boolean H or C was solved as the 0/1 matrix (a success), a boolean bound met
    # a bare NumPy TypeError ("numpy boolean negative ... is not supported")
    from taskspace.qp.solver import check_problem_data

    name = next(k for k, v in change.items() if v.dtype == bool)
    call = {
        "solve": QPSolver().solve,
        "solve_relaxed": QPSolver().solve_relaxed,
        "check_problem_data": check_problem_data,
    }[entry]
    with pytest.raises(InvalidInputError, match=f"QP {name} must hold real numbers, got a boolean"):
        call(_qp(**change))


def test_hierarchy_boolean_arrays_are_refused_naming_the_array() -> None:
    # before: converted to 0/1 floats and solved (a boolean J, C or bound: a success)
    with pytest.raises(
        InvalidInputError, match="HierarchyLevel 'a' J must be real numbers, got boolean"
    ):
        HierarchyLevel("a", np.eye(2, dtype=bool), [3.0, 1.0])
    with pytest.raises(InvalidInputError, match="'a' C must be real numbers, got boolean"):
        HierarchyLevel("a", np.eye(2), [3.0, 1.0], C=np.eye(2, dtype=bool), l=[0, 0], u=[1, 1])
    for kwargs, name in (
        ({"C": np.eye(2, dtype=bool), "l": -np.ones(2), "u": np.ones(2)}, "C"),
        ({"lb": np.array([True, False]), "ub": np.ones(2)}, "lb"),
        ({"A": [[True, False]], "b": [0.5]}, "A"),
    ):
        with pytest.raises(
            InvalidInputError, match=f"data {name} must be real numbers, got boolean"
        ):
            HierarchySolver().solve(_level(), 2, **kwargs)
