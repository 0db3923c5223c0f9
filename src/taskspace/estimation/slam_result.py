"""Result of an online SLAM run (EKF-SLAM, FastSLAM)."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from taskspace._validation import FloatArray


class SLAMStatus(enum.Enum):
    """Outcome of a SLAM run."""

    SUCCESS = "success"
    NUMERICAL_FAILURE = "numerical_failure"


@dataclass(frozen=True)
class SLAMResult:
    """Trajectory and map estimated by an online SLAM filter.

    Attributes:
        success: ``True`` if every estimate stayed finite.
        status: outcome.
        poses: ``(T, 3)`` pose estimates after each step.
        landmarks: ``(L, 2)`` final landmark estimates (in the filter's own numbering).
        landmark_covs: ``(L, 2, 2)`` final landmark marginal covariances.
        landmark_ids: ``(L,)`` true id each map landmark was created from (``-1`` if unknown).
        num_associated: measurements matched to an existing landmark.
        num_new: landmarks created.
        num_rejected: measurements dropped by the gate (ambiguous).
        time_s: wall time [s].
        message: diagnostic text.
    """

    success: bool
    status: SLAMStatus
    poses: FloatArray
    landmarks: FloatArray
    landmark_covs: FloatArray
    landmark_ids: FloatArray
    num_associated: int
    num_new: int
    num_rejected: int
    time_s: float
    message: str = ""
