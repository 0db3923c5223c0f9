"""Exact Dubins curves (slides 3:59-3:60).

The Dubins car drives forward only, at constant speed, with steering ``|phi| <= Phi``, so its
paths have curvature at most ``1/r`` with turning radius ``r = L / tan(Phi)`` (slide 3:47).
Dubins (1957) showed that a shortest path between two poses is one of six words::

    {L_a R_b L_c, R_a L_b R_c, L_a S_d L_c, L_a S_d R_c, R_a S_d L_c, R_a S_d R_c}

with arcs ``a, c in [0, 2 pi)``, middle arc ``b in (pi, 2 pi)`` and straight ``d >= 0``
(slide 3:59). Each word is solved in closed form; the shortest valid word is the Dubins
distance, usable as the RRT metric and steering function of slide 3:60.

Normalised problem: start ``(0, 0, 0)``, goal ``(x, y, phi)`` in units of ``r``; with
``d = sqrt(x^2 + y^2)``, ``alpha = -atan2(y, x)``, ``beta = phi - atan2(y, x)`` (mod 2 pi),
e.g. for LSL::

    p^2 = 2 + d^2 - 2 cos(alpha - beta) + 2 d (sin alpha - sin beta)
    t = -alpha + atan2(cos beta - cos alpha, d + sin alpha - sin beta)   (mod 2 pi)
    q = beta - atan2(cos beta - cos alpha, d + sin alpha - sin beta)     (mod 2 pi)

All formulas are evaluated vectorised over many queries at once (:func:`dubins_distance`).

:func:`dubins_shortest` and :func:`dubins_distance` run in the compiled planning kernel
(``taskspace/_native/curves.cpp``: the same formulas, one query after the other in C++, about
0.3 us per query) when it is built, and in NumPy otherwise (same results to rounding; the
NumPy versions are :func:`dubins_shortest_numpy` and :func:`dubins_distance_numpy`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from taskspace._native import planning_kernel
from taskspace._validation import check_positive
from taskspace.errors import ShapeError, SolverError
from taskspace.planning.se2 import CurvePath, check_pose, finite_distances, pose_arrays, to_local

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: The six Dubins words, in the order of the rows returned by :func:`dubins_word_lengths`.
DUBINS_WORDS: tuple[str, ...] = ("LSL", "RSR", "LSR", "RSL", "RLR", "LRL")

#: Segment letters of every word (the ``word`` of its :class:`CurvePath`).
_LETTERS: tuple[tuple[str, ...], ...] = tuple(tuple(w) for w in DUBINS_WORDS)

_TWO_PI = 2.0 * np.pi
_SNAP = 1e-10


# The compiled planning kernel's functions, bound at the first query (or stand-ins returning
# None, the NumPy path, when the kernel is not built): module globals called directly, not a
# planning_kernel() call and an attribute lookup per query (a single query takes 0.4-1 us).
def _no_kernel(*args: Any) -> None:
    return None


def _bind_kernel() -> None:
    global _native_shortest, _native_distance
    kernel = planning_kernel()
    _native_shortest = kernel.dubins_shortest if kernel is not None else _no_kernel
    _native_distance = kernel.dubins_distance if kernel is not None else _no_kernel


def _first_shortest(*args: Any) -> Any:
    _bind_kernel()
    return _native_shortest(*args)


_native_shortest: Callable[..., Any] = _first_shortest


def _first_distance(*args: Any) -> Any:
    _bind_kernel()
    return _native_distance(*args)


_native_distance: Callable[..., Any] = _first_distance


def _mod2pi(a: FloatArray) -> FloatArray:
    """Reduce to ``[0, 2 pi)``, snapping values within 1e-10 of ``2 pi`` to 0."""
    m = np.mod(a, _TWO_PI)
    return np.where(m > _TWO_PI - _SNAP, 0.0, m)


def dubins_word_lengths(x: Any, y: Any, phi: Any) -> tuple[FloatArray, BoolArray]:
    """Segment lengths of all six Dubins words for normalised queries (unit radius).

    Args:
        x: goal x in the start frame, divided by the turning radius, shape ``(N,)``.
        y: goal y, same convention, shape ``(N,)``.
        phi: goal heading minus start heading [rad], shape ``(N,)``.

    Returns:
        ``(lengths, valid)``: lengths ``(6, N, 3)`` (non-negative, unit radius) in the order
        of :data:`DUBINS_WORDS`, and a boolean mask ``(6, N)`` of the words that exist.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    y = np.atleast_1d(np.asarray(y, dtype=float))
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    d = np.hypot(x, y)
    th = np.arctan2(y, x)
    a = _mod2pi(-th)
    b = _mod2pi(phi - th)
    sa, sb, ca, cb = np.sin(a), np.sin(b), np.cos(a), np.cos(b)
    cab = np.cos(a - b)
    n = x.shape[0]
    out = np.full((6, n, 3), np.nan)
    valid = np.zeros((6, n), dtype=bool)

    with np.errstate(invalid="ignore"):
        # LSL
        p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sa - sb)
        tmp = np.arctan2(cb - ca, d + sa - sb)
        # p2 is a sum of two squares: their norm stays exact where start and goal nearly
        # coincide (the expanded sum cancels to 4e-8 for a true 1e-10)
        p = np.hypot(d + sa - sb, cb - ca)
        out[0] = np.stack([_mod2pi(-a + tmp), p, _mod2pi(b - tmp)], -1)
        valid[0] = p2 >= -1e-12
        # RSR
        p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sb - sa)
        tmp = np.arctan2(ca - cb, d - sa + sb)
        p = np.hypot(d - sa + sb, ca - cb)
        out[1] = np.stack([_mod2pi(a - tmp), p, _mod2pi(-b + tmp)], -1)
        valid[1] = p2 >= -1e-12
        # LSR
        p2 = -2.0 + d * d + 2.0 * cab + 2.0 * d * (sa + sb)
        p = np.sqrt(np.maximum(p2, 0.0))
        tmp = np.arctan2(-ca - cb, d + sa + sb) - np.arctan2(-2.0, p)
        out[2] = np.stack([_mod2pi(-a + tmp), p, _mod2pi(-b + tmp)], -1)
        valid[2] = p2 >= -1e-12
        # RSL
        p2 = -2.0 + d * d + 2.0 * cab - 2.0 * d * (sa + sb)
        p = np.sqrt(np.maximum(p2, 0.0))
        tmp = np.arctan2(ca + cb, d - sa - sb) - np.arctan2(2.0, p)
        out[3] = np.stack([_mod2pi(a - tmp), p, _mod2pi(b - tmp)], -1)
        valid[3] = p2 >= -1e-12
        # RLR
        c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sa - sb)) / 8.0
        p = _mod2pi(_TWO_PI - np.arccos(np.clip(c, -1.0, 1.0)))
        t = _mod2pi(a - np.arctan2(ca - cb, d - sa + sb) + 0.5 * p)
        out[4] = np.stack([t, p, _mod2pi(a - b - t + p)], -1)
        valid[4] = np.abs(c) <= 1.0 + 1e-12
        # LRL
        c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sb - sa)) / 8.0
        p = _mod2pi(_TWO_PI - np.arccos(np.clip(c, -1.0, 1.0)))
        t = _mod2pi(-a - np.arctan2(ca - cb, d + sa - sb) + 0.5 * p)
        out[5] = np.stack([t, p, _mod2pi(b - a - t + p)], -1)
        valid[5] = np.abs(c) <= 1.0 + 1e-12
    return out, valid


def _check_radius(radius: float) -> float:
    return check_positive(radius, "radius")


def dubins_paths(start: Any, goal: Any, radius: float) -> list[CurvePath]:
    """All existing Dubins words from ``start`` to ``goal``, shortest first.

    Args:
        start: start pose ``(x, y, theta)`` [m, m, rad].
        goal: goal pose ``(x, y, theta)`` [m, m, rad].
        radius: minimum turning radius ``r = L / tan(Phi)`` [m], > 0.

    Returns:
        One :class:`CurvePath` per existing word (between 4 and 6), sorted by length.
    """
    s = check_pose(start, "start")
    g = check_pose(goal, "goal")
    r = _check_radius(radius)
    x, y, phi = to_local(s, g, r)
    lengths, valid = dubins_word_lengths(x, y, phi)
    paths = [
        CurvePath(
            (float(s[0]), float(s[1]), float(s[2])),
            tuple(word),
            tuple(float(v) * r for v in lengths[i, 0]),
            r,
            word,
        )
        for i, word in enumerate(DUBINS_WORDS)
        if valid[i, 0]
    ]
    return sorted(paths, key=lambda p: p.length)


def dubins_shortest(start: Any, goal: Any, radius: float) -> CurvePath:
    """Shortest Dubins path from ``start`` to ``goal`` (minimum over the six words).

    Computed by the compiled planning kernel when it is built (the first of equally short
    words, as :func:`dubins_shortest_numpy`).

    Args:
        start: start pose ``(x, y, theta)`` [m, m, rad].
        goal: goal pose ``(x, y, theta)`` [m, m, rad].
        radius: minimum turning radius [m], > 0.

    Returns:
        The optimal :class:`CurvePath`; ``path.family`` is its word, ``path.length`` the
        Dubins distance [m].

    Raises:
        SolverError: if no word exists (never happens for finite input).
    """
    out = _native_shortest(start, goal, radius)
    if out is None:  # not plain floats, or no kernel: validate (taskspace's errors), convert
        s = check_pose(start, "start")
        g = check_pose(goal, "goal")
        out = _native_shortest(s, g, _check_radius(radius))
    if out is not None:
        st, i, lengths, r = out
        return CurvePath(st, _LETTERS[i], lengths, r, DUBINS_WORDS[i])
    return dubins_shortest_numpy(start, goal, radius)


def dubins_shortest_numpy(start: Any, goal: Any, radius: float) -> CurvePath:
    """:func:`dubins_shortest` in NumPy (the reference of the compiled kernel)."""
    paths = dubins_paths(start, goal, radius)
    if not paths:
        raise SolverError(f"no Dubins word connects {start} to {goal}")
    return paths[0]


def dubins_distance(start: Any, goal: Any, radius: float) -> FloatArray:
    """Dubins distance (shortest forward path length) for many queries, vectorised.

    Args:
        start: start pose(s) ``(3,)`` or ``(N, 3)`` [m, m, rad].
        goal: goal pose(s) ``(3,)`` or ``(N, 3)``, broadcastable with ``start``.
        radius: minimum turning radius [m], > 0.

    Returns:
        Distances ``(N,)`` [m] (shape ``(1,)`` for single poses).

    Raises:
        NotFiniteError: NaN or inf in a pose.
    """
    out = _native_distance(start, goal, radius)
    if out is not None:
        return out  # type: ignore[no-any-return]
    r = _check_radius(radius)
    s, g = pose_arrays(start, goal)
    out = _native_distance(s, g, r)
    if out is not None:
        return out  # type: ignore[no-any-return]
    with np.errstate(over="ignore", invalid="ignore"):  # (finite_distances says why)
        out = dubins_distance_numpy(s, g, r)
    return finite_distances(out)


def dubins_distance_numpy(start: Any, goal: Any, radius: float) -> FloatArray:
    """:func:`dubins_distance` in NumPy (the reference of the compiled kernel)."""
    r = _check_radius(radius)
    s = np.atleast_2d(np.asarray(start, dtype=float))
    g = np.atleast_2d(np.asarray(goal, dtype=float))
    if s.shape[-1] != 3 or g.shape[-1] != 3:
        raise ShapeError("start/goal", (-1, 3), tuple(s.shape if s.shape[-1] != 3 else g.shape))
    x, y, phi = to_local(s, g, r)
    lengths, valid = dubins_word_lengths(x, y, phi)
    total = np.where(valid, lengths.sum(axis=-1), np.inf)
    return np.asarray(total.min(axis=0) * r, dtype=float)
