"""Fitted value iteration on a grid for continuous-state optimal control, with the HJB residual.

Continuous problem: ``x' = f(x, u)``, cost-to-go ``J(x) = min int_0^inf e^{-rho t} l(x, u) dt``
(``rho = 0``: undiscounted, which needs a zero-cost absorbing target or ``l -> 0`` at a goal).
Its value solves the Hamilton-Jacobi-Bellman equation

``rho J(x) = min_u [ l(x, u) + dJ/dx(x) f(x, u) ]``.

Discretization (semi-Lagrangian): hold ``u`` from a finite action set for ``dt``, integrate
``x_+ = phi(x, u)`` (RK4), and interpolate ``J`` at ``x_+`` on the grid (multilinear):

``J(x_i) = min_a [ l(x_i, u_a) dt + gamma sum_j W_a[i, j] J(x_j) ]``,   ``gamma = exp(-rho dt)``.

The interpolation weights form stochastic matrices, so this is value iteration on a finite MDP
(:mod:`taskspace.optimal_control.dynamic_programming`) with rewards ``-l dt``; the fixed point
exists and is unique for ``gamma < 1`` or with a reachable absorbing target. The HJB residual
``min_u [l + dJ/dx f] - rho J`` (finite-difference gradient of the grid values) measures how
well the result satisfies the continuous equation where ``J`` is smooth.

Thread safety: the solver keeps its state local to the call; :class:`FittedValueIterationOptions`
is immutable; a :class:`FittedValueIterationResult` is plain result data (arrays), not locked: do
not modify it while another thread reads it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from taskspace._validation import FloatArray, as_float_array, check_count, check_positive
from taskspace.dynamics.simulation import memory_budget
from taskspace.errors import InvalidInputError, ShapeError, TaskspaceError
from taskspace.optimal_control.dynamic_programming import (
    DPResult,
    ValueIterationOptions,
    value_iteration,
)
from taskspace.optimal_control.grid import StateGrid
from taskspace.optimal_control.mdp import MDP, make_mdp

MAX_REFINEMENTS = 64
"""Largest ``FittedValueIterationOptions.refinements``."""

MAX_GRID_BYTES = 8 * 2**30
"""Cap on the (state, action) tables of :func:`fitted_value_iteration` (or half the available
memory when less)."""

Dynamics = Callable[[FloatArray, FloatArray], FloatArray]
"""``f(X, U)``: state derivatives (K x d) of states X (K x d) under actions U (K x m)."""
Cost = Callable[[FloatArray, FloatArray], FloatArray]
"""``l(X, U)``: running cost per second (K,) of states X (K x d) under actions U (K x m)."""
Target = Callable[[FloatArray], np.ndarray]
"""``target(X)``: boolean mask (K,) of absorbing zero-cost goal states."""


@dataclass(frozen=True, kw_only=True)
class FittedValueIterationOptions:
    """Settings of :func:`fitted_value_iteration`.

    Attributes:
        dt: time an action is held [s].
        substeps: RK4 steps per ``dt``.
        discount_rate: ``rho`` [1/s], ``gamma = exp(-rho dt)``.
        value_iteration: options of the discrete value iteration (tolerance on ``J``).
        refinements: rounds of local action refinement after the solve on the action set
            (0: none). Each round re-solves (warm-started) with, at every grid point, the
            greedy action of the last round plus ``{-2, -1, 0, 1, 2} delta / 4`` per input
            component (clipped to the action set's box), ``delta`` starting at the largest gap
            of the action set and halved every round: the control resolution becomes
            ``delta_0 / 2^(refinements + 1)`` at the cost of ``5^m`` actions per point and
            round, instead of a global action set that fine.
    """

    dt: float = 0.05
    substeps: int = 2
    discount_rate: float = 0.0
    refinements: int = 0
    value_iteration: ValueIterationOptions = field(
        default_factory=lambda: ValueIterationOptions(tolerance=1e-9, max_iterations=20_000)
    )


@dataclass
class FittedValueIterationResult:
    """Cost-to-go on a grid, its greedy policy and the HJB residual.

    Attributes:
        success: the value iteration converged.
        grid: the state grid.
        actions: the action set (A x m).
        J: cost-to-go at the grid points (N,).
        policy: index of the greedy action at the grid points (N,) in ``actions`` (without
            refinement) or in the last round's local set.
        greedy_action: the greedy action at the grid points (N x m).
        hjb_residual: ``min_u [l + dJ/dx f] - rho J`` at the grid points (N,) (large where ``J``
            has kinks, e.g. on switching curves, and at clipped boundaries).
        target: mask of target grid points (N,).
        mdp: the discrete MDP that was solved.
        dp: the value-iteration result (of the last round).
        iterations: value-iteration backups over all rounds.
        solve_time: wall time of building and solving [s].
    """

    success: bool
    grid: StateGrid
    actions: FloatArray
    J: FloatArray
    policy: np.ndarray
    greedy_action: FloatArray
    hjb_residual: FloatArray
    target: np.ndarray
    mdp: MDP
    dp: DPResult
    solve_time: float
    iterations: int = 0

    def value(self, X: Any) -> FloatArray:
        """Interpolated cost-to-go at states X (K x d)."""
        return self.grid.interpolate(self.J, X)

    def control(self, X: Any, dynamics: Dynamics, cost: Cost, dt: float) -> FloatArray:
        """Greedy action (K x m) at arbitrary states by one-step lookahead.

        Minimizes ``l dt + J(x + f dt)`` (one Euler step, interpolated ``J``) over the actions.
        """
        X = np.atleast_2d(as_float_array(X, "X"))
        if X.ndim != 2 or X.shape[1] != self.grid.dim:
            raise ShapeError("X", (-1, self.grid.dim), X.shape)
        dt = check_positive(dt, "dt [s]")
        K, A = X.shape[0], self.actions.shape[0]
        XX = np.repeat(X, A, axis=0)
        UU = np.tile(self.actions, (K, 1))
        q = (cost(XX, UU) * dt + self.value(XX + dt * dynamics(XX, UU))).reshape(K, A)
        return np.asarray(self.actions[np.argmin(q, axis=1)], dtype=float)


def rk4_step(
    dynamics: Dynamics, X: FloatArray, U: FloatArray, dt: float, substeps: int = 1
) -> FloatArray:
    """``substeps`` RK4 steps of ``x' = f(x, u)`` with ``u`` held, total time ``dt`` [s].

    Raises:
        InvalidInputError: ``dt`` not finite and > 0, ``substeps`` not an integer >= 1, or
            ``dynamics`` raising or returning an array of another shape than ``X`` (a (K, 1)
            output was broadcast over every state component).
    """
    dt = check_positive(dt, "dt [s]")
    substeps = check_count(substeps, "substeps", minimum=1)
    X = as_float_array(X, "X")
    h = dt / substeps

    def f(Y: FloatArray) -> FloatArray:
        out = as_float_array(_call(dynamics, "dynamics", Y, U), "dynamics(X, U)")
        if out.shape != Y.shape:
            raise ShapeError("dynamics(X, U)", Y.shape, out.shape)
        return out

    for _ in range(substeps):
        k1 = f(X)
        k2 = f(X + 0.5 * h * k1)
        k3 = f(X + 0.5 * h * k2)
        k4 = f(X + h * k3)
        X = X + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return X


def _call(fn: Callable[..., Any], name: str, *args: Any) -> Any:
    """Call a user function; its own exception becomes an InvalidInputError naming it."""
    if not callable(fn):
        raise InvalidInputError(f"{name} must be a function, got {type(fn).__name__}")
    try:
        return fn(*args)
    except TaskspaceError:
        raise
    except Exception as exc:
        raise InvalidInputError(
            f"the user function {name} raised {type(exc).__name__}: {exc} (it is called with "
            "the grid states X (K x d) and actions U (K x m) as arrays)"
        ) from exc


def fitted_value_iteration(
    grid: StateGrid,
    actions: Any,
    dynamics: Dynamics,
    cost: Cost,
    options: FittedValueIterationOptions | None = None,
    *,
    target: Target | None = None,
) -> FittedValueIterationResult:
    """Solve the discretized HJB equation on ``grid`` by value iteration.

    Args:
        grid: state grid (see :func:`taskspace.optimal_control.grid.make_grid`).
        actions: finite action set (A x m), or (A,) for a scalar input.
        dynamics: vectorized ``f(X, u)``.
        cost: vectorized running cost ``l(X, u)`` per second (>= 0).
        options: see :class:`FittedValueIterationOptions`.
        target: absorbing zero-cost goal states (e.g. minimum time problems).

    Raises:
        InvalidInputError: bad options, non-finite successors or negative costs.
    """
    options = options or FittedValueIterationOptions()
    check_positive(options.dt, "dt [s]")
    check_positive(options.discount_rate, "discount_rate [1/s]", strict=False)
    check_count(options.substeps, "substeps", minimum=1)
    t0 = time.perf_counter()
    if not isinstance(grid, StateGrid):
        raise InvalidInputError(
            f"grid must be a StateGrid (make_grid(...)), got {type(grid).__name__}"
        )
    U = as_float_array(actions, "actions")
    if U.ndim == 1:
        U = U[:, None]
    if U.ndim != 2 or U.shape[0] == 0 or not np.all(np.isfinite(U)):
        raise InvalidInputError("actions must be a non-empty finite (A x m) array")
    refinements = check_count(options.refinements, "refinements")
    if refinements > MAX_REFINEMENTS:  # each round is a full value iteration (10**9 hung)
        raise InvalidInputError(
            f"refinements must be at most {MAX_REFINEMENTS} (the action resolution halves each "
            f"round: 2^-{MAX_REFINEMENTS} of the action gap is below float64 precision), "
            f"got {refinements}"
        )
    N, m, d = grid.size, U.shape[1], grid.dim
    pairs = N * max(U.shape[0], 5**m if refinements else 1)
    # states and successors of every (state, action) pair, its input and cost, and the sparse
    # interpolation row (2^d weights and column indices); a 10^15-point grid was a bare
    # MemoryError ("Unable to allocate 7.11 PiB")
    needed = pairs * (16 * d + 8 * m + 8 + 12 * 2**d)
    budget = memory_budget(MAX_GRID_BYTES)
    if needed > budget:
        raise InvalidInputError(
            f"the grid ({' x '.join(str(k) for k in grid.shape)} = {N:,} points) with "
            f"{pairs // N:,} actions per point would need at least {needed / 1e9:.3g} GB but the "
            f"budget is {budget / 1e9:.3g} GB (half the available memory, at most "
            f"{MAX_GRID_BYTES / 2**30:g} GiB): use a coarser grid (geometric_axis) or fewer "
            "actions"
        )
    X = grid.points()
    goal = np.zeros(N, dtype=bool)
    if target is not None:
        goal = np.asarray(_call(target, "target", X))
        if goal.shape != (N,) or goal.dtype.kind not in "biu":
            raise InvalidInputError(
                f"target(X) must return a boolean mask of shape ({N},), got shape {goal.shape} "
                f"and dtype {goal.dtype}"
            )
        goal = goal.astype(bool)
    # All (state, action) pairs at once, row s A + a (the MDP's stacked order).
    UU = np.tile(U, (N, 1))
    mdp, dp, c, XX = _solve(grid, X, UU, U.shape[0], goal, dynamics, cost, options)
    iterations = dp.iterations
    lo, hi = U.min(axis=0), U.max(axis=0)
    gaps = [np.diff(np.unique(U[:, j])) for j in range(m)]
    delta = np.array([g.max() if g.size else 0.0 for g in gaps])
    offsets = np.stack(np.meshgrid(*[np.arange(-2, 3)] * m, indexing="ij"), -1).reshape(-1, m)
    for _ in range(refinements):
        best = UU.reshape(N, -1, m)[np.arange(N), dp.policy]
        local = np.clip(best[:, None, :] + 0.25 * offsets[None, :, :] * delta, lo, hi)
        UU = local.reshape(-1, m)
        options_k = replace(
            options,
            value_iteration=replace(options.value_iteration, initial_value=dp.V),
        )
        mdp, dp, c, XX = _solve(grid, X, UU, offsets.shape[0], goal, dynamics, cost, options_k)
        iterations += dp.iterations
        delta = 0.5 * delta
    A = UU.shape[0] // N
    J = -dp.V
    # HJB residual: min_u [l + grad J . f] - rho J.
    G = grid.gradient(J)
    ham = (c + np.sum(np.repeat(G, A, axis=0) * dynamics(XX, UU), axis=1)).reshape(N, A)
    residual = np.min(ham, axis=1) - options.discount_rate * J
    residual[goal] = 0.0
    return FittedValueIterationResult(
        success=dp.success,
        grid=grid,
        actions=U,
        J=J,
        policy=dp.policy,
        greedy_action=np.asarray(UU.reshape(N, A, m)[np.arange(N), dp.policy], dtype=float),
        hjb_residual=residual,
        target=goal,
        mdp=mdp,
        dp=dp,
        solve_time=time.perf_counter() - t0,
        iterations=iterations,
    )


def _solve(
    grid: StateGrid,
    X: FloatArray,
    UU: FloatArray,
    A: int,
    goal: np.ndarray,
    dynamics: Dynamics,
    cost: Cost,
    options: FittedValueIterationOptions,
) -> tuple[MDP, DPResult, FloatArray, FloatArray]:
    """Build and solve the MDP of the (state, action) rows ``UU`` (row ``s A + a``)."""
    N = X.shape[0]
    XX = np.repeat(X, A, axis=0)
    Xn = rk4_step(dynamics, XX, UU, options.dt, options.substeps)
    if not np.all(np.isfinite(Xn)):
        raise InvalidInputError("the dynamics gave non-finite successors")
    c = as_float_array(_call(cost, "cost", XX, UU), "cost(X, U)")
    if c.shape != (N * A,) or np.any(c < 0) or not np.all(np.isfinite(c)):
        raise InvalidInputError("cost(X, U) must return one finite nonnegative value per row")
    W = grid.interpolation_matrix(Xn).tocsr()
    goal_rows = np.repeat(goal, A)
    if np.any(goal_rows):
        W = sp.diags((~goal_rows).astype(float)) @ W + sp.csr_matrix(
            (
                np.ones(int(goal_rows.sum())),
                (np.flatnonzero(goal_rows), np.repeat(np.flatnonzero(goal), A)),
            ),
            shape=W.shape,
        )
    W = sp.csr_matrix(W)
    by_action = sp.csr_matrix(W[(np.arange(N)[None, :] * A + np.arange(A)[:, None]).ravel()])
    mats = [sp.csr_matrix(by_action[a * N : (a + 1) * N]) for a in range(A)]
    R = np.where(goal[:, None], 0.0, -c.reshape(N, A) * options.dt)
    gamma = float(np.exp(-options.discount_rate * options.dt))
    mdp = make_mdp(mats, R, gamma, tolerance=1e-8)
    mdp.__dict__["stacked"] = W  # already in the stacked row order
    dp = value_iteration(mdp, options.value_iteration)
    return mdp, dp, c, XX
