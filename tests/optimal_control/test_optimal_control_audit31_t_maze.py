"""``t_maze`` sizes that are not integers (audit, session 31).

``t_maze(stem=2.5)``, ``stem=nan`` or an arm of length ``1.5`` were bare ``TypeError``s from
``range()``; a NaN reward passed to ``make_mdp`` (refused there). Valid mazes: the value of
the start with gamma = 0.5 is the closed form ``gamma^(stem-1+k-1) r`` of the better arm.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.optimal_control import t_maze, value_iteration


def test_closed_form_values() -> None:
    mdp = t_maze(stem=np.int64(3))
    V = value_iteration(mdp).V
    # right arm: 2 cells, reward 3 on entering the second; from stem0: 2 stem moves + 2 arm moves
    assert V[0] == pytest.approx(0.5**3 * 3.0)
    assert mdp.state_names[-1] == "right2" and "end" not in mdp.state_names


@pytest.mark.parametrize(
    "kwargs",
    [{"stem": 2.5}, {"stem": np.nan}, {"stem": True}, {"left": (1.5, 1.0)}, {"right": (2,)}],
    ids=["stem_float", "stem_nan", "stem_bool", "arm_float", "arm_pair"],
)
def test_bad_sizes_are_named(kwargs: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        t_maze(**kwargs)  # type: ignore[arg-type]
