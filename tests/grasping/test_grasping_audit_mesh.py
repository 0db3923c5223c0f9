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


def test_ray_exit_names_rays_of_the_wrong_shape():
    box = box_mesh([0.1, 0.2, 0.3])
    t, face = box.ray_exit([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]])
    assert t == pytest.approx([0.05]) and face[0] >= 0  # the face at x = 0.05, by hand
    for origins, directions in (
        (np.zeros(3), np.array([1.0, 0.0, 0.0])),  # one ray as (3,): was an IndexError
        (np.zeros((2, 3)), np.ones((1, 3))),
        (np.zeros((1, 3)), np.array([[np.nan, 0.0, 0.0]])),
    ):
        with pytest.raises(InvalidInputError):
            box.ray_exit(origins, directions)
