"""Rauch-Tung-Striebel smoother: ``P(x_t | y_0:T)`` (smoothing, slide 7:13).

Backward recursion over a forward filter run (``F_k`` maps step ``k-1`` to ``k``):
``G_k = P_k F_{k+1}^T (P^-_{k+1})^-1``,
``x^s_k = x_k + G_k (x^s_{k+1} - x^-_{k+1})``,
``P^s_k = P_k + G_k (P^s_{k+1} - P^-_{k+1}) G_k^T``, starting from ``x^s_T = x_T``.

A singular predicted covariance (a state known exactly: zero prior variance and no process
noise on it, a constant parameter) takes its Moore-Penrose inverse: for a degenerate Gaussian,
``E[x_k | x_{k+1}, z_0..k] = x_k + P_k F^T (P^-_{k+1})^+ (x_{k+1} - x^-_{k+1})`` (the
difference lies in the range of ``P^-_{k+1}``), so the recursion stays exact.
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


def _gain(Pp: FloatArray, FP: FloatArray, step: int) -> FloatArray:
    """``G = (Pp^+ F P)^T`` for the predicted covariance ``Pp`` and ``FP = F P_k``.

    Cholesky when ``Pp`` is well conditioned (its smallest pivot squared above
    ``n eps 1e3`` times the largest diagonal entry); else the symmetric pseudo-inverse, the
    eigenvalues below that threshold times the largest taken as zero.
    """
    n = Pp.shape[0]
    if not np.isfinite(Pp).all():
        raise SolverError(f"predicted covariance at step {step} is not finite")
    top = float(np.max(np.diag(Pp))) if n else 0.0
    tol = n * np.finfo(float).eps * 1e3
    if top > 0.0:
        try:
            L = scipy.linalg.cholesky(Pp, lower=True)
            if float(np.min(np.diag(L))) ** 2 > tol * top:
                return np.asarray(scipy.linalg.cho_solve((L, True), FP).T)
        except np.linalg.LinAlgError:
            pass
    w, V = np.linalg.eigh(0.5 * (Pp + Pp.T))
    big = float(np.max(np.abs(w))) if n else 0.0
    if big > 0.0 and float(np.min(w)) < -tol * big:
        raise SolverError(
            f"predicted covariance at step {step} is not positive semidefinite "
            f"(eigenvalue {float(np.min(w)):.3g}, largest {big:.3g})"
        )
    keep = w > tol * big
    inverse = (V[:, keep] / w[keep]) @ V[:, keep].T
    return np.asarray((inverse @ FP).T)


def rts_smooth(result: FilterResult) -> SmootherResult:
    """Run the RTS backward pass over a :class:`FilterResult` (KF, EKF or UKF run).

    Args:
        result: forward filter run (needs predicted beliefs and transition Jacobians).

    Returns:
        The :class:`SmootherResult`.

    Raises:
        InvalidInputError: if the run failed or is empty.
        SolverError: a predicted covariance that is not finite or not positive
            semidefinite (eigenvalues below ``-tol`` times the largest).
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
        Gk = _gain(Pp, F @ result.covs[k], k + 1)
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
