"""Time-optimal time parametrization of a geometric path (TOPP by reachability analysis).

Given a path ``q(s)``, ``s in [s_0, s_1]`` (e.g. a spline through waypoints, slide 2:34, or the
output of path optimization, section 4), find the fastest timing ``s(t)`` such that every joint
respects its velocity and acceleration limits. With ``x = sdot^2`` and ``u = sddot``,

    qd  = q'(s) sdot,            |qd_i|  <= v_i   <=>  q'_i(s)^2 x <= v_i^2,
    qdd = q'(s) u + q''(s) x,    |qdd_i| <= a_i,

which is linear in ``(u, x)``. On a grid ``s_0 < ... < s_N`` with ``u`` constant on each
segment, ``x_{k+1} = x_k + 2 Delta_k u_k`` (exact for constant ``sddot``). The algorithm
(Pham & Pham, "A new approach to time-optimal path parameterization based on reachability
analysis", 2018) is

1. per grid point, the static bound ``x_k <= xs_k`` from the velocity limits and from
   eliminating ``u`` between every lower and upper acceleration row (Fourier-Motzkin on the 2-D
   polygon in ``(u, x)``) -- the maximum velocity curve, computed for all grid points and joints
   at once with numpy;
2. backward pass: controllable sets ``K_k = [0, beta_k]`` with ``beta_N = x_end`` and
   ``beta_k = max {x <= xs_k : exists feasible u with x + 2 Delta_k u in K_{k+1}}``;
3. forward greedy pass: from ``x_0 = x_start`` take the largest feasible ``u_k`` that keeps
   ``x_{k+1} in K_{k+1}``.

Acceleration constraints are enforced at ``s_k`` (collocation) and, by default, also at
``s_{k+1}`` with ``(x_k + 2 Delta_k u_k, u_k)`` (interpolation, as toppra's default for joint
accelerations). Times follow from ``t_{k+1} - t_k = 2 Delta_k / (sdot_k + sdot_{k+1})``.

Optional jerk limit (heuristic, post-hoc iterative slowdown): the jerk is measured on the grid
as ``(qdd_{k+1} - qdd_k) / (t_{k+1} - t_k)``. Wherever it exceeds ``j_max`` by a ratio
``r > 1``, the admissible ``x`` at both ends of that segment is capped to ``x / r`` and the two
passes are repeated, until the jerk limit holds or ``jerk_max_iterations`` is reached. This
only slows the motion down (velocity and acceleration limits stay satisfied at every
iteration) but is not jerk-time-optimal.

Thread safety: :func:`time_parametrize` keeps its state local to the call and may run from
several threads (a :class:`CallablePath` calls the user's function, which must then be safe to
call from them). Options, samples and statuses are immutable; a
:class:`TimeParametrizationResult` is plain result data, not locked.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_scalar,
    check_count,
    check_finite,
    check_positive,
)
from taskspace.errors import InvalidInputError, ShapeError, TaskspaceError, UnknownNameError
from taskspace.trajopt.motion_profile import _limit_vector
from taskspace.trajopt.spline import BoundaryCondition, Spline, cubic_spline

__all__ = [
    "CallablePath",
    "Discretization",
    "TimeParametrizationOptions",
    "TimeParametrizationResult",
    "TimeParametrizationStatus",
    "TrajectorySample",
    "time_parametrize",
]

logger = logging.getLogger(__name__)

MAX_GRID_POINTS = 10_000_000
"""Largest ``grid_points`` (a few arrays of this size are allocated)."""

MAX_SAMPLES = 10_000_000
"""Largest number of samples of :meth:`TimeParametrizationResult.sample`."""

PathFunction = Callable[[FloatArray], tuple[Any, Any, Any]]
_BIG = 1e300
_FLOAT_MAX = float(np.finfo(np.float64).max)


@dataclass(frozen=True)
class CallablePath:
    """A geometric path given by a function returning ``q(s), q'(s), q''(s)``.

    Attributes:
        function: maps a 1-D array of ``m`` path parameters to three arrays of shape
            ``(m, n)``: ``q`` [rad], ``dq/ds`` [rad], ``d^2q/ds^2`` [rad].
        s_start: first path parameter ``s_0`` [-].
        s_end: last path parameter ``s_1`` [-].
    """

    function: PathFunction
    s_start: float = 0.0
    s_end: float = 1.0


class Discretization(str, Enum):
    """Where acceleration constraints are enforced on each segment ``[s_k, s_{k+1}]``.

    COLLOCATION: at ``s_k`` only.
    INTERPOLATION: at ``s_k`` and at ``s_{k+1}`` (with ``x_k + 2 Delta_k u_k``); safer.
    """

    COLLOCATION = "collocation"
    INTERPOLATION = "interpolation"


@dataclass(frozen=True, kw_only=True)
class TimeParametrizationOptions:
    """Settings of :func:`time_parametrize`.

    Attributes:
        grid_points: number of grid points ``N + 1`` on the path (>= 2).
        discretization: ``"interpolation"`` (default) or ``"collocation"``.
        start_path_velocity: ``sdot(s_0)`` [1/s] (0 = start at rest).
        end_path_velocity: ``sdot(s_1)`` [1/s] (0 = stop at the end).
        spline_boundary: boundary condition of the cubic spline built through waypoints
            (``"clamped"``: zero path derivative at both ends, or ``"natural"``).
        jerk_max_iterations: iterations of the jerk slowdown heuristic (an integer >= 0).
        jerk_tolerance: relative tolerance on the jerk limit.
        active_tolerance: a limit is reported active when ``|value| >= (1 - tol) limit``.
    """

    grid_points: int = 100
    discretization: Discretization | str = Discretization.INTERPOLATION
    start_path_velocity: float = 0.0
    end_path_velocity: float = 0.0
    spline_boundary: BoundaryCondition | str = BoundaryCondition.CLAMPED
    jerk_max_iterations: int = 100
    jerk_tolerance: float = 1e-6
    active_tolerance: float = 1e-6


class TimeParametrizationStatus(str, Enum):
    """Outcome of :func:`time_parametrize`."""

    SUCCESS = "success"
    INFEASIBLE = "infeasible"
    JERK_LIMIT_NOT_MET = "jerk_limit_not_met"


@dataclass(frozen=True)
class TrajectorySample:
    """A time-sampled joint trajectory.

    Attributes:
        time: ``(m,)`` [s].
        q: ``(m, n)`` joint positions [rad].
        qd: ``(m, n)`` joint velocities [rad/s].
        qdd: ``(m, n)`` joint accelerations [rad/s^2].
    """

    time: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray


@dataclass
class TimeParametrizationResult:
    """Result of :func:`time_parametrize` (arrays are per grid point unless stated).

    Attributes:
        success: ``True`` iff ``status`` is ``SUCCESS``.
        status: outcome.
        duration: ``t_N`` [s] (``inf`` if infeasible).
        times: ``t_k`` [s], shape ``(N+1,)``.
        s: grid ``s_k``.
        s_dot: ``sdot_k`` [1/s].
        s_ddot: ``u_k`` [1/s^2] (segment ``k``; the last entry repeats ``u_{N-1}``).
        q: ``q(s_k)``, shape ``(N+1, n)`` [rad].
        qd: ``q'(s_k) sdot_k`` [rad/s].
        qdd: ``q'(s_k) u_k + q''(s_k) x_k`` [rad/s^2].
        qddd: grid jerk ``(qdd_{k+1} - qdd_k) / (t_{k+1} - t_k)``, shape ``(N, n)``
            [rad/s^3].
        velocity_limit: ``sqrt(xs_k)``, the maximum path velocity allowed by the velocity and
            acceleration limits at each grid point alone (maximum velocity curve) [1/s].
        controllable_limit: ``sqrt(beta_k)``, the largest path velocity from which the end
            can still be reached (upper end of the controllable set) [1/s].
        active_velocity: ``(N+1, n)`` bool, joint velocity limit active.
        active_acceleration: ``(N+1, n)`` bool, joint acceleration limit active.
        jerk_iterations: iterations of the jerk heuristic (0 without jerk limit).
        solve_time: wall time [s].
        path: the path that was parametrized (for :meth:`sample`).
    """

    success: bool
    status: TimeParametrizationStatus
    duration: float
    times: FloatArray
    s: FloatArray
    s_dot: FloatArray
    s_ddot: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray
    qddd: FloatArray
    velocity_limit: FloatArray
    controllable_limit: FloatArray
    active_velocity: Any
    active_acceleration: Any
    jerk_iterations: int = 0
    solve_time: float = 0.0
    path: Spline | CallablePath | None = field(default=None, repr=False)

    def evaluate(self, t: Any) -> TrajectorySample:
        """Evaluate the trajectory at times ``t`` [s] (clipped to ``[0, duration]``).

        Within segment ``k`` the path acceleration is constant:
        ``s(t) = s_k + sdot_k tau + u_k tau^2 / 2``, ``sdot = sdot_k + u_k tau``.
        """
        if not self.success and self.status is TimeParametrizationStatus.INFEASIBLE:
            raise InvalidInputError("cannot evaluate an infeasible time parametrization")
        if self.path is None:
            raise InvalidInputError("result has no path to evaluate")
        t = np.atleast_1d(as_float_array(t, "t"))
        check_finite(t, "t")
        t = np.clip(t, 0.0, self.duration)
        n_seg = self.times.shape[0] - 1
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, n_seg - 1)
        tau = t - self.times[k]
        u = self.s_ddot[k]
        sd = np.maximum(self.s_dot[k] + u * tau, 0.0)
        s = np.clip(self.s[k] + self.s_dot[k] * tau + 0.5 * u * tau**2, self.s[k], self.s[k + 1])
        q, dq, ddq = _evaluate_path(self.path, s)
        rate = sd[:, None]  # (q'' sdot) sdot: sdot^2 overflows on a path parameter ~1e-200
        return TrajectorySample(t, q, dq * rate, dq * u[:, None] + (ddq * rate) * rate)

    def sample(self, dt: float) -> TrajectorySample:
        """Sample uniformly every ``dt`` [s] (the last sample is at ``duration``)."""
        if self.status is TimeParametrizationStatus.INFEASIBLE:
            raise InvalidInputError("cannot sample an infeasible time parametrization")
        step = as_scalar(dt, "dt")  # a list or a string was a bare TypeError
        if not step > 0.0:
            raise InvalidInputError(f"dt must be finite and > 0, got {dt!r}")
        samples = self.duration / step
        if not samples <= MAX_SAMPLES:  # np.arange(1e300) was a bare ValueError
            raise InvalidInputError(
                f"sample(dt={dt!r}) would take {samples:.3g} samples over {self.duration:.6g} s "
                f"(at most {MAX_SAMPLES:,}): use a larger dt"
            )
        n = int(np.ceil(samples - 1e-9))
        return self.evaluate(np.minimum(np.arange(n + 1) * step, self.duration))


def _evaluate_path(path: Spline | CallablePath, s: FloatArray) -> tuple[Any, Any, Any]:
    if isinstance(path, Spline):
        q, dq, ddq = path.evaluate_derivatives(s, 2)
        return q, dq, ddq
    try:
        out = path.function(s)
    except TaskspaceError:
        raise
    except Exception as exc:  # a user function: its own error was a bare traceback
        raise InvalidInputError(
            f"the path function raised {type(exc).__name__}: {exc} (it is called with an array "
            "s of shape (m,) in [s_start, s_end] and must return (q, dq/ds, d2q/ds2))"
        ) from exc
    try:
        q, dq, ddq = (as_float_array(x, "path function output") for x in out)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"path function must return (q, dq/ds, d2q/ds2) arrays of shape (m, n): {exc}"
        ) from exc
    if q.ndim == 1:
        q, dq, ddq = q[:, None], dq[:, None], ddq[:, None]
    for name, arr in (("q", q), ("dq/ds", dq), ("d2q/ds2", ddq)):
        if arr.shape != q.shape or arr.shape[0] != s.shape[0]:
            raise ShapeError(f"path function output {name}", (s.shape[0], -1), arr.shape)
        check_finite(arr, f"path function output {name}")
    return q, dq, ddq


def _as_path(path: Any, boundary: BoundaryCondition | str) -> Spline | CallablePath:
    if isinstance(path, (Spline, CallablePath)):
        return path
    if callable(path):
        return CallablePath(path)
    return cubic_spline(path, None, boundary=boundary)


def _static_bounds(
    dq: FloatArray,
    ddq: FloatArray,
    delta: FloatArray,
    vmax: FloatArray,
    amax: FloatArray,
    interpolation: bool,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Static bound ``xs`` per grid point and the u-bound rows per segment.

    Every two-sided row ``-a_i <= alpha u + beta x <= a_i`` of segment ``k`` becomes an upper
    row ``u <= eU - fU x`` and a lower row ``u >= eL - fL x`` (``alpha != 0``), or a pure bound
    on ``x`` (``alpha = 0``).

    Returns:
        ``xs (N+1,)``, ``eU, fU, eL, fL`` of shape ``(N, R)``.
    """
    # velocity limits: q'_i^2 x <= v_i^2 (a pure x-bound at every grid point)
    dq_abs = np.abs(dq)
    moving = dq_abs > 0.0
    with np.errstate(over="ignore"):  # a nearly still joint: (v / q')^2 overflows to inf
        xv = np.min(np.where(moving, (vmax / np.where(moving, dq_abs, 1.0)) ** 2, _BIG), axis=1)
    xv = np.minimum(xv, _BIG)
    # acceleration rows of segment k: at s_k, and (interpolation) at s_{k+1}
    alpha = [dq[:-1]]
    beta = [ddq[:-1]]
    lim = [np.broadcast_to(amax, dq[:-1].shape)]
    if interpolation:
        alpha.append(dq[1:] + 2.0 * delta[:, None] * ddq[1:])
        beta.append(ddq[1:])
        lim.append(lim[0])
    al = np.concatenate(alpha, axis=1)
    be = np.concatenate(beta, axis=1)
    c = np.concatenate(lim, axis=1)
    scale = np.max(np.abs(al), axis=1, keepdims=True) + 1e-300
    nz = np.abs(al) > 1e-12 * scale
    safe = np.where(nz, al, 1.0)
    pos = nz & (al > 0.0)
    neg = nz & (al < 0.0)
    # alpha > 0: u <= (c - beta x)/alpha, u >= (-c - beta x)/alpha; alpha < 0: swapped
    # (+-inf where a limit that does not bind, scaled to ~1e308, over a small alpha overflows)
    with np.errstate(over="ignore"):
        eU = np.where(pos, c / safe, np.where(neg, -c / safe, _BIG))
        eL = np.where(pos, -c / safe, np.where(neg, c / safe, -_BIG))
    f = np.where(nz, be / safe, 0.0)
    fU = f
    fL = f.copy()
    # nonnegativity of x_{k+1}: u >= -x / (2 Delta)
    eL = np.concatenate([eL, np.zeros((eL.shape[0], 1))], axis=1)
    fL = np.concatenate([fL, (0.5 / delta)[:, None]], axis=1)
    # pure x-bounds from alpha == 0 rows: |beta| x <= c
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        xz = np.where(~nz & (be != 0.0), c / np.abs(np.where(be != 0.0, be, 1.0)), _BIG)
    xs_seg = np.min(xz, axis=1)
    # Fourier-Motzkin: eL_i - fL_i x <= eU_j - fU_j x  =>  (fU_j - fL_i) x <= eU_j - eL_i
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        C = fU[:, None, :] - fL[:, :, None]
        D = eU[:, None, :] - eL[:, :, None]
        bound = np.where(C > 0.0, D / np.where(C > 0.0, C, 1.0), _BIG)
    xs_seg = np.minimum(xs_seg, bound.reshape(bound.shape[0], -1).min(axis=1))
    # the last grid point has no segment: only its velocity bound applies (its acceleration
    # rows belong to segment N-1 in the interpolation scheme)
    xs = xv.copy()
    xs[:-1] = np.minimum(xs[:-1], xs_seg)
    return np.maximum(xs, 0.0), eU, fU, eL, fL


def _passes(
    xs: FloatArray,
    eU: FloatArray,
    fU: FloatArray,
    eL: FloatArray,
    fL: FloatArray,
    delta: FloatArray,
    x_start: float,
    x_end: float,
) -> tuple[FloatArray | None, FloatArray, FloatArray]:
    """Backward controllable sets and forward greedy pass.

    Returns:
        ``x (N+1,)`` or ``None`` if infeasible, ``u (N,)``, ``beta (N+1,)``.
    """
    n_seg = delta.shape[0]
    inv2d = 0.5 / delta
    # goal row u <= (beta_{k+1} - x) / (2 Delta) paired with each lower row:
    # x (1/(2 Delta) - fL_i) <= beta_{k+1} / (2 Delta) - eL_i
    C = inv2d[:, None] - fL
    valid = C > 1e-300
    safe = np.where(valid, C, 1.0)
    w = np.where(valid, inv2d[:, None] / safe, 0.0)
    z = np.where(valid, -eL / safe, _BIG)
    beta = np.empty(n_seg + 1)
    beta[-1] = x_end
    b = x_end
    xs_l = xs.tolist()
    for k in range(n_seg - 1, -1, -1):
        b = min(xs_l[k], float((w[k] * b + z[k]).min()))
        if b < 0.0:
            b = 0.0
        beta[k] = b
    u = np.zeros(n_seg)
    if x_end > xs[-1] * (1.0 + 1e-12) or x_start > beta[0] * (1.0 + 1e-9) + 1e-300:
        return None, u, beta
    x = np.empty(n_seg + 1)
    xk = min(x_start, beta[0])
    x[0] = xk
    beta_l = beta.tolist()
    d_l = delta.tolist()
    for k in range(n_seg):
        uk = min(float((eU[k] - fU[k] * xk).min()), (beta_l[k + 1] - xk) * inv2d[k])
        xn = xk + 2.0 * d_l[k] * uk
        if xn < 0.0:
            xn = 0.0
            uk = -xk * inv2d[k]
        u[k] = uk
        x[k + 1] = xn
        xk = xn
    return x, u, beta


def time_parametrize(
    path: Any,
    max_velocity: Any,
    max_acceleration: Any,
    *,
    max_jerk: Any = None,
    options: TimeParametrizationOptions | None = None,
) -> TimeParametrizationResult:
    """Time-optimal parametrization of ``path`` under joint velocity/acceleration limits.

    Args:
        path: a :class:`Spline`, a :class:`CallablePath`, a callable ``s -> (q, q', q'')`` on
            ``[0, 1]``, or waypoints ``(m, n)`` (a cubic spline through them with knots
            ``linspace(0, 1, m)`` and ``options.spline_boundary``).
        max_velocity: ``v_i > 0`` [rad/s], scalar or ``(n,)``.
        max_acceleration: ``a_i > 0`` [rad/s^2], scalar or ``(n,)``.
        max_jerk: optional ``j_i > 0`` [rad/s^3] (heuristic, see the module docstring).
        options: settings.

    Returns:
        The result; ``success`` is ``False`` when the requested start/end path velocities are
        not reachable (``INFEASIBLE``; also when the path velocity is 0 at both ends of a grid
        segment, so that the path cannot move there, or the duration overflows) or the jerk
        heuristic did not converge.

    Raises:
        InvalidInputError: non-positive limits, NaN waypoints, bad options.
        ShapeError: mismatched shapes.
        UnknownNameError: unknown discretization or boundary name.
    """
    t0 = time.perf_counter()
    opts = options if options is not None else TimeParametrizationOptions()
    try:
        disc = Discretization(opts.discretization)
    except ValueError:
        raise UnknownNameError(
            "discretization", str(opts.discretization), [d.value for d in Discretization]
        ) from None
    n_grid = check_count(opts.grid_points, "grid_points", minimum=2)
    if n_grid > MAX_GRID_POINTS:
        raise InvalidInputError(
            f"grid_points must be at most {MAX_GRID_POINTS} (the grid's arrays are allocated "
            f"at once), got {n_grid}"
        )
    check_count(opts.jerk_max_iterations, "jerk_max_iterations")
    check_positive(opts.jerk_tolerance, "jerk_tolerance", strict=False)
    check_positive(opts.active_tolerance, "active_tolerance", strict=False)
    sd0 = check_positive(opts.start_path_velocity, "start_path_velocity", strict=False)
    sd1 = check_positive(opts.end_path_velocity, "end_path_velocity", strict=False)
    geo = _as_path(path, opts.spline_boundary)
    if isinstance(geo, Spline):
        s0, s1 = geo.interval
    else:
        s0, s1 = float(geo.s_start), float(geo.s_end)
        if not (np.isfinite(s0) and np.isfinite(s1) and s1 > s0):
            raise InvalidInputError(f"path interval must satisfy s_start < s_end, got {s0}, {s1}")
    s = np.linspace(s0, s1, int(n_grid))
    q, dq, ddq = _evaluate_path(geo, s)
    n = q.shape[1]
    vmax = _limit_vector(max_velocity, n, "max_velocity")
    amax = _limit_vector(max_acceleration, n, "max_acceleration")
    jmax = _limit_vector(max_jerk, n, "max_jerk")
    if vmax is None or amax is None:
        raise InvalidInputError("max_velocity and max_acceleration are required")
    delta = np.diff(s)
    interp = disc is Discretization.INTERPOLATION
    # Solve on the path parameter w = (s - s_0) / 2^p of length ~1 (exact: a power of two):
    # q'(w) = 2^p q'(s), q''(w) = 2^2p q''(s), wdot = sdot / 2^p. On an interval of 1e-200
    # (q' ~ 1e200) the products q' u overflowed: SUCCESS with a duration 20 % off.
    p = _parameter_exponent(s1 - s0)
    if p:
        dq, ddq, delta = np.ldexp(dq, p), np.ldexp(ddq, 2 * p), np.ldexp(delta, -p)
    # Solve in the time t' = 2^e t that makes the path velocity ~1 (exact: powers of two):
    # limits v / 2^e, a / 2^2e, j / 2^3e; sdot = 2^e sdot', times t = t' / 2^e.
    # x = sdot^2 is capped at 1e300 internally and floored by underflow: limits near 1e150
    # returned SUCCESS with a duration 27 % off, limits near 1e-200 a fake 2e300 s timing.
    e = _time_exponent(dq, ddq, vmax, amax, float(np.ldexp(s1 - s0, -p)))
    vmax_s, amax_s, jmax_s = vmax, amax, jmax
    x_start, x_end = sd0 * sd0, sd1 * sd1
    if e:
        # the limit that does not bind may leave the floats once scaled (v = 1e-300 with
        # a = 1e300): the largest float instead of inf, where it still does not bind
        with np.errstate(over="ignore"):
            vmax_s = np.minimum(np.ldexp(vmax, -e), _FLOAT_MAX)
            amax_s = np.minimum(np.ldexp(amax, -2 * e), _FLOAT_MAX)
            jmax_s = None if jmax is None else np.minimum(np.ldexp(jmax, -3 * e), _FLOAT_MAX)
    if e or p:
        with np.errstate(over="ignore"):  # inf: a start or end velocity beyond any limit
            x_start = float(np.ldexp(sd0, -e - p)) ** 2
            x_end = float(np.ldexp(sd1, -e - p)) ** 2
    xs, eU, fU, eL, fL = _static_bounds(dq, ddq, delta, vmax_s, amax_s, interp)

    cap = xs
    iterations = 0
    status = TimeParametrizationStatus.SUCCESS
    previous: tuple[FloatArray, ...] | None = None  # the last iterate meeting every limit
    while True:
        x, u, beta = _passes(cap, eU, fU, eL, fL, delta, x_start, x_end)
        failure = ""
        if x is None:
            failure = "no timing within the velocity and acceleration limits"
        elif x[-1] < x_end * (1.0 - 1e-9):
            # the greedy forward pass reaches the largest end velocity there is: below the
            # requested one it is unreachable (returned as SUCCESS, ending slower, before)
            failure = (
                f"the end path velocity {sd1:g} is not reachable (at most "
                f"{float(_unscaled_rate(x[-1:], e + p)[0]):.6g} under the limits)"
            )
        else:
            sd = np.sqrt(x)
            stuck = np.flatnonzero(sd[:-1] + sd[1:] <= 0.0)
            if stuck.size:  # dt = 2 delta / 1e-300: a "successful" timing lasting 2e300 s
                failure = (
                    f"path velocity 0 at both ends of grid segment(s) {stuck[:10].tolist()}: the "
                    "path cannot move there (too few grid_points for zero start/end velocities, "
                    "or limits so small that sdot^2 underflows)"
                )
        if failure or x is None:
            if previous is None:
                logger.warning("time_parametrize: %s; reported infeasible", failure)
                return _infeasible(geo, s, n, xs, beta, t0, e + p)
            # a jerk slowdown left no timing with the given end velocities: the last iterate
            # meets the velocity and acceleration limits and the end velocities, not the jerk
            x, u, beta, sd, dt, u_full, qdd, qddd = previous
            status = TimeParametrizationStatus.JERK_LIMIT_NOT_MET
            logger.warning(
                "jerk limit not met: after %d slowdown iterations %s", iterations, failure
            )
            break
        dt = 2.0 * delta / (sd[:-1] + sd[1:])
        u_full = np.append(u, u[-1])
        qdd = dq * u_full[:, None] + ddq * x[:, None]
        qddd = np.diff(qdd, axis=0) / dt[:, None]
        if jmax_s is None:
            break
        previous = (x, u, beta, sd, dt, u_full, qdd, qddd)
        ratio = np.max(np.abs(qddd) / jmax_s, axis=1)
        if np.all(ratio <= 1.0 + opts.jerk_tolerance):
            break
        if iterations >= opts.jerk_max_iterations:
            status = TimeParametrizationStatus.JERK_LIMIT_NOT_MET
            logger.warning("jerk limit not met after %d iterations", iterations)
            break
        iterations += 1
        factor = np.ones(x.shape[0])
        over = ratio > 1.0 + opts.jerk_tolerance
        r = np.where(over, ratio, 1.0)
        factor[:-1] = np.minimum(factor[:-1], 1.0 / r)
        factor[1:] = np.minimum(factor[1:], 1.0 / r)
        cap = np.minimum(cap, np.where(factor < 1.0, x * factor, cap))
    times = np.concatenate(([0.0], np.cumsum(dt)))
    if e:  # back to seconds
        with np.errstate(over="ignore"):
            times = np.ldexp(times, -e)  # t = t' / 2^e
            sd, u_full = np.ldexp(sd, e), np.ldexp(u_full, 2 * e)
            qdd, qddd = np.ldexp(qdd, 2 * e), np.ldexp(qddd, 3 * e)
    if not np.isfinite(times[-1]):
        logger.warning("time_parametrize: the duration overflows float64; reported infeasible")
        return _infeasible(geo, s, n, xs, beta, t0, e + p)
    qd = dq * sd[:, None]
    if p:  # back to the path parameter s
        sd, u_full = np.ldexp(sd, p), np.ldexp(u_full, p)
    tol = 1.0 - opts.active_tolerance
    return TimeParametrizationResult(
        success=status is TimeParametrizationStatus.SUCCESS,
        status=status,
        duration=float(times[-1]),
        times=times,
        s=s,
        s_dot=sd,
        s_ddot=u_full,
        q=q,
        qd=qd,
        qdd=qdd,
        qddd=qddd,
        velocity_limit=_unscaled_rate(xs, e + p),
        controllable_limit=_unscaled_rate(beta, e + p),
        active_velocity=np.abs(qd) >= tol * vmax,
        active_acceleration=np.abs(qdd) >= tol * amax,
        jerk_iterations=iterations,
        solve_time=time.perf_counter() - t0,
        path=geo,
    )


def _time_exponent(
    dq: FloatArray, ddq: FloatArray, vmax: FloatArray, amax: FloatArray, length: float
) -> int:
    """``e`` such that in the time ``t' = 2^e t`` the path velocity is about 1.

    The path velocity the limits allow is at most ``v / max|q'|`` (velocity) and
    ``sqrt(a / max(max|q''|, max|q'| / L))`` (acceleration: the curvature term, and the speed
    reached from rest over the path length ``L = s_1 - s_0``, the only one on a straight
    path). ``e`` is the log2 of the smaller, the limit that binds (logs: no overflow). The mean
    of the two logs (with no acceleration term on a straight line) took the scale of a limit
    that does not bind: a straight path with ``v = 1e200``, ``a = 1`` scaled ``a`` to 0 and
    was reported INFEASIBLE.
    """
    logs = []
    top_d, top_dd = float(np.abs(dq).max()), float(np.abs(ddq).max())
    curvature = [math.log2(top_dd)] if top_dd > 0.0 else []
    if top_d > 0.0:  # min over Python floats: numpy's reduction dispatch costs ~5 us each
        logs.append(math.log2(min(vmax.tolist())) - math.log2(top_d))
        curvature.append(math.log2(top_d) - math.log2(length))  # log2(max|q'| / L)
    if curvature:
        logs.append(0.5 * (math.log2(min(amax.tolist())) - max(curvature)))
    if not logs:
        return 0
    e = max(-1000, min(1000, round(min(logs))))
    # path velocities within 2^+-64 of 1 are far from the 1e300 cap and from underflow:
    # solved unscaled (bit-identical to before, and no rescaling cost)
    return 0 if abs(e) <= 64 else e


def _parameter_exponent(length: float) -> int:
    """``p`` with ``(s_1 - s_0) / 2^p`` about 1, 0 for lengths within ``2^+-64`` of 1."""
    p = round(math.log2(length))
    return 0 if abs(p) <= 64 else p


def _unscaled_rate(x: FloatArray, e: int) -> FloatArray:
    """``sqrt(x)`` in 1/s from ``x = (ds/dt')^2`` with ``t' = 2^e t`` (inf if beyond)."""
    if not e:
        return np.sqrt(x)
    with np.errstate(over="ignore"):
        return np.asarray(np.ldexp(np.sqrt(x), e))


def _infeasible(
    geo: Spline | CallablePath,
    s: FloatArray,
    n: int,
    xs: FloatArray,
    beta: FloatArray,
    t0: float,
    e: int = 0,
) -> TimeParametrizationResult:
    nan1 = np.full(s.shape[0], np.nan)
    nan2 = np.full((s.shape[0], n), np.nan)
    return TimeParametrizationResult(
        success=False,
        status=TimeParametrizationStatus.INFEASIBLE,
        duration=float("inf"),
        times=nan1,
        s=s,
        s_dot=nan1.copy(),
        s_ddot=nan1.copy(),
        q=nan2,
        qd=nan2.copy(),
        qdd=nan2.copy(),
        qddd=nan2[:-1].copy(),
        velocity_limit=_unscaled_rate(xs, e),
        controllable_limit=_unscaled_rate(beta, e),
        active_velocity=np.zeros((s.shape[0], n), dtype=bool),
        active_acceleration=np.zeros((s.shape[0], n), dtype=bool),
        solve_time=time.perf_counter() - t0,
        path=geo,
    )
