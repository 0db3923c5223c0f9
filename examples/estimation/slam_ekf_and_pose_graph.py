"""EKF-SLAM map and a Manhattan pose graph before/after optimization (graph SLAM).

Run: python examples/estimation/slam_ekf_and_pose_graph.py [--save DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import fast, finish, parse

from taskspace.estimation.ekf_slam import EKFSLAM, EKFSLAMOptions
from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.observation_models import RangeBearingModel
from taskspace.estimation.pose_graph import manhattan_pose_graph, optimize_pose_graph
from taskspace.estimation.simulation import loop_controls, simulate_landmark_world
from taskspace.viz.plots_estimation import plot_covariance_ellipse, plot_pose_graph


def main() -> None:
    args = parse(__doc__ or "")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(0)
    motion = VelocityMotionModel(dt=0.2)
    sensor = RangeBearingModel(sigma_range=0.1, sigma_bearing=0.02, max_range=8.0)
    lms = rng.uniform(-8, 8, size=(20, 2))
    T = 60 if fast() else 160
    sim = simulate_landmark_world(motion, sensor, [0, -5, 0], loop_controls(T, 1.0, 0.2), lms, rng)
    res = EKFSLAM(
        motion, sensor, [0, -5, 0], 1e-6 * np.eye(3), EKFSLAMOptions(association="nearest_neighbor")
    ).run(list(sim.controls), sim.observations)
    fig1, ax = plt.subplots(figsize=(7, 7))
    ax.plot(*lms.T, "k^", label="true landmarks")
    ax.plot(*sim.states[:, :2].T, "k-", label="truth")
    ax.plot(*sim.dead_reckoning[:, :2].T, "r:", label="dead reckoning")
    ax.plot(*res.poses[:, :2].T, "b-", label="EKF-SLAM")
    for m, c in zip(res.landmarks, res.landmark_covs):
        plot_covariance_ellipse(ax, m, c, n_sigma=3.0, color="b", lw=0.8)
    ax.set_aspect("equal")
    ax.legend()
    ax.set_title("EKF-SLAM (nearest-neighbour association, 3-sigma landmark ellipses)")

    n = 500 if fast() else 3500
    graph, _truth = manhattan_pose_graph(n, np.random.default_rng(3))
    opt = optimize_pose_graph(graph)
    fig2, axes = plt.subplots(1, 2, figsize=(12, 6))
    plot_pose_graph(axes[0], graph.poses, graph.edges, color="r")
    axes[0].set_title(f"odometry initial guess (chi2 = {opt.initial_cost:.3g})")
    plot_pose_graph(axes[1], opt.poses, graph.edges, color="b")
    axes[1].set_title(f"optimized, {opt.iterations} iterations (chi2 = {opt.final_cost:.3g})")
    print(
        f"pose graph: {n} poses, {len(graph.edges)} edges, {opt.time_s:.2f} s, {opt.status.value}"
    )
    finish({"ekf_slam_map": fig1, "pose_graph": fig2}, args.save)


if __name__ == "__main__":
    main()
