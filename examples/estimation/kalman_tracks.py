"""KF, EKF and UKF tracks with 2-sigma covariance ellipses (slides 6:10, 7:26).

Linear CV target tracked with the KF; a car with range-bearing to a beacon tracked with the
EKF and UKF.
Run: python examples/estimation/kalman_tracks.py [--save DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import fast, finish, parse

from taskspace.estimation.constant_velocity_filter import constant_velocity_model
from taskspace.estimation.extended_kalman_filter import ExtendedKalmanFilter
from taskspace.estimation.kalman_filter import KalmanFilter
from taskspace.estimation.motion_models import KinematicCarModel
from taskspace.estimation.observation_models import RangeBearingModel
from taskspace.estimation.rts_smoother import rts_smooth
from taskspace.estimation.unscented_kalman_filter import UnscentedKalmanFilter
from taskspace.viz.plots_estimation import plot_covariance_ellipse


def main() -> None:
    args = parse(__doc__ or "")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(0)
    T = 30 if fast() else 100
    # --- linear KF + RTS
    F, Q, H = constant_velocity_model(0.1, 0.5)
    R = 0.05 * np.eye(2)
    x = np.array([0.0, 0.0, 1.0, 0.5])
    truth, zs = [], []
    for _ in range(T):
        x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
        truth.append(x)
        zs.append(H @ x + rng.multivariate_normal(np.zeros(2), R))
    truth, zs = np.array(truth), np.array(zs)
    res = KalmanFilter(F, H, Q, R, np.zeros(4), np.eye(4)).run(zs)
    sm = rts_smooth(res)
    fig1, ax = plt.subplots(figsize=(7, 5))
    ax.plot(*truth[:, :2].T, "k-", label="truth")
    ax.plot(*zs.T, "k.", ms=3, label="measurements")
    ax.plot(*res.means[:, :2].T, "b-", label="KF")
    ax.plot(*sm.means[:, :2].T, "g--", label="RTS smoother")
    for k in range(0, T, 10):
        plot_covariance_ellipse(ax, res.means[k], res.covs[k, :2, :2], color="b", lw=0.8)
    ax.legend()
    ax.set_aspect("equal")
    ax.set_title("Kalman filter and RTS smoother (2-sigma ellipses)")
    # --- EKF / UKF on a car with a range-bearing beacon
    car = KinematicCarModel(dt=0.1, wheelbase=2.5)
    sensor = RangeBearingModel(sigma_range=0.3, sigma_bearing=0.05)
    beacon = np.array([5.0, 8.0])
    u = np.array([3.0, 0.15])
    xt = np.zeros(3)
    states, meas = [], []
    for _ in range(T):
        xt = car.sample(xt, u, rng)
        states.append(xt)
        meas.append(sensor.predict(xt, beacon) + rng.normal(size=2) * [0.3, 0.05])
    states = np.array(states)
    Qc = car.state_covariance(np.zeros(3), u)
    f = lambda s, _u: car.mean(s, u)  # noqa: E731
    h = lambda s: sensor.predict(s, beacon)  # noqa: E731
    ekf = ExtendedKalmanFilter(
        f,
        lambda s, _u: car.jacobians(s, u)[0],
        h,
        lambda s: sensor.jacobians(s, beacon)[0],
        Qc,
        sensor.R,
        [0, 0, 0],
        0.1 * np.eye(3),
        residual=sensor.residual,
    ).run(meas)
    ukf = UnscentedKalmanFilter(
        f, h, Qc, sensor.R, [0, 0, 0], 0.1 * np.eye(3), residual=sensor.residual
    ).run(meas)
    fig2, ax = plt.subplots(figsize=(7, 5))
    ax.plot(*states[:, :2].T, "k-", label="truth")
    ax.plot(*ekf.means[:, :2].T, "b-", label="EKF")
    ax.plot(*ukf.means[:, :2].T, "m--", label="UKF")
    ax.plot(*beacon, "k^", ms=10, label="beacon")
    for k in range(0, T, 10):
        plot_covariance_ellipse(ax, ekf.means[k], ekf.covs[k, :2, :2], color="b", lw=0.8)
        plot_covariance_ellipse(ax, ukf.means[k], ukf.covs[k, :2, :2], color="m", lw=0.8)
    ax.legend()
    ax.set_aspect("equal")
    ax.set_title("EKF vs UKF, kinematic car with range-bearing beacon")
    for name, r in (("EKF", ekf), ("UKF", ukf)):
        print(
            f"{name} position RMSE: "
            f"{np.sqrt(np.mean(np.sum((r.means[:, :2] - states[:, :2]) ** 2, 1))):.3f} m"
        )
    finish({"kf_rts_track": fig1, "ekf_ukf_car": fig2}, args.save)


if __name__ == "__main__":
    main()
