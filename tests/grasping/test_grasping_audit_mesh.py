"""Triangle meshes from odd inputs (audit of session 30): indices are integers or an error."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.grasping import TriangleMesh, box_mesh


def test_faces_must_be_integer_indices():
    box = box_mesh([0.1, 0.2, 0.3])
    # integral floats (as a loader may give them) are the same mesh
    same = TriangleMesh(box.vertices, box.faces.astype(np.float64))
    assert np.array_equal(same.faces, box.faces)
    assert sum(same.areas) == pytest.approx(2 * (0.1 * 0.2 + 0.2 * 0.3 + 0.1 * 0.3))
    for bad in (
        box.faces + 0.5,  # was truncated to other vertices silently
        np.ones((2, 3), dtype=bool),  # was read as vertex 1
        [["a", "b", "c"]],  # was a numpy UFuncTypeError
        np.array([[0.0, 1.0, np.nan]]),
        box.faces[:, :2],
        box.faces + len(box.vertices),
    ):
        with pytest.raises(InvalidInputError, match="faces"):
            TriangleMesh(box.vertices, bad)
