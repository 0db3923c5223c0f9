"""A bool is not a number: scalar options refuse ``True``/``False`` (lead; audit3 left open).

Before, ``make_mdp(..., gamma=True)`` built an MDP with gamma 1.0, and every option read by
``as_scalar`` / ``check_positive`` took ``True`` as 1.0 and ``False`` as 0.0.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace._validation import as_scalar, check_positive
from taskspace.errors import InvalidInputError
from taskspace.optimal_control import make_mdp


@pytest.mark.parametrize("flag", [True, False, np.bool_(True), np.array([True])])
def test_scalars_refuse_bools(flag: object) -> None:
    with pytest.raises(InvalidInputError, match="number"):
        as_scalar(flag, "x")
    with pytest.raises(InvalidInputError, match="number"):
        check_positive(flag, "x")


def test_numbers_still_accepted() -> None:
    assert as_scalar(np.float32(0.5), "x") == 0.5
    assert as_scalar(np.array([2]), "x") == 2.0
    assert check_positive(3, "x") == 3.0


def test_mdp_gamma_true_is_refused() -> None:
    P = [np.eye(2), np.eye(2)]
    with pytest.raises(InvalidInputError, match="gamma"):
        make_mdp(P, np.zeros((2, 2)), gamma=True)
    assert make_mdp(P, np.zeros((2, 2)), gamma=1.0).gamma == 1.0
