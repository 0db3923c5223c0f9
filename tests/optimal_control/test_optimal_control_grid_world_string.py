"""grid_world given one string: its lines are the rows (each character was a row: a column).

Reference: the same world given as a list of rows (transition matrices and rewards equal).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.optimal_control import grid_world


def _same(a, b) -> None:
    (mdp_a, cells_a), (mdp_b, cells_b) = a, b
    assert cells_a == cells_b
    np.testing.assert_array_equal(mdp_a.rewards, mdp_b.rewards)
    for Pa, Pb in zip(mdp_a.transitions, mdp_b.transitions, strict=True):
        np.testing.assert_array_equal(Pa.toarray(), Pb.toarray())


@pytest.mark.parametrize(("text", "rows"), [("S.G", ["S.G"]), ("S.#\n..G", ["S.#", "..G"])])
def test_a_string_is_its_lines(text: str, rows: list[str]) -> None:
    _same(grid_world(text, gamma=0.9), grid_world(rows, gamma=0.9))
    _, cells = grid_world(text, gamma=0.9)
    assert max(r for r, _ in cells) == len(rows) - 1  # rows, not one row per character
