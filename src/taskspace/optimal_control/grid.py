"""Rectilinear state grids and multilinear interpolation (sparse weight matrices).

A grid is the product of sorted 1-D axes; a point ``x`` lies in one cell and its value is
interpolated from the ``2^d`` cell corners with the weights
``w_c = prod_i (t_i if c_i = 1 else 1 - t_i)`` with
``t_i = (x_i - a_i[k_i]) / (a_i[k_i+1] - a_i[k_i])``.
The weights are nonnegative and sum to 1, so an interpolation matrix is a stochastic matrix:
value iteration on a grid is value iteration on an MDP whose transition probabilities are the
interpolation weights of the successor states (Munos and Moore's barycentric view).

Axes are clipped at their ends, except periodic axes (angles), which wrap around with period
``period`` (the axis then covers ``[a_0, a_0 + period)``, the last point excluded).

Thread safety: a :class:`StateGrid` is an immutable value (frozen dataclass) whose methods build
new arrays, so it may be shared by threads as long as nobody modifies its axes in place.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from taskspace._validation import FloatArray, as_float_array, as_scalar, check_positive
from taskspace.errors import InvalidInputError


@dataclass(frozen=True)
class StateGrid:
    """A rectilinear grid; build it with :func:`make_grid`.

    Attributes:
        axes: sorted coordinates of each dimension.
        periods: period of each axis (``0.0``: not periodic).
    """

    axes: tuple[FloatArray, ...]
    periods: tuple[float, ...]

    @property
    def shape(self) -> tuple[int, ...]:
        """Number of points per axis."""
        return tuple(a.size for a in self.axes)

    @property
    def dim(self) -> int:
        """State dimension ``d``."""
        return len(self.axes)

    @property
    def size(self) -> int:
        """Number of grid points ``N``."""
        return int(np.prod(self.shape))

    def points(self) -> FloatArray:
        """All grid points (N x d), in C order (last axis fastest)."""
        mesh = np.meshgrid(*self.axes, indexing="ij")
        return np.stack([m.ravel() for m in mesh], axis=1)

    def interpolation_matrix(self, X: Any) -> sp.csr_matrix:
        """Sparse multilinear weights ``W`` (K x N) with ``f(X) ~ W f(grid)``.

        Args:
            X: query points (K x d); non-periodic coordinates are clipped to the axis range.
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if X.shape[1] != self.dim:
            raise InvalidInputError(f"points must have {self.dim} columns, got {X.shape[1]}")
        if not np.all(np.isfinite(X)):
            raise InvalidInputError("interpolation points must be finite")
        K = X.shape[0]
        lo_idx, hi_idx, frac = [], [], []
        for i, (axis, period) in enumerate(zip(self.axes, self.periods)):
            x = X[:, i]
            n = axis.size
            if period > 0.0:
                x = axis[0] + np.mod(x - axis[0], period)
                ext = np.append(axis, axis[0] + period)
                k = np.clip(np.searchsorted(ext, x, side="right") - 1, 0, n - 1)
                t = (x - ext[k]) / (ext[k + 1] - ext[k])
                lo_idx.append(k)
                hi_idx.append((k + 1) % n)
            else:
                x = np.clip(x, axis[0], axis[-1])
                if n == 1:
                    k = np.zeros(K, dtype=int)
                    t = np.zeros(K)
                    lo_idx.append(k)
                    hi_idx.append(k)
                    frac.append(t)
                    continue
                k = np.clip(np.searchsorted(axis, x, side="right") - 1, 0, n - 2)
                t = (x - axis[k]) / (axis[k + 1] - axis[k])
                lo_idx.append(k)
                hi_idx.append(k + 1)
            frac.append(np.clip(t, 0.0, 1.0))
        strides = np.array([int(np.prod(self.shape[i + 1 :])) for i in range(self.dim)])
        rows, cols, vals = [], [], []
        for corner in itertools.product((0, 1), repeat=self.dim):
            w = np.ones(K)
            idx = np.zeros(K, dtype=np.int64)
            for i, c in enumerate(corner):
                w = w * (frac[i] if c else 1.0 - frac[i])
                idx += strides[i] * (hi_idx[i] if c else lo_idx[i])
            rows.append(np.arange(K))
            cols.append(idx)
            vals.append(w)
        W = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(K, self.size),
        )
        W.eliminate_zeros()
        return W

    def interpolate(self, values: Any, X: Any) -> FloatArray:
        """Multilinear interpolation of grid values (N,) at points X (K x d)."""
        v = np.asarray(values, dtype=float).ravel()
        if v.size != self.size:
            raise InvalidInputError(f"need {self.size} grid values, got {v.size}")
        return np.asarray(self.interpolation_matrix(X) @ v, dtype=float)

    def gradient(self, values: Any) -> FloatArray:
        """Finite-difference gradient of grid values (N x d).

        Central differences inside, one-sided at the ends of non-periodic axes, wrapped on
        periodic axes.
        """
        V = np.asarray(values, dtype=float).reshape(self.shape)
        out = []
        for i, (axis, period) in enumerate(zip(self.axes, self.periods)):
            if period > 0.0:
                ext_lo = np.concatenate([[axis[-1] - period], axis[:-1]])
                ext_hi = np.concatenate([axis[1:], [axis[0] + period]])
                g = (np.roll(V, -1, axis=i) - np.roll(V, 1, axis=i)) / (
                    (ext_hi - ext_lo).reshape([-1 if j == i else 1 for j in range(self.dim)])
                )
            elif axis.size > 1:
                g = np.gradient(V, axis, axis=i)
            else:
                g = np.zeros_like(V)
            out.append(g.ravel())
        return np.stack(out, axis=1)


def make_grid(axes: Sequence[Any], *, periods: Sequence[float] | None = None) -> StateGrid:
    """Build a :class:`StateGrid`.

    Args:
        axes: one strictly increasing 1-D array per dimension.
        periods: period per axis (0: not periodic); a periodic axis must fit in one period.

    Raises:
        InvalidInputError: unsorted or non-finite axes, or a periodic axis longer than its
            period.
    """
    if isinstance(axes, (str, bytes)) or not hasattr(axes, "__iter__"):
        raise InvalidInputError(f"axes must be a sequence of 1-D arrays, got {axes!r}")
    arrs = tuple(as_float_array(a, f"axis {i}").ravel() for i, a in enumerate(axes))
    if not arrs:
        raise InvalidInputError("a grid needs at least one axis")
    per = tuple(
        check_positive(p, f"period of axis {i}", strict=False)  # NaN was accepted
        for i, p in enumerate(periods if periods is not None else [0.0] * len(arrs))
    )
    if len(per) != len(arrs):
        raise InvalidInputError(f"need {len(arrs)} periods, got {len(per)}")
    for i, (a, p) in enumerate(zip(arrs, per)):
        if a.size == 0 or not np.all(np.isfinite(a)):
            raise InvalidInputError(f"axis {i} must be a non-empty finite array")
        if a.size > 1 and np.any(np.diff(a) <= 0):
            raise InvalidInputError(f"axis {i} must be strictly increasing")
        if p < 0 or (p > 0 and a[-1] - a[0] >= p):
            raise InvalidInputError(
                f"axis {i} spans {a[-1] - a[0]:.4g} but its period is {p:.4g}: a periodic axis "
                "covers [a_0, a_0 + period) without its end point"
            )
    return StateGrid(axes=arrs, periods=per)


MAX_GEOMETRIC_POINTS = 1_000_000
"""Largest number of points on each side of a :func:`geometric_axis`."""


def geometric_axis(
    half_width: float, smallest: float, ratio: float, *, center: float = 0.0
) -> FloatArray:
    """A symmetric axis with spacing growing geometrically away from ``center``.

    Points ``center``, ``center +- smallest ratio^k`` (k = 0, 1, ...) up to
    ``center +- half_width``: the cell size is proportional to the distance from ``center``, so
    the relative interpolation error of a function like ``|x|^2`` is the same at every scale
    (used to resolve a value function near an equilibrium).
    """
    half_width = check_positive(half_width, "half_width")  # inf was a bare OverflowError
    smallest = check_positive(smallest, "smallest")
    ratio = check_positive(ratio, "ratio")
    center = as_scalar(center, "center")  # NaN gave an axis of NaNs
    if not (np.isfinite(center) and smallest < half_width and ratio > 1):
        raise InvalidInputError(
            "need half_width > 0, 0 < smallest < half_width, ratio > 1 and a finite center for "
            f"a geometric axis, got half_width={half_width}, smallest={smallest}, "
            f"ratio={ratio}, center={center}"
        )
    k = int(np.ceil(np.log(half_width / smallest) / np.log(ratio)))
    if k + 1 > MAX_GEOMETRIC_POINTS:  # ratio = 1 + 1e-15 asked NumPy for 4.32 EiB
        raise InvalidInputError(
            f"a geometric axis from {smallest:g} to {half_width:g} with ratio {ratio!r} needs "
            f"{k + 1:,} points per side (at most {MAX_GEOMETRIC_POINTS:,}): use a larger ratio "
            "or a larger smallest spacing"
        )
    pos = smallest * ratio ** np.arange(k + 1)
    pos = pos[pos < half_width * (1 - 1e-9)]
    pos = np.append(pos, half_width)
    axis = np.concatenate([center - pos[::-1], [center], center + pos])
    if np.any(np.diff(axis) <= 0):  # center = 1e300: every point rounds to the same float
        raise InvalidInputError(
            f"the spacing {smallest:g} is below the float resolution at center {center:g}: the "
            "axis points would not be distinct; shift the coordinates or use a larger spacing"
        )
    return axis
