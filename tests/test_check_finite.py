"""check_finite on huge finite entries (#15): no spurious overflow warning, exact verdict."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from taskspace._validation import as_matrix, as_vector, check_finite
from taskspace.errors import NotFiniteError

HUGE = [1e155, 1e200, 1e300, np.finfo(float).max]


@pytest.mark.parametrize("value", HUGE)
@pytest.mark.parametrize("shape", [(1,), (2,), (100,), (3, 3)])
def test_huge_finite_entries_pass_without_warning(value: float, shape: tuple[int, ...]) -> None:
    arr = np.full(shape, value)
    arr.flat[0] = 1.0
    assert np.isfinite(arr).all()  # the reference
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # was: RuntimeWarning overflow encountered in matmul
        check_finite(arr, "x")
        check_finite(arr.T, "x")
        check_finite(arr.astype(np.float32) if value < 3e38 else arr, "x")
        if arr.ndim == 1:
            as_vector(arr, None, "x")
        else:
            as_matrix(arr, (None, None), "x")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("other", [0.0, 1e200, -1e300])
def test_non_finite_entries_are_named(bad: float, other: float) -> None:
    arr = np.array([other, bad, other, bad])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NotFiniteError) as info:
            check_finite(arr, "x")
    assert "1" in str(info.value) and "3" in str(info.value)
    assert list(np.flatnonzero(~np.isfinite(arr))) == [1, 3]


def test_random_arrays_agree_with_numpy() -> None:
    rng = np.random.default_rng(0)
    pool = np.array([0.0, 1.0, -1e-300, 1e154, 1e155, 1e308, -1e308, np.nan, np.inf, -np.inf])
    for _ in range(300):
        arr = rng.choice(pool, size=int(rng.integers(1, 8)))
        expected = bool(np.isfinite(arr).all())
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                check_finite(arr, "x")
                got = True
            except NotFiniteError:
                got = False
        assert got == expected, arr
