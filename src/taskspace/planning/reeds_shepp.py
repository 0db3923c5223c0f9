"""Exact Reeds-Shepp curves (slide 3:60): shortest paths of a car that can drive backwards.

Reeds and Shepp (1990) showed that a shortest path with curvature at most ``1/r`` and cusps
allowed is one of 48 words in 9 groups (``|`` marks a cusp, ``beta`` equal arcs)::

    C|C|C   CC|C   C|CC   CSC   CC_b|C_bC   C|C_bC_b|C   C|C_{pi/2}SC   CSC_{pi/2}|C
    C|C_{pi/2}SC_{pi/2}|C

The paper gives closed forms for a few base words (its formulas 8.1-8.11, with the published
typos of 8.3/8.4 and 8.11 corrected) in the normalised problem: start ``(0, 0, 0)``, goal
``(x, y, phi)`` in units of ``r``. All other words follow from three symmetries of the base
formulas:

* time-flip: solve ``(-x, y, -phi)`` and negate every segment length (swap ``+`` and ``-``);
* reflect: solve ``(x, -y, -phi)`` and swap ``L`` and ``R``;
* backwards: solve ``(x cos phi + y sin phi, x sin phi - y cos phi, phi)`` and reverse the
  order of the segments.

Eight base formulas under these maps give 44 evaluations that cover all 48 words (the ``C|C|C``
formula also yields ``C|CC``, its backward version ``CC|C``). Lengths are signed: negative is
driving backwards. Every evaluation is vectorised over many queries (:func:`reeds_shepp_distance`).

:func:`reeds_shepp_shortest` and :func:`reeds_shepp_distance` run in the compiled planning
kernel (``taskspace/_native/curves.cpp``) when it is built, and in NumPy otherwise (same
results to rounding; the NumPy versions are :func:`reeds_shepp_shortest_numpy` and
:func:`reeds_shepp_distance_numpy`). The kernel evaluates the same 44 formulas one query at a
time and skips a formula, before its arc tangents, once a lower bound of its length (its
straight segment and fixed arcs, plus the least turn its two free arcs need to reach the goal
heading) exceeds the best word found so far by 1e-9 (a skipped word cannot be the answer).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
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
_Triple = tuple[FloatArray, FloatArray, FloatArray, BoolArray]

_ZERO = 1e-10
_HALF_PI = 0.5 * np.pi


# The compiled planning kernel's functions, bound at the first query (or stand-ins returning
# None, the NumPy path, when the kernel is not built): module globals called directly, not a
# planning_kernel() call and an attribute lookup per query (a single query takes 0.4-1 us).
def _no_kernel(*args: Any) -> None:
    return None


def _bind_kernel() -> None:
    global _native_shortest, _native_distance
    kernel = planning_kernel()
    _native_shortest = kernel.reeds_shepp_shortest if kernel is not None else _no_kernel
    _native_distance = kernel.reeds_shepp_distance if kernel is not None else _no_kernel


def _first_shortest(*args: Any) -> Any:
    _bind_kernel()
    return _native_shortest(*args)


_native_shortest: Callable[..., Any] = _first_shortest


def _first_distance(*args: Any) -> Any:
    _bind_kernel()
    return _native_distance(*args)


_native_distance: Callable[..., Any] = _first_distance


def _mod2pi(a: FloatArray) -> FloatArray:
    """Reduce an angle to ``[-pi, pi]`` (``fmod`` then one shift, as in the paper's M)."""
    v = np.fmod(a, 2.0 * np.pi)
    v = np.where(v < -np.pi, v + 2.0 * np.pi, v)
    return np.where(v > np.pi, v - 2.0 * np.pi, v)


def _polar(x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    return np.hypot(x, y), np.arctan2(y, x)


def _tau_omega(
    u: FloatArray, v: FloatArray, xi: FloatArray, eta: FloatArray, phi: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Auxiliary angles ``tau, omega`` of Reeds-Shepp formulas 8.7 and 8.8."""
    delta = _mod2pi(u - v)
    a = np.sin(u) - np.sin(delta)
    b = np.cos(u) - np.cos(delta) - 1.0
    t1 = np.arctan2(eta * a - xi * b, xi * a + eta * b)
    t2 = 2.0 * (np.cos(delta) - np.cos(v) - np.cos(u)) + 3.0
    tau = np.where(t2 < 0.0, _mod2pi(t1 + np.pi), _mod2pi(t1))
    omega = _mod2pi(tau - u + v - phi)
    return tau, omega


def _lp_sp_lp(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.1, word L+ S+ L+: ``(u, t) = polar(x - sin phi, y - 1 + cos phi)``."""
    u, t = _polar(x - np.sin(phi), y - 1.0 + np.cos(phi))
    v = _mod2pi(phi - t)
    return t, u, v, (t >= -_ZERO) & (v >= -_ZERO)


def _lp_sp_rp(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.2, word L+ S+ R+."""
    u1, t1 = _polar(x + np.sin(phi), y - 1.0 - np.cos(phi))
    u1sq = u1 * u1
    ok = u1sq >= 4.0
    u = np.sqrt(np.maximum(u1sq - 4.0, 0.0))
    theta = np.arctan2(2.0, u)
    t = _mod2pi(t1 + theta)
    v = _mod2pi(t - phi)
    return t, u, v, ok & (t >= -_ZERO) & (v >= -_ZERO)


def _lp_rm_l(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formulas 8.3/8.4 (corrected), word L+ R- L (last arc of either sign)."""
    xi = x - np.sin(phi)
    eta = y - 1.0 + np.cos(phi)
    u1, theta = _polar(xi, eta)
    ok = u1 <= 4.0
    u = -2.0 * np.arcsin(np.clip(0.25 * u1, -1.0, 1.0))
    t = _mod2pi(theta + 0.5 * u + np.pi)
    v = _mod2pi(phi - t + u)
    return t, u, v, ok & (t >= -_ZERO) & (u <= _ZERO)


def _lp_rup_lum_rm(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.7, word L+ R+_u L-_u R-."""
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho = 0.25 * (2.0 + np.hypot(xi, eta))
    ok = rho <= 1.0
    u = np.arccos(np.clip(rho, -1.0, 1.0))
    t, v = _tau_omega(u, -u, xi, eta, phi)
    return t, u, v, ok & (t >= -_ZERO) & (v <= _ZERO)


def _lp_rum_lum_rp(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.8, word L+ R-_u L-_u R+."""
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho = (20.0 - xi * xi - eta * eta) / 16.0
    ok = (rho >= 0.0) & (rho <= 1.0)
    u = -np.arccos(np.clip(rho, -1.0, 1.0))
    ok &= u >= -_HALF_PI
    t, v = _tau_omega(u, u, xi, eta, phi)
    return t, u, v, ok & (t >= -_ZERO) & (v >= -_ZERO)


def _lp_rm_sm_lm(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.9, word L+ R-_{pi/2} S- L-."""
    xi = x - np.sin(phi)
    eta = y - 1.0 + np.cos(phi)
    rho, theta = _polar(xi, eta)
    ok = rho >= 2.0
    r = np.sqrt(np.maximum(rho * rho - 4.0, 0.0))
    u = 2.0 - r
    t = _mod2pi(theta + np.arctan2(r, -2.0))
    v = _mod2pi(phi - _HALF_PI - t)
    return t, u, v, ok & (t >= -_ZERO) & (u <= _ZERO) & (v <= _ZERO)


def _lp_rm_sm_rm(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.10, word L+ R-_{pi/2} S- R-."""
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho, theta = _polar(-eta, xi)
    ok = rho >= 2.0
    t = theta
    u = 2.0 - rho
    v = _mod2pi(t + _HALF_PI - phi)
    return t, u, v, ok & (t >= -_ZERO) & (u <= _ZERO) & (v <= _ZERO)


def _lp_rm_s_lm_rp(x: FloatArray, y: FloatArray, phi: FloatArray) -> _Triple:
    """Formula 8.11 (corrected), word L+ R-_{pi/2} S- L-_{pi/2} R+."""
    xi = x + np.sin(phi)
    eta = y - 1.0 - np.cos(phi)
    rho, _ = _polar(xi, eta)
    ok = rho >= 2.0
    u = 4.0 - np.sqrt(np.maximum(rho * rho - 4.0, 0.0))
    ok &= u <= _ZERO
    t = _mod2pi(np.arctan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta))
    v = _mod2pi(t - phi)
    return t, u, v, ok & (t >= -_ZERO) & (v >= -_ZERO)


_LengthMap = Callable[[FloatArray, FloatArray, FloatArray], list[FloatArray]]


@dataclass(frozen=True)
class _Base:
    name: str
    formula: Callable[[FloatArray, FloatArray, FloatArray], _Triple]
    word: str
    lengths: _LengthMap
    backwards: bool


def _hp(t: FloatArray) -> FloatArray:
    return np.full_like(t, _HALF_PI)


_BASES: tuple[_Base, ...] = (
    _Base("LpSpLp", _lp_sp_lp, "LSL", lambda t, u, v: [t, u, v], False),
    _Base("LpSpRp", _lp_sp_rp, "LSR", lambda t, u, v: [t, u, v], False),
    _Base("LpRmL", _lp_rm_l, "LRL", lambda t, u, v: [t, u, v], True),
    _Base("LpRupLumRm", _lp_rup_lum_rm, "LRLR", lambda t, u, v: [t, u, -u, v], False),
    _Base("LpRumLumRp", _lp_rum_lum_rp, "LRLR", lambda t, u, v: [t, u, u, v], False),
    _Base("LpRmSmLm", _lp_rm_sm_lm, "LRSL", lambda t, u, v: [t, -_hp(t), u, v], True),
    _Base("LpRmSmRm", _lp_rm_sm_rm, "LRSR", lambda t, u, v: [t, -_hp(t), u, v], True),
    _Base(
        "LpRmSLmRp",
        _lp_rm_s_lm_rp,
        "LRSLR",
        lambda t, u, v: [t, -_hp(t), u, -_hp(t), v],
        False,
    ),
)

_SWAP = str.maketrans("LR", "RL")


@dataclass(frozen=True)
class RSFormula:
    """One of the 44 formula evaluations (base formula + symmetry).

    Attributes:
        base: name of the base formula (``"LpRmL"``...).
        timeflip: lengths negated (input ``(-x, y, -phi)``).
        reflect: ``L`` and ``R`` swapped (input ``(x, -y, -phi)``).
        backwards: segment order reversed (input in the goal frame).
        word: segment letters after the symmetries, e.g. ``"RLR"``.
    """

    base: str
    timeflip: bool
    reflect: bool
    backwards: bool
    word: str


def _formula_table() -> list[tuple[RSFormula, _Base]]:
    table = []
    for b in _BASES:
        for backwards in (False, True) if b.backwards else (False,):
            for timeflip, reflect in ((False, False), (True, False), (False, True), (True, True)):
                word = b.word.translate(_SWAP) if reflect else b.word
                if backwards:
                    word = word[::-1]
                table.append((RSFormula(b.name, timeflip, reflect, backwards, word), b))
    return table


_TABLE = _formula_table()
_GROUPS: tuple[tuple[_Base, tuple[RSFormula, ...]], ...] = tuple(
    (b, tuple(f for f, fb in _TABLE if fb is b)) for b in _BASES
)

#: All 44 formula evaluations, in enumeration order.
RS_FORMULAS: tuple[RSFormula, ...] = tuple(f for f, _ in _TABLE)

_LETTERS: tuple[tuple[str, ...], ...] = tuple(tuple(f.word) for f in RS_FORMULAS)


def signed_word(word: str, lengths: Any) -> str:
    """Reeds-Shepp word with directions, e.g. ``"L+R-L-"`` (``+`` forward, ``-`` backward)."""
    return "".join(f"{w}{'-' if ell < 0 else '+'}" for w, ell in zip(word, lengths))


def reeds_shepp_formula_lengths(
    x: Any, y: Any, phi: Any
) -> list[tuple[RSFormula, FloatArray, BoolArray]]:
    """Evaluate all 44 formula evaluations on normalised queries (unit turning radius).

    Args:
        x: goal x in the start frame divided by the turning radius, shape ``(N,)``.
        y: goal y, same convention, shape ``(N,)``.
        phi: goal heading minus start heading [rad], shape ``(N,)``.

    Returns:
        For every :data:`RS_FORMULAS` entry: the formula, signed segment lengths
        ``(N, k)`` (``k`` = number of segments) and the validity mask ``(N,)``.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    y = np.atleast_1d(np.asarray(y, dtype=float))
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    n = x.shape[0]
    c, s = np.cos(phi), np.sin(phi)
    xb = x * c + y * s
    yb = x * s - y * c
    out: list[tuple[RSFormula, FloatArray, BoolArray]] = []
    with np.errstate(invalid="ignore", divide="ignore"):
        for base, group in _GROUPS:
            # Stack the transformed inputs of every symmetry of this base formula so the
            # formula runs once on a (len(group) * N,) array.
            xs, ys, ps = [], [], []
            for f in group:
                x0, y0 = (xb, yb) if f.backwards else (x, y)
                xs.append(-x0 if f.timeflip else x0)
                ys.append(-y0 if f.reflect else y0)
                ps.append(-phi if f.timeflip != f.reflect else phi)
            t, u, v, ok = base.formula(np.concatenate(xs), np.concatenate(ys), np.concatenate(ps))
            all_lengths = np.stack(base.lengths(t, u, v), axis=-1)
            ok = ok & np.all(np.isfinite(all_lengths), axis=-1)
            for j, f in enumerate(group):
                lengths = all_lengths[j * n : (j + 1) * n]
                if f.timeflip:
                    lengths = -lengths
                if f.backwards:
                    lengths = lengths[:, ::-1]
                out.append((f, lengths, ok[j * n : (j + 1) * n]))
    return out


def reeds_shepp_paths(start: Any, goal: Any, radius: float) -> list[CurvePath]:
    """Every valid Reeds-Shepp candidate from ``start`` to ``goal``, shortest first.

    Args:
        start: start pose ``(x, y, theta)`` [m, m, rad].
        goal: goal pose ``(x, y, theta)`` [m, m, rad].
        radius: minimum turning radius ``r = L / tan(Phi)`` [m], > 0.

    Returns:
        One :class:`CurvePath` per valid formula evaluation (``family`` is the signed word,
        e.g. ``"L+R-L-"``), sorted by length. Zero-length segments are kept so each path
        keeps the letters of its word.
    """
    s = check_pose(start, "start")
    g = check_pose(goal, "goal")
    r = check_positive(radius, "radius")
    x, y, phi = to_local(s, g, r)
    start_t = (float(s[0]), float(s[1]), float(s[2]))
    paths = []
    for f, lengths, ok in reeds_shepp_formula_lengths(x, y, phi):
        if ok[0]:
            seg = tuple(float(v) * r for v in lengths[0])
            paths.append(CurvePath(start_t, tuple(f.word), seg, r, signed_word(f.word, seg)))
    return sorted(paths, key=lambda p: p.length)


def reeds_shepp_shortest(start: Any, goal: Any, radius: float) -> CurvePath:
    """Shortest Reeds-Shepp path (minimum over all 48 words).

    Args:
        start: start pose ``(x, y, theta)`` [m, m, rad].
        goal: goal pose ``(x, y, theta)`` [m, m, rad].
        radius: minimum turning radius [m], > 0.

    Returns:
        The optimal :class:`CurvePath`; ``path.length`` is the Reeds-Shepp distance [m].

    Raises:
        SolverError: if no formula is valid (never happens for finite input).
    """
    out = _native_shortest(start, goal, radius)
    if out is None:  # not plain floats, or no kernel: validate (taskspace's errors), convert
        s = check_pose(start, "start")
        g = check_pose(goal, "goal")
        out = _native_shortest(s, g, check_positive(radius, "radius"))
    if out is not None:
        st, i, lengths, r, family = out
        return CurvePath(st, _LETTERS[i], lengths, r, family)
    return reeds_shepp_shortest_numpy(start, goal, radius)


def reeds_shepp_shortest_numpy(start: Any, goal: Any, radius: float) -> CurvePath:
    """:func:`reeds_shepp_shortest` in NumPy (the reference of the compiled kernel)."""
    s = check_pose(start, "start")
    g = check_pose(goal, "goal")
    r = check_positive(radius, "radius")
    x, y, phi = to_local(s, g, r)
    best: tuple[float, RSFormula, FloatArray] | None = None
    for f, lengths, ok in reeds_shepp_formula_lengths(x, y, phi):
        if ok[0]:
            total = float(np.abs(lengths[0]).sum())
            if best is None or total < best[0]:
                best = (total, f, lengths[0])
    if best is None:
        raise SolverError(f"no Reeds-Shepp word connects {start} to {goal}")
    _, f, lengths = best
    seg = tuple(float(v) * r for v in lengths)
    start_t = (float(s[0]), float(s[1]), float(s[2]))
    return CurvePath(start_t, tuple(f.word), seg, r, signed_word(f.word, seg))


def reeds_shepp_distance(start: Any, goal: Any, radius: float) -> FloatArray:
    """Reeds-Shepp distance for many queries, vectorised over the 44 evaluations.

    Args:
        start: start pose(s) ``(3,)`` or ``(N, 3)`` [m, m, rad].
        goal: goal pose(s) ``(3,)`` or ``(N, 3)``, broadcastable with ``start``.
        radius: minimum turning radius [m], > 0.

    Returns:
        Distances ``(N,)`` [m].

    Raises:
        NotFiniteError: NaN or inf in a pose.
    """
    out = _native_distance(start, goal, radius)
    if out is not None:
        return out  # type: ignore[no-any-return]
    r = check_positive(radius, "radius")
    s, g = pose_arrays(start, goal)
    out = _native_distance(s, g, r)
    if out is not None:
        return out  # type: ignore[no-any-return]
    with np.errstate(over="ignore", invalid="ignore"):  # (finite_distances says why)
        out = reeds_shepp_distance_numpy(s, g, r)
    return finite_distances(out)


def reeds_shepp_distance_numpy(start: Any, goal: Any, radius: float) -> FloatArray:
    """:func:`reeds_shepp_distance` in NumPy (the reference of the compiled kernel)."""
    r = check_positive(radius, "radius")
    s = np.atleast_2d(np.asarray(start, dtype=float))
    g = np.atleast_2d(np.asarray(goal, dtype=float))
    if s.shape[-1] != 3 or g.shape[-1] != 3:
        raise ShapeError("start/goal", (-1, 3), tuple(s.shape if s.shape[-1] != 3 else g.shape))
    x, y, phi = to_local(s, g, r)
    best = np.full(np.shape(x), np.inf)
    for _, lengths, ok in reeds_shepp_formula_lengths(x, y, phi):
        best = np.where(ok, np.minimum(best, np.abs(lengths).sum(axis=-1)), best)
    return np.asarray(best * r, dtype=float)
