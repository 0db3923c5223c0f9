"""``fitted_value_iteration`` on grids too large to tabulate (audit, session 31).

A 100000^3 grid (10^15 points) was a bare ``MemoryError: Unable to allocate 7.11 PiB`` from
``grid.points()``; now an InvalidInputError naming the grid and the budget before anything
is allocated. Refinement rounds try ``5^m`` local actions per point: 14 inputs on a 2 x 2
grid asked NumPy for 683 GB (a bare MemoryError after the first solve). A small
double-integrator grid still solves.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.optimal_control import (
    DoubleIntegrator,
    FittedValueIterationOptions,
    fitted_value_iteration,
    make_grid,
)


def test_huge_grid_is_refused_before_allocating() -> None:
    problem = DoubleIntegrator()
    grid = make_grid([np.linspace(-1.0, 1.0, 100_000)] * 3)
    with pytest.raises(InvalidInputError, match="grid"):
        fitted_value_iteration(grid, [-1.0, 1.0], problem.dynamics, problem.cost)


def test_refinement_actions_count_in_the_budget() -> None:
    problem = DoubleIntegrator()
    grid = make_grid([np.linspace(-1.0, 1.0, 2)] * 2)
    actions = np.vstack([np.zeros(14), np.ones(14)])  # 5^14 = 6.1e9 local actions per point
    with pytest.raises(InvalidInputError, match="actions"):
        fitted_value_iteration(
            grid,
            actions,
            problem.dynamics,
            problem.cost,
            FittedValueIterationOptions(refinements=1),
        )


def test_small_grid_still_solves() -> None:
    problem = DoubleIntegrator()
    grid = make_grid([np.linspace(-1.0, 1.0, 11)] * 2)
    result = fitted_value_iteration(grid, [-1.0, 0.0, 1.0], problem.dynamics, problem.cost)
    assert result.success
    assert np.all(np.isfinite(result.J)) and result.J.shape == (121,)
