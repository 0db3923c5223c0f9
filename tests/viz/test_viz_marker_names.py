"""Marker names map to distinct meshcat nodes (#15).

Before: "a/b", "a b" and "a_b" all became the node "markers/a_b": the second marker silently
replaced the first (and delete("a/b") removed "a_b").
"""

from __future__ import annotations

import numpy as np
import pytest
import umsgpack

from taskspace.errors import UnknownNameError
from taskspace.viz import Viewer

NAMES = ["a/b", "a_b", "a b", "a%2Fb", "a", "%", "ä/✓"]


def _objects(viewer: Viewer) -> dict[str, dict]:
    commands = map(umsgpack.unpackb, viewer.recorder.packed_commands())
    return {c["path"]: c for c in commands if c["type"] == "set_object"}


def test_every_name_has_its_own_node() -> None:
    viewer = Viewer()
    for k, name in enumerate(NAMES):
        viewer.add_points(name, np.full((1, 3), float(k)))
    objects = _objects(viewer)
    markers = [p for p in objects if p.startswith("/meshcat/markers/")]
    assert len(markers) == len(NAMES)
    # each node is one path element below markers/ and holds its own point
    assert all(p.count("/") == 3 for p in markers)
    lo, hi = viewer.scene_bounds()
    np.testing.assert_allclose(lo, 0.0)
    np.testing.assert_allclose(hi, len(NAMES) - 1.0)


@pytest.mark.parametrize("gone", NAMES)
def test_delete_removes_only_its_marker(gone: str) -> None:
    viewer = Viewer()
    for name in NAMES:
        viewer.add_points(name, np.zeros((1, 3)))
    before = set(_objects(viewer))
    viewer.delete(gone)
    after = set(_objects(viewer))
    assert len(before - after) == 1
    with pytest.raises(UnknownNameError) as info:
        viewer.delete(gone)
    # the error lists the remaining names as the user wrote them
    for name in NAMES:
        if name != gone:
            assert repr(name)[1:-1] in str(info.value) or name in str(info.value)
