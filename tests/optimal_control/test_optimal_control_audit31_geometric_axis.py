"""``geometric_axis`` at the edges of its parameters (audit, session 31).

``ratio = 1 + 1e-15`` asked NumPy for 4.32 EiB (a bare ``MemoryError``), ``half_width = inf``
was a bare ``OverflowError``, a NaN ``center`` gave an axis of NaNs and ``center = 1e300`` one
whose points all round to the same float (not strictly increasing, refused only later by
``make_grid``). Valid axes are checked against the closed form written here.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.optimal_control import geometric_axis, make_grid


def test_closed_form() -> None:
    ax = geometric_axis(1.0, 0.1, 2.0, center=3.0)
    pos = np.array([0.1, 0.2, 0.4, 0.8, 1.0])
    np.testing.assert_allclose(ax, np.concatenate([3.0 - pos[::-1], [3.0], 3.0 + pos]))
    make_grid([ax])
    assert geometric_axis(1, 0.1, np.int64(3)).size == 9  # 0.1, 0.3, 0.9, 1.0 per side


@pytest.mark.parametrize(
    ("half_width", "smallest", "ratio", "center"),
    [
        (1.0, 0.1, 1.0 + 1e-15, 0.0),
        (1.0, 1e-300, 1.0 + 1e-9, 0.0),
        (np.inf, 0.1, 2.0, 0.0),
        (1.0, 0.1, 2.0, np.nan),
        (1.0, 0.1, 2.0, np.inf),
        (1.0, 0.1, 2.0, 1e300),
        (1.0, 0.1, np.nan, 0.0),
        ("1", 0.1, 2.0, 0.0),
    ],
    ids=[
        "ratio_1p1e-15",
        "tiny_ratio",
        "inf_width",
        "nan_center",
        "inf_center",
        "huge_center",
        "nan_ratio",
        "text",
    ],
)
def test_bad_parameters_are_named(
    half_width: float, smallest: float, ratio: float, center: float
) -> None:
    with pytest.raises(InvalidInputError):
        geometric_axis(half_width, smallest, ratio, center=center)
