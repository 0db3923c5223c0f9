"""OccupancyGrid values other than booleans and 0/1 (sweep of session 35).

Any non-zero value was an obstacle: an occupancy probability of 0.2 blocked its cell, and an
image with white (255) free space and black (0) walls was read inverted, without a word.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.planning import OccupancyGrid, grid_search


@pytest.mark.parametrize("value", [0.2, 0.5, 255, -1, np.inf])
def test_values_other_than_0_and_1_are_refused(value: float) -> None:
    occ = np.zeros((4, 5))
    occ[2, 3] = value
    with pytest.raises(InvalidInputError, match="threshold"):
        OccupancyGrid(occ)


def test_text_values_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="dtype"):
        OccupancyGrid(np.full((2, 2), "x"))


@pytest.mark.parametrize("dtype", [bool, np.int8, np.uint8, np.float32, np.float64])
def test_zero_one_grids_are_the_boolean_grid(dtype: type) -> None:
    walls = np.zeros((5, 5), bool)
    walls[1:4, 2] = True
    grid = OccupancyGrid(walls.astype(dtype))
    assert grid.occupied.dtype == np.bool_ and np.array_equal(grid.occupied, walls)
    # the same search as on the boolean grid (the wall at column 2 forces a detour)
    res = grid_search(grid, (2, 0), (2, 4))
    ref = grid_search(OccupancyGrid(walls), (2, 0), (2, 4))
    assert res.success and res.cost == ref.cost
