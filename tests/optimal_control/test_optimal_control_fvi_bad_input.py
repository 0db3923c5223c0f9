"""Bad inputs to fitted value iteration (issue #15): a right answer or a TaskspaceError,
never a bare exception, a hang, or a silently broadcast dynamics output.

Reference: ``rk4_step`` on ``x' = (x_2, u)`` is exact for a constant ``u`` (cubic-free
polynomial motion): ``x_1 + x_2 dt + u dt^2 / 2``, ``x_2 + u dt``.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.optimal_control import (
    FittedValueIterationOptions,
    fitted_value_iteration,
    make_grid,
    rk4_step,
)
from taskspace.optimal_control.problems import DoubleIntegrator

DI = DoubleIntegrator()
GRID = make_grid([np.linspace(-1.0, 1.0, 5), np.linspace(-1.0, 1.0, 5)])


def solve(**kw: object):  # type: ignore[no-untyped-def]
    return fitted_value_iteration(
        kw.pop("grid", GRID),  # type: ignore[arg-type]
        kw.pop("actions", [-1.0, 0.0, 1.0]),
        kw.pop("dynamics", DI.dynamics),  # type: ignore[arg-type]
        kw.pop("cost", DI.cost),  # type: ignore[arg-type]
        kw.pop("options", None),  # type: ignore[arg-type]
        **kw,  # type: ignore[arg-type]
    )


def test_rk4_reference_and_checks() -> None:
    X, U = np.array([[0.3, -0.2]]), np.array([[0.7]])
    np.testing.assert_allclose(
        rk4_step(DI.dynamics, X, U, 0.5, 3), [[0.3 - 0.1 + 0.7 * 0.125, -0.2 + 0.35]], rtol=1e-14
    )
    with pytest.raises(InvalidInputError):  # bare ZeroDivisionError
        rk4_step(DI.dynamics, X, U, 0.5, 0)
    with pytest.raises(InvalidInputError):  # returned NaN
        rk4_step(DI.dynamics, X, U, np.nan)


@pytest.mark.parametrize(
    "kw",
    [
        {"actions": "ab"},  # bare ValueError
        {"actions": [1j, 1.0]},  # bare TypeError
        {"dynamics": lambda X, U: X[:, :1]},  # (K, 1) broadcast over both components
        {"dynamics": lambda X, U: 1 / 0},  # bare ZeroDivisionError
        {"cost": lambda X, U: 1 / 0},
        {"target": lambda X: np.ones(3)},  # bare matmul ValueError
        {"target": lambda X: 1 / 0},
        {"grid": 5},  # bare AttributeError
        {"grid": make_grid([np.linspace(-1.0, 1.0, 5)])},  # bare IndexError in the dynamics
        {"options": FittedValueIterationOptions(refinements=10**9)},  # ran for ever
    ],
)
def test_bad_arguments_are_refused(kw: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        solve(**kw)


def test_result_queries_check_their_inputs() -> None:
    res = solve()
    assert res.success
    with pytest.raises(InvalidInputError):
        res.control("ab", DI.dynamics, DI.cost, 0.1)  # bare ValueError
    with pytest.raises(InvalidInputError):
        res.control([[0.0, 0.0]], DI.dynamics, DI.cost, np.nan)
    with pytest.raises(InvalidInputError):
        res.control([[0.0, 0.0, 0.0]], DI.dynamics, DI.cost, 0.1)
