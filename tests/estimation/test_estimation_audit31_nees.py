"""nees() checks its covariances and names bad shapes (audit 31).

An indefinite "covariance" gave a negative NEES (nees([[0, 0]], [[1, 0]], [[[-1, 0], [0, 1]]])
was [-1.0]) and a non-symmetric one a value of its own; 1-D truth and means were refused as
"means must have shape (2,), got (2,)".
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation import nees


def test_nees_matches_the_closed_form():
    rng = np.random.default_rng(7)
    T, n = 5, 3
    A = rng.normal(size=(T, n, n))
    P = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(n)
    x, m = rng.normal(size=(T, n)), rng.normal(size=(T, n))
    ref = [(x[k] - m[k]) @ np.linalg.inv(P[k]) @ (x[k] - m[k]) for k in range(T)]
    np.testing.assert_allclose(nees(x, m, P), ref, rtol=1e-10)
    assert (nees(x, m, P) >= 0).all()


def test_a_covariance_that_is_not_one_is_refused():
    with pytest.raises(InvalidInputError, match=r"covs\[0\].*positive definite"):
        nees([[0.0, 0.0]], [[1.0, 0.0]], [[[-1.0, 0.0], [0.0, 1.0]]])
    with pytest.raises(InvalidInputError, match=r"covs\[1\].*symmetric"):
        nees(np.zeros((2, 2)), np.ones((2, 2)), [np.eye(2), [[1.0, 5.0], [0.0, 1.0]]])


def test_one_dimensional_inputs_are_named():
    with pytest.raises(ShapeError, match=r"truth must have shape \(-1, -1\), got \(2,\)"):
        nees([0.0, 1.0], [1.0, 0.0], [[1.0]])
