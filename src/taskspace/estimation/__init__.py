"""State estimation and SLAM (lecture sections 6-7): Bayes, particle and Kalman filters, SLAM.

The Kalman-family filters take what filterpy users pass: scalar or column measurements,
``update(None)`` (no measurement), a per-call ``R`` (and ``H``, or ``h`` / ``H_jacobian``),
process noise from :func:`discrete_white_noise` / :func:`continuous_white_noise` (filterpy's
``Q_discrete_white_noise`` / ``Q_continuous_white_noise``), and residual and mean functions
for angles (:func:`angle_residual`, :func:`angle_mean`).
"""

from __future__ import annotations

from taskspace.estimation.angles import angle_mean, angle_residual
from taskspace.estimation.batch_kalman_filter import BatchKalmanFilter
from taskspace.estimation.consistency import chi2_bounds, nees
from taskspace.estimation.constant_velocity_filter import (
    ConstantVelocityKalmanFilter,
    constant_velocity_model,
)
from taskspace.estimation.ekf_slam import EKFSLAM, EKFSLAMOptions
from taskspace.estimation.extended_kalman_filter import ExtendedKalmanFilter
from taskspace.estimation.fastslam import FastSLAM, FastSLAMOptions
from taskspace.estimation.filter_result import FilterResult, FilterStatus
from taskspace.estimation.g2o import read_g2o, write_g2o
from taskspace.estimation.gaussian import Gaussian, gaussian_product, gaussian_propagation
from taskspace.estimation.histogram_filter import HallwayWorld, HistogramFilter
from taskspace.estimation.kalman_filter import KalmanFilter, KalmanFilterOptions
from taskspace.estimation.motion_models import (
    KinematicCarModel,
    OdometryMotionModel,
    VelocityMotionModel,
)
from taskspace.estimation.observation_models import PositionModel, RangeBearingModel
from taskspace.estimation.particle_filter import ParticleFilter, ParticleFilterOptions
from taskspace.estimation.pose_graph import PoseGraph, PoseGraphOptions, optimize_pose_graph
from taskspace.estimation.process_noise import continuous_white_noise, discrete_white_noise
from taskspace.estimation.resampling import effective_sample_size
from taskspace.estimation.rts_smoother import rts_smooth
from taskspace.estimation.unscented_kalman_filter import UnscentedKalmanFilter, UnscentedOptions

__all__ = [
    "EKFSLAM",
    "BatchKalmanFilter",
    "ConstantVelocityKalmanFilter",
    "EKFSLAMOptions",
    "ExtendedKalmanFilter",
    "FastSLAM",
    "FastSLAMOptions",
    "FilterResult",
    "FilterStatus",
    "Gaussian",
    "HallwayWorld",
    "HistogramFilter",
    "KalmanFilter",
    "KalmanFilterOptions",
    "KinematicCarModel",
    "OdometryMotionModel",
    "ParticleFilter",
    "ParticleFilterOptions",
    "PoseGraph",
    "PoseGraphOptions",
    "PositionModel",
    "RangeBearingModel",
    "UnscentedKalmanFilter",
    "UnscentedOptions",
    "VelocityMotionModel",
    "angle_mean",
    "angle_residual",
    "chi2_bounds",
    "constant_velocity_model",
    "continuous_white_noise",
    "discrete_white_noise",
    "effective_sample_size",
    "gaussian_product",
    "gaussian_propagation",
    "nees",
    "optimize_pose_graph",
    "read_g2o",
    "rts_smooth",
    "write_g2o",
]
