"""A persistent QP solver with proxsuite as default and daqp, osqp, quadprog as alternatives.

The proxsuite workspace is created once per problem structure ``(n, n_eq, n_in)`` and then
``update``-d (keeping its preconditioner) and warm-started; it is never rebuilt per step. Before
calling any backend the solver tries the unconstrained minimizer (one Cholesky
factorization): when it already satisfies every constraint it is the optimum.

Every result is checked: a result is ``SOLVED`` only when its KKT residuals (primal, dual,
complementarity, see :mod:`taskspace.qp.kkt`) at the returned point and multipliers meet
``eps_abs + eps_rel * scale``. That is a bound on residuals, not on the distance to the
optimum, which can be ``dual residual / lambda_min(H)``; proxsuite's and OSQP's converged points are
therefore refined on their active set (``QPSolverOptions.refine``) and the active-set
backends (daqp, quadprog) solve that system directly: every ``SOLVED`` point of the default
pipeline is then the optimum to rounding (``~1e-10`` on cond(H) ~ 1e6). A backend that
stops above the tolerances (``INACCURATE``) or at its iteration limit gets one refinement:
the KKT system of the active set its point suggests, with primal-dual active-set
corrections. When a backend still cannot solve a problem, the next backend in ``fallbacks``
is tried; when the constraints truly conflict, the least-violating
solution is computed (slack variables with a large penalty) and the result names the
constraint blocks at fault.

Every solve is bounded: the problem data are checked before a backend sees them (finite, and
no entry beyond :data:`MAX_QP_MAGNITUDE`: :class:`~taskspace.errors.NotFiniteError` or
:class:`~taskspace.errors.InvalidInputError` naming the array, the rows and their block),
proxsuite runs at most ``max_iter`` outer times ``max_iter_in`` inner iterations, the
active-set refinement at most ``max_polish_iter`` corrections, the relaxation is one
well-conditioned QP, and ``time_limit`` stops the pipeline between its stages. A result
is ``SOLVED`` (or ``UNCONSTRAINED``) only with its KKT residuals within the tolerances; an
iteration limit, an infeasible problem or a failed relaxation never is (except a proxsuite
run stopped at its limit while asked for more than the certificate, ``proxsuite_eps_rel``
below ``eps_rel``, whose point meets the certificate).

Thread safety: a :class:`QPSolver` is a workspace (the warm-started proxsuite solver and the state
of the current solve) and is not locked: one solver per thread (the IK and inverse-dynamics solvers
that own one serialize their calls). :class:`QPSolverOptions` is immutable; the module functions
keep their state local to the call.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg.lapack import dgesv, dposv, dpotrf

from taskspace._validation import FloatArray
from taskspace.errors import (
    InvalidInputError,
    NotFiniteError,
    ShapeError,
    SolverError,
    UnknownNameError,
)
from taskspace.qp.kkt import (
    KKTResiduals,
    equality_kkt_residuals,
    kkt_residuals,
    stacked_kkt_residuals,
)
from taskspace.qp.problem import INF, QPProblem, RowBlock
from taskspace.qp.result import QPResult, QPStatus

logger = logging.getLogger(__name__)

# A constraint block is a culprit of a relaxed result when its largest violation exceeds this.
RELAXED_VIOLATION = 1e-6

BACKENDS = ("proxsuite", "daqp", "osqp", "quadprog")
"""Backend names accepted by :class:`QPSolver`."""


_POLISHABLE = (QPStatus.INACCURATE, QPStatus.MAX_ITERATIONS)
"""Statuses whose ``x`` is close enough to the optimum for :meth:`QPSolver._polish`."""

_max = np.maximum.reduce  # NaN-propagating, no BLAS
_min = np.minimum.reduce

MAX_QP_MAGNITUDE = 1e30
"""Largest magnitude accepted in ``H``, ``g``, ``A``, ``b`` and ``C`` of a problem given to a
backend. Robotics QPs are many orders below it (weights up to ~1e8, relaxation penalties
1e6); data beyond it come from a diverged state (e.g. a simulation that blew up), on which a
backend only burns iterations. Bounds (``l``, ``u``, ``b``, ``lb``, ``ub``) at or beyond
:data:`~taskspace.qp.problem.INF` mean "no bound"."""


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


MAX_TOLERANCE = 1e-2
"""Largest accepted KKT tolerance of :class:`QPSolverOptions` (``eps_abs``, ``eps_rel``...)."""


@dataclass(frozen=True, kw_only=True)
class QPSolverOptions:
    """Settings of :class:`QPSolver`.

    Attributes:
        backend: ``proxsuite`` (default), ``daqp``, ``osqp`` or ``quadprog``. On the
            project's own QPs (``python -m benchmarks.run qp_backends``) daqp is 3-5x faster
            than proxsuite on IK and inverse-dynamics steps (both exact on all of them), but
            fails degenerate hierarchy-level QPs that proxsuite with the cascade's settings
            solves; proxsuite stays the default for that robustness (the design's choice),
            the hierarchy cascade tries daqp first, and ``backend="daqp"`` (with proxsuite in
            ``fallbacks``) is the faster choice for well-posed Python-path IK/ID steps. The
            compiled kernels use their own methods (held to this setting's tolerances).
        eps_abs: absolute tolerance of the KKT residuals (and of the backends).
        eps_rel: relative tolerance of the KKT residuals (see :mod:`taskspace.qp.kkt`): a
            result is ``SOLVED`` only when its primal, dual and complementarity residuals are
            below ``eps_abs + eps_rel * scale``; otherwise the next backend is tried.
        max_iter: iteration limit of the backends: proxsuite's outer (proximal) iterations
            (daqp gets at least 1000 active-set iterations).
        max_iter_in: proxsuite's inner iterations per outer iteration. A proxsuite run is at
            most ``max_iter * (max_iter_in + 1)`` iterations: with the defaults about 6,000,
            0.05-0.4 s on 20-150 variables where it does not converge (converging solves of
            the project's IK and inverse-dynamics QPs take 5-100 iterations in total). The
            former 1000 x 1000 let one solve on a diverged state run for minutes.
        max_polish_iter: active-set corrections of the refinement of an inaccurate result
            (each one a least-squares KKT solve).
        refine: solve the KKT system of the active set of proxsuite's (and OSQP's) converged
            result once (one LAPACK factorization of the free variables and active rows), keep that
            point when its KKT residuals are within the tolerances. proxsuite stops at
            residuals ``~eps``, and a point with dual residual ``r`` is up to
            ``r / lambda_min(H)`` from the optimum: ``1e-3`` on a G1 IK step whose floating
            base only the ``1e-6`` damping holds (cond(H) ~ 1e6), ``1e-10`` after the
            refinement. Costs 10-15 % of a Python-path IK solve; ``False`` keeps the
            residual-only guarantee.
        time_limit: wall-time budget of one :meth:`QPSolver.solve` [s], checked between its
            stages (backend, refinement, fallback, relaxation): once spent, the remaining
            stages are skipped and the best result so far is returned (not ``SOLVED`` unless
            certified). A single backend run is bounded by its iteration limits, not
            interrupted. ``None``: no budget.
        try_unconstrained: try the unconstrained minimizer before calling the backend.
        fallbacks: backends tried, in order, when the main one fails or is inaccurate.
        relax_on_failure: compute the least-violating solution when no backend succeeds.
        relaxation_weight: penalty on squared constraint violations in the relaxed problem.
        feasibility_tolerance: tolerance of the unconstrained-shortcut feasibility test.
        proxsuite_rho: proxsuite's proximal parameter ``rho`` (its ``default_rho``, 1e-6).
            A direction of ``H`` with curvature ``mu`` far below ``rho`` moves by a factor
            ``~mu / rho`` per proximal iteration: cascade levels (curvature ``1e-9`` on the
            freedom their rows leave to lower levels) need ``rho <= ~1e-9``.
        proxsuite_eps_rel: proxsuite's own relative stopping tolerance (default ``eps_rel``).
            Its test omits complementarity: stopping it below ``eps_rel`` lets the active-set
            refinement find the right active set on degenerate problems.
        proxsuite_duality_gap: proxsuite also stops on its duality gap (closes the hole of
            its primal/dual-only test on IK problems). On degenerate problems the multipliers
            of nearly dependent active rows are huge (``1e5``) and the gap test never passes
            at the exact solution; complementarity is then certified by the KKT residuals.
        proxsuite_eps_primal_inf: proxsuite's tolerance of its primal infeasibility
            certificate (its default ``1e-4``). Rows of norm ``1e-8..1e-5`` with multipliers
            ``1e5`` pass that test on feasible problems; ``1e-12`` leaves true certificates
            (``A dy = 0`` to rounding) and drops those.
        proxsuite_warm_start: keep proxsuite's workspace between solves of the same
            structure (its preconditioner is not recomputed; the previous result is the
            initial guess). ``False``: every solve starts afresh (new preconditioner, no
            initial guess), for sequences whose coordinates change between solves: a cascade
            level's QP lives in a nullspace basis that rotates from one step to the next,
            where the stale preconditioner and warm start made proxsuite fail.
    """

    backend: str = "proxsuite"
    eps_abs: float = 1e-9
    eps_rel: float = 1e-9
    max_iter: int = 200
    max_iter_in: int = 30
    max_polish_iter: int = 20
    refine: bool = True
    time_limit: float | None = None
    try_unconstrained: bool = True
    fallbacks: tuple[str, ...] = ("daqp",)
    relax_on_failure: bool = True
    relaxation_weight: float = 1e6
    feasibility_tolerance: float = 1e-10
    proxsuite_rho: float = 1e-6
    proxsuite_eps_rel: float | None = None
    proxsuite_duality_gap: bool = True
    proxsuite_eps_primal_inf: float = 1e-4
    proxsuite_warm_start: bool = True

    def __post_init__(self) -> None:
        """Refuse iteration limits and budgets a solve could not honour (a hang or nothing)."""
        for name in ("max_iter", "max_iter_in", "max_polish_iter"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise InvalidInputError(f"{name} must be an integer, got {value!r}")
            if not 1 <= value <= 10**6:
                raise InvalidInputError(f"{name} must be in [1, 1e6], got {value}")
        if self.proxsuite_eps_rel is not None and not (
            isinstance(self.proxsuite_eps_rel, int | float)
            and np.isfinite(self.proxsuite_eps_rel)
            and self.proxsuite_eps_rel >= 0
        ):
            raise InvalidInputError(
                f"proxsuite_eps_rel must be finite and >= 0 or None, got {self.proxsuite_eps_rel!r}"
            )
        for name in ("proxsuite_rho", "proxsuite_eps_primal_inf"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
                raise InvalidInputError(f"{name} must be finite and > 0, got {value!r}")
        for name in ("eps_abs", "eps_rel", "relaxation_weight", "feasibility_tolerance"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and np.isfinite(value) and value >= 0):
                raise InvalidInputError(f"{name} must be finite and >= 0, got {value!r}")
        # ``SOLVED`` certifies the KKT conditions to these tolerances: past MAX_TOLERANCE the
        # certificate says nothing (1e300 passed every point)
        for name in ("eps_abs", "eps_rel", "feasibility_tolerance", "proxsuite_eps_rel"):
            value = getattr(self, name)
            if value is not None and value > MAX_TOLERANCE:
                raise InvalidInputError(
                    f"{name} must be in [0, {MAX_TOLERANCE:g}] (a KKT residual tolerance; "
                    f"SOLVED would certify nothing above it), got {value!r}"
                )
        if self.proxsuite_eps_primal_inf > 1.0:
            raise InvalidInputError(
                "proxsuite_eps_primal_inf must be in (0, 1] (proxsuite's infeasibility "
                f"certificate tolerance), got {self.proxsuite_eps_primal_inf!r}"
            )
        if self.relaxation_weight <= 0:
            raise InvalidInputError(
                f"relaxation_weight must be > 0, got {self.relaxation_weight!r}"
            )
        if self.time_limit is not None and not (
            isinstance(self.time_limit, int | float) and self.time_limit > 0
        ):
            # inf is accepted (no budget); NaN, 0 and negatives are refused
            raise InvalidInputError(f"time_limit must be > 0 or None, got {self.time_limit!r}")


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
        self._infeasible = False  # a backend of the current solve proved infeasibility

    # ------------------------------------------------------------------ public
    def solve(self, problem: QPProblem) -> QPResult:
        """Solve ``problem`` (see the module docstring for the strategy).

        Raises:
            InvalidInputError: an array that is not a real numpy array, or bad data (see
                :func:`check_problem_data`).
            ShapeError: arrays that do not fit together.
        """
        t0 = time.perf_counter()
        check_structure(problem)
        if not problem.n:
            return _empty_result(problem)
        opts = self.options
        if opts.try_unconstrained:
            solved = self._kkt.solve_with_multipliers(problem)
            if solved is not None:
                x, y = solved
                violation = _max_violation(problem, x)
                if violation <= opts.feasibility_tolerance:  # False for NaN
                    kkt = equality_kkt_residuals(problem, x, y, violation)
                    if kkt.within(opts.eps_abs, opts.eps_rel):
                        z, z_box = self._zeros(problem)
                        return QPResult(
                            True,
                            QPStatus.UNCONSTRAINED,
                            x,
                            _objective(problem, x),
                            0,
                            time.perf_counter() - t0,
                            "cholesky",
                            kkt=kkt,
                            y=y,
                            z=z,
                            z_box=z_box,
                        )
        check_problem_data(problem)
        deadline = math.inf if opts.time_limit is None else t0 + opts.time_limit
        last: QPResult | None = None
        relaxed: QPResult | None = None
        self._infeasible = False
        for backend in (opts.backend, *[b for b in opts.fallbacks if b != opts.backend]):
            if last is not None and time.perf_counter() > deadline:
                break
            try:
                result = self._solve_with(backend, problem)
            except Exception as exc:  # a backend raising is a failure of that backend
                logger.debug("QP backend %s raised %r", backend, exc)
                result = QPResult.failed(problem.n, backend, 0.0)
            # after a certificate of infeasibility (daqp, proxsuite) no refinement can succeed
            if (
                not result.success
                and result.status in _POLISHABLE
                and not self._infeasible
                and time.perf_counter() <= deadline
            ):
                result = self._polish(problem, result) or result
            if result.success:
                result.solve_time = time.perf_counter() - t0
                return result
            last = result
            if self._infeasible and opts.relax_on_failure and relaxed is None:
                # A backend proved infeasibility: relax now rather than run the fallbacks
                # into their iteration limits (simple_humanoid's ID-QP: 0.13 s of proxsuite).
                # The relaxation checks the certificate: if its point violates nothing, the
                # constraints were compatible and the fallbacks still get their turn.
                relaxed = self.solve_relaxed(problem)
                if relaxed.status in (QPStatus.RELAXED, QPStatus.SOLVED):
                    relaxed.solve_time = time.perf_counter() - t0
                    return relaxed
        if relaxed is None and opts.relax_on_failure and time.perf_counter() <= deadline:
            relaxed = self.solve_relaxed(problem)
        out = relaxed if relaxed is not None else last
        assert out is not None
        out.solve_time = time.perf_counter() - t0
        return out

    def _polish(self, p: QPProblem, start: QPResult) -> QPResult | None:
        """Refine an inaccurate result by solving the KKT system of its active set.

        The active set is guessed from ``start`` (rows at their bound or with a multiplier
        of the bound's sign), the KKT system ``[H G_a^T; G_a 0] [x; w] = [-g; h_a]`` is solved in
        the least-squares sense (degenerate active sets are rank-deficient), then rows whose
        multiplier has the wrong sign are released and violated rows added, a few times over
        (a primal-dual active-set iteration), at most ``max_polish_iter`` times. Returns a
        ``SOLVED`` result when the KKT residuals meet the tolerances, else ``None``.
        """
        if not np.all(np.isfinite(start.x)):
            return None
        t0 = time.perf_counter()
        n = p.n
        # all bounds as rows of one system: G x {<=, >=, =} h
        G = np.vstack([p.C, np.eye(n)])
        lo = np.concatenate([p.l, p.lb])
        hi = np.concatenate([p.u, p.ub])
        z0 = np.concatenate(
            [
                start.z if start.z.size == p.n_in else np.zeros(p.n_in),
                start.z_box if start.z_box.size == n else np.zeros(n),
            ]
        )
        Gx = G.dot(start.x)
        scale = max(1.0, float(np.abs(Gx).max(initial=0.0)))
        tol = 1e-6 * scale
        zscale = max(1e-12, 1e-9 * float(np.abs(z0).max(initial=0.0)))
        upper = (hi < INF) & ((hi - Gx <= tol) | (z0 > zscale))
        lower = (lo > -INF) & ((Gx - lo <= tol) | (z0 < -zscale)) & ~upper
        for _ in range(min(2 * (G.shape[0] + 1), self.options.max_polish_iter)):
            iu, il = np.flatnonzero(upper), np.flatnonzero(lower)
            rows = np.vstack([p.A, G[iu], G[il]])
            rhs_c = np.concatenate([p.b, hi[iu], lo[il]])
            m = rows.shape[0]
            K = np.zeros((n + m, n + m))
            K[:n, :n] = p.H
            K[:n, n:] = rows.T
            K[n:, :n] = rows
            sol = np.linalg.lstsq(K, np.concatenate([-p.g, rhs_c]), rcond=1e-13)[0]
            x, w = sol[:n], sol[n:]
            zz = np.zeros(G.shape[0])
            zz[iu] += w[p.n_eq : p.n_eq + iu.size]
            zz[il] += w[p.n_eq + iu.size :]
            Gx = G.dot(x)
            wrong = (upper & (zz < 0)) | (lower & (zz > 0))
            violated_u = ~upper & (Gx > hi + tol * 1e-3)
            violated_l = ~lower & (Gx < lo - tol * 1e-3)
            if not (wrong.any() or violated_u.any() or violated_l.any()):
                break
            if wrong.any():  # release the most wrong multiplier
                k = int(np.argmax(np.abs(np.where(wrong, zz, 0.0))))
                upper[k] = lower[k] = False
            else:  # add the most violated row
                viol = np.maximum(
                    np.where(violated_u, Gx - hi, 0), np.where(violated_l, lo - Gx, 0)
                )
                k = int(np.argmax(viol))
                upper[k], lower[k] = bool(violated_u[k]), bool(violated_l[k])
        out = self._finish(
            start.backend + "+polish",
            p,
            True,
            x,
            w[: p.n_eq].copy(),
            zz[: p.n_in].copy(),
            zz[p.n_in :].copy(),
            start.iterations,
            time.perf_counter() - t0,
        )
        return out if out.success else None

    def _zeros(self, p: QPProblem) -> tuple[FloatArray, FloatArray]:
        """Zero inequality and bound multipliers (fresh arrays: results keep them)."""
        return np.zeros(p.n_in), np.zeros(p.n)

    def _finish(
        self,
        backend: str,
        p: QPProblem,
        converged: bool,
        x: FloatArray,
        y: FloatArray,
        z: FloatArray,
        z_box: FloatArray,
        iterations: int,
        elapsed: float,
        status: QPStatus = QPStatus.FAILED,
    ) -> QPResult:
        """Result of a backend run, ``SOLVED`` only when the KKT residuals meet the tolerances.

        Args:
            converged: the backend reported success; otherwise ``status`` is reported.
        """
        kkt = kkt_residuals(p, x, y, z, z_box)
        if converged:
            ok = kkt.within(self.options.eps_abs, self.options.eps_rel)
            status = QPStatus.SOLVED if ok else QPStatus.INACCURATE
            if not ok:
                logger.debug("QP backend %s inaccurate: %s", backend, kkt)
        return QPResult(
            status is QPStatus.SOLVED,
            status,
            x,
            _objective(p, x),
            iterations,
            elapsed,
            backend,
            kkt=kkt,
            y=y,
            z=z,
            z_box=z_box,
        )

    def solve_relaxed(self, problem: QPProblem) -> QPResult:
        """Least-violating solution: every constraint row gets a slack with a large penalty.

        ``min f(x) + w/2 |s|^2`` s.t. ``A x - s_eq = b``, ``l - s_in <= C x <= u + s_in``,
        ``lb - s_box <= x <= ub + s_box``, ``s >= 0`` for inequality slacks, solved once as
        one QP in ``(x, t)`` with the slacks scaled, ``s = t / sqrt(w)``: its Hessian is
        ``diag(H, I)``, as well conditioned as ``H`` (with ``w |s|^2`` the penalty made it
        ``1e14``-conditioned on inverse-dynamics QPs, daqp's Cholesky failed and proxsuite
        ran into its iteration limit: seconds per solve). The result is ``RELAXED`` only when
        that QP is solved (its own KKT residuals within the tolerances) and some block is
        violated by more than ``1e-6``; it is ``FAILED`` when the relaxed QP is not solved.
        When the slacks vanish (the constraints are compatible after all) and the KKT
        residuals of the original problem meet the tolerances, the result is ``SOLVED``;
        when they vanish but the residuals do not (the penalty leaves violations of order
        ``|z| / w``), it is ``INACCURATE``.

        Raises:
            InvalidInputError: ``problem``'s data, as :meth:`solve` refuses them.
        """
        check_problem_data(problem)  # also H convex: the relaxation is marked convex
        relaxed, n = _relaxed_problem(problem, self.options.relaxation_weight), problem.n
        solver = QPSolver(
            QPSolverOptions(
                backend="daqp" if "daqp" in available_backends() else self.options.backend,
                fallbacks=("proxsuite",),
                relax_on_failure=False,
                try_unconstrained=False,
                eps_abs=self.options.eps_abs,
                eps_rel=self.options.eps_rel,
                max_iter=self.options.max_iter,
                max_iter_in=self.options.max_iter_in,
                max_polish_iter=self.options.max_polish_iter,
            )
        )
        inner = solver.solve(relaxed)
        x = inner.x[:n]
        violations = problem.violations(x)
        culprits = [name for name, v in violations.items() if v > RELAXED_VIOLATION]
        y, z, z_box = _original_multipliers(problem, inner)
        kkt = kkt_residuals(problem, x, y, z, z_box)
        if not inner.success or not np.all(np.isfinite(x)):
            status = QPStatus.FAILED
        elif culprits:
            status = QPStatus.RELAXED
        elif kkt.within(self.options.eps_abs, self.options.eps_rel):
            status = QPStatus.SOLVED  # the constraints were compatible: a genuine solution
            culprits = []
        else:
            status = QPStatus.INACCURATE
        return QPResult(
            status is QPStatus.SOLVED,
            status,
            x,
            _objective(problem, x),
            inner.iterations,
            inner.solve_time,
            inner.backend,
            culprits,
            violations,
            kkt=kkt,
            y=y,
            z=z,
            z_box=z_box,
            # the constraints as they are now (a caller's buffers change at its next step)
            conflict_problem=problem.copy(objective=False) if status is QPStatus.RELAXED else None,
        )

    # ------------------------------------------------------------------ backends
    def _solve_with(self, backend: str, problem: QPProblem) -> QPResult:
        if backend == "proxsuite":
            return self._solve_proxsuite(problem)
        if backend == "daqp":
            return self._solve_daqp(problem)
        return self._solve_qpsolvers(backend, problem)

    def _proxsuite_settings(self, qp: Any) -> None:
        from proxsuite import proxqp

        opts = self.options
        settings = qp.settings
        eps_rel = opts.eps_rel if opts.proxsuite_eps_rel is None else opts.proxsuite_eps_rel
        settings.eps_abs = opts.eps_abs
        settings.eps_rel = eps_rel
        # proxsuite's default test checks primal and dual residuals only: it then stops at
        # points whose multipliers belong to another active set (steps 1e-5..5e-2 from the
        # optimum on IK problems). The duality-gap test closes that hole.
        settings.check_duality_gap = opts.proxsuite_duality_gap
        settings.eps_duality_gap_abs = opts.eps_abs
        settings.eps_duality_gap_rel = eps_rel
        settings.default_rho = opts.proxsuite_rho
        settings.eps_primal_inf = opts.proxsuite_eps_primal_inf
        settings.max_iter = opts.max_iter
        settings.max_iter_in = opts.max_iter_in
        settings.verbose = False
        settings.initial_guess = proxqp.InitialGuess.NO_INITIAL_GUESS

    def _solve_proxsuite(self, p: QPProblem) -> QPResult:
        from proxsuite import proxqp

        t0 = time.perf_counter()
        structure = p.structure()
        A = p.A if p.n_eq else None
        b = p.b if p.n_eq else None
        C = p.C if p.n_in else None
        l = p.l if p.n_in else None
        u = p.u if p.n_in else None
        if (
            self._proxsuite is None
            or self._proxsuite_structure != structure
            or not self.options.proxsuite_warm_start
        ):
            qp = proxqp.dense.QP(p.n, p.n_eq, p.n_in, True)
            self._proxsuite_settings(qp)
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
        results = qp.results
        info = results.info
        status = info.status
        self._infeasible |= status == proxqp.PROXQP_PRIMAL_INFEASIBLE
        x = np.array(results.x)
        z_all = np.array(results.z)
        converged = status == proxqp.PROXQP_SOLVED
        eps_inner = self.options.proxsuite_eps_rel
        if (
            status == proxqp.PROXQP_MAX_ITER_REACHED
            and eps_inner is not None
            and eps_inner < self.options.eps_rel
        ):
            # proxsuite was asked for more than the certificate (to help the refinement): a
            # point it stops at by its iteration limit may still meet the certificate; it is
            # SOLVED only if its (refined) KKT residuals are within the tolerances
            converged = True
        if converged and self.options.refine:
            # proxsuite stops at KKT residuals ~eps; on an ill-conditioned H (a G1 IK step
            # whose floating base only the 1e-6 damping holds) that is a step 1e-3 from the
            # optimum (residual / lambda_min(H)). One direct solve of the KKT system of its
            # active set gives the optimum to rounding; kept when it is certified.
            refined = _refine_on_active_set(p, x, z_all[: p.n_in], z_all[p.n_in :])
            if refined is not None:
                out = self._finish(
                    "proxsuite", p, True, *refined, int(info.iter), time.perf_counter() - t0
                )
                if out.success:
                    return out
        if converged and eps_inner is not None and eps_inner < self.options.eps_rel:
            # asked for more than the certificate: a certified point whose active set did not
            # refine (degenerate) is still up to ``dual residual / lambda_min(H)`` from the
            # optimum (G1 cascade: a level's residual 1.7e-4 worse than daqp's exact one,
            # certified at 1e-6): the primal-dual active-set polish gets the exact point
            out = self._finish(
                "proxsuite",
                p,
                True,
                x,
                np.array(results.y),
                z_all[: p.n_in],
                z_all[p.n_in :],
                int(info.iter),
                time.perf_counter() - t0,
            )
            if out.success:
                return (self._polish(p, out) if self.options.refine else None) or out
            converged = converged and status != proxqp.PROXQP_MAX_ITER_REACHED
        out = self._finish(
            "proxsuite",
            p,
            converged,
            x,
            np.array(results.y),
            z_all[: p.n_in],
            z_all[p.n_in :],
            int(info.iter),
            time.perf_counter() - t0,
            QPStatus.MAX_ITERATIONS
            if status == proxqp.PROXQP_MAX_ITER_REACHED
            else QPStatus.FAILED,
        )
        if not out.success:
            # the preconditioner or the warm start may be stale: rebuild the workspace next time
            self._proxsuite = None
        return out

    def _solve_daqp(self, p: QPProblem) -> QPResult:
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
        args = (
            np.ascontiguousarray(p.H),
            np.ascontiguousarray(p.g),
            np.ascontiguousarray(A),
            bu,
            bl,
            np.concatenate(sense),
        )
        iter_limit = max(self.options.max_iter, 1000)
        x, _, exitflag, info = daqp.solve(*args, iter_limit=iter_limit, eps_prox=0)
        if exitflag in (-1, -5):
            # "infeasible" or "Cholesky failed": with an ill-conditioned H (eigenvalues
            # 1e-8..1) daqp reports feasible problems infeasible. Its proximal-point mode
            # (H + eps I, iterated to the exact solution) settles it: same answer on
            # well-posed problems, a confirmed certificate (0.3 ms on a humanoid's
            # inverse-dynamics QP) on truly infeasible ones.
            x, _, exitflag, info = daqp.solve(*args, iter_limit=iter_limit, eps_prox=1e-4)
        x = np.asarray(x)
        elapsed = time.perf_counter() - t0
        iterations = int(info.get("iterations", 0)) if isinstance(info, dict) else 0
        lam = info.get("lam") if isinstance(info, dict) else None
        if lam is None or len(lam) != p.n + p.n_eq + p.n_in:
            lam = np.zeros(p.n + p.n_eq + p.n_in)
        lam = np.asarray(lam, dtype=float)
        n, m = p.n, p.n_eq
        kkt = stacked_kkt_residuals(p.H, p.g, x, A, bl, bu, lam)
        converged = exitflag >= 1
        self._infeasible |= exitflag == -1  # daqp's certificate of primal infeasibility
        if converged and kkt.within(self.options.eps_abs, self.options.eps_rel):
            status = QPStatus.SOLVED
        elif converged:
            status = QPStatus.INACCURATE
        else:
            status = QPStatus.MAX_ITERATIONS if exitflag == -4 else QPStatus.FAILED
        return QPResult(
            status is QPStatus.SOLVED,
            status,
            x,
            _objective(p, x),
            iterations,
            elapsed,
            "daqp",
            kkt=kkt,
            y=lam[n : n + m],
            z=lam[n + m :],
            z_box=lam[:n],
        )

    def _solve_qpsolvers(self, backend: str, p: QPProblem) -> QPResult:
        import qpsolvers

        t0 = time.perf_counter()
        options = self.options
        G = h = None
        finite_u = p.u < INF
        finite_l = p.l > -INF
        if p.n_in:
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
        if not solution.found or solution.x is None:
            return QPResult.failed(p.n, backend, elapsed)
        x = np.asarray(solution.x, dtype=float)
        y = np.asarray(solution.y, dtype=float) if p.n_eq and solution.y is not None else None
        z = np.zeros(p.n_in)
        if p.n_in and solution.z is not None:
            k = int(finite_u.sum())
            z[finite_u] += solution.z[:k]
            z[finite_l] -= solution.z[k:]
        z_box = (
            np.asarray(solution.z_box, dtype=float) if solution.z_box is not None else np.zeros(p.n)
        )
        y = y if y is not None else np.zeros(p.n_eq)
        if backend == "osqp" and options.refine:
            # OSQP (ADMM) stops at residuals ~eps: on an ill-conditioned H (a G1 IK step whose
            # floating base only the 1e-6 damping holds) that point passed the certificate
            # 0.16 rad/s from the optimum (residual / lambda_min(H)). As for proxsuite: one
            # direct solve on its active set, kept when certified, else the active-set polish.
            refined = _refine_on_active_set(p, x, z, z_box)
            if refined is not None:
                out = self._finish(backend, p, True, *refined, 0, time.perf_counter() - t0)
                if out.success:
                    return out
            out = self._finish(backend, p, True, x, y, z, z_box, 0, elapsed)
            if out.success:
                return self._polish(p, out) or out
            return out
        return self._finish(backend, p, True, x, y, z, z_box, 0, elapsed)


# ---------------------------------------------------------------------- helpers
def _original_multipliers(
    p: QPProblem, inner: QPResult
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Multipliers of ``p`` from those of its relaxation (see :func:`_relaxed_problem`).

    The slack scaling changes only the slack columns, so the rows' multipliers are ``p``'s.
    """
    m_eq, m_in, n = p.n_eq, p.n_in, p.n
    y = inner.y[:m_eq] if inner.y.size == m_eq else np.zeros(m_eq)
    box_rows = np.flatnonzero((p.lb > -INF) | (p.ub < INF))
    k = len(box_rows)
    z = np.zeros(m_in)
    z_box = np.zeros(n)
    if inner.z.size == 2 * (m_in + k):
        z = inner.z[:m_in] + inner.z[m_in : 2 * m_in]
        r0 = 2 * m_in
        z_box[box_rows] = inner.z[r0 : r0 + k] + inner.z[r0 + k :]
    return y, z, z_box


def _refine_on_active_set(
    p: QPProblem, x: FloatArray, z: FloatArray, z_box: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None:
    """The exact minimizer on the active set of an approximate solution, with multipliers.

    Active: rows and bounds within ``1e-6 max(1, |x|)`` of their bound with a multiplier of
    the bound's sign. Bounds at their value are fixed (the KKT system is reduced to the free
    variables); the equality and active inequality rows enter ``[H_FF R_F'; R_F 0]``, solved
    by LAPACK (Cholesky when there are no rows); the bound multipliers follow from
    stationarity. ``None`` when that system is singular. The caller certifies the result by
    its KKT residuals (a wrong active set shows there).
    """
    n = p.n
    tol = 1e-6 * max(1.0, float(_max(np.abs(x)))) if n else 0.0
    upper = (z_box > 0.0) & (p.ub - x <= tol)
    lower = (z_box < 0.0) & (x - p.lb <= tol)
    lower &= ~upper
    fixed = upper | lower
    any_fixed = bool(fixed.any())
    free = ~fixed
    H, g = p.H, p.g
    if any_fixed:
        x_fixed = np.where(upper, p.ub, p.lb)[fixed]
        H_free = H[free][:, free]
        rhs_x = H[free][:, fixed].dot(x_fixed)
        rhs_x += g[free]
        np.negative(rhs_x, out=rhs_x)
    else:
        x_fixed = np.zeros(0)
        H_free = H
        rhs_x = -g
    if p.n_in:
        Cx = p.C.dot(x)
        row_up = (z > 0.0) & (p.u - Cx <= tol)
        row_lo = (z < 0.0) & (Cx - p.l <= tol)
        row_lo &= ~row_up
        active = row_up | row_lo
        R = np.vstack((p.A, p.C[active])) if active.any() else p.A
        r = np.concatenate((p.b, np.where(row_up, p.u, p.l)[active]))
    else:
        active = np.zeros(0, dtype=bool)
        R, r = p.A, p.b
    m = R.shape[0]
    n_free = H_free.shape[0]
    if n_free + m == 0:  # every variable at a bound
        sol, info = np.zeros(0), 0
    elif m == 0:
        _, sol, info = dposv(H_free, rhs_x)
    else:
        R_free = R[:, free] if any_fixed else R
        K = np.zeros((n_free + m, n_free + m), order="F")
        K[:n_free, :n_free] = H_free
        K[:n_free, n_free:] = R_free.T
        K[n_free:, :n_free] = R_free
        rhs = np.concatenate((rhs_x, r))
        if any_fixed:
            rhs[n_free:] -= R[:, fixed].dot(x_fixed)
        _, _, sol, info = dgesv(K, rhs, overwrite_a=1, overwrite_b=1)
    if info != 0:
        return None
    if any_fixed:
        x_new = np.empty(n)
        x_new[free] = sol[:n_free]
        x_new[fixed] = x_fixed
    else:
        x_new = np.array(sol[:n_free])
    w = sol[n_free:]
    z_new = np.zeros(p.n_in)
    if m:
        z_new[active] = w[p.n_eq :]
    z_box_new = np.zeros(n)
    if any_fixed:
        stationarity = H[fixed].dot(x_new)
        stationarity += g[fixed]
        if m:
            stationarity += R[:, fixed].T.dot(w)
        z_box_new[fixed] = -stationarity
    return x_new, np.array(w[: p.n_eq]), z_new, z_box_new


def _max_violation(p: QPProblem, x: FloatArray) -> float:
    """:meth:`QPProblem.max_violation`, but NaN when a constraint datum is NaN.

    (``max(0.0, nan)`` is ``0.0`` in Python: a NaN row would pass the shortcut's test.)
    """
    if p.stacked is not None:
        G, lo, hi = p.stacked
        if not G.shape[0]:
            return 0.0
        Gx = G.dot(x)
        parts = [float(_max(lo - Gx)), float(_max(Gx - hi))]
    else:
        parts = [float(_max(p.lb - x)), float(_max(x - p.ub))] if p.n else []
        if p.n_in:
            Cx = p.C.dot(x)
            parts += [float(_max(p.l - Cx)), float(_max(Cx - p.u))]
        if p.n_eq:
            parts.append(float(_max(np.abs(p.A.dot(x) - p.b))))
    worst = 0.0
    for v in parts:
        if not v <= worst:  # larger, or NaN
            if v != v:
                return math.nan
            worst = v
    return worst


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
        solved = self.solve_with_multipliers(p)
        return None if solved is None else solved[0]

    def solve_with_multipliers(self, p: QPProblem) -> tuple[FloatArray, FloatArray] | None:
        """The equality-constrained minimizer and its multipliers, or ``None`` if singular.

        Returns ``(x, y)`` with ``H x + g + A^T y = 0`` and ``A x = b``.
        """
        try:
            if not p.A.shape[0]:
                # Cholesky solve through LAPACK directly (np.linalg.solve costs 4x more on 7x7);
                # it succeeds only for a positive definite H (also the convexity check)
                if not p.n:
                    return np.zeros(0), np.zeros(0)
                _, x, info = dposv(p.H, -p.g)
                return (x, np.zeros(0)) if info == 0 else None
            if not p.convex:  # the KKT system's solution is a minimizer only for a convex QP
                check_convex(p.H)
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
            return (np.array(sol[:n]), np.array(sol[n:])) if info == 0 else None
        except (np.linalg.LinAlgError, ValueError):
            return None


def _relaxed_problem(p: QPProblem, weight: float) -> QPProblem:
    """The relaxation of ``p`` in ``(x, t)``, slacks ``s = t / sqrt(weight)``.

    See :meth:`QPSolver.solve_relaxed`: ``min f(x) + |t|^2 / 2`` s.t. ``A x - c t_eq = b``,
    ``C x + c t_in >= l``, ``C x - c t_in <= u``, the box rows likewise, ``t_in, t_box >= 0``
    with ``c = 1 / sqrt(weight)``. Only the finite box bounds get a slack.
    """
    n, m_eq, m_in = p.n, p.n_eq, p.n_in
    c = 1.0 / math.sqrt(weight)
    box_rows = np.flatnonzero((p.lb > -INF) | (p.ub < INF))
    k = len(box_rows)
    ns = m_eq + m_in + k
    N = n + ns
    H = np.zeros((N, N))
    H[:n, :n] = p.H
    H[n:, n:] = np.eye(ns)
    g = np.concatenate([p.g, np.zeros(ns)])
    A = np.zeros((m_eq, N))
    A[:, :n] = p.A
    A[:, n : n + m_eq] = -c * np.eye(m_eq)
    # inequality rows: C x + c t >= l and C x - c t <= u, box rows likewise
    s_in = slice(n + m_eq, n + m_eq + m_in)
    s_box = slice(n + m_eq + m_in, N)
    C = np.zeros((2 * (m_in + k), N))
    l = np.full(2 * (m_in + k), -INF)
    u = np.full(2 * (m_in + k), INF)
    C[:m_in, :n] = p.C
    C[:m_in, s_in] = c * np.eye(m_in)
    l[:m_in] = p.l
    C[m_in : 2 * m_in, :n] = p.C
    C[m_in : 2 * m_in, s_in] = -c * np.eye(m_in)
    u[m_in : 2 * m_in] = p.u
    r0 = 2 * m_in
    E = np.eye(n)[box_rows]
    C[r0 : r0 + k, :n] = E
    C[r0 : r0 + k, s_box] = c * np.eye(k)
    l[r0 : r0 + k] = p.lb[box_rows]
    C[r0 + k :, :n] = E
    C[r0 + k :, s_box] = -c * np.eye(k)
    u[r0 + k :] = p.ub[box_rows]
    lb = np.concatenate([np.full(n + m_eq, -INF), np.zeros(m_in + k)])
    ub = np.full(N, INF)
    # diag(H, I): convex (p's H was checked, or is convex by construction, before relaxing)
    return QPProblem(H, g, A, np.asarray(p.b, dtype=float), C, l, u, lb, ub, convex=True)


_DOT_SIZE = 10_000
"""Arrays up to this size are checked by one dot product (OpenBLAS threads ddot above 10,000)."""


def _block_of(blocks: list[RowBlock], row: int) -> str:
    """Name of the block holding ``row`` (empty when unnamed)."""
    for blk in blocks:
        if blk.start <= row < blk.stop:
            return blk.name
    return ""


def _empty_result(p: QPProblem) -> QPResult:
    """The solution of a QP without variables: ``x`` empty, its rows ``l <= 0 <= u``, ``0 = b``.

    ``UNCONSTRAINED`` when the rows hold, else ``RELAXED`` naming the blocks they violate.
    """
    check_problem_data(p)
    x = np.zeros(0)
    violations = p.violations(x)
    culprits = [name for name, v in violations.items() if v > RELAXED_VIOLATION]
    worst = max(violations.values(), default=0.0)
    kkt = KKTResiduals(worst, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    status = QPStatus.RELAXED if culprits else QPStatus.UNCONSTRAINED
    return QPResult(
        not culprits,
        status,
        x,
        0.0,
        backend="empty",
        culprits=culprits,
        violations=violations,
        kkt=kkt,
        y=np.zeros(p.n_eq),
        z=np.zeros(p.n_in),
        z_box=x,
    )


# numpy dtype kinds a QP's arrays may have (float, int, unsigned); not bool: a boolean array
# is a mask passed by mistake, not numbers (as :func:`taskspace._validation.as_float_array`)
_REAL = frozenset("fiu")
_QP_ARRAYS = ("H", "g", "A", "b", "C", "l", "u", "lb", "ub")
_F64 = np.dtype(np.float64)


def check_structure(p: QPProblem) -> None:
    """Refuse arrays that are not real numpy arrays or do not fit together.

    ``g`` sets ``n``; ``H`` is ``(n, n)``, ``A`` ``(len(b), n)``, ``C`` ``(len(l), n)``, ``u``
    like ``l``, ``lb`` and ``ub`` ``(n,)``, the vectors 1-D. Float, signed and unsigned
    integer dtypes are accepted; boolean, complex and object arrays are refused (a boolean
    ``H`` or ``C`` was solved as the 0/1 matrix, a boolean bound met a bare ``TypeError``).
    The dtypes are looked at only when some array is not float64 (the builders' arrays are).
    A list, a 2-D ``g`` or a ``C`` of the wrong width otherwise reached NumPy or LAPACK (bare
    ``TypeError``, ``ValueError`` or an f2py error) or broadcast silently.

    Raises:
        InvalidInputError: an array that is not a numpy array of real numbers (or is boolean).
        ShapeError: the shapes do not fit together.
    """
    try:
        g, l, H, A, b, C, u, lb, ub = p.g, p.l, p.H, p.A, p.b, p.C, p.u, p.lb, p.ub
        n = g.shape[0]
        m = l.shape[0]
        ok = (
            g.ndim == 1
            and H.shape == (n, n)
            and b.ndim == 1
            and A.shape == (b.shape[0], n)
            and l.ndim == 1
            and C.shape == (m, n)
            and u.shape == (m,)
            and lb.shape == (n,)
            and ub.shape == (n,)
        )
        if ok and not (  # (written out, not a generator over the names: every solve runs this)
            H.dtype is _F64
            and g.dtype is _F64
            and A.dtype is _F64
            and b.dtype is _F64
            and C.dtype is _F64
            and l.dtype is _F64
            and u.dtype is _F64
            and lb.dtype is _F64
            and ub.dtype is _F64
        ):
            ok = all(getattr(p, name).dtype.kind in _REAL for name in _QP_ARRAYS)
    except (AttributeError, IndexError):  # not an array, or a 0-d g
        ok = False
    if not ok:
        _refuse_structure(p)


def _refuse_structure(p: QPProblem) -> None:
    """Raise the error of :func:`check_structure`, naming the array."""
    for name in _QP_ARRAYS:
        arr = getattr(p, name)
        if not isinstance(arr, np.ndarray):
            raise InvalidInputError(
                f"QP {name} must be a numpy array, got {type(arr).__name__} "
                f"(use np.asarray({name}, dtype=float))"
            )
        if arr.dtype.kind == "b":
            raise InvalidInputError(
                f"QP {name} must hold real numbers, got a boolean array (dtype bool): a "
                f"mask is not numbers; if 0/1 is meant, use np.asarray({name}, dtype=float)"
            )
        if arr.dtype.kind not in _REAL:
            raise InvalidInputError(
                f"QP {name} must hold real numbers, got dtype {arr.dtype} "
                f"(use np.asarray({name}, dtype=float))"
            )
    for name in ("g", "b", "l", "u", "lb", "ub"):
        arr = getattr(p, name)
        if arr.ndim != 1:
            raise ShapeError(f"QP {name}", (-1,), arr.shape)
    p.check()


def check_problem_data(problem: QPProblem) -> None:
    """Refuse data no backend can solve in bounded time (called before every backend run).

    ``H``, ``g``, ``A``, ``b`` and ``C`` must be finite with entries at most
    :data:`MAX_QP_MAGNITUDE`; the bounds ``l``, ``u``, ``lb``, ``ub`` must not be NaN (they may
    be infinite). One dot product per array on the normal path (a NaN or an overflow shows in
    the sum of squares); the offending entries are located only when one fails.

    Raises:
        NotFiniteError: NaN or infinite data; ``name`` says the array, the rows and their
            block (e.g. ``"QP C rows [3] ('torque limits')"``), ``indices`` the rows.
        InvalidInputError: an entry beyond :data:`MAX_QP_MAGNITUDE`, with the same details.
    """
    p = problem
    check_structure(p)
    if p.stacked is not None:  # A and C are rows of G, b, l, u and the box within lo, hi
        G, lo, hi = p.stacked
        data: tuple[FloatArray, ...] = (p.H, p.g, G, p.b)
        bounds: tuple[FloatArray, ...] = (lo, hi)
    else:
        data = (p.H, p.g, p.A, p.b, p.C)
        bounds = (p.l, p.u, p.lb, p.ub)
    # (the sums of squares overflow, to inf, for entries beyond ~1.3e154: refused data, or
    # bounds of 1e200 that mean "no bound"; NumPy's "overflow encountered in dot" warning
    # is not for the user to see)
    with np.errstate(over="ignore"):
        ok = _magnitudes_ok(data) and _bounds_ok(bounds)
    if not ok:
        _refuse(p)
    lower, upper = bounds[0::2], bounds[1::2]  # (l, lb) or (lo,), (u, ub) or (hi,)
    for name, arr in zip(("l", "lb"), lower):
        if arr.size and not _max(arr) < INF:
            rows = np.flatnonzero(arr >= INF)[:20].tolist()
            raise InvalidInputError(
                f"QP {name if p.stacked is None else 'lower bound'} entries {rows} are +inf: a "
                "lower bound of +inf can never hold (the QP is infeasible); use -inf for no bound"
            )
    for name, arr in zip(("u", "ub"), upper):
        if arr.size and not -_max(-arr) > -INF:
            rows = np.flatnonzero(arr <= -INF)[:20].tolist()
            raise InvalidInputError(
                f"QP {name if p.stacked is None else 'upper bound'} entries {rows} are -inf: an "
                "upper bound of -inf can never hold (the QP is infeasible); use +inf for no bound"
            )
    if not p.convex:
        check_convex(p.H)


CONVEXITY_TOLERANCE = 1e-9
"""Relative tolerance of :func:`check_convex` (of the Hessian's largest diagonal entry)."""


def check_convex(H: FloatArray) -> None:
    """Refuse a Hessian that is not symmetric positive semi-definite (the QP is not convex).

    Every backend solves convex QPs only: on an indefinite ``H`` they return a point where the
    first-order (KKT) conditions hold, a saddle or a maximum, e.g. ``x = 0`` for ``H = -I`` in
    a box, whose minimizers are the box's corners. With ``s`` the largest diagonal entry of
    ``H`` (its largest entry in absolute value, for a PSD matrix on the diagonal):
    ``|H - H^T| <= tol s`` entrywise and ``H + tol s I`` has a Cholesky factor
    (``tol`` = :data:`CONVEXITY_TOLERANCE`; eigenvalues down to ``-tol s``, rounding of a
    built ``J^T W J``, pass). One Cholesky factorization.

    Raises:
        InvalidInputError: ``H`` not symmetric, or with a negative eigenvalue beyond the
            tolerance (the message gives the smallest eigenvalue).
    """
    n = H.shape[0]
    if n == 0:
        return
    scale = float(_max(np.abs(H).ravel()))  # of a PSD matrix: its largest diagonal entry
    tol = CONVEXITY_TOLERANCE * scale if scale > 0.0 else 1.0
    asym = float(_max(np.abs(H - H.T).ravel()))
    if not asym <= tol:
        raise InvalidInputError(
            f"QP H must be symmetric: |H - H^T| reaches {asym:.3g} (largest entry "
            f"{scale:.3g}); pass (H + H.T) / 2 if the quadratic form x^T H x is what is meant"
        )
    shifted = H + tol * np.eye(n)
    _, info = dpotrf(shifted, lower=0, overwrite_a=1, clean=0)
    if info != 0:
        least = float(np.linalg.eigvalsh(0.5 * (H + H.T))[0])
        raise InvalidInputError(
            f"QP H must be positive semi-definite (a convex QP), but its smallest eigenvalue "
            f"is {least:.6g} (largest entry {scale:.6g}): the solvers would return a "
            "stationary point (a saddle or a maximum), not a minimizer"
        )


def _magnitudes_ok(arrays: tuple[FloatArray, ...]) -> bool:
    """Whether every entry is finite and at most :data:`MAX_QP_MAGNITUDE`.

    May say False for a large array whose sum of squares overflows: :func:`_refuse` then
    looks closer.
    """
    limit = MAX_QP_MAGNITUDE * MAX_QP_MAGNITUDE
    for arr in arrays:
        if not arr.size:
            continue
        flat = arr.reshape(-1)
        if flat.size <= _DOT_SIZE:
            if not flat.dot(flat) <= limit:  # NaN compares False
                return False
        # no BLAS: a threaded ddot waits for its threads (ms on a loaded machine)
        elif not (_max(flat) <= MAX_QP_MAGNITUDE and _min(flat) >= -MAX_QP_MAGNITUDE):
            return False
    return True


def _bounds_ok(arrays: tuple[FloatArray, ...]) -> bool:
    """Whether no entry is NaN (infinite bounds are allowed)."""
    for arr in arrays:
        if arr.size and math.isnan(arr.dot(arr) if arr.size <= _DOT_SIZE else _max(arr)):
            return False  # squares: inf stays inf, only NaN makes NaN
    return True


def _refuse(p: QPProblem) -> None:
    """Locate the bad entries and raise (see :func:`check_problem_data`)."""
    blocks = {
        "A": p.eq_blocks,
        "b": p.eq_blocks,
        "C": p.in_blocks,
        "l": p.in_blocks,
        "u": p.in_blocks,
        "lb": p.box_blocks,
        "ub": p.box_blocks,
    }
    for name in ("H", "g", "A", "b", "C", "l", "u", "lb", "ub"):
        arr = getattr(p, name)
        rows_of = arr if arr.ndim == 2 else arr[:, None]
        kind = "rows" if arr.ndim == 2 else "entries"
        checks = [(np.isnan(rows_of), False)]  # bounds may be infinite
        if name not in ("l", "u", "lb", "ub"):
            checks = [(~np.isfinite(rows_of), False), (np.abs(rows_of) > MAX_QP_MAGNITUDE, True)]
        for bad, big in checks:
            rows = np.flatnonzero(bad.any(axis=1))[:20]
            if not rows.size:
                continue
            names = sorted({_block_of(blocks.get(name, []), int(r)) for r in rows} - {""})
            where = f"QP {name} {kind} {rows.tolist()}" + (
                f" ({', '.join(names)})" if names else ""
            )
            if not big:
                raise NotFiniteError(where, rows.tolist())
            raise InvalidInputError(
                f"{where}: entries up to {float(np.abs(rows_of).max()):.3g}, beyond "
                f"{MAX_QP_MAGNITUDE:g}: the problem was built from a diverged or invalid state "
                "(check the robot's state, its velocities and the task gains)"
            )


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
    "CONVEXITY_TOLERANCE",
    "MAX_QP_MAGNITUDE",
    "KKTWorkspace",
    "QPSolver",
    "QPSolverOptions",
    "RowBlock",
    "SolverError",
    "available_backends",
    "check_backend",
    "check_convex",
    "check_problem_data",
    "unconstrained_minimizer",
    "validate_problem",
]
