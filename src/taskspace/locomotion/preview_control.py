"""ZMP preview control of the cart-table model (Kajita et al. 2003, after Katayama et al. 1985).

The controller tracks a ZMP reference ``r`` known ``N`` samples ahead. In incremental form,
with the tracking error ``e_k = C x_k - r_k`` and ``dx_k = x_k - x_{k-1}``, the augmented state
``xt_k = (e_k, dx_k)`` obeys

    xt_{k+1} = At xt_k + Bt du_k + E dr_{k+1},
    At = [[1, C A], [0, A]],   Bt = [C B; B],   E = [-1; 0],

and the controller minimizes ``sum_k Q_e e_k^2 + R du_k^2`` (the input increment ``du`` gives
integral action: a constant offset is rejected). With ``P`` the stabilizing solution of the
discrete Riccati equation of ``(At, Bt, diag(Q_e, 0), R)`` (:func:`solve_discrete_riccati`),
``S = R + Bt^T P Bt``, ``K = S^-1 Bt^T P At`` and ``Ac = At - Bt K``, the optimal law with
the reference increments previewed ``N`` steps is

    du_k = -K xt_k - sum_{j=1..N} f_j dr_{k+j},   f_j = S^-1 Bt^T (Ac^T)^(j-1) P E.

Summed over time this is Kajita's form ``u_k = -G_i sum_{i<=k} e_i - G_x x_k -
sum_j G_p(j) r_{k+j}`` with ``G_i = K_e``, ``G_x = K_dx`` and ``G_p(j) = f_j``.

Thread safety: a :class:`PreviewController` is not changed by its methods (its gains are
computed once; a run integrates in local arrays), so one controller may run from several
threads; options and patterns are immutable.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, check_finite, check_positive
from taskspace.control.riccati import solve_discrete_riccati
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.locomotion.footsteps import FootstepPlan, check_plan
from taskspace.locomotion.lipm import CartTable, LipmTrajectory
from taskspace.locomotion.zmp_reference import zmp_reference


@dataclass(frozen=True, kw_only=True)
class PreviewOptions:
    """Settings of :class:`PreviewController` (defaults: Kajita et al. 2003).

    Attributes:
        preview_time: preview horizon ``N dt`` [s].
        error_weight: ``Q_e`` on the ZMP error [1/m^2].
        input_weight: ``R`` on the jerk increment.
    """

    preview_time: float = 1.6
    error_weight: float = 1.0
    input_weight: float = 1e-6

    def __post_init__(self) -> None:
        check_positive(self.preview_time, "preview_time")
        check_positive(self.error_weight, "error_weight")
        check_positive(self.input_weight, "input_weight")


def augmented_system(model: CartTable) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(At, Bt, E)`` of the incremental error system (module docstring)."""
    A, B, C = model.A, model.B, model.C
    At = np.zeros((4, 4))
    At[0, 0] = 1.0
    At[0, 1:] = (C @ A)[0]
    At[1:, 1:] = A
    Bt = np.vstack([C @ B, B])
    E = np.array([[-1.0], [0.0], [0.0], [0.0]])
    return At, Bt, E


class PreviewController:
    """Kajita's ZMP preview controller (see the module docstring).

    Args:
        model: the cart-table model (``com_height``, ``dt``).
        options: weights and preview horizon.

    Attributes:
        P: (4, 4) Riccati solution of the augmented system.
        K: (4,) state-feedback gain on ``(e, dx)``.
        preview_gains: (N,) gains ``f_j`` on the reference increments ``dr_{k+j}``.
        integral_gain: ``G_i`` (Kajita's form).
        state_gain: (3,) ``G_x`` (Kajita's form).
        horizon: ``N`` samples.
    """

    def __init__(self, model: CartTable, options: PreviewOptions | None = None) -> None:
        self.model = model
        self.options = options or PreviewOptions()
        opts = self.options
        self.horizon = max(1, round(opts.preview_time / model.dt))
        At, Bt, E = augmented_system(model)
        Q = np.diag([opts.error_weight, 0.0, 0.0, 0.0])
        R = np.array([[opts.input_weight]])
        riccati = solve_discrete_riccati(At, Bt, Q, R)
        self.riccati = riccati
        P = riccati.P
        S = float(R[0, 0] + (Bt.T @ P @ Bt)[0, 0])
        K = (Bt.T @ P @ At)[0] / S
        Ac = At - Bt @ K[None, :]
        gains = np.empty(self.horizon)
        X = P @ E
        for j in range(self.horizon):
            gains[j] = float((Bt.T @ X)[0, 0]) / S
            X = Ac.T @ X
        self.P, self.K, self.preview_gains = P, K, gains
        self.integral_gain = float(K[0])
        self.state_gain = K[1:].copy()
        self.closed_loop = Ac
        self._A, self._B, self._C = model.A, model.B, model.C

    def jerk_increment(self, augmented_state: Any, reference_increments: Any) -> FloatArray:
        """``du_k = -K xt_k - sum_j f_j dr_{k+j}`` for one or more axes.

        Args:
            augmented_state: (4,) or (4, axes) ``(e_k, x_k - x_{k-1})``.
            reference_increments: (N,) or (N, axes) ``r_{k+j} - r_{k+j-1}``, j = 1..N.
        """
        xt = as_float_array(augmented_state, "augmented_state")
        dr = as_float_array(reference_increments, "reference_increments")
        if xt.shape[0] != 4 or dr.shape[0] != self.horizon or xt.shape[1:] != dr.shape[1:]:
            raise ShapeError("reference_increments", (self.horizon,), tuple(dr.shape))
        return np.asarray(-(self.K @ xt) - self.preview_gains @ dr)

    def simulate(self, reference: Any, initial_state: Any = None) -> LipmTrajectory:
        """Run the controller on the cart-table model along a sampled ZMP reference.

        Args:
            reference: (T, 2) ZMP reference at ``t_k = k dt`` [m]; held at its last value
                beyond the end for the preview.
            initial_state: (3, 2) ``(c, cdot, cddot)`` per axis at ``t_0``; default at rest
                above ``reference[0]``.
        """
        r = as_float_array(reference, "reference")
        if r.ndim != 2 or r.shape[1] != 2 or r.shape[0] < 1 or not np.isfinite(r).all():
            raise InvalidInputError(
                f"reference must be a finite (T, 2) array of ZMP samples, got shape {r.shape}"
            )
        if initial_state is None:
            x = np.zeros((3, 2))
            x[0] = r[0]
        else:
            x = as_float_array(initial_state, "initial_state").copy()
            if x.shape != (3, 2):
                raise ShapeError("initial_state", (3, 2), tuple(x.shape))
            check_finite(x, "initial_state")
        T, N = r.shape[0], self.horizon
        padded = np.vstack([r, np.repeat(r[-1:], N + 1, axis=0)])
        dr = np.diff(padded, axis=0)  # dr[k] = r_{k+1} - r_k
        A, B, c = self._A, self._B[:, 0], self._C[0]
        K, f = self.K, self.preview_gains
        states = np.empty((T, 3, 2))
        jerk = np.empty((T, 2))
        x_prev = x.copy()
        u = np.zeros(2)
        for k in range(T):
            states[k] = x
            e = c @ x - r[k]
            du = -(K[0] * e + K[1:] @ (x - x_prev)) - f @ dr[k : k + N]
            u = u + du
            jerk[k] = u
            x_prev = x
            x = A @ x + np.outer(B, u)
        return _trajectory(self.model, states, r, jerk)


def _trajectory(
    model: CartTable, states: FloatArray, reference: FloatArray, jerk: FloatArray
) -> LipmTrajectory:
    zmp = states[:, 0] - model.com_height / model.gravity * states[:, 2]
    return LipmTrajectory(
        times=np.arange(states.shape[0], dtype=np.float64) * model.dt,
        com=states[:, 0].copy(),
        com_velocity=states[:, 1].copy(),
        com_acceleration=states[:, 2].copy(),
        zmp=zmp,
        zmp_reference=reference.copy(),
        jerk=jerk,
        com_height=model.com_height,
    )


@dataclass(frozen=True)
class WalkingPattern:
    """CoM trajectory of a footstep plan.

    Attributes:
        plan: the footstep plan.
        trajectory: the sampled CoM/ZMP trajectory.
        compute_time: wall time of the generation [s].
    """

    plan: FootstepPlan
    trajectory: LipmTrajectory
    compute_time: float


def preview_walking_pattern(
    plan: FootstepPlan,
    model: CartTable | None = None,
    options: PreviewOptions | None = None,
) -> WalkingPattern:
    """CoM trajectory for a footstep plan by preview control (reference from the plan)."""
    t0 = time.perf_counter()
    model = model or CartTable()
    times = model.sample_times(check_plan(plan).duration)
    ref = zmp_reference(plan, times)
    traj = PreviewController(model, options).simulate(ref)
    return WalkingPattern(plan, traj, time.perf_counter() - t0)
