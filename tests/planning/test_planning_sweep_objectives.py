"""Objectives on inputs they were not designed around (sweep of session 35).

Each case was silently wrong or a bare NumPy traceback before: a resolution so fine that
the piece count overflowed int64 and became ONE piece (a wrong integral), a 1-D path costed
as one waypoint (0), NaN costs, a metric returning negative lengths.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, NotFiniteError
from taskspace.planning.objectives import (
    Clearance,
    MechanicalWork,
    MetricLength,
    PathLength,
    WeightedSum,
)


def line_clearance(Q: np.ndarray) -> np.ndarray:
    """Distance [m] of each row to the line x = -1 (exact: x + 1)."""
    return np.atleast_2d(Q)[:, 0] + 1.0


def test_clearance_resolution_too_fine_is_refused_not_one_piece() -> None:
    # along y at x = 0 the integrand is constant 1 / (eps + 1): the exact cost is L / (eps + 1)
    path = np.array([[0.0, 0.0], [0.0, 2.0]])
    exact = 2.0 / (0.01 + 1.0)
    assert Clearance(line_clearance, resolution=0.1).path_cost(path) == pytest.approx(exact)
    # along x the integrand varies: 1e-300 used to overflow ceil(L / res) in int64 and fall
    # back to a single trapezoid (cost 1.32 instead of the integral ln(3.01 / 1.01) = 1.092)
    fine = Clearance(line_clearance, resolution=1e-300)
    with pytest.raises(InvalidInputError, match="resolution=1e-300"):
        fine.path_cost(np.array([[0.0, 0.0], [2.0, 0.0]]))
    ok = Clearance(line_clearance, resolution=1e-3).path_cost(np.array([[0.0, 0.0], [2.0, 0.0]]))
    assert ok == pytest.approx(math.log(3.01 / 1.01), rel=1e-6)


def test_mechanical_work_resolution_too_fine_is_refused_not_one_piece() -> None:
    model = pin.buildSampleModelManipulator()
    a = np.zeros(model.nq)
    b = np.full(model.nq, 0.5)
    with pytest.raises(InvalidInputError, match="MechanicalWork: resolution=1e-300"):
        MechanicalWork(model, resolution=1e-300).motion_costs(a, b)
    # inf still means one piece
    one = MechanicalWork(model, resolution=math.inf).motion_cost(a, b)
    tau = pin.computeGeneralizedGravity(model, model.createData(), (a + b) / 2)
    assert one == pytest.approx(abs(float(tau @ (b - a))), rel=1e-12)


@pytest.mark.parametrize(
    "objective",
    [PathLength(), Clearance(line_clearance), WeightedSum([(2.0, PathLength())])],
    ids=["length", "clearance", "sum"],
)
def test_path_cost_reads_paths_as_the_planners_do(objective: object) -> None:
    # a 1-D array is ambiguous (3 waypoints of a 1-D space, or one of 3 coordinates): it was
    # costed as one waypoint, 0
    with pytest.raises(InvalidInputError, match="ambiguous"):
        objective.path_cost([0.0, 1.0, 2.0])  # type: ignore[attr-defined]
    with pytest.raises(NotFiniteError):
        objective.path_cost([[0.0, 0.0], [np.nan, 1.0]])  # type: ignore[attr-defined]
    with pytest.raises(InvalidInputError, match="m >= 1"):
        objective.path_cost(np.zeros((0, 2)))  # type: ignore[attr-defined]
    with pytest.raises(InvalidInputError, match="shape"):
        objective.path_cost(np.zeros((2, 2, 2)))  # type: ignore[attr-defined]
    assert objective.path_cost([[0.5, 0.5]]) == 0.0  # type: ignore[attr-defined]


def test_path_cost_of_a_1d_space_path() -> None:
    assert PathLength().path_cost([[0.0], [1.0], [3.0]]) == 3.0


def test_motion_cost_takes_lists_and_refuses_nan() -> None:
    assert PathLength().motion_cost([0, 0], [3, 4]) == 5.0
    assert PathLength([1.0, 2.0]).motion_cost(np.float32([0, 0]), [3, 2]) == 5.0
    with pytest.raises(NotFiniteError, match="q1"):
        PathLength().motion_cost(np.zeros(2), np.array([1.0, np.nan]))
    with pytest.raises(InvalidInputError, match="q1"):
        PathLength().motion_cost([0.0, 0.0], [1.0, 1.0, 1.0])


def test_metric_length_refuses_what_is_not_a_metric() -> None:
    with pytest.raises(InvalidInputError, match="function"):
        MetricLength(3)  # type: ignore[arg-type]
    path = np.zeros((3, 2))
    with pytest.raises(InvalidInputError, match=">= 0"):
        MetricLength(lambda a, b: -np.ones(len(a))).path_cost(path)
    with pytest.raises(InvalidInputError, match=">= 0"):
        MetricLength(lambda a, b: np.full(len(a), np.nan)).path_cost(path)
    with pytest.raises(InvalidInputError, match="5 values for 2 pairs"):
        MetricLength(lambda a, b: np.ones(5)).path_cost(path)
    taxicab = MetricLength(lambda a, b: np.abs(b - a).sum(axis=1))
    assert taxicab.path_cost([[0, 0], [1, 2], [1, 3]]) == 4.0


def test_clearance_max_clearance_numpy_scalar_and_bool() -> None:
    bound = Clearance(line_clearance, epsilon=0.5, max_clearance=np.float32(1.5))
    assert bound.cost_lower_bounds(np.zeros(2), np.array([3.0, 4.0]))[0] == pytest.approx(2.5)
    with pytest.raises(InvalidInputError, match="max_clearance"):
        Clearance(line_clearance, max_clearance=True)


def test_clearance_max_clearance_must_bound_the_clearance() -> None:
    # along x in [0, 2] the clearance x + 1 reaches 3 m: a max_clearance of 1.5 m made
    # c_hat = L / (eps + 1.5) larger than the cost (an inadmissible bound: BIT*'s heuristic,
    # informed pruning and the optimum test would cut the optimal path)
    path = np.array([[0.0, 0.0], [2.0, 0.0]])
    with pytest.raises(InvalidInputError, match="max_clearance"):
        Clearance(line_clearance, max_clearance=1.5).path_cost(path)
    bound = Clearance(line_clearance, resolution=1e-3, max_clearance=3.0)
    cost = bound.path_cost(path)
    assert cost == pytest.approx(math.log(3.01 / 1.01), rel=1e-6)
    assert bound.cost_lower_bounds(path[0], path[1])[0] <= cost
