"""Result of running a Gaussian filter (KF, EKF, UKF) over a measurement sequence.

Thread safety: :class:`FilterResult` (a frozen dataclass) and :class:`FilterStatus` are immutable
values; the result's arrays are not locked: do not modify them while another thread reads them.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from taskspace._validation import FloatArray


class FilterStatus(enum.Enum):
    """Outcome of a filter run."""

    SUCCESS = "success"
    NUMERICAL_FAILURE = "numerical_failure"


@dataclass(frozen=True)
class FilterResult:
    """Trajectory of beliefs of a Gaussian filter.

    Step ``k`` predicts from the belief of step ``k - 1`` (the prior for ``k = 0``) and then
    updates with measurement ``z_k`` (skipped when ``z_k`` is ``None``).

    Attributes:
        success: ``True`` if every step produced a finite, PSD covariance.
        status: outcome.
        means: ``(T, n)`` filtered means ``E[x_k | z_0..k]``.
        covs: ``(T, n, n)`` filtered covariances.
        predicted_means: ``(T, n)`` predicted means ``E[x_k | z_0..k-1]``.
        predicted_covs: ``(T, n, n)`` predicted covariances.
        transition_jacobians: ``(T, n, n)`` state-transition matrices (Jacobians for the EKF)
            used by the prediction of each step; what the RTS smoother needs.
        nis: ``(T,)`` normalized innovation squared ``r^T S^-1 r`` (NaN when no update).
        log_likelihood: ``sum_k log N(z_k | z_hat_k, S_k)``.
        num_updates: number of measurement updates performed.
        time_s: wall time of the run [s].
        message: diagnostic text (empty on success).
    """

    success: bool
    status: FilterStatus
    means: FloatArray
    covs: FloatArray
    predicted_means: FloatArray
    predicted_covs: FloatArray
    transition_jacobians: FloatArray
    nis: FloatArray
    log_likelihood: float
    num_updates: int
    time_s: float
    message: str = ""
