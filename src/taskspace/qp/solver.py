"""A persistent QP solver with proxsuite as default and daqp, osqp, quadprog as alternatives.

The proxsuite workspace is created once per problem structure ``(n, n_eq, n_in)`` and then
``update``-d (keeping its preconditioner) and warm-started; it is never rebuilt per step. Before
calling any backend the solver tries the unconstrained minimizer (one Cholesky
factorization): when it already satisfies every constraint it is the optimum.

When a backend cannot solve a problem, the next backend in ``fallbacks`` is tried; when the
constraints truly conflict, the least-violating solution is computed (slack variables with a
large penalty) and the result names the constraint blocks at fault.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg.lapack import dgesv, dposv

from taskspace._validation import FloatArray
from taskspace.errors import InvalidInputError, SolverError, UnknownNameError
from taskspace.qp.problem import INF, QPProblem, RowBlock
from taskspace.qp.result import QPResult, QPStatus

logger = logging.getLogger(__name__)

BACKENDS = ("proxsuite", "daqp", "osqp", "quadprog")
"""Backend names accepted by :class:`QPSolver`."""


def available_backends() -> list[str]:
    """Backends whose Python package can be imported here."""
    out = []
    for name in BACKENDS:
        module = {"proxsuite": "proxsuite", "daqp": "daqp", "osqp": "osqp", "quadprog": "quadprog"}
        try:
            __import__(module[name])
        except ImportError:
            continue
        out.append(name)
    return out


def check_backend(name: str) -> str:
    """Return ``name`` if it is an available backend, else raise listing the available ones."""
    if name not in available_backends():
        raise UnknownNameError("QP backend", name, available_backends())
    return name


@dataclass(frozen=True, kw_only=True)
class QPSolverOptions:
    """Settings of :class:`QPSolver`.

    Attributes:
        backend: ``proxsuite`` (default), ``daqp``, ``osqp`` or ``quadprog``.
        eps_abs: absolute tolerance of the backends.
        max_iter: iteration limit of the backends.
        try_unconstrained: try the unconstrained minimizer before calling the backend.
        fallbacks: backends tried, in order, when the main one fails.
        relax_on_failure: compute the least-violating solution when no backend succeeds.
        relaxation_weight: penalty on squared constraint violations in the relaxed problem.
        feasibility_tolerance: tolerance of the unconstrained-shortcut feasibility test.
    """

    backend: str = "proxsuite"
    eps_abs: float = 1e-9
    max_iter: int = 1000
    try_unconstrained: bool = True
    fallbacks: tuple[str, ...] = ("daqp",)
    relax_on_failure: bool = True
    relaxation_weight: float = 1e6
    feasibility_tolerance: float = 1e-10


class QPSolver:
    """Solves :class:`QPProblem` instances, keeping backend workspaces between calls.

    Args:
        options: settings (default :class:`QPSolverOptions`).
    """

    def __init__(self, options: QPSolverOptions | None = None) -> None:
        self.options = options or QPSolverOptions()
        check_backend(self.options.backend)
        for name in self.options.fallbacks:
            check_backend(name)
        self._proxsuite: Any = None
        self._proxsuite_structure: tuple[int, int, int] | None = None
        self._kkt = KKTWorkspace()

    # ------------------------------------------------------------------ public
    def solve(self, problem: QPProblem) -> QPResult:
        """Solve ``problem`` (see the module docstring for the strategy)."""
        t0 = time.perf_counter()
        opts = self.options
        if opts.try_unconstrained:
            x = self._kkt.solve(problem)
            if x is not None and problem.is_feasible(x, opts.feasibility_tolerance):
                return QPResult(
                    True,
                    QPStatus.UNCONSTRAINED,
                    x,
                    float(0.5 * (problem.g @ x)) if not problem.n_eq else _objective(problem, x),
                    0,
                    time.perf_counter() - t0,
                    "cholesky",
                )
        last: QPResult | None = None
        for backend in (opts.backend, *[b for b in opts.fallbacks if b != opts.backend]):
            try:
                result = self._solve_with(backend, problem)
            except Exception as exc:  # a backend raising is a failure of that backend
                logger.debug("QP backend %s raised %r", backend, exc)
                result = QPResult.failed(problem.n, backend, 0.0)
            if result.success:
                result.solve_time = time.perf_counter() - t0
                return result
            last = result
        if opts.relax_on_failure:
            result = self.solve_relaxed(problem)
            result.solve_time = time.perf_counter() - t0
            return result
        assert last is not None
        last.solve_time = time.perf_counter() - t0
        return last

    def solve_relaxed(self, problem: QPProblem) -> QPResult:
        """Least-violating solution: every constraint row gets a slack with a large penalty.

        ``min f(x) + w/2 |s|^2`` s.t. ``A x - s_eq = b``, ``l - s_in <= C x <= u + s_in``,
        ``lb - s_box <= x <= ub + s_box``, ``s >= 0`` for inequality slacks.
        """
        relaxed, n = _relaxed_problem(problem, self.options.relaxation_weight), problem.n
        solver = QPSolver(
            QPSolverOptions(
                backend="daqp" if "daqp" in available_backends() else self.options.backend,
                fallbacks=("proxsuite",),
                relax_on_failure=False,
                try_unconstrained=False,
            )
        )
        inner = solver.solve(relaxed)
        x = inner.x[:n]
        violations = problem.violations(x)
        culprits = [name for name, v in violations.items() if v > 1e-6]
        status = QPStatus.RELAXED if inner.status is not QPStatus.FAILED else QPStatus.FAILED
        if not culprits and inner.status is not QPStatus.FAILED:
            # The relaxation found the constraints compatible after all: a genuine solution.
            return QPResult(
                True,
                QPStatus.SOLVED,
                x,
                _objective(problem, x),
                inner.iterations,
                inner.solve_time,
                inner.backend,
                [],
                violations,
            )
        return QPResult(
            False,
            status,
            x,
            _objective(problem, x),
            inner.iterations,
            inner.solve_time,
            inner.backend,
            culprits,
            violations,
        )

    # ------------------------------------------------------------------ backends
    def _solve_with(self, backend: str, problem: QPProblem) -> QPResult:
        if backend == "proxsuite":
            return self._solve_proxsuite(problem)
        if backend == "daqp":
            return _solve_daqp(problem, self.options)
        return _solve_qpsolvers(backend, problem, self.options)

    def _solve_proxsuite(self, p: QPProblem) -> QPResult:
        from proxsuite import proxqp

        t0 = time.perf_counter()
        structure = p.structure()
        A = p.A if p.n_eq else None
        b = p.b if p.n_eq else None
        C = p.C if p.n_in else None
        l = p.l if p.n_in else None
        u = p.u if p.n_in else None
        if self._proxsuite is None or self._proxsuite_structure != structure:
            qp = proxqp.dense.QP(p.n, p.n_eq, p.n_in, True)
            qp.settings.eps_abs = self.options.eps_abs
            qp.settings.eps_rel = 0.0
            qp.settings.max_iter = self.options.max_iter
            qp.settings.max_iter_in = self.options.max_iter
            qp.settings.verbose = False
            qp.settings.initial_guess = proxqp.InitialGuess.NO_INITIAL_GUESS
            qp.init(p.H, p.g, A, b, C, l, u, p.lb, p.ub)
            qp.solve()
            # warm start only once a previous result exists (setting it before the first
            # solve crashes proxsuite 0.8)
            qp.settings.initial_guess = proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            self._proxsuite = qp
            self._proxsuite_structure = structure
        else:
            qp = self._proxsuite
            qp.update(p.H, p.g, A, b, C, l, u, p.lb, p.ub, update_preconditioner=False)
            qp.solve()
        info = qp.results.info
        x = np.array(qp.results.x)
        status = info.status
        elapsed = time.perf_counter() - t0
        if status == proxqp.PROXQP_SOLVED:
            return QPResult(
                True, QPStatus.SOLVED, x, _objective(p, x), int(info.iter), elapsed, "proxsuite"
            )
        if status == proxqp.PROXQP_MAX_ITER_REACHED:
            # the preconditioner may be stale: rebuild the workspace next time
            self._proxsuite = None
            return QPResult(
                False,
                QPStatus.MAX_ITERATIONS,
                x,
                _objective(p, x),
                int(info.iter),
                elapsed,
                "proxsuite",
            )
        self._proxsuite = None
        return QPResult(
            False, QPStatus.FAILED, x, _objective(p, x), int(info.iter), elapsed, "proxsuite"
        )


def _solve_daqp(p: QPProblem, options: QPSolverOptions) -> QPResult:
    import daqp

    t0 = time.perf_counter()
    rows = []
    upper = [p.ub]
    lower = [p.lb]
    sense = [np.zeros(p.n, dtype=np.int32)]
    if p.n_eq:
        rows.append(p.A)
        upper.append(p.b)
        lower.append(p.b)
        sense.append(np.full(p.n_eq, 5, dtype=np.int32))
    if p.n_in:
        rows.append(p.C)
        upper.append(p.u)
        lower.append(p.l)
        sense.append(np.zeros(p.n_in, dtype=np.int32))
    A = np.vstack(rows) if rows else np.zeros((0, p.n))
    bu = np.minimum(np.concatenate(upper), 1e30)
    bl = np.maximum(np.concatenate(lower), -1e30)
    x, _, exitflag, info = daqp.solve(
        np.ascontiguousarray(p.H),
        np.ascontiguousarray(p.g),
        np.ascontiguousarray(A),
        bu,
        bl,
        np.concatenate(sense),
        iter_limit=max(options.max_iter, 1000),
        eps_prox=0,
    )
    x = np.asarray(x)
    elapsed = time.perf_counter() - t0
    iterations = int(info.get("iterations", 0)) if isinstance(info, dict) else 0
    if exitflag >= 1:
        return QPResult(True, QPStatus.SOLVED, x, _objective(p, x), iterations, elapsed, "daqp")
    status = QPStatus.MAX_ITERATIONS if exitflag == -4 else QPStatus.FAILED
    return QPResult(False, status, x, _objective(p, x), iterations, elapsed, "daqp")


def _solve_qpsolvers(backend: str, p: QPProblem, options: QPSolverOptions) -> QPResult:
    import qpsolvers

    t0 = time.perf_counter()
    G = h = None
    if p.n_in:
        finite_u = p.u < INF
        finite_l = p.l > -INF
        G = np.vstack([p.C[finite_u], -p.C[finite_l]])
        h = np.concatenate([p.u[finite_u], -p.l[finite_l]])
    lb = np.where(p.lb > -INF, p.lb, -np.inf)
    ub = np.where(p.ub < INF, p.ub, np.inf)
    kwargs: dict[str, Any] = {}
    if backend == "osqp":
        kwargs = {
            "eps_abs": max(options.eps_abs, 1e-7),
            "eps_rel": 0.0,
            "max_iter": 20000,
            "polishing": True,
        }
    problem = qpsolvers.Problem(
        p.H, p.g, G, h, p.A if p.n_eq else None, p.b if p.n_eq else None, lb, ub
    )
    solution = qpsolvers.solve_problem(problem, solver=backend, **kwargs)
    elapsed = time.perf_counter() - t0
    if solution.found and solution.x is not None:
        x = np.asarray(solution.x)
        return QPResult(True, QPStatus.SOLVED, x, _objective(p, x), 0, elapsed, backend)
    return QPResult.failed(p.n, backend, elapsed)


# ---------------------------------------------------------------------- helpers
def _objective(p: QPProblem, x: FloatArray) -> float:
    return float(0.5 * x.dot(p.H.dot(x)) + p.g.dot(x))


def unconstrained_minimizer(
    p: QPProblem, workspace: KKTWorkspace | None = None
) -> FloatArray | None:
    """Minimizer of the objective subject to the equality constraints only.

    Args:
        p: the problem (inequalities and bounds are ignored).
        workspace: buffers reused between calls of the same size (a :class:`QPSolver`
            keeps one); a fresh one when omitted.

    Returns ``None`` when ``H`` (or the KKT matrix) is singular.
    """
    return (workspace or KKTWorkspace()).solve(p)


class KKTWorkspace:
    """Buffers of the equality-constrained solve ``[H A^T; A 0] [x; y] = [-g; b]``.

    The KKT matrix and right-hand side are refilled in place and factorized by LAPACK's
    ``dgesv`` overwriting them, so a step allocates nothing of size ``(n + m)^2``.
    """

    def __init__(self) -> None:
        self._shape = (-1, -1)
        self._K = np.zeros((0, 0), order="F")
        self._rhs = np.zeros(0)

    def solve(self, p: QPProblem) -> FloatArray | None:
        """The equality-constrained minimizer of ``p``, or ``None`` if singular."""
        try:
            if not p.A.shape[0]:
                # Cholesky solve through LAPACK directly (np.linalg.solve costs 4x more on 7x7)
                _, x, info = dposv(p.H, -p.g)
                return x if info == 0 else None
            n, m = p.n, p.n_eq
            if self._shape != (n, m):
                self._shape = (n, m)
                self._K = np.zeros((n + m, n + m), order="F")
                self._rhs = np.zeros(n + m)
            K, rhs = self._K, self._rhs
            K[:n, :n] = p.H
            K[:n, n:] = p.A.T
            K[n:, :n] = p.A
            K[n:, n:] = 0.0
            np.negative(p.g, out=rhs[:n])
            rhs[n:] = p.b
            _, _, sol, info = dgesv(K, rhs, overwrite_a=1, overwrite_b=1)
            return np.array(sol[:n]) if info == 0 else None
        except (np.linalg.LinAlgError, ValueError):
            return None


def _relaxed_problem(p: QPProblem, weight: float) -> QPProblem:
    n, m_eq, m_in = p.n, p.n_eq, p.n_in
    box_rows = np.flatnonzero((p.lb > -INF) | (p.ub < INF))
    k = len(box_rows)
    ns = m_eq + m_in + k
    N = n + ns
    H = np.zeros((N, N))
    H[:n, :n] = p.H
    H[n:, n:] = weight * np.eye(ns)
    g = np.concatenate([p.g, np.zeros(ns)])
    A = np.zeros((m_eq, N))
    A[:, :n] = p.A
    A[:, n : n + m_eq] = -np.eye(m_eq)
    # inequality rows: C x + s >= l and C x - s <= u, box rows likewise
    s_in = slice(n + m_eq, n + m_eq + m_in)
    s_box = slice(n + m_eq + m_in, N)
    C = np.zeros((2 * (m_in + k), N))
    l = np.full(2 * (m_in + k), -INF)
    u = np.full(2 * (m_in + k), INF)
    C[:m_in, :n] = p.C
    C[:m_in, s_in] = np.eye(m_in)
    l[:m_in] = p.l
    C[m_in : 2 * m_in, :n] = p.C
    C[m_in : 2 * m_in, s_in] = -np.eye(m_in)
    u[m_in : 2 * m_in] = p.u
    r0 = 2 * m_in
    E = np.eye(n)[box_rows]
    C[r0 : r0 + k, :n] = E
    C[r0 : r0 + k, s_box] = np.eye(k)
    l[r0 : r0 + k] = p.lb[box_rows]
    C[r0 + k :, :n] = E
    C[r0 + k :, s_box] = -np.eye(k)
    u[r0 + k :] = p.ub[box_rows]
    lb = np.concatenate([np.full(n + m_eq, -INF), np.zeros(m_in + k)])
    ub = np.full(N, INF)
    return QPProblem(H, g, A, np.asarray(p.b, dtype=float), C, l, u, lb, ub)


def validate_problem(problem: QPProblem) -> None:
    """Shapes fit and every array is finite (bounds may be +-INF)."""
    problem.check()
    for name in ("H", "g", "A", "b", "C"):
        arr = getattr(problem, name)
        if not np.all(np.isfinite(arr)):
            raise InvalidInputError(f"QP {name} has non-finite entries")
    for name in ("l", "u", "lb", "ub"):
        if np.any(np.isnan(getattr(problem, name))):
            raise InvalidInputError(f"QP {name} has NaN entries")
    if problem.n_in and np.any(problem.l > problem.u):
        raise InvalidInputError("QP inequality bounds have l > u")


__all__ = [
    "BACKENDS",
    "KKTWorkspace",
    "QPSolver",
    "QPSolverOptions",
    "RowBlock",
    "SolverError",
    "available_backends",
    "check_backend",
    "unconstrained_minimizer",
    "validate_problem",
]
