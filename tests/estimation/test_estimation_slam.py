"""SLAM against ground truth of simulated worlds; pose graphs; g2o round trip."""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.estimation.ekf_slam import EKFSLAM, EKFSLAMOptions
from taskspace.estimation.fastslam import FastSLAM, FastSLAMOptions
from taskspace.estimation.g2o import read_g2o, write_g2o
from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.observation_models import RangeBearingModel
from taskspace.estimation.pose_graph import (
    LandmarkEdge,
    PoseEdge,
    PoseGraph,
    PoseGraphOptions,
    compose,
    manhattan_pose_graph,
    optimize_pose_graph,
    relative,
)
from taskspace.estimation.simulation import loop_controls, simulate_landmark_world


@pytest.fixture(scope="module")
def world():
    rng = np.random.default_rng(0)
    motion = VelocityMotionModel(dt=0.2)
    sensor = RangeBearingModel(sigma_range=0.1, sigma_bearing=0.02, max_range=8.0)
    lms = rng.uniform(-8, 8, size=(20, 2))
    sim = simulate_landmark_world(
        motion, sensor, [0, -5, 0], loop_controls(160, 1.0, 0.2), lms, rng
    )
    return motion, sensor, lms, sim


@pytest.mark.parametrize("assoc,bound", [("known", 0.3), ("nearest_neighbor", 0.5)])
def test_ekf_slam_map_error_below_bound(world, assoc, bound):
    motion, sensor, lms, sim = world
    slam = EKFSLAM(motion, sensor, [0, -5, 0], 1e-6 * np.eye(3), EKFSLAMOptions(association=assoc))
    res = slam.run(list(sim.controls), sim.observations)
    assert res.success
    seen = np.unique(np.concatenate([o.ids for o in sim.observations]))
    assert set(res.landmark_ids.astype(int)) == set(seen.tolist())
    err = np.hypot(*(res.landmarks - lms[res.landmark_ids.astype(int)]).T)
    assert err.max() < bound  # stated bound [m]
    traj = np.hypot(*(res.poses[:, :2] - sim.states[1:, :2]).T)
    dr = np.hypot(*(sim.dead_reckoning[1:, :2] - sim.states[1:, :2]).T)
    assert traj.max() < bound and traj.max() < dr.max()
    if assoc == "nearest_neighbor":
        assert res.num_new <= len(seen) + 2


def test_fastslam_map_error_below_bound(world):
    motion, sensor, lms, sim = world
    fs = FastSLAM(
        motion, sensor, [0, -5, 0], 20, np.random.default_rng(1), FastSLAMOptions(num_particles=100)
    )
    res = fs.run(list(sim.controls), sim.observations)
    err = np.hypot(*(res.landmarks - lms[res.landmark_ids.astype(int)]).T)
    assert err.max() < 0.3
    assert np.hypot(*(res.poses[:, :2] - sim.states[1:, :2]).T).max() < 0.3


def test_slam_errors():
    m, s = VelocityMotionModel(), RangeBearingModel()
    with pytest.raises(UnknownNameError, match="valid associations are: known, nearest_neighbor"):
        EKFSLAM(m, s, np.zeros(3), np.eye(3), EKFSLAMOptions(association="jcbb"))
    with pytest.raises(InvalidInputError, match="P0 must be positive semi-definite"):
        EKFSLAM(m, s, np.zeros(3), -np.eye(3))
    with pytest.raises(InvalidInputError, match="num_particles must be an integer >= 1"):
        FastSLAM(m, s, np.zeros(3), 3, np.random.default_rng(0), FastSLAMOptions(num_particles=0))


# ---------------------------------------------------------------- pose graphs


def test_se2_compose_relative_inverse():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(10, 3)), rng.normal(size=(10, 3))
    np.testing.assert_allclose(compose(a, relative(a, b))[:, :2], b[:, :2], atol=1e-12)


@pytest.mark.parametrize("method", ["gauss_newton", "levenberg_marquardt"])
def test_pose_graph_recovers_truth_on_noise_free_data(method):
    g, truth = manhattan_pose_graph(300, np.random.default_rng(2), noise_scale=0.0)
    g.poses = g.poses + np.random.default_rng(3).normal(0, 0.1, g.poses.shape)
    g.poses[0] = truth[0]
    res = optimize_pose_graph(g, PoseGraphOptions(method=method))
    assert res.success and res.final_cost < 1e-12
    np.testing.assert_allclose(res.poses[:, :2], truth[:, :2], atol=1e-6)
    assert np.abs(np.angle(np.exp(1j * (res.poses[:, 2] - truth[:, 2])))).max() < 1e-6


def test_pose_graph_reduces_error_on_noisy_data():
    g, truth = manhattan_pose_graph(500, np.random.default_rng(4))
    assert any(abs(e.i - e.j) > 1 for e in g.edges)  # loop closures exist
    res = optimize_pose_graph(g)
    rmse = lambda P: np.sqrt(np.mean(np.sum((P[:, :2] - truth[:, :2]) ** 2, 1)))  # noqa: E731
    assert res.success and res.final_cost < 0.01 * res.initial_cost
    assert rmse(res.poses) < 0.25 * rmse(g.poses) and rmse(res.poses) < 0.6
    # chi-square at the optimum ~ dof = 3 E - 3 (P - 1)
    dof = 3 * len(g.edges) - 3 * (len(g.poses) - 1)
    assert 0.5 * dof < res.final_cost < 1.5 * dof


def test_pose_graph_with_landmarks_noise_free():
    truth = np.array([[0, 0, 0], [1, 0, 0.5], [1.5, 1, 1.2], [0.5, 1.5, 2.5]], dtype=float)
    lms = np.array([[2.0, 2.0], [-1.0, 1.0]])
    edges = [
        PoseEdge(i, i + 1, relative(truth[i], truth[i + 1]), np.eye(3) * 100) for i in range(3)
    ]
    ledges = []
    for i in range(4):
        for k in range(2):
            c, s = np.cos(truth[i, 2]), np.sin(truth[i, 2])
            d = lms[k] - truth[i, :2]
            ledges.append(
                LandmarkEdge(
                    i, k, np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]), np.eye(2) * 50
                )
            )
    g = PoseGraph(poses=truth + 0.2, landmarks=lms + 0.3, edges=edges, landmark_edges=ledges)
    g.poses[0] = truth[0]
    res = optimize_pose_graph(g)
    np.testing.assert_allclose(res.poses, truth, atol=1e-7)
    np.testing.assert_allclose(res.landmarks, lms, atol=1e-7)


def test_g2o_round_trip(tmp_path):
    g, _ = manhattan_pose_graph(50, np.random.default_rng(5))
    g.landmarks = np.array([[1.0, 2.0]])
    g.landmark_edges = [
        LandmarkEdge(3, 0, np.array([0.5, -0.25]), np.array([[4.0, 1.0], [1.0, 3.0]]))
    ]
    path = tmp_path / "g.g2o"
    write_g2o(g, path)
    h = read_g2o(path)
    np.testing.assert_array_equal(h.poses, g.poses)
    np.testing.assert_array_equal(h.landmarks, g.landmarks)
    assert [(e.i, e.j) for e in h.edges] == [(e.i, e.j) for e in g.edges]
    for a, b in zip(h.edges, g.edges):
        np.testing.assert_array_equal(a.measurement, b.measurement)
        np.testing.assert_array_equal(a.information, b.information)
    np.testing.assert_array_equal(h.landmark_edges[0].information, [[4.0, 1.0], [1.0, 3.0]])
    assert "EDGE_SE2 0 1" in path.read_text()


def test_g2o_and_graph_errors(tmp_path):
    p = tmp_path / "bad.g2o"
    p.write_text("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n")
    with pytest.raises(InvalidInputError, match=r"bad.g2o:2: edge refers to unknown vertex 7"):
        read_g2o(p)
    p.write_text("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n")
    with pytest.raises(InvalidInputError, match="unsupported g2o tag 'VERTEX_SE3:QUAT'"):
        read_g2o(p)
    g = PoseGraph(poses=np.zeros((2, 3)), edges=[PoseEdge(0, 5, np.zeros(3), np.eye(3))])
    with pytest.raises(InvalidInputError, match=r"edge \(0, 5\) refers to missing poses"):
        optimize_pose_graph(g)
    g = PoseGraph(poses=np.zeros((2, 3)), edges=[PoseEdge(0, 1, np.zeros(3), -np.eye(3))])
    with pytest.raises(InvalidInputError, match="information matrix is not positive definite"):
        optimize_pose_graph(g)
    with pytest.raises(UnknownNameError, match="unknown method 'newton'"):
        optimize_pose_graph(g, PoseGraphOptions(method="newton"))
