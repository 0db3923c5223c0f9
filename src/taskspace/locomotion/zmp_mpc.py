"""Model predictive control of the cart-table model with the ZMP kept in the support polygon.

Same incremental error system and cost as :mod:`~taskspace.locomotion.preview_control`
(``xt = (e, dx)``, input ``du``), but over a finite horizon ``N`` with the Riccati cost-to-go
as terminal cost and the ZMP constrained at every predicted sample (Wieber 2006):

    min_{du_0..du_{N-1}}  sum_{k=1}^{N-1} xt_k^T Q xt_k + xt_N^T P xt_N + R sum_k du_k^2
    s.t.  xt_{k+1} = At xt_k + Bt du_k + E dr_{k+1},
          A_k p_k <= b_k   (p_k = e_k + r_k, the support polygon at ``t_k``, both axes).

Without active constraints the minimizer is exactly the preview law (the terminal cost is the
infinite-horizon cost-to-go once the previewed reference increments are over), so the two
controllers agree; with active constraints the ZMP stays in the polygon where the preview
controller would leave it. Both axes are solved together because the polygon couples them;
the QP goes through :class:`~taskspace.qp.QPSolver` (its workspace is kept between steps:
every polygon is padded to the same number of rows).

Everything but the linear term and the polygon rows is built once (the condensed prediction,
``H`` and its Cholesky factor); a step writes ``g``, ``C`` and ``u`` into reused buffers, and
the unconstrained minimizer (from the kept factor) is taken without calling the QP solver when
it satisfies the polygon rows and its KKT residuals meet the tolerances, as the solver's own
first try would. Every step's KKT residuals are in the result (``ZmpMpcResult.kkt``): each
step is solved (``SOLVED``, or ``UNCONSTRAINED`` for the shortcut) only with primal, dual and
complementarity residuals within ``ZmpMpcOptions.qp``'s ``eps_abs + eps_rel * scale`` (see
:mod:`taskspace.qp.kkt`), as every QP of the library.

Thread safety: :class:`ZmpMpc` serializes its runs with a lock (see there); options and results
are immutable and :func:`mpc_walking_pattern` builds its own controller per call.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs

from taskspace._validation import FloatArray, as_float_array, check_finite, check_positive
from taskspace.errors import InvalidInputError, ShapeError, SolverError
from taskspace.locomotion.footsteps import FootstepPlan, check_plan
from taskspace.locomotion.lipm import CartTable, LipmTrajectory
from taskspace.locomotion.preview_control import (
    PreviewController,
    PreviewOptions,
    WalkingPattern,
    _trajectory,
    augmented_system,
)
from taskspace.locomotion.support_polygon import SupportPolygon
from taskspace.locomotion.zmp_reference import SoleSize, support_polygons, zmp_reference
from taskspace.qp import INF, QPProblem, QPSolver, QPSolverOptions, QPStatus
from taskspace.qp.kkt import KKTResiduals

MAX_EDGES = 8
"""Rows reserved per predicted sample for the support polygon (a hull of two soles)."""


@dataclass(frozen=True, kw_only=True)
class ZmpMpcOptions:
    """Settings of :class:`ZmpMpc`.

    Attributes:
        preview: horizon and weights (the same meaning as for the preview controller).
        constrain_zmp: add the support-polygon constraints.
        zmp_margin: distance kept from the polygon edges [m].
        qp: settings of the QP solver.
    """

    preview: PreviewOptions = field(default_factory=PreviewOptions)
    constrain_zmp: bool = True
    zmp_margin: float = 0.0
    qp: QPSolverOptions = field(default_factory=QPSolverOptions)

    def __post_init__(self) -> None:
        if not isinstance(self.constrain_zmp, (bool, np.bool_)):
            raise InvalidInputError(
                f"constrain_zmp must be True or False, got {self.constrain_zmp!r}"
            )
        # a negative margin would let the ZMP leave the support polygon
        check_positive(self.zmp_margin, "zmp_margin [m]", strict=False)
        for name, kind in (("preview", PreviewOptions), ("qp", QPSolverOptions)):
            if not isinstance(getattr(self, name), kind):
                raise InvalidInputError(
                    f"{name} must be {kind.__name__}, got {type(getattr(self, name)).__name__}"
                )


@dataclass(frozen=True)
class ZmpMpcResult:
    """Result of :meth:`ZmpMpc.simulate`.

    Attributes:
        trajectory: the CoM / ZMP trajectory.
        statuses: QP status of every step.
        active_steps: number of steps where a ZMP constraint was active.
        solve_times: (T,) QP time per step [s].
        kkt: the KKT residuals of every step's QP (primal, dual, complementarity, duality
            gap and their scales, :class:`~taskspace.qp.kkt.KKTResiduals`); a step is solved
            only when they are within the QP options' tolerances.
    """

    trajectory: LipmTrajectory
    statuses: list[QPStatus]
    active_steps: int
    solve_times: FloatArray
    kkt: tuple[KKTResiduals, ...] = ()

    @property
    def max_kkt(self) -> dict[str, float]:
        """The largest KKT residuals over the run: ``primal``, ``dual``, ``complementarity``.

        NaN when a step has none (or the run has no step).
        """
        out = {}
        for name in ("primal", "dual", "complementarity"):
            values = np.array([getattr(k, name) for k in self.kkt], dtype=float)
            out[name] = float(np.max(values)) if values.size else float("nan")
        return out

    @property
    def success(self) -> bool:
        """Every QP was solved."""
        return all(s in (QPStatus.SOLVED, QPStatus.UNCONSTRAINED) for s in self.statuses)


class ZmpMpc:
    """ZMP MPC of the cart-table model (see the module docstring).

    Thread safety: :meth:`simulate` and :meth:`build` may be called from several threads on one
    controller: they hold its lock while they use its QP workspace and half-space cache, so
    runs go one at a time and each gives the result it would give alone. For parallel runs,
    give each thread its own controller.

    Args:
        model: cart-table model (its ``dt`` is the MPC sampling period).
        options: settings.
    """

    def __init__(self, model: CartTable, options: ZmpMpcOptions | None = None) -> None:
        self.model = model
        self.options = options or ZmpMpcOptions()
        self.preview = PreviewController(model, self.options.preview)
        N = self.horizon = self.preview.horizon
        At, Bt, E = augmented_system(model)
        powers = [np.eye(4)]
        for _ in range(N):
            powers.append(At @ powers[-1])
        # xt_k = Phi_k xt_0 + sum_{i<k} Gam_{k,i} du_i + Psi_{k,i} dr_{i+1}, k = 1..N
        self._Phi = np.stack([powers[k] for k in range(1, N + 1)])  # (N, 4, 4)
        Gam = np.zeros((N, 4, N))
        Psi = np.zeros((N, 4, N))
        for k in range(1, N + 1):
            for i in range(k):
                Gam[k - 1, :, i] = (powers[k - 1 - i] @ Bt)[:, 0]
                Psi[k - 1, :, i] = (powers[k - 1 - i] @ E)[:, 0]
        self._Gam, self._Psi = Gam, Psi
        opts = self.options.preview
        W = np.zeros((N, 4, 4))
        W[:, 0, 0] = opts.error_weight
        W[-1] = self.preview.P
        self._W = W
        Gf = Gam.reshape(N * 4, N)
        Wb = np.zeros((N * 4, N * 4))
        for k in range(N):
            Wb[4 * k : 4 * k + 4, 4 * k : 4 * k + 4] = W[k]
        self._Wb = Wb
        H1 = Gf.T @ Wb @ Gf + opts.input_weight * np.eye(N)
        self._H = np.kron(np.eye(2), 0.5 * (H1 + H1.T))
        self._Gf = Gf
        self._GfW = Gf.T @ Wb
        self._Esel = Gam[:, 0, :]  # e_k rows: (N, N)
        # Per step only the linear term and the polygon rows change: g_a = Gx xt_a + Gr dr_a
        # and the free e_k = Phi_k[0] xt_0 + Psi_k[0] dr (both axes as the two columns).
        self._Gx = self._GfW @ self._Phi.reshape(N * 4, 4)  # (N, 4)
        self._Gr = self._GfW @ Psi.reshape(N * 4, N)  # (N, N)
        self._Fx = self._Phi[:, 0, :].copy()  # (N, 4)
        self._Fr = Psi[:, 0, :].copy()  # (N, N)
        self._solver = QPSolver(self.options.qp)
        # Cholesky factor of the constant H for the unconstrained shortcut of simulate()
        chol, info = dpotrf(self._H, lower=0)
        self._chol: FloatArray | None = chol if info == 0 else None
        # id(polygon) -> (polygon, A, b, padded A, padded b); the polygon is kept so that its
        # id stays its own. Padded: (MAX_EDGES, 2) / (MAX_EDGES,), rows past the edges are
        # zero with b = +inf (an unbounded row).
        self._halfspace_cache: dict[
            int, tuple[SupportPolygon, FloatArray, FloatArray, FloatArray, FloatArray]
        ] = {}
        self._lock = threading.RLock()

    def build(
        self,
        augmented_state: FloatArray,
        reference: FloatArray,
        polygons: list[SupportPolygon] | None,
    ) -> QPProblem:
        """The QP of one step (a new problem; :meth:`simulate` reuses its buffers).

        Args:
            augmented_state: (4, 2) ``(e_0, dx_0)`` per axis.
            reference: (N + 1, 2) ``r_0 .. r_N``.
            polygons: N support polygons at ``t_1 .. t_N`` (``None``: unconstrained).
        """
        with self._lock:
            if polygons is None:
                return self._fill(augmented_state, reference, None, None, None)
            Ah, bh = self._padded(polygons)
            return self._fill(augmented_state, reference, Ah, bh, None)

    def _padded(self, polygons: list[SupportPolygon]) -> tuple[FloatArray, FloatArray]:
        """(K, MAX_EDGES, 2) and (K, MAX_EDGES) padded half-spaces of K polygons."""
        entries = [self._halfspaces_entry(poly, k) for k, poly in enumerate(polygons)]
        return np.stack([e[3] for e in entries]), np.stack([e[4] for e in entries])

    def _fill(
        self,
        augmented_state: FloatArray,
        reference: FloatArray,
        Ah: FloatArray | None,
        bh: FloatArray | None,
        out: QPProblem | None,
    ) -> QPProblem:
        """The QP of one step from padded half-spaces ``Ah`` (N, MAX_EDGES, 2), ``bh``.

        ``out``: a problem of the right shape whose ``g``, ``C`` and ``u`` are overwritten
        (``H`` and ``l`` are constant); ``None`` allocates a new one.
        """
        N = self.horizon
        dr = reference[1:] - reference[:-1]  # (N, 2): dr_{1..N}
        if out is None:
            out = QPProblem.unconstrained(self._H, np.empty(2 * N))
            if Ah is not None:
                rows = N * MAX_EDGES
                out.C, out.l, out.u = np.empty((rows, 2 * N)), np.full(rows, -INF), np.empty(rows)
        g = (self._Gx @ augmented_state + self._Gr @ dr).T  # (2, N)
        out.g.reshape(2, N)[:] = g
        if Ah is None or bh is None:
            return out
        free = self._Fx @ augmented_state + self._Fr @ dr  # (N, 2): e_k without inputs
        C = out.C.reshape(N, MAX_EDGES, 2, N)
        np.multiply(Ah[:, :, :, None], self._Esel[:, None, None, :], out=C)
        p = free + reference[1:]  # (N, 2)
        u = out.u.reshape(N, MAX_EDGES)
        np.subtract(bh, self.options.zmp_margin, out=u)
        u -= np.einsum("kmj,kj->km", Ah, p)
        return out

    def _margin_hint(self, polygons: list[SupportPolygon]) -> str:
        """Why a step may be infeasible: a polygon narrower than twice ``zmp_margin``."""
        margin = self.options.zmp_margin
        if margin <= 0.0:
            return ""
        seen: dict[int, float] = {}
        for poly in polygons:
            if id(poly) not in seen:
                seen[id(poly)] = _inradius(poly)
        if not seen or min(seen.values()) >= margin:
            return ""
        return (
            f": zmp_margin = {margin:g} m exceeds the inradius {min(seen.values()):.4g} m of a "
            "support polygon of the horizon (the largest distance a ZMP can keep from all its "
            "edges); lower zmp_margin or use larger soles"
        )

    def _halfspaces(self, poly: SupportPolygon, k: int) -> tuple[FloatArray, FloatArray]:
        """``poly.halfspaces()``, computed once per polygon object (a walk repeats them)."""
        entry = self._halfspaces_entry(poly, k)
        return entry[1], entry[2]

    def _halfspaces_entry(
        self, poly: SupportPolygon, k: int
    ) -> tuple[SupportPolygon, FloatArray, FloatArray, FloatArray, FloatArray]:
        hit = self._halfspace_cache.get(id(poly))
        if hit is not None and hit[0] is poly:
            return hit
        if poly.is_degenerate:
            raise InvalidInputError(
                f"the support polygon at predicted step {k + 1} has no interior"
            )
        Ah, bh = poly.halfspaces()
        m = Ah.shape[0]
        if m > MAX_EDGES:
            raise InvalidInputError(
                f"support polygon with {m} edges; at most {MAX_EDGES} supported"
            )
        A_pad = np.zeros((MAX_EDGES, 2))
        A_pad[:m] = Ah
        b_pad = np.full(MAX_EDGES, INF)
        b_pad[:m] = bh
        if len(self._halfspace_cache) > 4096:
            self._halfspace_cache.clear()
        entry = (poly, Ah, bh, A_pad, b_pad)
        self._halfspace_cache[id(poly)] = entry
        return entry

    def _unconstrained(self, problem: QPProblem) -> tuple[FloatArray, float] | None:
        """The unconstrained minimizer ``-H^-1 g`` and its largest row violation, if feasible.

        :class:`~taskspace.qp.QPSolver`'s first try (``try_unconstrained``: LAPACK's ``dposv``,
        i.e. ``dpotrf`` + ``dpotrs``) with the factor of the constant ``H`` kept: the same point,
        without refactorizing ``H`` every step. ``None``: a row is violated by more than
        ``feasibility_tolerance`` (or NaN), the QP solver decides. Its KKT residuals:
        :meth:`_shortcut_residuals`.
        """
        x, info = dpotrs(self._chol, -problem.g, lower=0)
        if info != 0:
            return None
        violation = 0.0
        if problem.C.shape[0]:
            violation = max(0.0, float(np.max(problem.C @ x - problem.u)))
            if not violation <= self.options.qp.feasibility_tolerance:
                return None
        return np.asarray(x), violation

    def _shortcut_residuals(
        self, X: FloatArray, G: FloatArray, violations: list[float]
    ) -> list[KKTResiduals]:
        """KKT residuals of unconstrained minimizers ``X`` (m, 2N) of linear terms ``G``.

        :func:`taskspace.qp.kkt.equality_kkt_residuals` without equalities (zero multipliers:
        the dual residual is ``|H x + g|``), for ``m`` steps at once.
        """
        HX = X @ self._H  # H is symmetric
        R = HX + G
        dual = np.abs(R).max(axis=1)
        xs, hx, gs = np.abs(X).max(axis=1), np.abs(HX).max(axis=1), np.abs(G).max(axis=1)
        xHx = np.einsum("ij,ij->i", X, HX)
        gx = np.einsum("ij,ij->i", G, X)
        return [
            KKTResiduals(v, d, 0.0, abs(a + b), s, max(h, q), max(1.0, abs(a), abs(b)))
            for v, d, a, b, s, h, q in zip(
                violations,
                dual.tolist(),
                xHx.tolist(),
                gx.tolist(),
                xs.tolist(),
                hx.tolist(),
                gs.tolist(),
                strict=True,
            )
        ]

    def simulate(
        self,
        reference: Any,
        polygons: list[SupportPolygon] | None = None,
        initial_state: Any = None,
    ) -> ZmpMpcResult:
        """Closed-loop run along a sampled reference.

        Args:
            reference: (T, 2) ZMP reference at ``k dt`` [m] (held after the end).
            polygons: T support polygons (held after the end); required when
                ``constrain_zmp``.
            initial_state: (3, 2) ``(c, cdot, cddot)`` per axis (default: at rest above
                ``reference[0]``).
        """
        r = as_float_array(reference, "reference")
        if r.ndim != 2 or r.shape[1] != 2 or not np.isfinite(r).all():
            raise InvalidInputError(f"reference must be a finite (T, 2) array, got {r.shape}")
        constrain = self.options.constrain_zmp
        if constrain and (polygons is None or len(polygons) != r.shape[0]):
            raise InvalidInputError(
                "constrain_zmp needs one support polygon per reference sample "
                "(or ZmpMpcOptions(constrain_zmp=False))"
            )
        if initial_state is not None:
            x0 = as_float_array(initial_state, "initial_state")
            if x0.shape != (3, 2):  # a (2, 3) or (6,) state was reshaped silently
                raise ShapeError("initial_state", (3, 2), tuple(x0.shape))
            check_finite(x0, "initial_state")
        with self._lock:
            return self._simulate(r, polygons, constrain, initial_state)

    def _simulate(
        self,
        r: FloatArray,
        polygons: list[SupportPolygon] | None,
        constrain: bool,
        initial_state: Any,
        check_each: bool = False,
    ) -> ZmpMpcResult:
        """The closed loop of :meth:`simulate`.

        The shortcut steps' residuals are computed at the end, for all steps at once
        (``check_each=False``); if one misses the tolerances the run is made again with each
        step checked before its shortcut is taken (``check_each=True``), so that a step whose
        shortcut misses them is solved by the QP solver, as in :class:`QPSolver`.
        """
        T, N = r.shape[0], self.horizon
        padded = np.vstack([r, np.repeat(r[-1:], N + 1, axis=0)])
        polys = list(polygons) + [polygons[-1]] * (N + 1) if polygons else None
        x = np.zeros((3, 2))
        x[0] = r[0]
        if initial_state is not None:
            x = as_float_array(initial_state, "initial_state").reshape(3, 2).copy()
        A, B, c = self.model.A, self.model.B[:, 0], self.model.C[0]
        x_prev, u = x.copy(), np.zeros(2)
        states, jerk = np.empty((T, 3, 2)), np.empty((T, 2))
        statuses, times, active = [], np.empty(T), 0
        kkts: list[KKTResiduals | None] = []
        quick_x: list[FloatArray] = []  # shortcut steps: minimizer, linear term, violation
        quick_g: list[FloatArray] = []
        quick_v: list[float] = []
        quick_k: list[int] = []
        eps_abs, eps_rel = self.options.qp.eps_abs, self.options.qp.eps_rel
        # padded half-spaces of every sample once; a step takes a window of them
        Ah_all, bh_all = self._padded(polys) if polys and constrain else (None, None)
        problem: QPProblem | None = None
        xt = np.empty((4, 2))
        shortcut = self.options.qp.try_unconstrained and self._chol is not None
        for k in range(T):
            states[k] = x
            np.subtract(c @ x, r[k], out=xt[0])
            np.subtract(x, x_prev, out=xt[1:])
            if Ah_all is None or bh_all is None:
                problem = self._fill(xt, padded[k : k + N + 1], None, None, problem)
            else:
                Ah, bh = Ah_all[k + 1 : k + N + 1], bh_all[k + 1 : k + N + 1]
                problem = self._fill(xt, padded[k : k + N + 1], Ah, bh, problem)
            t0 = time.perf_counter()
            quick = self._unconstrained(problem) if shortcut else None
            step_kkt: KKTResiduals | None = None
            if quick is not None and check_each:
                g = problem.g
                step_kkt = self._shortcut_residuals(quick[0][None], g[None], [quick[1]])[0]
                if not step_kkt.within(eps_abs, eps_rel):
                    quick = None
            if quick is None:
                res = self._solver.solve(problem)
                if not res.success:
                    raise SolverError(
                        f"ZMP MPC QP failed at step {k} ({res.status.value})"
                        + self._margin_hint(polys[k + 1 : k + N + 1] if polys else [])
                    )
                sol, status, step_kkt = res.x, res.status, res.kkt
            else:
                sol, status = quick[0], QPStatus.UNCONSTRAINED
                if not check_each:  # residuals at the end, for all shortcut steps at once
                    quick_x.append(sol)
                    quick_g.append(problem.g.copy())  # a buffer, refilled by the next step
                    quick_v.append(quick[1])
                    quick_k.append(k)
            times[k] = time.perf_counter() - t0
            statuses.append(status)
            kkts.append(step_kkt)
            if problem.C.shape[0] and np.any(problem.C @ sol >= problem.u - 1e-7):
                active += 1
            u = u + np.array([sol[0], sol[N]])
            jerk[k] = u
            x_prev = x
            x = A @ x + np.outer(B, u)
        if quick_k:
            batch = self._shortcut_residuals(np.array(quick_x), np.array(quick_g), quick_v)
            if not all(kkt.within(eps_abs, eps_rel) for kkt in batch):
                return self._simulate(r, polygons, constrain, initial_state, check_each=True)
            for k, kkt in zip(quick_k, batch, strict=True):
                kkts[k] = kkt
        return ZmpMpcResult(
            _trajectory(self.model, states, r, jerk),
            statuses,
            active,
            times,
            tuple(k for k in kkts if k is not None),
        )


def _inradius(poly: SupportPolygon) -> float:
    """Radius [m] of the largest disk inside a polygon (0 when it has no interior)."""
    if poly.is_degenerate:
        return 0.0
    from scipy.optimize import linprog

    A, b = poly.halfspaces()
    # max rho s.t. a_i^T p + rho <= b_i (unit a_i): variables (p_x, p_y, rho)
    res = linprog(
        [0.0, 0.0, -1.0],
        A_ub=np.column_stack([A, np.ones(len(b))]),
        b_ub=b,
        bounds=[(None, None), (None, None), (0.0, None)],
        method="highs",
    )
    return float(res.x[2]) if res.status == 0 else 0.0


def mpc_walking_pattern(
    plan: FootstepPlan,
    model: CartTable | None = None,
    options: ZmpMpcOptions | None = None,
    sole: SoleSize | None = None,
) -> tuple[WalkingPattern, ZmpMpcResult]:
    """CoM trajectory of a footstep plan by ZMP MPC (reference and polygons from the plan)."""
    t0 = time.perf_counter()
    model = model or CartTable(dt=0.05)
    times = model.sample_times(check_plan(plan).duration)
    ref = zmp_reference(plan, times)
    polys = support_polygons(plan, times, sole)
    res = ZmpMpc(model, options).simulate(ref, polys)
    return WalkingPattern(plan, res.trajectory, time.perf_counter() - t0), res
