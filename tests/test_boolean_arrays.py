"""Boolean arrays are masks, not numbers: as_float_array (every array input) refuses them.

GraspContact(position=[True, False, True], ...) was taken as the point (1, 0, 1) m.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace._validation import as_float_array, as_vector
from taskspace.errors import InvalidInputError
from taskspace.grasping.contact import GraspContact


@pytest.mark.parametrize(
    "value",
    [
        True,
        np.bool_(False),
        [True, False, True],
        np.array([True, False, True]),
        [[True, False], [False, True]],
        np.array([1.0, True], dtype=object),
    ],
)
def test_as_float_array_refuses_booleans(value: object) -> None:
    with pytest.raises(InvalidInputError, match=r"x must be real numbers, got (a )?boolean"):
        as_float_array(value, "x")
    with pytest.raises(InvalidInputError, match="boolean"):
        as_vector(value, None, "x")


def test_as_float_array_still_takes_numbers() -> None:
    np.testing.assert_array_equal(as_float_array([1, 0, 1], "x"), [1.0, 0.0, 1.0])
    np.testing.assert_array_equal(as_float_array(np.array([1, 0], np.int8), "x"), [1.0, 0.0])
    assert as_float_array(2, "x") == 2.0


@pytest.mark.parametrize("field", ["position", "normal"])
def test_grasp_contact_refuses_boolean_position_and_normal(field: str) -> None:
    kwargs = {"position": [0.0, 0.0, 0.05], "normal": [0.0, 0.0, -1.0]}
    kwargs[field] = np.array([True, False, True])
    with pytest.raises(InvalidInputError, match=f"{field} must be real numbers, got boolean"):
        GraspContact(**kwargs)
    kwargs[field] = [True, False, True]
    with pytest.raises(InvalidInputError, match=f"{field} must be real numbers, got boolean"):
        GraspContact(**kwargs)
