"""SupportPolygon.from_points at any finite scale, against scipy.spatial.ConvexHull.

The old hull rounded the points to 12 decimals (a 1e-7 m square came out as a segment, a
1e-13 m one as a point) and overflowed in its cross products near 1e154 m (1e200 m points
gave a wrong hull with an overflow warning).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from taskspace.locomotion.support_polygon import SupportPolygon

SCALES = [1e-300, 1e-13, 1e-7, 1e-3, 1.0, 1e3, 1e150, 1e200, 1e300]


def _cloud(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(0.0, 1.0, 25))
    a = rng.uniform(0.0, 2.0 * np.pi, 25)
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


@pytest.mark.parametrize("scale", SCALES)
@pytest.mark.parametrize("seed", [0, 1])
def test_hull_area_centroid_margin_match_qhull_at_any_scale(scale: float, seed: int) -> None:
    unit = _cloud(seed) + np.array([0.3, -0.2])
    pts = unit * scale
    ref = ConvexHull(unit)  # the same hull at unit scale (scaling keeps the hull)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow / invalid-value warnings
        poly = SupportPolygon.from_points(pts)
        A, b = poly.halfspaces()
        inside = np.array([0.3, -0.2]) * scale
        outside = np.array([2.3, -0.2]) * scale
        m_in, m_out = poly.margin(inside), poly.margin(outside)
        centroid = poly.centroid
        area = poly.area
    # the vertices: exactly the input points qhull finds on the hull, counter-clockwise
    assert sorted(map(tuple, poly.vertices)) == sorted(map(tuple, pts[ref.vertices]))
    u = poly.vertices / scale
    e0 = np.roll(u, -1, axis=0) - u
    e1 = np.roll(e0, -1, axis=0)
    turn = e0[:, 0] * e1[:, 1] - e0[:, 1] * e1[:, 0]
    assert np.all(turn > 0.0)
    # the area: qhull's volume times scale^2 (inf or 0 where that leaves the float range)
    expected_area = ref.volume * scale * scale
    if np.isfinite(expected_area) and expected_area > 1e-300:
        assert area == pytest.approx(expected_area, rel=1e-12)
    else:
        assert area == expected_area
    # the area centroid of qhull's polygon (shoelace at unit scale), scaled
    hv = unit[ref.vertices]
    x, y = hv[:, 0], hv[:, 1]
    cr = x * np.roll(y, -1) - np.roll(x, -1) * y
    c_ref = np.array([((x + np.roll(x, -1)) * cr).sum(), ((y + np.roll(y, -1)) * cr).sum()])
    c_ref /= 3.0 * cr.sum()
    np.testing.assert_allclose(centroid / scale, c_ref, rtol=1e-12, atol=1e-12)
    # unit normals, and the margin from qhull's half-spaces (n . p + d <= 0, |n| = 1)
    np.testing.assert_allclose(np.hypot(A[:, 0], A[:, 1]), 1.0, rtol=1e-14)
    np.testing.assert_allclose(b / scale, np.einsum("ij,ij->i", A, u), rtol=1e-12, atol=1e-12)
    eq = ref.equations
    assert m_in / scale == pytest.approx(-np.max(eq[:, :2] @ [0.3, -0.2] + eq[:, 2]), rel=1e-9)
    # outside: minus the distance to the nearest vertex or edge (enumerated at unit scale)
    p = np.array([2.3, -0.2])
    d = min(
        np.linalg.norm(p - (a + np.clip((p - a) @ (c - a) / ((c - a) @ (c - a)), 0, 1) * (c - a)))
        for a, c in zip(hv, np.roll(hv, -1, axis=0), strict=True)
    )
    assert m_out / scale == pytest.approx(-d, rel=1e-9)


@pytest.mark.parametrize("scale", [1e-13, 1e-9, 1e-7, 1.0, 1e200])
def test_small_square_with_interior_and_edge_points(scale: float) -> None:
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [0.5, 0.0], [1.0, 0.25]])
    poly = SupportPolygon.from_points(sq * scale)
    assert poly.vertices.shape == (4, 2)  # the collinear edge points are not vertices
    assert sorted(map(tuple, poly.vertices / scale)) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert poly.margin(np.array([0.5, 0.5]) * scale) == pytest.approx(0.5 * scale, rel=1e-12)


def test_degenerate_inputs_stay_degenerate_at_small_scale() -> None:
    seg = SupportPolygon.from_points(np.array([[0.0, 0.0], [1e-9, 0.0], [2e-9, 0.0]]))
    # collinear points: a segment between its end points (not a triangle, not a point)
    assert seg.is_degenerate
    assert sorted(map(tuple, seg.vertices)) in ([(0.0, 0.0), (2e-9, 0.0)],)
    pt = SupportPolygon.from_points(np.array([[1e-9, 2e-9], [1e-9, 2e-9]]))
    assert pt.vertices.tolist() == [[1e-9, 2e-9]]
    assert pt.margin([1e-9 + 3e-12, 2e-9 + 4e-12]) == pytest.approx(-5e-12, rel=1e-12)
