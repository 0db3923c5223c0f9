"""Interpolating splines through joint-space waypoints (lecture slides 2:33-2:35, 4:1).

A spline ``q(t)`` through waypoints ``q_0..q_m`` at knots ``t_0 < ... < t_m`` is a polynomial of
degree ``p`` on each segment ``[t_k, t_{k+1}]``, stored in the local power basis

    q(t) = sum_{r=0}^{p} c_{k,r} (t - t_k)^r,      t in [t_k, t_{k+1}].

Two families are provided, both for multi-dimensional waypoints (one column per joint):

- :func:`cubic_spline`: C2 cubic spline. The unknown knot velocities ``v_i`` solve the
  tridiagonal system (``h_i = t_{i+1} - t_i``, ``delta_i = (q_{i+1} - q_i) / h_i``)

      h_i v_{i-1} + 2 (h_{i-1} + h_i) v_i + h_{i-1} v_{i+1}
          = 3 (h_i delta_{i-1} + h_{i-1} delta_i),       i = 1..m-1,

  closed by ``natural`` (``q'' = 0`` at both ends: ``2 v_0 + v_1 = 3 delta_0``,
  ``v_{m-1} + 2 v_m = 3 delta_{m-1}``) or ``clamped`` (given end velocities) boundary conditions.
  Each segment is then the cubic Hermite interpolant of ``(q_k, v_k, q_{k+1}, v_{k+1})``.
- :func:`quintic_spline`: with given knot velocities and accelerations, the C2 quintic Hermite
  spline; otherwise the C4 quintic spline whose knot velocities and accelerations solve the
  banded (bandwidth 3) system expressing continuity of jerk and snap at interior knots, with
  velocity and acceleration given at both ends (rest-to-rest by default).

Linear systems are solved with ``scipy.linalg.solve_banded`` (LAPACK ``gbsv``), ``O(m)``.

Thread safety: a :class:`Spline` is immutable (a frozen dataclass; its arrays are not written
by its methods) and may be evaluated from several threads.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any, ParamSpec

import numpy as np
from scipy.linalg import LinAlgError, solve_banded

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_vector,
    check_count,
    check_finite,
)
from taskspace.errors import InvalidInputError, ShapeError, SolverError, UnknownNameError

__all__ = ["BoundaryCondition", "Spline", "cubic_spline", "quintic_spline"]

_P = ParamSpec("_P")


def _refuse_quietly(build: Callable[_P, Spline]) -> Callable[_P, Spline]:
    """Run a spline builder with numpy's floating-point warnings off.

    Waypoints, velocities or knot spacings beyond float64 overflow (or underflow, or divide by
    a zero spacing product) while the coefficients are computed; :func:`_interpolating` and
    :func:`_banded_solve` then refuse the spline with an :class:`InvalidInputError`, which is
    the only report the user gets (numpy's RuntimeWarnings came first, naming no input).
    """

    @functools.wraps(build)
    def quiet(*args: _P.args, **kwargs: _P.kwargs) -> Spline:
        with np.errstate(all="ignore"):
            return build(*args, **kwargs)

    return quiet


class BoundaryCondition(str, Enum):
    """End conditions of a cubic spline.

    NATURAL: zero second derivative at both ends.
    CLAMPED: given first derivative (velocity) at both ends (zero by default).
    """

    NATURAL = "natural"
    CLAMPED = "clamped"


@dataclass(frozen=True)
class Spline:
    """Piecewise-polynomial curve ``q: [t_0, t_m] -> R^n`` (power basis per segment).

    Attributes:
        knots: ``t_0 < ... < t_m``, shape ``(m+1,)`` [s or path parameter].
        coefficients: ``c[k, r, j]`` of ``(t - t_k)^r`` for joint ``j`` on segment ``k``,
            shape ``(m, p+1, n)``.
        continuity: highest derivative order that is continuous at the interior knots.
    """

    knots: FloatArray
    coefficients: FloatArray
    continuity: int

    @property
    def degree(self) -> int:
        """Polynomial degree ``p``."""
        return int(self.coefficients.shape[1]) - 1

    @property
    def dim(self) -> int:
        """Number of joints ``n``."""
        return int(self.coefficients.shape[2])

    @property
    def interval(self) -> tuple[float, float]:
        """``(t_0, t_m)``."""
        return float(self.knots[0]), float(self.knots[-1])

    @property
    def waypoints(self) -> FloatArray:
        """The interpolated points ``q(t_k)``, shape ``(m+1, n)``."""
        last = self.evaluate(self.knots[-1:], side="left")
        return np.vstack([self.coefficients[:, 0, :], last])

    def _locate(self, t: FloatArray, side: str) -> tuple[FloatArray, Any]:
        if side not in ("left", "right"):
            raise UnknownNameError("side", side, ["left", "right"])
        m = self.coefficients.shape[0]
        idx = np.searchsorted(self.knots, t, side="left" if side == "left" else "right") - 1
        idx = np.clip(idx, 0, m - 1)
        return t - self.knots[idx], idx

    def evaluate_derivatives(
        self, t: Any, max_order: int = 2, *, side: str = "right"
    ) -> list[FloatArray]:
        """Return ``[q(t), q'(t), ..., q^(max_order)(t)]``, each of shape ``(len(t), n)``.

        Args:
            t: evaluation points (1-D); points outside ``[t_0, t_m]`` extrapolate the end
                segments.
            max_order: highest derivative order.
            side: ``"right"`` uses the segment starting at a knot (right limit),
                ``"left"`` the segment ending there (left limit).
        """
        t = np.atleast_1d(as_float_array(t, "t"))
        if t.ndim != 1:
            raise InvalidInputError(f"t must be a time or a 1-D array of times, not {t.shape}")
        check_finite(t, "t")
        max_order = check_count(max_order, "max_order")
        u, idx = self._locate(t, side)
        c = self.coefficients[idx]  # (len(t), p+1, n)
        p = self.degree
        u = u[:, None]
        out: list[FloatArray] = []
        for order in range(max_order + 1):
            if order > p:
                out.append(np.zeros((t.shape[0], self.dim)))
                continue
            acc = c[:, p, :] * (math.factorial(p) / math.factorial(p - order))
            with np.errstate(over="ignore", invalid="ignore"):
                for r in range(p - 1, order - 1, -1):
                    acc = acc * u + c[:, r, :] * (math.factorial(r) / math.factorial(r - order))
            if not np.isfinite(acc).all():
                # far extrapolation (a cubic at t = 4e102 is ~1e308 or more) or waypoints and
                # knot spacings whose derivatives exceed float64: refuse instead of inf/NaN
                bad = np.flatnonzero(~np.isfinite(acc).all(axis=1))
                raise InvalidInputError(
                    f"the spline's derivative of order {order} overflows float64 at "
                    f"t = {t[bad[:5]].tolist()} (knots [{self.knots[0]:g}, {self.knots[-1]:g}]; "
                    "outside them the end polynomials are extrapolated): evaluate within or "
                    "nearer the knot range, or rescale the waypoints"
                )
            out.append(acc)
        return out

    def evaluate(self, t: Any, order: int = 0, *, side: str = "right") -> FloatArray:
        """Return ``q^(order)(t)`` with shape ``(len(t), n)`` (``(n,)`` for scalar ``t``)."""
        order = check_count(order, "order")
        t = as_float_array(t, "t")  # before np.ndim: a ragged list gave a bare ValueError
        scalar = t.ndim == 0
        val = self.evaluate_derivatives(t, order, side=side)[order]
        return val[0] if scalar else val

    def position(self, t: Any) -> FloatArray:
        """``q(t)``."""
        return self.evaluate(t, 0)

    def velocity(self, t: Any) -> FloatArray:
        """``q'(t)``."""
        return self.evaluate(t, 1)

    def acceleration(self, t: Any) -> FloatArray:
        """``q''(t)``."""
        return self.evaluate(t, 2)

    def jerk(self, t: Any) -> FloatArray:
        """``q'''(t)``."""
        return self.evaluate(t, 3)


def _validate(knots: Any, waypoints: Any) -> tuple[FloatArray, FloatArray]:
    """Knots ``(m+1,)`` strictly increasing, waypoints ``(m+1, n)`` finite."""
    q = as_float_array(waypoints, "waypoints")
    if q.ndim == 1:
        q = q[:, None]
    if q.ndim != 2 or q.shape[0] < 2 or q.shape[1] < 1:
        raise InvalidInputError(
            f"waypoints must have shape (m+1, n) with at least 2 points, got {q.shape}"
        )
    check_finite(q, "waypoints")
    if knots is None:
        t = np.linspace(0.0, 1.0, q.shape[0])
    else:
        t = as_vector(knots, None, "knots")
        if t.shape[0] != q.shape[0]:
            raise ShapeError("knots", (q.shape[0],), t.shape)
        if np.any(np.diff(t) <= 0.0):
            bad = np.flatnonzero(np.diff(t) <= 0.0).tolist()
            raise InvalidInputError(
                f"knots must be strictly increasing; not increasing after indices {bad}"
            )
    return t, np.ascontiguousarray(q)


def _end_vector(x: Any, n: int, name: str) -> FloatArray:
    if x is None:
        return np.zeros(n)
    arr = as_float_array(x, name)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    return as_vector(arr, n, name)


def _beyond_float64(t: FloatArray, q: FloatArray, what: str) -> InvalidInputError:
    """The error of a spline whose coefficients float64 cannot hold accurately."""
    h = np.diff(t)
    return InvalidInputError(
        f"{what}: the knot spacings (from {float(h.min()):.3g} to {float(h.max()):.3g}) and "
        f"data (waypoints up to |{float(np.max(np.abs(q))):.3g}|, with the given velocities "
        "and accelerations) are beyond what float64 power-basis coefficients of this spline "
        "can hold (it would miss its waypoints): rescale the knots (for example to [0, 1]) "
        "and the waypoints' units"
    )


def _banded_solve(
    lu: tuple[int, int], ab: FloatArray, rhs: FloatArray, what: str, t: FloatArray, q: FloatArray
) -> FloatArray:
    """Solve the banded system of a spline's knot derivatives.

    The systems are nonsingular for strictly increasing knots (exact arithmetic): a system
    that is not finite or singular in float64 comes from knot spacings or data beyond its
    range (quintic spacings below ~1e-100 underflow its rows to 0) and is refused as such.
    """
    if not (np.isfinite(ab).all() and np.isfinite(rhs).all()):
        raise _beyond_float64(t, q, what)
    try:
        sol: FloatArray = solve_banded(lu, ab, rhs, check_finite=False)
    except LinAlgError as exc:
        raise _beyond_float64(t, q, f"{what} ({exc} in float64)") from exc
    except ValueError as exc:
        raise SolverError(f"{what}: banded solve failed ({exc})") from exc
    return sol


def _cubic_hermite(h: FloatArray, q: FloatArray, v: FloatArray) -> FloatArray:
    """Coefficients ``(m, 4, n)`` of the cubic Hermite segments."""
    hh = h[:, None]
    delta = (q[1:] - q[:-1]) / hh
    c = np.empty((h.shape[0], 4, q.shape[1]))
    c[:, 0] = q[:-1]
    c[:, 1] = v[:-1]
    c[:, 2] = (3.0 * delta - 2.0 * v[:-1] - v[1:]) / hh
    c[:, 3] = (v[:-1] + v[1:] - 2.0 * delta) / hh**2
    return c


def _interpolating(t: FloatArray, c: FloatArray, q: FloatArray, continuity: int) -> Spline:
    """The spline of knots ``t`` and coefficients ``c``, checked to end each segment on ``q``.

    The power-basis coefficient of ``(t - t_k)^r`` scales like ``q / h^r``: for knot spacings
    ``h`` beyond ~1e100 the high-order ones underflowed to 0 (and for tiny ones overflowed),
    and the spline missed its waypoints silently (knots ``(0, 1, 2, 3) * 1e150``: 0.5667
    instead of 0.7125 at the middle). Refused with the spacings to rescale.

    Each segment's end ``sum_r c_r h^r`` must meet the next waypoint within ``1e-8`` times
    ``max(1, max |q|, sum_r |c_r| h^r)``: the last term is the size of the terms summed,
    whose rounding a fixed scale refused by luck (a quintic leaving ``(0, 1, 2)`` at
    velocity 1e10 was refused, at 1e12 accepted).
    """
    h = np.diff(t)[:, None]
    end = c[:, -1, :]
    size = np.abs(end)
    for r in range(c.shape[1] - 2, -1, -1):
        end = end * h + c[:, r, :]
        size = size * h + np.abs(c[:, r, :])
    scale = np.maximum(max(1.0, float(np.max(np.abs(q)))), size)
    if not (np.isfinite(c).all() and np.all(np.abs(end - q[1:]) <= 1e-8 * scale)):
        raise _beyond_float64(t, q, "spline")
    return Spline(t, c, continuity=continuity)


@_refuse_quietly
def cubic_spline(
    waypoints: Any,
    knots: Any = None,
    *,
    boundary: BoundaryCondition | str = BoundaryCondition.NATURAL,
    start_velocity: Any = None,
    end_velocity: Any = None,
) -> Spline:
    """C2 cubic spline through ``waypoints`` (see the module docstring for the equations).

    Args:
        waypoints: ``(m+1, n)`` points (a 1-D array is one joint).
        knots: ``(m+1,)`` strictly increasing parameters; default ``linspace(0, 1, m+1)``.
        boundary: ``"natural"`` or ``"clamped"``.
        start_velocity: ``q'(t_0)`` for clamped splines, scalar or ``(n,)`` (default 0).
        end_velocity: ``q'(t_m)`` for clamped splines (default 0).

    Returns:
        The spline, ``continuity = 2``.

    Raises:
        InvalidInputError: bad shapes, non-finite values, non-increasing knots, or knot
            spacings and data whose coefficients float64 cannot hold (no numpy warning first).
        UnknownNameError: unknown boundary condition.
    """
    t, q = _validate(knots, waypoints)
    try:
        bc = BoundaryCondition(boundary)
    except ValueError:
        raise UnknownNameError(
            "boundary condition", str(boundary), [b.value for b in BoundaryCondition]
        ) from None
    if bc is BoundaryCondition.NATURAL and (start_velocity is not None or end_velocity is not None):
        raise InvalidInputError("start/end velocities are only used with boundary='clamped'")
    n_pts, n = q.shape
    h = np.diff(t)
    delta = (q[1:] - q[:-1]) / h[:, None]
    ab = np.zeros((3, n_pts))
    rhs = np.empty((n_pts, n))
    # interior rows i = 1..m-1: lower h_i, diagonal 2(h_{i-1} + h_i), upper h_{i-1}
    ab[2, :-2] = h[1:]
    ab[1, 1:-1] = 2.0 * (h[:-1] + h[1:])
    ab[0, 2:] = h[:-1]
    rhs[1:-1] = 3.0 * (h[1:, None] * delta[:-1] + h[:-1, None] * delta[1:])
    if bc is BoundaryCondition.NATURAL:
        ab[1, 0], ab[0, 1], rhs[0] = 2.0, 1.0, 3.0 * delta[0]
        ab[2, -2], ab[1, -1], rhs[-1] = 1.0, 2.0, 3.0 * delta[-1]
    else:
        ab[1, 0], ab[0, 1], rhs[0] = 1.0, 0.0, _end_vector(start_velocity, n, "start_velocity")
        ab[2, -2], ab[1, -1], rhs[-1] = 0.0, 1.0, _end_vector(end_velocity, n, "end_velocity")
    v = _banded_solve((1, 1), ab, rhs, "cubic spline", t, q)
    return _interpolating(t, _cubic_hermite(h, q, v), q, 2)


def _quintic_hermite(h: FloatArray, q: FloatArray, v: FloatArray, a: FloatArray) -> FloatArray:
    """Coefficients ``(m, 6, n)`` of quintic Hermite segments.

    ``c3 = (20 dp - (8 v1 + 12 v0) h - (3 a0 - a1) h^2) / (2 h^3)``,
    ``c4 = (-30 dp + (14 v1 + 16 v0) h + (3 a0 - 2 a1) h^2) / (2 h^4)``,
    ``c5 = (12 dp - 6 (v1 + v0) h - (a0 - a1) h^2) / (2 h^5)``.
    """
    hh = h[:, None]
    dp = q[1:] - q[:-1]
    v0, v1, a0, a1 = v[:-1], v[1:], a[:-1], a[1:]
    c = np.empty((h.shape[0], 6, q.shape[1]))
    c[:, 0] = q[:-1]
    c[:, 1] = v0
    c[:, 2] = 0.5 * a0
    c[:, 3] = (20.0 * dp - (8.0 * v1 + 12.0 * v0) * hh - (3.0 * a0 - a1) * hh**2) / (2.0 * hh**3)
    c[:, 4] = (-30.0 * dp + (14.0 * v1 + 16.0 * v0) * hh + (3.0 * a0 - 2.0 * a1) * hh**2) / (
        2.0 * hh**4
    )
    c[:, 5] = (12.0 * dp - 6.0 * (v1 + v0) * hh - (a0 - a1) * hh**2) / (2.0 * hh**5)
    return c


@_refuse_quietly
def quintic_spline(
    waypoints: Any,
    knots: Any = None,
    *,
    velocities: Any = None,
    accelerations: Any = None,
    start_velocity: Any = None,
    end_velocity: Any = None,
    start_acceleration: Any = None,
    end_acceleration: Any = None,
) -> Spline:
    """Quintic spline through ``waypoints``.

    With ``velocities`` and ``accelerations`` (both ``(m+1, n)``) every segment is the quintic
    Hermite interpolant of its end positions, velocities and accelerations (``continuity = 2``).
    Without them, the knot velocities and accelerations are chosen so that jerk and snap are
    continuous too (``continuity = 4``): with ``J(h), S(h)`` the jerk and snap at the ends of a
    Hermite segment (linear in ``q, v, a``), the rows ``J_end(left) = J_start(right)`` and
    ``S_end(left) = S_start(right)`` at each interior knot plus the four end conditions form a
    banded system with 3 sub- and 3 super-diagonals in ``(v_0, a_0, v_1, a_1, ...)``.

    Args:
        waypoints: ``(m+1, n)`` points (a 1-D array is one joint).
        knots: ``(m+1,)`` strictly increasing parameters; default ``linspace(0, 1, m+1)``.
        velocities: knot velocities ``(m+1, n)`` (Hermite mode).
        accelerations: knot accelerations ``(m+1, n)`` (Hermite mode).
        start_velocity: ``q'(t_0)`` in C4 mode, scalar or ``(n,)`` (default 0).
        end_velocity: ``q'(t_m)`` in C4 mode (default 0).
        start_acceleration: ``q''(t_0)`` in C4 mode (default 0).
        end_acceleration: ``q''(t_m)`` in C4 mode (default 0).

    Returns:
        The spline.

    Raises:
        InvalidInputError: bad shapes or values, only one of velocities/accelerations given,
            or knot spacings and data whose coefficients float64 cannot hold (no numpy
            warning first).
    """
    t, q = _validate(knots, waypoints)
    n_pts, n = q.shape
    h = np.diff(t)
    if (velocities is None) != (accelerations is None):
        raise InvalidInputError(
            "give both velocities and accelerations (quintic Hermite), or neither (C4 spline)"
        )
    if velocities is not None:
        ends = (start_velocity, end_velocity, start_acceleration, end_acceleration)
        if any(x is not None for x in ends):
            raise InvalidInputError(
                "start/end velocity/acceleration are only used without knot velocities"
            )
        v = _as_points(velocities, q.shape, "velocities")
        a = _as_points(accelerations, q.shape, "accelerations")
        return _interpolating(t, _quintic_hermite(h, q, v, a), q, 2)

    # C4 system: unknown x = (v_0, a_0, v_1, a_1, ..., v_m, a_m); row 2i: jerk, 2i+1: snap
    size = 2 * n_pts
    lo = up = 3
    ab = np.zeros((lo + up + 1, size))
    rhs = np.zeros((size, n))

    def put(rows: Any, cols: Any, vals: Any) -> None:
        ab[up + rows - cols, cols] = vals

    rows0 = np.array([0, 1, size - 2, size - 1])
    put(rows0, rows0, 1.0)
    rhs[0] = _end_vector(start_velocity, n, "start_velocity")
    rhs[1] = _end_vector(start_acceleration, n, "start_acceleration")
    rhs[-2] = _end_vector(end_velocity, n, "end_velocity")
    rhs[-1] = _end_vector(end_acceleration, n, "end_acceleration")
    if n_pts > 2:
        hl, hr = h[:-1], h[1:]  # segment left and right of interior knot i = 1..m-1
        dpl, dpr = (q[1:-1] - q[:-2]), (q[2:] - q[1:-1])
        # rows are scaled by hbar^3 (jerk) and hbar^4 (snap) for conditioning
        sj, ss = ((hl + hr) / 2.0) ** 3, ((hl + hr) / 2.0) ** 4
        i = np.arange(1, n_pts - 1)
        rj, rs = 2 * i, 2 * i + 1
        cvm, cam, cv, ca, cvp, cap = 2 * i - 2, 2 * i - 1, 2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3
        # J_end(left) - J_start(right) = 0 with
        #   J_start = (60 dp - (24 v1 + 36 v0) h - (9 a0 - 3 a1) h^2) / h^3
        #   J_end   = (60 dp - (36 v1 + 24 v0) h + (9 a1 - 3 a0) h^2) / h^3
        put(rj, cvm, sj * (-24.0 / hl**2))
        put(rj, cam, sj * (-3.0 / hl))
        put(rj, cv, sj * (-36.0 / hl**2 + 36.0 / hr**2))
        put(rj, ca, sj * (9.0 / hl + 9.0 / hr))
        put(rj, cvp, sj * (24.0 / hr**2))
        put(rj, cap, sj * (-3.0 / hr))
        rhs[rj] = (sj * 60.0)[:, None] * (dpr / hr[:, None] ** 3 - dpl / hl[:, None] ** 3)
        # S_end(left) - S_start(right) = 0 with
        #   S_start = (-360 dp + (192 v0 + 168 v1) h + (36 a0 - 24 a1) h^2) / h^4
        #   S_end   = (360 dp - (168 v0 + 192 v1) h + (36 a1 - 24 a0) h^2) / h^4
        put(rs, cvm, ss * (-168.0 / hl**3))
        put(rs, cam, ss * (-24.0 / hl**2))
        put(rs, cv, ss * (-192.0 / hl**3 - 192.0 / hr**3))
        put(rs, ca, ss * (36.0 / hl**2 - 36.0 / hr**2))
        put(rs, cvp, ss * (-168.0 / hr**3))
        put(rs, cap, ss * (24.0 / hr**2))
        rhs[rs] = -(ss * 360.0)[:, None] * (dpl / hl[:, None] ** 4 + dpr / hr[:, None] ** 4)
    x = _banded_solve((lo, up), ab, rhs, "quintic spline", t, q)
    return _interpolating(t, _quintic_hermite(h, q, x[0::2], x[1::2]), q, 4)


def _as_points(x: Any, shape: tuple[int, int], name: str) -> FloatArray:
    arr = as_float_array(x, name)
    if arr.ndim == 1 and shape[1] == 1:
        arr = arr[:, None]
    if arr.shape != shape:
        raise ShapeError(name, shape, tuple(arr.shape))
    check_finite(arr, name)
    return arr
