"""The closed-form formulas refuse inputs whose products overflow (were NaN results).

Before: a Jacobian with entries 1e300 (finite, so accepted) made ``J^T C J`` inf and the
damped and weighted pseudo-inverses, ``ik_step`` and ``stacked_step`` returned NaN arrays
without a word. Reference for the finite cases: NumPy's SVD pseudo-inverse (a full-row-rank
``J`` with ``W = I``, ``C -> inf``: the damped and weighted forms tend to it).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.qp import closed_form as cf

J = np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 1.0]])
W, C, e = np.eye(3), np.eye(2), np.array([1.0, 2.0])

CALLS = {
    "damped_pseudo_inverse": lambda J: cf.damped_pseudo_inverse(J, 0.1),
    "weighted_pseudo_inverse": lambda J: cf.weighted_pseudo_inverse(J, W, C),
    "weighted_pseudo_inverse_woodbury": lambda J: cf.weighted_pseudo_inverse_woodbury(J, W, C),
    "ik_step": lambda J: cf.ik_step(J, e, W, C),
    "stacked_step": lambda J: cf.stacked_step([J], [e], [1.0], W),
    "hierarchical_step_regularized": lambda J: cf.hierarchical_step_regularized(
        [J], [e], [1.0], W, np.zeros(3)
    ),
}


@pytest.mark.parametrize("name", sorted(CALLS))
def test_overflowing_products_are_refused(name: str) -> None:
    with pytest.raises(InvalidInputError, match="overflow"):
        CALLS[name](1e300 * J)


def test_tiny_damping_and_huge_precision_tend_to_the_pseudo_inverse() -> None:
    ref = np.linalg.pinv(J)
    np.testing.assert_allclose(cf.damped_pseudo_inverse(J, 1e-8), ref, atol=1e-12)
    np.testing.assert_allclose(cf.weighted_pseudo_inverse(J, W, 1e8 * C), ref, atol=1e-6)
    np.testing.assert_allclose(cf.pseudo_inverse(1e100 * J), 1e-100 * ref, rtol=1e-12)
