"""Iteration caps of iterative algorithms: one convention, a clear error for anything else.

A cap is an integer (``check_count``): ``inf``, ``nan``, ``2.5``, ``None``, ``True`` or text
raise :class:`InvalidInputError` naming the option, instead of a bare ``TypeError`` from
``range`` (potential field, dynamic programming, Newton-Kleinman, compass-gait limit cycle,
bug algorithms) or a loop that never ends (``max_attempts=inf`` of the car's control tree when
every motion collides). A valid cap still gives the algorithm's result.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from taskspace.control.riccati import RiccatiOptions, solve_continuous_riccati
from taskspace.errors import InvalidInputError
from taskspace.locomotion.compass_gait import CompassGait, LimitCycleOptions, find_limit_cycle
from taskspace.optimal_control import (
    DoubleIntegrator,
    FittedValueIterationOptions,
    ValueIterationOptions,
    fitted_value_iteration,
    geometric_axis,
    make_grid,
    policy_iteration,
    t_maze,
    value_iteration,
)
from taskspace.planning.bug import BugOptions, bug1, bug2
from taskspace.planning.car import CarModel, ControlSamplingOptions, grow_control_tree
from taskspace.planning.kinodynamic_rrt import parking_lot
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    PotentialStatus,
    gradient_descent,
)

BAD_CAPS = [math.inf, math.nan, 2.5, None, True, "10", 1j, -1]

RECT = PolygonWorld((Polygon.rectangle(3, -2, 5, 2),), (-2.0, -6.0, 12.0, 6.0))
ASIDE = PolygonWorld((Polygon.rectangle(3, 3, 5, 5),), (-2.0, -6.0, 12.0, 6.0))


def _potential(options: PotentialFieldOptions) -> Any:
    field = PotentialField(ASIDE, (9, 0), options)
    return gradient_descent(field, (0, 0))


def _riccati(options: RiccatiOptions) -> Any:
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    return solve_continuous_riccati(A, B, np.eye(2), 1.0, options, initial_gain=[[1.0, 1.0]])


def _limit_cycle(options: LimitCycleOptions) -> Any:
    return find_limit_cycle(CompassGait(), [-0.2, 1.0, -0.4], options)


def _fitted(options: FittedValueIterationOptions) -> Any:
    problem = DoubleIntegrator()
    axis = geometric_axis(1.2, 1e-2, 1.5)
    grid = make_grid([axis, axis])
    return fitted_value_iteration(
        grid, geometric_axis(2.0, 1e-2, 1.5), problem.dynamics, problem.cost, options
    )


def _car(options: ControlSamplingOptions) -> Any:
    world, start, _ = parking_lot()
    return grow_control_tree(CarModel(), world, start, options=options)


# (algorithm, options class, cap field, valid options)
CASES: dict[str, tuple[Callable[[Any], Any], Any, str]] = {
    "potential_field.max_iterations": (
        _potential,
        PotentialFieldOptions(max_iterations=2000),
        "max_iterations",
    ),
    "potential_field.stall_window": (
        _potential,
        PotentialFieldOptions(max_iterations=2000),
        "stall_window",
    ),
    "value_iteration": (
        lambda o: value_iteration(t_maze(gamma=0.5), o),
        ValueIterationOptions(),
        "max_iterations",
    ),
    "policy_iteration": (
        lambda o: policy_iteration(t_maze(gamma=0.5), o),
        ValueIterationOptions(),
        "max_iterations",
    ),
    "newton_kleinman": (
        _riccati,
        RiccatiOptions(method="newton_kleinman"),
        "max_iterations",
    ),
    "compass_gait": (_limit_cycle, LimitCycleOptions(), "max_iterations"),
    "bug1": (lambda o: bug1(RECT, (0, 0), (11, 0), options=o), BugOptions(), "max_hits"),
    "bug2": (lambda o: bug2(RECT, (0, 0), (11, 0), options=o), BugOptions(), "max_hits"),
    "fitted_value_iteration.refinements": (
        _fitted,
        FittedValueIterationOptions(dt=1.0, refinements=1),
        "refinements",
    ),
    "fitted_value_iteration.substeps": (_fitted, FittedValueIterationOptions(dt=1.0), "substeps"),
    "car.max_attempts": (_car, ControlSamplingOptions(n_nodes=5), "max_attempts"),
    "car.n_nodes": (_car, ControlSamplingOptions(n_nodes=5), "n_nodes"),
}


@pytest.mark.parametrize("cap", BAD_CAPS, ids=repr)
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_cap_that_is_not_an_integer_is_refused(case: str, cap: Any) -> None:
    algorithm, options, field = CASES[case]
    with pytest.raises(InvalidInputError, match=field):
        algorithm(replace(options, **{field: cap}))


@pytest.mark.parametrize("case", sorted(CASES))
def test_integral_caps_still_work(case: str) -> None:
    """numpy integers and huge Python integers (clamped to int64) are caps like any other."""
    algorithm, options, field = CASES[case]
    value = getattr(options, field)
    assert algorithm(replace(options, **{field: np.int64(value)})).success
    fixed_work = ("n_nodes", "stall_window", "refinements", "substeps")
    if field not in fixed_work and case != "compass_gait":  # loops that end on success
        assert algorithm(replace(options, **{field: 10**30})).success


def test_a_huge_cap_ends_on_the_algorithms_own_criterion() -> None:
    """The potential field at a local minimum stops by its stall test, not by the cap."""
    cup = Polygon(
        np.array(
            [[4, -2], [6, -2], [6, 2], [4, 2], [4, 1.5], [5.5, 1.5], [5.5, -1.5], [4, -1.5]],
            float,
        )
    )
    field = PotentialField(
        PolygonWorld((cup,), (-2.0, -6.0, 12.0, 6.0)),
        (9, 0),
        PotentialFieldOptions(zeta=1.0, d_star=2.0, eta=0.5, q_star=1.0, max_iterations=10**30),
    )
    assert gradient_descent(field, (0, 0)).status is PotentialStatus.LOCAL_MINIMUM
