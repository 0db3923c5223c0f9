"""Nearest-neighbour search in a growing set of configurations (RRT ``q_near``, slide 3:39).

Nodes are stored in a preallocated array that doubles when full, with their squared norms; a
query ranks the nodes by ``|q_i - q|^2 - |q|^2 = |q_i|^2 - 2 q_i . q`` (one matrix-vector
product, O(n d), about 5 us for a few hundred 7-D nodes) and computes the exact distance of
the winner only, which beats tree structures for the tree sizes of single-query planners.

Thread safety: a :class:`GrowingNearest` is a mutable workspace (its points grow in place) and is
not locked: one per thread, as owned by the planner call that builds it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class GrowingNearest:
    """Append-only point set with brute-force vectorized nearest-neighbour queries.

    Args:
        dim: dimension ``d``.
        capacity: initial capacity (doubled when exceeded).
        metric: ``metric(points, q) -> distances`` (shape (n,)) for a non-Euclidean space
            (e.g. :meth:`ConfigurationSpace.distances` on a joint manifold); ``None``: the
            Euclidean distance by the fast ranking above.
    """

    def __init__(self, dim: int, capacity: int = 1024, metric: Any = None) -> None:
        self._metric = metric
        self._points = np.empty((max(1, capacity), dim))
        self._sq = np.empty(max(1, capacity))
        self._n = 0
        self._disabled = 0

    def __len__(self) -> int:
        return self._n

    @property
    def points(self) -> FloatArray:
        """The stored points, shape (n, d) (a view)."""
        return self._points[: self._n]

    def add(self, q: FloatArray) -> int:
        """Store ``q`` and return its index."""
        n = self._n
        if n == self._points.shape[0]:
            grown = np.empty((2 * n, self._points.shape[1]))
            grown[:n] = self._points
            self._points = grown
            sq = np.empty(2 * n)
            sq[:n] = self._sq
            self._sq = sq
        self._points[n] = q
        self._sq[n] = float(q @ q)
        self._n = n + 1
        return self._n - 1

    def disable(self, indices: list[int]) -> None:
        """Exclude the points ``indices`` from future queries (their coordinates become 0).

        Their squared norm is set to inf, so they never rank first (unless all are excluded);
        a ``metric`` is evaluated on the other points only.
        """
        idx = np.asarray(indices, dtype=np.int64)
        self._points[idx] = 0.0
        self._sq[idx] = np.inf
        self._disabled = int(np.count_nonzero(np.isinf(self._sq[: self._n])))

    def nearest(self, q: FloatArray) -> tuple[int, float]:
        """Index of the stored point closest to ``q`` and the distance ``|q_i - q|``."""
        n = self._n
        points = self._points
        if self._metric is not None:
            if not self._disabled:
                dist = self._metric(points[:n], q)
            else:  # the metric of the live points only: a disabled one's zeros are no
                # configuration (a (cos, sin) pair of norm 0 gave NaN and RuntimeWarnings)
                live = ~np.isinf(self._sq[:n])
                dist = np.full(n, np.inf)
                if live.any():
                    dist[live] = self._metric(points[:n][live], q)
            i = int(dist.argmin())
            return i, float(dist[i])
        i = int((self._sq[:n] - 2.0 * (points[:n] @ q)).argmin())
        diff = points[i] - q
        return i, math.sqrt(float(diff @ diff))
