"""Histogram filter prior and motion kernel of huge or non-finite weights (sweep35).

Both were normalized by their sum: weights near 1e308 summed to inf and the belief (or the
transition matrix) came out all zeros, an inf weight gave NaN columns, silently. References:
the normalized weights written out.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation import HistogramFilter
from taskspace.estimation.histogram_filter import shift_transition_matrix


def test_prior_of_huge_weights() -> None:
    np.testing.assert_allclose(HistogramFilter([1e308, 1e308]).belief, [0.5, 0.5])
    np.testing.assert_allclose(HistogramFilter([1e308, 3e307]).belief, [1 / 1.3, 0.3 / 1.3])


def test_kernel_of_huge_weights() -> None:
    T = shift_transition_matrix(5, 1, [1e308, 1e308, 1e307])
    ref = shift_transition_matrix(5, 1, [1.0, 1.0, 0.1])
    np.testing.assert_allclose(T, ref, rtol=1e-15)
    np.testing.assert_allclose(T.sum(axis=0), np.ones(5))
    np.testing.assert_allclose(T[:, 0], [1 / 2.1, 1 / 2.1, 0.1 / 2.1, 0.0, 0.0])


@pytest.mark.parametrize("kernel", [[np.inf, 1.0, 1.0], [np.nan, 1.0, 1.0], [0.0, 0.0, 0.0]])
def test_kernel_not_finite_or_zero_is_refused(kernel: list[float]) -> None:
    with pytest.raises(InvalidInputError, match="kernel"):
        shift_transition_matrix(4, 1, kernel)
