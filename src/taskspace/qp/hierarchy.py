"""Strict task hierarchies as a lexicographic cascade of QPs (slides 2:42-2:44).

The limit ``rho_1 >> rho_2 >> ...`` of the weighted problem.

Level k minimizes ``|J_k x - r_k|^2`` plus the squared violations ``w`` of its inequalities
``l_k <= C_k x <= u_k``, subject to every earlier level held at its optimum and to the hard
constraints (box bounds and hard inequalities). Earlier equality levels are held exactly by
searching in the nullspace of their stacked Jacobians, ``x = x_{k-1} + Z_{k-1} z`` (so the
optimal residuals of earlier levels cannot change); earlier inequalities are held with their
optimal slacks (``l' = min(l, C x*)``, ``u' = max(u, C x*)``). Each level is one QP solved by a
persistent :class:`~taskspace.qp.solver.QPSolver` (unconstrained shortcut first).

Thread safety: a :class:`HierarchySolver` keeps one :class:`~taskspace.qp.QPSolver` per level
(warm-start workspaces) and is not locked: one solver per thread. :class:`HierarchyOptions` is
immutable; :class:`HierarchyLevel` and :class:`HierarchyResult` are plain data, not locked: do not
modify them while another thread reads them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.linalg.lapack import dgeqp3, dgeqrf, dorgqr, dposv, dtrtrs

from taskspace._validation import FloatArray, as_float_array, check_finite
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
from taskspace.qp.kkt import KKTResiduals, least_squares_kkt_residuals
from taskspace.qp.problem import INF, QPProblem, RowBlock
from taskspace.qp.result import QPResult, QPStatus
from taskspace.qp.solver import RELAXED_VIOLATION, QPSolver, QPSolverOptions


def _is_float64(value: Any) -> bool:
    """``value`` is a float64 NumPy array (kept as it is)."""
    return type(value) is np.ndarray and value.dtype == np.float64


@dataclass
class HierarchyLevel:
    """One priority level.

    Attributes:
        name: label used in results.
        J, r: least-squares rows ``min |J x - r|^2`` (0 rows allowed).
        C, l, u: inequalities of this level, minimized in violation then held (0 rows allowed).
        damping: this level's regularization ``mu`` (default: the solver's option); use 0 for
            levels that must hold exactly (physical equality constraints).
    """

    name: str
    J: FloatArray
    r: FloatArray
    C: FloatArray | None = None
    l: FloatArray | None = None
    u: FloatArray | None = None
    damping: float | None = None

    def __post_init__(self) -> None:
        # array-likes (lists) as float arrays; a float64 array is kept as it is (no copy);
        # boolean, complex and text data refused (a boolean J was taken as the 0/1 matrix)
        # (checked only when not float64 already, the name made then: a level per IK step)
        if not _is_float64(self.J):
            self.J = as_float_array(self.J, self._field_name("J"))
        if not _is_float64(self.r):
            self.r = as_float_array(self.r, self._field_name("r"))
        if self.C is not None and not _is_float64(self.C):
            self.C = as_float_array(self.C, self._field_name("C"))
        if self.l is not None and not _is_float64(self.l):
            self.l = as_float_array(self.l, self._field_name("l"))
        if self.u is not None and not _is_float64(self.u):
            self.u = as_float_array(self.u, self._field_name("u"))

    def _field_name(self, field: str) -> str:
        return f"HierarchyLevel '{self.name}' {field}"

    @property
    def n_in(self) -> int:
        """Number of inequality rows."""
        return 0 if self.C is None else int(self.C.shape[0])


def _check_levels(
    levels: Sequence[HierarchyLevel],
    n: int,
    lb: FloatArray | None,
    ub: FloatArray | None,
    C: FloatArray | None,
    l: FloatArray | None,
    u: FloatArray | None,
    A: FloatArray | None,
    b: FloatArray | None,
) -> None:
    """Shapes, finite rows and dampings of a cascade's input (HierarchySolver.solve).

    Shapes, and one dot product for all the levels' ``J`` and ``r`` (NaN and inf show in the
    sum of squares; the arrays are located only then): a level's bad ``J`` is named here, not
    later as the QP's ``H``. Bounds may be infinite, not NaN (the QP checks those).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise InvalidInputError(f"n (number of variables) must be an integer >= 0, got {n!r}")
    total = 0.0
    for k, level in enumerate(levels):
        if not isinstance(level, HierarchyLevel):
            raise InvalidInputError(f"levels[{k}] must be a HierarchyLevel, got {type(level)}")
        J, r = level.J, level.r
        if not (
            type(J) is np.ndarray
            and J.ndim == 2
            and J.shape[1] == n
            and type(r) is np.ndarray
            and r.shape == (J.shape[0],)
        ):
            _refuse_level(k, level, n)
        total += float(np.vdot(J, J)) + float(np.vdot(r, r))
        if level.C is not None or level.l is not None or level.u is not None:
            _check_rows(level.C, level.l, level.u, n, f"level {k} ('{level.name}')")
        d = level.damping
        if d is not None and not (
            isinstance(d, (int, float, np.floating, np.integer)) and 0.0 <= d < math.inf
        ):
            raise InvalidInputError(
                f"level {k} ('{level.name}'): damping must be finite and >= 0, got {d!r}"
            )
    if not math.isfinite(total):
        for k, level in enumerate(levels):
            for name in ("J", "r"):
                arr = getattr(level, name).ravel()
                if not np.isfinite(arr).all():
                    raise NotFiniteError(
                        f"level {k} ('{level.name}') {name}",
                        np.flatnonzero(~np.isfinite(arr)).tolist()[:20],
                    )
    if C is not None or l is not None or u is not None:
        _check_rows(C, l, u, n, "hard inequalities")
    for name, arr in (("lb", lb), ("ub", ub)):
        if arr is not None and not (type(arr) is np.ndarray and arr.shape == (n,)):
            raise ShapeError(name, (n,), tuple(np.shape(arr)))
        if arr is not None:
            check_finite(arr, name, allow_inf=True, by_row=True)
    if (A is None) != (b is None):
        raise InvalidInputError("hard equalities: A and b go together (got only one)")
    if A is not None and b is not None:
        if not (np.ndim(A) == 2 and np.shape(A)[1] == n):
            raise ShapeError("A", (np.shape(b)[0] if np.ndim(b) else -1, n), tuple(np.shape(A)))
        if np.shape(b) != (np.shape(A)[0],):
            raise ShapeError("b", (np.shape(A)[0],), tuple(np.shape(b)))
        check_finite(A, "hard equalities A", by_row=True)
        check_finite(b, "hard equalities b")


def _refuse_level(k: int, level: HierarchyLevel, n: int) -> None:
    """Raise the ShapeError of level ``k``'s ``J`` or ``r``."""
    what = f"level {k} ('{level.name}')"
    J_shape = tuple(np.shape(level.J))
    if len(J_shape) != 2 or J_shape[1] != n:
        rows = J_shape[0] if J_shape else -1
        raise ShapeError(f"{what} J", (rows, n), J_shape)
    raise ShapeError(f"{what} r", (J_shape[0],), tuple(np.shape(level.r)))


def _check_rows(C: Any, l: Any, u: Any, n: int, what: str) -> None:
    """``C`` (m, n), ``l`` and ``u`` (m,), given together."""
    if C is None or l is None or u is None:
        raise InvalidInputError(f"{what}: C, l and u go together (got only some of them)")
    m = np.shape(C)[0] if np.ndim(C) else -1
    if np.ndim(C) != 2 or np.shape(C)[1] != n:
        raise ShapeError(f"{what} C", (m, n), tuple(np.shape(C)))
    for name, arr in (("l", l), ("u", u)):
        if np.shape(arr) != (m,):
            raise ShapeError(f"{what} {name}", (m,), tuple(np.shape(arr)))
    check_finite(C, f"{what} C", by_row=True)
    check_finite(l, f"{what} l", allow_inf=True)
    check_finite(u, f"{what} u", allow_inf=True)


@dataclass
class HierarchyResult:
    """Result of a cascade.

    Attributes:
        success: every level's QP succeeded.
        status: the worst status over the levels.
        x: solution.
        residuals: per level, ``|J_k x - r_k|`` (equality part).
        violations: per level, the largest violation of its inequalities at ``x``.
        nullspace_dims: dimension of the remaining freedom after each level.
        level_results: the QP result of each level.
        solve_time: total wall time [s].
        culprits: empty on success. Otherwise first the names of the hard inequality blocks
            (``hard_names`` of :meth:`HierarchySolver.solve`, ``"hard inequalities"`` for
            unnamed rows) and ``"bounds"`` that ``x`` violates by more than ``1e-6`` (as a
            relaxed :class:`~taskspace.qp.QPResult` names its blocks), then one sentence per
            set of hard or held inequality rows that no level could satisfy: projected onto a
            level's freedom they vanish (they lie in the row space of the hard equalities or
            of higher levels' equalities) while their bounds exclude the cascade's point, so
            they stay violated (``success`` is then ``False``, ``status`` ``RELAXED``); it
            names the level, the row block, the rows and the violation.
    """

    success: bool
    status: QPStatus
    x: FloatArray
    residuals: list[float] = field(default_factory=list)
    violations: list[float] = field(default_factory=list)
    nullspace_dims: list[int] = field(default_factory=list)
    level_results: list[QPResult] = field(default_factory=list)
    solve_time: float = 0.0
    culprits: list[str] = field(default_factory=list)


CASCADE_SOLVER_OPTIONS = QPSolverOptions(
    backend="proxsuite",
    fallbacks=("daqp", "quadprog"),
    eps_rel=1e-6,
    proxsuite_rho=1e-11,
    proxsuite_eps_rel=1e-8,
    proxsuite_duality_gap=False,
    proxsuite_eps_primal_inf=1e-12,
    proxsuite_warm_start=False,
)
"""QP solver settings of cascade levels (see :class:`HierarchyOptions` and the
``qp_backends`` benchmark, which measures them on the G1 cascade's level QPs)."""

EXACT_FIRST_OPTIONS = QPSolverOptions(
    backend="daqp",
    fallbacks=(),
    relax_on_failure=False,
    eps_rel=1e-9,
)
"""First pass of each cascade level: daqp's active-set method, kept only when its KKT residuals
meet ``1e-9`` (relative): then it is the level's optimum to rounding, at a fraction of
proxsuite's cost. Its results certified only at ``1e-6`` can be far from the optimum on
degenerate levels (G1 cascade: a level objective 10 % off), so they go to
:data:`CASCADE_SOLVER_OPTIONS` instead."""


@dataclass(frozen=True, kw_only=True)
class HierarchyOptions:
    """Settings of :class:`HierarchySolver`.

    Attributes:
        damping: ``mu`` of the regularization ``mu |z|^2`` of every level (selects the
            least-norm solution among a level's minimizers; bounds steps near singularities).
        rank_tolerance: singular values below ``rank_tolerance * max(1, s_max)`` count as zero
            when computing nullspaces.
        row_tolerance: a bound or held inequality row ``c`` whose projection ``c Z`` onto a
            level's freedom has norm at most ``row_tolerance * |c|`` is taken as zero (the row
            lies in the row space of the hard equalities and higher levels' equalities, and
            its projection is rounding noise, ``1e-20..1e-15`` on the G1 cascade, against
            ``>= 1e-8`` for the rows that keep a component): it is left out of the level's QP
            (zero row, infinite bounds; the QP keeps its size). Such a row's value cannot
            change in that level; its bounds contain the current point (after the first QP
            level they always do), else it is reported in :attr:`HierarchyResult.culprits`.
            Kept, the noise rows get multipliers ``~1e12`` (solvers report failure or stall).
        exact_first: options of a first pass on each level QP (:data:`EXACT_FIRST_OPTIONS`:
            daqp at a 1e-9 KKT tolerance), kept when it certifies; ``None``: ``solver`` only.
            daqp is exact on most levels (G1 cascade: 173 of 200) at a tenth of proxsuite's
            time; without it, random 4-level hierarchies with active boxes took 4-9 ms
            instead of 0.7 ms.
        solver: options of the per-level QP solvers (:data:`CASCADE_SOLVER_OPTIONS`):
            proxsuite, then daqp and quadprog. A level's Hessian is ``JZ^T JZ + damping``:
            the freedom its rows leave to lower levels has curvature ``damping`` only (1e-9
            against ``|JZ|^2 ~ 1``), and the levels after the first hold earlier inequalities
            (degenerate: many active, nearly dependent rows). proxsuite's defaults stall there.
            Measured on the G1 cascade's 200 level QPs (``qp_backends`` benchmark, two
            recordings of the set: proxsuite defaults 172-180 solved, daqp 175-182, quadprog
            153-156, osqp 66-69; these settings 198-200, with ``exact_first`` 199), each
            setting set back to proxsuite's default: ``rho = 1e-11`` (the proximal term must
            not dominate the flat directions; 1e-6: 197 and 3x the time; 1e-12 made proxsuite
            0.8 return NaN iterates on one QP, nondeterministically), its own stopping
            tolerance ``1e-8`` below the certificate's ``1e-6`` (its test omits
            complementarity; 193), infeasibility tolerance ``1e-12`` (false certificates on
            feasible levels; 188), a fresh workspace per solve (the nullspace basis, so the
            level's coordinates, rotates between steps: a kept preconditioner and warm start
            fail; 189), no duality-gap test (never met with the huge multipliers of dependent
            active rows: no effect on that set, 189 against 198 on an earlier one). The KKT
            tolerance is relative ``1e-6``: the Hessian is conditioned like
            ``|J|^2 / damping``, where no backend reliably reaches ``1e-9``.
    """

    damping: float = 1e-9
    rank_tolerance: float = 1e-8
    row_tolerance: float = 1e-10
    solver: QPSolverOptions = field(default_factory=lambda: CASCADE_SOLVER_OPTIONS)
    exact_first: QPSolverOptions | None = field(default_factory=lambda: EXACT_FIRST_OPTIONS)

    def __post_init__(self) -> None:
        """Refuse values that would hide levels or rows (NaN, negative, absurdly large)."""
        for name, high in (("damping", 1.0), ("rank_tolerance", 1e-2), ("row_tolerance", 1e-2)):
            value = getattr(self, name)
            if not (
                isinstance(value, int | float)
                and not isinstance(value, bool)
                and math.isfinite(value)
                and 0.0 <= value <= high
            ):
                raise InvalidInputError(f"{name} must be in [0, {high:g}], got {value!r}")
        for name in ("solver", "exact_first"):
            value = getattr(self, name)
            if not isinstance(value, QPSolverOptions) and not (
                name == "exact_first" and value is None
            ):
                raise InvalidInputError(
                    f"{name} must be QPSolverOptions{' or None' if name == 'exact_first' else ''}, "
                    f"got {type(value).__name__}"
                )


def _qr_level(JZ: FloatArray, res: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """Least-norm solution of ``JZ z = res`` and a basis of ``null(JZ)`` by one QR of ``JZ^T``.

    ``JZ^T = Q R``: ``z = Q_1 R_1^-T res``, ``null(JZ) = span(Q_2)``. About twice as fast as
    the SVD on G1-sized blocks. With at least as many rows as columns (``m >= r``, e.g. a
    posture level) and full column rank the nullspace is empty and ``z`` is the least-squares
    solution ``(R^T R)^-1 JZ^T res`` from the QR of ``JZ`` itself. Returns ``None`` (the caller
    uses the damped SVD) when ``JZ`` is close to rank-deficient.
    """
    m, r = JZ.shape
    if m >= r:
        if r == 0:
            return np.zeros(0), np.zeros((0, 0))
        qr, _, _, info = dgeqrf(JZ)
        if info != 0:
            return None
        R = qr[:r]
        diag = np.abs(R.diagonal())
        if diag.min() <= 1e-6 * max(1.0, float(diag.max())):
            return None
        y, info = dtrtrs(R, JZ.T.dot(res), lower=0, trans=1)
        if info != 0:
            return None
        z, info = dtrtrs(R, y, lower=0)
        if info != 0:
            return None
        return z, np.zeros((r, 0))
    qr, tau, _, info = dgeqrf(JZ.T)
    if info != 0:
        return None
    diag = np.abs(qr.diagonal())
    if diag.min() <= 1e-6 * max(1.0, float(diag.max())):
        return None
    padded = np.zeros((r, r))
    padded[:, :m] = qr
    Q, _, info = dorgqr(padded, tau)
    if info != 0:
        return None
    y, info = dtrtrs(qr[:m, :m], res, lower=0, trans=1)
    if info != 0:
        return None
    return Q[:, :m] @ y, Q[:, m:]


def _pivoted_qr_level(
    JZ: FloatArray, res: FloatArray, tol: float
) -> tuple[FloatArray, FloatArray] | None:
    """:func:`_qr_level` for rank-deficient blocks: a QR with column pivoting of ``JZ^T``.

    ``JZ^T P = Q R`` (LAPACK ``dgeqp3``, about 8x cheaper than the SVD of a 35 x 14 block)
    reveals the rank ``k`` (diagonal of ``R`` above ``tol`` times its largest entry):
    ``range(JZ^T) = span(Q_1)``, ``null(JZ) = span(Q_2)``, and the least-norm least-squares
    step is ``z = Q_1 y`` with ``R_1^T y ~ P^T res``. Returns ``None`` (the caller uses the
    damped SVD) when the diagonal has entries between ``tol`` and ``1e-6`` of its largest,
    where the damping of the SVD step would matter.
    """
    m, r = JZ.shape
    p = min(m, r)
    if p == 0:
        return np.zeros(r), np.eye(r)
    qr, jpvt, tau, _, info = dgeqp3(JZ.T)
    if info != 0:
        return None
    d = np.abs(qr.diagonal())
    scale = max(1.0, float(d[0]))
    k = int(np.count_nonzero(d > tol * scale))
    if k != int(np.count_nonzero(d > 1e-6 * scale)):
        return None
    padded = np.zeros((r, r))
    padded[:, :p] = qr[:, :p]
    Q, _, info = dorgqr(padded, tau)
    if info != 0:
        return None
    if k == 0:
        return np.zeros(r), Q
    R1 = np.triu(qr[:k])  # k x m, full row rank
    w = R1.dot(res[jpvt - 1])
    # y = (R1 R1^T)^-1 R1 P^T res through the triangular factor of R1^T (semi-normal equations)
    if k == m:
        Rt = R1[:, :k]
        y, info = dtrtrs(Rt, res[jpvt - 1], lower=0, trans=1)
    else:
        qr2, _, _, info = dgeqrf(R1.T)
        if info != 0:
            return None
        Rt = qr2[:k]
        t, info = dtrtrs(Rt, w, lower=0, trans=1)
        if info != 0:
            return None
        y, info = dtrtrs(Rt, t, lower=0)
    if info != 0:
        return None
    return Q[:, :k].dot(y), Q[:, k:]


def _level_step(
    JZ: FloatArray, res: FloatArray, mu: float, tol: float
) -> tuple[FloatArray, FloatArray]:
    """Step ``z`` of one equality level and the basis of ``null(JZ)``.

    QR when ``JZ`` is well conditioned, pivoted QR when it is clearly rank-deficient, else
    the damped SVD ``z = V diag(s / (s^2 + mu)) U^T res`` with rank cut at ``tol``.
    """
    return _damped_level_step(JZ, res, mu, tol)[:2]


def _damped_level_step(
    JZ: FloatArray, res: FloatArray, mu: float, tol: float
) -> tuple[FloatArray, FloatArray, float]:
    """:func:`_level_step` and the damping its step minimizes with.

    The QR steps are the least-norm minimizers of the undamped ``|JZ z - res|^2`` (damping
    0: the limit of the damped minimizer as ``mu -> 0``; they differ by about ``mu /
    s_min^2`` relative, ``s_min`` the smallest singular value of ``JZ``); the SVD step is the
    damped one (``mu``).
    """
    step = _qr_level(JZ, res)
    if step is None:
        step = _pivoted_qr_level(JZ, res, tol)
    if step is not None:
        return step[0], step[1], 0.0
    z, basis = _svd_level(JZ, res, mu, tol)
    return z, basis, mu


def _svd_level(
    JZ: FloatArray, res: FloatArray, mu: float, tol: float
) -> tuple[FloatArray, FloatArray]:
    """Damped step ``z = V diag(s / (s^2 + mu)) U^T res`` and ``null(JZ)`` (rank cut at ``tol``)."""
    U, s, Vt = np.linalg.svd(JZ, full_matrices=True)
    smax = max(1.0, float(s[0]) if s.size else 0.0)
    rank = int(np.count_nonzero(s > tol * smax))
    z = Vt[:rank].T @ ((s[:rank] / (s[:rank] ** 2 + mu)) * (U[:, :rank].T @ res))
    return z, Vt[rank:].T


def _drop_vanished_rows(
    P: FloatArray,
    norms: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    tol: float,
) -> tuple[npt.NDArray[np.intp], float] | None:
    """Neutralise the rows of ``P`` (projected rows) that vanish against their own scale.

    Rows with ``|P_i| <= tol * norms_i`` (``norms``: the rows' norms before projection) are
    zeroed in place and their bounds ``lo``, ``hi`` (also changed in place) set to ``-+INF``.
    Returns ``None`` when no row vanished, else the indices of the vanished rows whose bounds
    exclude 0 by more than ``1e-9 * (1 + |bound|)`` and the largest such exclusion.
    """
    size = np.sqrt(np.einsum("ij,ij->i", P, P))
    small = size <= tol * norms
    if not small.any():
        return None
    idx = np.flatnonzero(small)
    lo_s, hi_s = lo[idx], hi[idx]
    excess = np.maximum(lo_s - 1e-9 * (1.0 + np.abs(lo_s)), -hi_s - 1e-9 * (1.0 + np.abs(hi_s)))
    P[idx] = 0.0
    lo[idx] = -INF
    hi[idx] = INF
    bad = excess > 0.0
    return idx[bad], float(np.maximum(lo_s, -hi_s)[bad].max(initial=0.0))


def _float_array(value: Any, name: str) -> FloatArray | None:
    """``value`` as a float64 array (lists, int and float32 arrays; ``None`` stays ``None``).

    Raises:
        InvalidInputError: values that are not real numbers (boolean, complex, text, None),
            naming the hard constraint data ``name``.
    """
    if value is None or _is_float64(value):
        return value
    return as_float_array(value, f"hard constraint data {name}")


def _inconsistent(out: HierarchyResult, status: QPStatus) -> None:
    """Mark a cascade whose hard equalities ``A x = b`` have no solution (see ``solve``)."""
    out.success = False
    out.status = status if status in (QPStatus.RELAXED, QPStatus.FAILED) else QPStatus.RELAXED
    out.culprits.insert(0, "hard equalities")


def _hard_blocks(hard_names: Any, m: int) -> list[RowBlock]:
    """The named blocks of the ``m`` hard inequality rows, rows in no block as one of their own.

    Raises:
        InvalidInputError: an entry that is not a :class:`RowBlock` of rows in ``[0, m)``.
    """
    if isinstance(hard_names, RowBlock) or not isinstance(hard_names, Sequence):
        raise InvalidInputError(
            f"hard_names must be a list of RowBlock, got {type(hard_names).__name__}"
        )
    covered = np.zeros(m, dtype=bool)
    out: list[RowBlock] = []
    for k, blk in enumerate(hard_names):
        if not (
            isinstance(blk, RowBlock)
            and isinstance(blk.name, str)
            and isinstance(blk.start, (int, np.integer))
            and isinstance(blk.stop, (int, np.integer))
            and 0 <= blk.start <= blk.stop <= m
        ):
            raise InvalidInputError(
                f"hard_names[{k}] must be a RowBlock(name, start, stop) with "
                f"0 <= start <= stop <= {m} (the number of hard inequality rows), got {blk!r}"
            )
        out.append(RowBlock(blk.name, int(blk.start), int(blk.stop)))
        covered[blk.start : blk.stop] = True
    gaps = np.flatnonzero(np.diff(np.concatenate([[0], (~covered).view(np.int8), [0]])))
    out += [RowBlock("hard inequalities", int(a), int(b)) for a, b in zip(gaps[::2], gaps[1::2])]
    return out


def _violated_blocks(
    x: FloatArray,
    blocks: list[RowBlock],
    C: FloatArray | None,
    l: FloatArray | None,
    u: FloatArray | None,
    lb: FloatArray,
    ub: FloatArray,
) -> list[str]:
    """Names of the hard blocks (then ``"bounds"``) violated at ``x`` by more than 1e-6."""
    out: list[str] = []
    if C is not None and l is not None and u is not None and C.shape[0]:
        Cx = C @ x
        v = np.maximum(l - Cx, Cx - u)
        for blk in blocks:
            if blk.name not in out and v[blk.start : blk.stop].max(initial=0.0) > RELAXED_VIOLATION:
                out.append(blk.name)
    if np.maximum(lb - x, x - ub).max(initial=0.0) > RELAXED_VIOLATION:
        out.append("bounds")
    return out


def _affine_start(
    A: FloatArray | None, b: FloatArray | None, n: int, tol: float
) -> tuple[FloatArray, FloatArray | None]:
    """Least-norm solution of ``A x = b`` and a basis of ``null(A)`` (identity if no ``A``)."""
    if A is None or b is None or A.shape[0] == 0:
        return np.zeros(n), None
    step = _qr_level(A, b) if A.shape[0] < n else None
    if step is not None:  # one QR of A^T: half the cost of the SVD (G1: 18 x 47)
        return step
    U, s, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.count_nonzero(s > tol * max(1.0, float(s[0]) if s.size else 0.0)))
    x0 = Vt[:rank].T @ ((U[:, :rank].T @ b) / s[:rank])
    return x0, Vt[rank:].T


class _ClosedFormLevelResult(QPResult):
    """The result of a level solved by the equality cascade (no QP).

    The level's QP is its damped least-squares problem ``min 1/2 |JZ z - res|^2 + mu/2
    |z|^2`` with every inequality inactive (all multipliers zero); ``x`` is the level's step
    ``z``. ``mu`` is the damping the step minimizes with: 0 for a level solved by QR (the
    least-norm minimizer of the undamped problem, as exact as the factorization: the damped
    minimizer differs from it by about ``mu / s_min^2`` relative, ``s_min`` the smallest
    singular value of ``JZ``), the level's damping for a damped SVD step and for the last level
    (Cholesky of the damped normal equations). ``objective`` and ``kkt``
    (:func:`~taskspace.qp.kkt.least_squares_kkt_residuals`,
    the primal residual being the largest violation of the bounds, hard rows and the level's
    inequalities at the cascade's point) are computed on first access: most steps never read
    them.
    """

    def __init__(
        self, step: tuple[FloatArray, FloatArray, FloatArray, float], primal: float
    ) -> None:
        self._pending: tuple[FloatArray, FloatArray, FloatArray, float, float] | None = None
        super().__init__(True, QPStatus.UNCONSTRAINED, step[2], float("nan"), backend="closed form")
        self._pending = (*step, primal)

    def _evaluate(self) -> None:
        pending = self._pending
        if pending is None:
            return
        self._pending = None
        JZ, res, z, mu, primal = pending
        self._kkt = least_squares_kkt_residuals(JZ, res, z, mu, primal)
        self._objective = (
            0.5 * float(np.sum((JZ.dot(z) - res) ** 2) + mu * z.dot(z)) if z.size else 0.0
        )

    @property  # type: ignore[override]
    def kkt(self) -> KKTResiduals:
        """KKT residuals of the level's least-squares QP (computed on first access)."""
        self._evaluate()
        return self._kkt

    @kkt.setter
    def kkt(self, value: KKTResiduals) -> None:
        self._kkt = value

    @property  # type: ignore[override]
    def objective(self) -> float:
        """``1/2 |JZ z - res|^2 + mu/2 |z|^2`` (computed on first access)."""
        self._evaluate()
        return self._objective

    @objective.setter
    def objective(self, value: float) -> None:
        self._objective = value


class HierarchySolver:
    """Lexicographic cascade over any number of levels (one persistent QP solver per level)."""

    def __init__(self, options: HierarchyOptions | None = None) -> None:
        self.options = options or HierarchyOptions()
        self._solvers: list[QPSolver] = []
        self._exact_solvers: list[QPSolver] = []

    def _solver(self, k: int) -> QPSolver:
        while len(self._solvers) <= k:
            self._solvers.append(QPSolver(self.options.solver))
        return self._solvers[k]

    def _exact_solver(self, k: int) -> QPSolver | None:
        if self.options.exact_first is None:
            return None
        while len(self._exact_solvers) <= k:
            self._exact_solvers.append(QPSolver(self.options.exact_first))
        return self._exact_solvers[k]

    def _solve_level(self, k: int, problem: QPProblem) -> QPResult:
        """Level ``k``'s QP: the exact first pass if it certifies, else ``solver``."""
        first = self._exact_solver(k)
        if first is not None:
            result = first.solve(problem)
            if result.success:
                return result
        return self._solver(k).solve(problem)

    def solve(
        self,
        levels: Sequence[HierarchyLevel],
        n: int,
        *,
        lb: FloatArray | None = None,
        ub: FloatArray | None = None,
        C: FloatArray | None = None,
        l: FloatArray | None = None,
        u: FloatArray | None = None,
        hard_names: Sequence[RowBlock] = (),
        A: FloatArray | None = None,
        b: FloatArray | None = None,
    ) -> HierarchyResult:
        """Solve the cascade.

        Args:
            levels: highest priority first.
            n: number of variables.
            lb, ub: hard box bounds (default none).
            C, l, u: hard inequalities (default none).
            hard_names: row blocks naming the hard inequalities ``C`` (``[start, stop)`` rows;
                rows in no block are named ``"hard inequalities"``). The level QPs carry these
                names, so a relaxed level's ``culprits`` and the cascade's
                :attr:`HierarchyResult.culprits` name the blocks at fault.
            A, b: hard equalities ``A x = b`` (held exactly by starting in the affine set
                ``x0 + null(A)``), e.g. equations of motion and rigid contacts. Inconsistent
                ones (no solution: ``|A x0 - b| > 1e-6`` at their least-squares point ``x0``)
                make the result ``RELAXED``, not a success, with ``"hard equalities"`` first
                in its culprits.
            The hard data may be lists or arrays of any real dtype. ``C``, ``A``, ``b`` must
            be finite, the bounds ``l``, ``u``, ``lb``, ``ub`` not NaN (they may be infinite).

        Raises:
            NotFiniteError: NaN in any level's or the hard data (inf in ``J``, ``r``, ``C``,
                ``A``, ``b``), naming the array and its rows.
            ShapeError, InvalidInputError: arrays that do not fit ``n`` or each other.
        """
        t0 = time.perf_counter()
        opts = self.options
        lb, ub, C, l, u, A, b = (
            _float_array(a, nm)
            for a, nm in zip((lb, ub, C, l, u, A, b), ("lb", "ub", "C", "l", "u", "A", "b"))
        )
        _check_levels(levels, n, lb, ub, C, l, u, A, b)
        hard_blocks = _hard_blocks(hard_names, 0 if C is None else C.shape[0])
        lb = np.full(n, -INF) if lb is None else lb
        ub = np.full(n, INF) if ub is None else ub
        # Fast path: the cascade of the equality rows alone (one SVD per level). When its
        # solution satisfies every inequality and bound, it is the constrained optimum too.
        x0, Z0 = _affine_start(A, b, n, opts.rank_tolerance)
        # inconsistent hard equalities: x0 is their least-squares point (every level moves
        # in null(A), so A x stays A x0): reported, never a success
        inconsistent = (
            A is not None
            and b is not None
            and b.size > 0
            and not float(np.abs(A @ x0 - b).max()) <= RELAXED_VIOLATION
        )
        shortcut = self._equality_cascade(levels, n, x0, Z0)
        violations = (
            None if shortcut is None else self._violations(shortcut[0], levels, lb, ub, C, l, u)
        )
        if shortcut is not None and violations is not None:
            x, dims, steps = shortcut
            done = HierarchyResult(True, QPStatus.UNCONSTRAINED, x, nullspace_dims=dims)
            if inconsistent:
                _inconsistent(done, QPStatus.UNCONSTRAINED)
            return self._finish(
                done,
                levels,
                t0,
                [_ClosedFormLevelResult(step, primal) for step, primal in zip(steps, violations)],
            )
        held_C: list[FloatArray] = [] if C is None else [C]
        held_l: list[FloatArray] = [] if l is None else [l]
        held_u: list[FloatArray] = [] if u is None else [u]
        held_names: list[str] = [] if C is None else ["hard inequalities"]
        x = x0
        held_once = False  # a QP level has been solved: x meets the hard rows
        Z: FloatArray | None = Z0  # None = identity (no reduction yet)
        out = HierarchyResult(True, QPStatus.UNCONSTRAINED, x)
        worst = 0
        order = [
            QPStatus.UNCONSTRAINED,
            QPStatus.SOLVED,
            QPStatus.INACCURATE,
            QPStatus.MAX_ITERATIONS,
            QPStatus.RELAXED,
            QPStatus.FAILED,
        ]
        for k, level in enumerate(levels):
            r_dim = n if Z is None else Z.shape[1]
            p = level.n_in
            if r_dim == 0:
                # no freedom left: the level is only evaluated
                # (its inequalities' slacks take any violation: the empty QP is feasible)
                out.level_results.append(
                    QPResult(
                        True,
                        QPStatus.UNCONSTRAINED,
                        np.zeros(0),
                        0.0,
                        kkt=KKTResiduals(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
                    )
                )
            else:
                JZ = level.J if Z is None else level.J @ Z
                res0 = level.J @ x - level.r
                N = r_dim + p
                H = np.zeros((N, N))
                H[:r_dim, :r_dim] = JZ.T @ JZ
                mu_k = opts.damping if level.damping is None else level.damping
                H[np.arange(r_dim), np.arange(r_dim)] += max(mu_k, 1e-14)
                g = np.zeros(N)
                g[:r_dim] = JZ.T @ res0
                if p:
                    H[r_dim:, r_dim:] = np.eye(p)
                rows_C: list[FloatArray] = []
                rows_l: list[FloatArray] = []
                rows_u: list[FloatArray] = []
                blocks: list[RowBlock] = []
                row = 0
                # After the first QP, x meets the hard rows up to the solver's tolerance (or at
                # their least violation when relaxed): their bounds relative to x are clipped so
                # that z = 0 stays feasible, else round-off at active rows (1e-9) can make a
                # lower level spuriously infeasible.
                slack = 0.0 if held_once else INF
                if Z is None:
                    box_lb = np.concatenate([np.minimum(lb - x, slack), np.zeros(p)])
                    box_ub = np.concatenate([np.maximum(ub - x, -slack), np.full(p, INF)])
                else:
                    box_lb = np.concatenate([np.full(r_dim, -INF), np.zeros(p)])
                    box_ub = np.full(N, INF)
                    finite = np.flatnonzero((lb > -INF) | (ub < INF))
                    if finite.size:
                        block = np.zeros((finite.size, N))
                        block[:, :r_dim] = Z[finite]
                        lo_b = np.minimum(lb[finite] - x[finite], slack)
                        hi_b = np.maximum(ub[finite] - x[finite], -slack)
                        self._drop_rows(
                            out, level.name, "bounds", block[:, :r_dim], 1.0, lo_b, hi_b, finite
                        )
                        rows_C.append(block)
                        rows_l.append(lo_b)
                        rows_u.append(hi_b)
                        blocks.append(RowBlock("bounds", row, row + finite.size))
                        row += finite.size
                for j, (Ch, lh, uh) in enumerate(zip(held_C, held_l, held_u)):
                    block = np.zeros((Ch.shape[0], N))
                    Cx = Ch @ x
                    lo_h = np.minimum(lh - Cx, slack)
                    hi_h = np.maximum(uh - Cx, -slack)
                    named = hard_blocks if j == 0 and C is not None else None
                    if Z is None:
                        block[:, :r_dim] = Ch
                    else:
                        block[:, :r_dim] = Ch @ Z
                        self._drop_rows(
                            out,
                            level.name,
                            held_names[j],
                            block[:, :r_dim],
                            np.sqrt(np.einsum("ij,ij->i", Ch, Ch)),
                            lo_h,
                            hi_h,
                            named=named,
                        )
                    rows_C.append(block)
                    rows_l.append(lo_h)
                    rows_u.append(hi_h)
                    if named is None:
                        blocks.append(RowBlock(held_names[j], row, row + Ch.shape[0]))
                    else:  # the hard rows under their own names
                        blocks += [RowBlock(b.name, row + b.start, row + b.stop) for b in named]
                    row += Ch.shape[0]
                if p:
                    assert level.C is not None and level.l is not None and level.u is not None
                    CZ = level.C if Z is None else level.C @ Z
                    Cx = level.C @ x
                    # l - w <= C x <= u + w, as two one-sided rows sharing the slack w >= 0
                    lo = np.zeros((p, N))
                    lo[:, :r_dim] = CZ
                    lo[:, r_dim:] = np.eye(p)
                    hi = np.zeros((p, N))
                    hi[:, :r_dim] = CZ
                    hi[:, r_dim:] = -np.eye(p)
                    rows_C += [lo, hi]
                    rows_l += [level.l - Cx, np.full(p, -INF)]
                    rows_u += [np.full(p, INF), level.u - Cx]
                    blocks.append(RowBlock(level.name, row, row + 2 * p))
                    row += 2 * p
                problem = QPProblem(
                    H,
                    g,
                    np.zeros((0, N)),
                    np.zeros(0),
                    np.vstack(rows_C) if rows_C else np.zeros((0, N)),
                    np.concatenate(rows_l) if rows_l else np.zeros(0),
                    np.concatenate(rows_u) if rows_u else np.zeros(0),
                    box_lb,
                    box_ub,
                    in_blocks=blocks,
                    box_blocks=[RowBlock("bounds", 0, r_dim)],
                    convex=True,  # the level's J^T W J in the nullspace basis, damped
                )
                result = self._solve_level(k, problem)
                held_once = True
                out.level_results.append(result)
                worst = max(worst, order.index(result.status))
                if not result.success:
                    out.success = False
                z = result.x[:r_dim]
                x = x + (z if Z is None else Z @ z)
            if p:
                assert level.C is not None and level.l is not None and level.u is not None
                Cx = level.C @ x
                held_C.append(level.C)
                held_l.append(np.minimum(level.l, Cx))
                held_u.append(np.maximum(level.u, Cx))
                held_names.append(f"held inequalities of {level.name}")
            # remaining freedom: nullspace of this level's equality rows
            if level.J.shape[0] and k < len(levels) - 1 and r_dim > 0:
                JZ = level.J if Z is None else level.J @ Z
                _, basis = _level_step(JZ, np.zeros(JZ.shape[0]), 0.0, opts.rank_tolerance)
                Z = basis if Z is None else Z @ basis
            out.nullspace_dims.append(n if Z is None else Z.shape[1])
        out.x = x
        out.status = order[worst]
        if out.culprits:
            out.success = False
            out.status = order[max(worst, order.index(QPStatus.RELAXED))]
        if not out.success:
            # the hard blocks the cascade's point violates (as a relaxed QP names them),
            # then the cascade's own diagnostics (rows no level could satisfy)
            out.culprits[:0] = _violated_blocks(x, hard_blocks, C, l, u, lb, ub)
        if inconsistent:
            _inconsistent(out, out.status)
        return self._finish(out, levels, t0, None)

    def _drop_rows(
        self,
        out: HierarchyResult,
        level: str,
        block: str,
        P: FloatArray,
        norms: FloatArray | float,
        lo: FloatArray,
        hi: FloatArray,
        rows: npt.NDArray[np.intp] | None = None,
        named: list[RowBlock] | None = None,
    ) -> None:
        """Leave projected rows that vanish out of a level's QP (see ``row_tolerance``).

        ``P`` (a view of the level's constraint block), ``lo`` and ``hi`` are changed in place;
        rows whose bounds exclude the current point are named in ``out.culprits`` (with the
        names of their blocks in ``named``, the hard inequalities' ``hard_names``).
        """
        dropped = _drop_vanished_rows(
            P, np.broadcast_to(norms, P.shape[:1]), lo, hi, self.options.row_tolerance
        )
        if dropped is None or not dropped[0].size:
            return
        idx = dropped[0] if rows is None else rows[dropped[0]]
        names = ""
        if named is not None:
            hit = [b.name for b in named if ((idx >= b.start) & (idx < b.stop)).any()]
            if hit != [block]:  # named blocks (not only the unnamed rows')
                names = f" ({', '.join(dict.fromkeys(hit))})"
        out.culprits.append(
            f"level {level!r}: {block} rows {idx.tolist()}{names} vanish in the level's freedom "
            f"(they lie in the span of the hard equalities and higher levels' equalities) "
            f"but are violated by up to {dropped[1]:.3g}"
        )

    def _equality_cascade(
        self,
        levels: Sequence[HierarchyLevel],
        n: int,
        x0: FloatArray,
        Z0: FloatArray | None,
    ) -> (
        tuple[FloatArray, list[int], list[tuple[FloatArray, FloatArray, FloatArray, float]]] | None
    ):
        """Lexicographic damped least squares of the equality rows.

        Level k: ``z = argmin |J_k Z z - (r_k - J_k x)|^2 + mu |z|^2`` by an SVD of ``J_k Z``,
        which also gives the next nullspace basis ``Z <- Z V_null``; the last level needs no
        basis and is solved by one Cholesky factorization of the normal equations. Also
        returns, per level, ``(JZ, res, z, mu)`` (the level's least-squares problem and step,
        for its KKT residuals).
        """
        mu = self.options.damping
        tol = self.options.rank_tolerance
        x = x0
        Z: FloatArray | None = Z0
        dims = []
        steps: list[tuple[FloatArray, FloatArray, FloatArray, float]] = []
        last = len(levels) - 1
        empty = np.zeros(0)
        for k, level in enumerate(levels):
            J = level.J
            if J.shape[0] and (Z is None or Z.shape[1]):
                mu = self.options.damping if level.damping is None else level.damping
                JZ = J if Z is None else J @ Z
                res = level.r - J @ x
                if k == last:
                    mu = max(mu, 1e-12)
                    G = JZ.T @ JZ
                    G.flat[:: G.shape[0] + 1] += mu
                    _, z, info = dposv(G, JZ.T @ res)
                    if info != 0:
                        return None
                elif level.damping is not None and level.damping > self.options.damping:
                    # a level's own, larger damping (Levenberg-Marquardt) shapes its step:
                    # the undamped QR step would ignore it
                    z, basis = _svd_level(JZ, res, mu, tol)
                else:
                    z, basis, mu = _damped_level_step(JZ, res, mu, tol)
                x = x + (z if Z is None else Z @ z)
                if k < last:
                    Z = basis if Z is None else Z @ basis
                steps.append((JZ.copy() if JZ is J else JZ, res, z, mu))  # J: a buffer
            else:  # no rows (or no freedom): the level's step is zero
                steps.append((np.zeros((0, 0)), empty, empty, 0.0))
            dims.append(n if Z is None else Z.shape[1])
        if not np.all(np.isfinite(x)):
            return None
        return x, dims, steps

    @staticmethod
    def _violations(
        x: FloatArray,
        levels: Sequence[HierarchyLevel],
        lb: FloatArray,
        ub: FloatArray,
        C: FloatArray | None,
        l: FloatArray | None,
        u: FloatArray | None,
        tol: float = 1e-10,
    ) -> list[float] | None:
        """Per level, the largest violation at ``x`` of the rows the level must respect.

        Those are the bounds, the hard inequalities and the level's own inequalities; ``None``
        as soon as one violation exceeds ``tol`` (the cascade's point is infeasible).
        """
        hard = max(0.0, -float(np.minimum(x - lb, ub - x).min(initial=INF)))
        if hard > tol:
            return None
        if C is not None and l is not None and u is not None and C.shape[0]:
            Cx = C @ x
            hard = max(hard, -float(np.minimum(Cx - l, u - Cx).min()))
            if hard > tol:
                return None
        out = []
        for level in levels:
            v = hard
            if level.n_in:
                assert level.C is not None and level.l is not None and level.u is not None
                Cx = level.C @ x
                v = max(v, -float(np.minimum(Cx - level.l, level.u - Cx).min()))
                if v > tol:
                    return None
            out.append(v)
        return out

    @staticmethod
    def _finish(
        out: HierarchyResult,
        levels: Sequence[HierarchyLevel],
        t0: float,
        level_results: list[QPResult] | None,
    ) -> HierarchyResult:
        x = out.x
        if level_results is not None:
            out.level_results = level_results
        for level in levels:
            d = level.J @ x
            d -= level.r
            out.residuals.append(math.sqrt(float(d.dot(d))))  # np.linalg.norm's own formula
            if level.n_in:
                assert level.C is not None and level.l is not None and level.u is not None
                Cx = level.C @ x
                out.violations.append(
                    float(np.maximum(level.l - Cx, Cx - level.u).max(initial=0.0))
                )
            else:
                out.violations.append(0.0)
        out.solve_time = time.perf_counter() - t0
        return out
