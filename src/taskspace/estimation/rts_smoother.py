"""Rauch-Tung-Striebel smoother: ``P(x_t | y_0:T)`` (smoothing, slide 7:13).

Backward recursion over a forward filter run (``F_k`` maps step ``k-1`` to ``k``):
``G_k = P_k F_{k+1}^T (P^-_{k+1})^-1``,
``x^s_k = x_k + G_k (x^s_{k+1} - x^-_{k+1})``,
``P^s_k = P_k + G_k (P^s_{k+1} - P^-_{k+1}) G_k^T``, starting from ``x^s_T = x_T``.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from taskspace._validation import FloatArray
from taskspace.errors import InvalidInputError, SolverError
from taskspace.estimation.filter_result import FilterResult


class SmootherStatus(enum.Enum):
    """Outcome of a smoother run."""

    SUCCESS = "success"


@dataclass(frozen=True)
class SmootherResult:
    """Smoothed beliefs.

    Attributes:
        success: always ``True`` when returned (failures raise).
        status: outcome.
        means: ``(T, n)`` smoothed means ``E[x_k | z_0..T-1]``.
        covs: ``(T, n, n)`` smoothed covariances.
        gains: ``(T-1, n, n)`` smoother gains ``G_k``.
        time_s: wall time [s].
    """

    success: bool
    status: SmootherStatus
    means: FloatArray
    covs: FloatArray
    gains: FloatArray
    time_s: float


def rts_smooth(result: FilterResult) -> SmootherResult:
    """Run the RTS backward pass over a :class:`FilterResult` (KF, EKF or UKF run).

    Args:
        result: forward filter run (needs predicted beliefs and transition Jacobians).

    Returns:
        The :class:`SmootherResult`.

    Raises:
        InvalidInputError: if the run failed or is empty.
        SolverError: if a predicted covariance is singular.
    """
    if not isinstance(result, FilterResult):
        raise InvalidInputError(
            f"rts_smooth needs the FilterResult of a KF, EKF or UKF run, got "
            f"{type(result).__name__}"
        )
    if not result.success:
        raise InvalidInputError(f"cannot smooth a failed filter run: {result.message}")
    T, n = result.means.shape
    if T == 0:
        raise InvalidInputError("cannot smooth an empty filter run")
    t0 = time.perf_counter()
    xs = result.means.copy()
    Ps = result.covs.copy()
    G = np.empty((max(T - 1, 0), n, n))
    for k in range(T - 2, -1, -1):
        Pp = result.predicted_covs[k + 1]
        F = result.transition_jacobians[k + 1]
        try:
            cf = scipy.linalg.cho_factor(Pp)
            Gk = scipy.linalg.cho_solve(cf, F @ result.covs[k]).T
        except np.linalg.LinAlgError as exc:
            raise SolverError(f"predicted covariance at step {k + 1} is singular: {exc}") from exc
        xs[k] = result.means[k] + Gk @ (xs[k + 1] - result.predicted_means[k + 1])
        P = result.covs[k] + Gk @ (Ps[k + 1] - Pp) @ Gk.T
        Ps[k] = 0.5 * (P + P.T)
        G[k] = Gk
    return SmootherResult(
        success=True,
        status=SmootherStatus.SUCCESS,
        means=xs,
        covs=Ps,
        gains=G,
        time_s=time.perf_counter() - t0,
    )
