"""``quaternion(R)`` on inputs that are not rotations (audit, session 31).

It handed any array to ``pinocchio.Quaternion``: a NaN matrix gave a NaN quaternion, ``2 I`` a
quaternion of norm 1.32, a reflection ``-I`` the quaternion of a half turn, and a 2 x 2 or a
stack of rotations a Boost.Python ``ArgumentError``. Rotations still match SciPy's
``Rotation.as_quat`` (x, y, z, w) up to the sign.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from taskspace.errors import InvalidInputError
from taskspace.learning import quaternion


def test_rotations_match_scipy() -> None:
    for R in Rotation.random(50, random_state=3).as_matrix():
        q = quaternion(R)
        ref = Rotation.from_matrix(R).as_quat()
        assert min(np.abs(q - ref).max(), np.abs(q + ref).max()) < 1e-12
    np.testing.assert_array_equal(quaternion(np.eye(3).tolist()), [0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    "R",
    [
        np.full((3, 3), np.nan),
        2.0 * np.eye(3),
        -np.eye(3),
        np.diag([1.0, 1.0, -1.0]),
        np.eye(2),
        np.stack([np.eye(3)] * 2),
        np.eye(3) + 1e-3,
        "abc",
    ],
    ids=["nan", "scaled", "minus_identity", "reflection", "2x2", "stack", "perturbed", "text"],
)
def test_non_rotations_are_named(R: object) -> None:
    with pytest.raises(InvalidInputError, match="rotation"):
        quaternion(R)  # type: ignore[arg-type]
