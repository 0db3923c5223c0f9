"""Ferrari-Canny epsilon written from the textbook definition, one QP per hull facet.

As Dex-Net computes it: the grasp wrench space is the convex hull of the primitive wrenches;
for each facet (a simplex of hull vertices) the nearest point of the facet to the origin is
the QP ``min |V^T a|^2, a >= 0, sum a = 1``; epsilon is the least such distance (0 when the
origin is outside the hull). Slow on purpose: it is the reference for tests and benchmarks.
"""

from __future__ import annotations

import numpy as np
import quadprog
from scipy.spatial import ConvexHull, QhullError


def epsilon_reference(W: np.ndarray) -> float:
    try:
        hull = ConvexHull(W)
    except QhullError:
        return 0.0
    if np.any(hull.equations[:, -1] >= 0):  # the origin is not strictly inside
        return 0.0
    best = np.inf
    for simplex in hull.simplices:
        V = W[simplex]
        k = len(simplex)
        G = V @ V.T + 1e-12 * np.eye(k)
        C = np.hstack([np.ones((k, 1)), np.eye(k)])
        b = np.hstack([1.0, np.zeros(k)])
        a = quadprog.solve_qp(G, np.zeros(k), C, b, meq=1)[0]
        best = min(best, float(np.linalg.norm(V.T @ a)))
    return best
