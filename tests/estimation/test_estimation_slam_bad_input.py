"""Bad and extreme inputs to the SLAM back ends (pose graph, EKF-SLAM, FastSLAM; issue #15):
a right answer or a TaskspaceError, never a bare exception or a silently wrong result.

Reference: a chain of exact odometry edges, whose MAP is the composition of the measurements
(by hand: poses (0, 0, 0), (1, 0, 0), (2, 0, 0)).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation.ekf_slam import EKFSLAM, EKFSLAMOptions
from taskspace.estimation.fastslam import FastSLAM, FastSLAMOptions
from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.observation_models import (
    LandmarkObservation,
    RangeBearingModel,
)
from taskspace.estimation.pose_graph import (
    LandmarkEdge,
    PoseEdge,
    PoseGraph,
    compose,
    manhattan_pose_graph,
    optimize_pose_graph,
    relative,
)

STEP = np.array([1.0, 0.0, 0.0])
TRUTH = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])


def chain(info: np.ndarray | None = None, **kw: object) -> PoseGraph:
    info = np.eye(3) if info is None else info
    args: dict[str, object] = {
        "poses": np.zeros((3, 3)),
        "edges": [PoseEdge(0, 1, STEP, info), PoseEdge(1, 2, STEP, info)],
    }
    args.update(kw)
    return PoseGraph(**args)  # type: ignore[arg-type]


@pytest.mark.parametrize("scale", [1e-300, 1.0, 1e300])
def test_information_scale_does_not_change_the_map(scale: float) -> None:
    # information 1e300 I: J^T J overflowed, every step was rejected and the initial guess
    # (all poses at 0) came back CONVERGED
    res = optimize_pose_graph(chain(scale * np.eye(3)))
    assert res.success
    np.testing.assert_allclose(res.poses, TRUTH, atol=1e-9)
    assert res.initial_cost == pytest.approx(2.0 * scale, rel=1e-12, abs=0.0)  # user units


def test_disconnected_nodes_are_reported() -> None:
    # any placement of a node without factors is optimal (tests/test_no_hang.py keeps the free
    # pose where it was); the result now names the undetermined nodes
    graph = chain(poses=np.zeros((4, 3)), landmarks=np.zeros((1, 2)))
    assert graph.disconnected() == ([3], [0])
    res = optimize_pose_graph(graph)
    np.testing.assert_allclose(res.poses[:3], TRUTH, atol=1e-9)
    assert "poses [3] and landmarks [0] are not connected" in res.message


@pytest.mark.parametrize(
    "edge",
    [
        PoseEdge(0, 1.5, STEP, np.eye(3)),  # type: ignore[arg-type]  # was truncated to 1
        PoseEdge(0, "1", STEP, np.eye(3)),  # type: ignore[arg-type]
        PoseEdge(0, True, STEP, np.eye(3)),  # type: ignore[arg-type]
        PoseEdge(0, 1, np.array([1.0, 0.0]), np.eye(3)),  # bare ValueError (reshape)
        PoseEdge(0, 1, "abc", np.eye(3)),  # type: ignore[arg-type]
        PoseEdge(0, 1, np.array([1j, 0, 0]), np.eye(3)),  # imaginary part dropped
        PoseEdge(0, 1, np.array([np.nan, 0, 0]), np.eye(3)),  # FAILED result
        PoseEdge(0, 1, STEP, np.full((3, 3), np.nan)),
        PoseEdge(0, 1, STEP, np.array([[1.0, 5.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])),
        PoseEdge(0, 1, STEP, (1 + 1j) * np.eye(3)),
    ],
)
def test_bad_edges_are_refused(edge: PoseEdge) -> None:
    with pytest.raises(InvalidInputError):
        optimize_pose_graph(chain(edges=[edge, PoseEdge(1, 2, STEP, np.eye(3))]))


@pytest.mark.parametrize(
    "kw",
    [
        {"edges": None},
        {"edges": [(0, 1, STEP, np.eye(3))]},  # bare AttributeError
        {"fixed": 1.5},  # bare TypeError (slice)
        {"poses": np.zeros((3, 3), dtype=complex)},
        {"poses": "abc"},
        {
            "landmarks": np.zeros((1, 2)),
            "landmark_edges": [LandmarkEdge(0, 0, np.array([1.0, 0.0]), np.eye(3))],
        },  # bare reshape ValueError
        {
            "landmarks": np.zeros((1, 2)),
            "landmark_edges": [LandmarkEdge(0, 0.5, np.array([1.0, 0.0]), np.eye(2))],  # type: ignore[arg-type]
        },
    ],
)
def test_bad_graphs_are_refused(kw: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        optimize_pose_graph(chain(**kw))


def test_compose_and_relative_check_their_poses() -> None:
    a, b = np.array([1.0, 2.0, 0.5]), np.array([0.3, -0.2, 0.1])
    np.testing.assert_allclose(relative(a, compose(a, b)), b, atol=1e-15)
    with pytest.raises(ShapeError):  # bare IndexError
        compose([1.0, 2.0], b)
    with pytest.raises(InvalidInputError):  # bare ValueError
        relative("abc", b)
    with pytest.raises(InvalidInputError):  # returned NaN
        compose([np.nan, 0.0, 0.0], b)


@pytest.mark.parametrize(
    "args, kw",
    [
        ((2.5, np.random.default_rng(0)), {}),  # bare TypeError
        ((10**12, np.random.default_rng(0)), {}),  # bare MemoryError (21.8 TiB)
        ((10, None), {}),  # bare AttributeError
        ((10, np.random.default_rng(0)), {"sigma_xy": np.nan}),
        ((10, np.random.default_rng(0)), {"grid_size": 0}),  # walked off the grid
        ((10, np.random.default_rng(0)), {"noise_scale": -1.0}),
    ],
)
def test_manhattan_arguments_are_checked(args: tuple[object, ...], kw: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        manhattan_pose_graph(*args, **kw)  # type: ignore[arg-type]


# --- EKF-SLAM and FastSLAM -------------------------------------------------------------------

MOTION, SENSOR = VelocityMotionModel(), RangeBearingModel()
GOOD = LandmarkObservation(ids=np.array([0]), z=np.array([[2.0, 0.1]]))


def ekf(**kw: object) -> EKFSLAM:
    return EKFSLAM(MOTION, SENSOR, np.zeros(3), 0.01 * np.eye(3), **kw)  # type: ignore[arg-type]


def fastslam(options: FastSLAMOptions | None = None, **kw: object) -> FastSLAM:
    args: dict[str, object] = {"num_landmarks": 3, "rng": np.random.default_rng(0)}
    args.update(kw)
    return FastSLAM(MOTION, SENSOR, np.zeros(3), options=options, **args)  # type: ignore[arg-type]


def test_first_landmark_is_placed_by_the_inverse_model() -> None:
    # reference: pose (0, 0, 0), range 2, bearing 0.1 -> landmark 2 (cos 0.1, sin 0.1)
    f = ekf()
    f.update(GOOD)
    np.testing.assert_allclose(f.mu[3:], [2 * np.cos(0.1), 2 * np.sin(0.1)], rtol=1e-12)
    g = fastslam()
    g.update(GOOD)
    np.testing.assert_allclose(g.means[:, 0], [[2 * np.cos(0.1), 2 * np.sin(0.1)]] * 100)


@pytest.mark.parametrize(
    "obs",
    [
        LandmarkObservation(ids=np.array([0.5]), z=np.array([[2.0, 0.1]])),  # truncated to 0
        LandmarkObservation(ids=np.array([np.nan]), z=np.array([[2.0, 0.1]])),  # bare
        LandmarkObservation(ids=np.array(["a"]), z=np.array([[2.0, 0.1]])),  # bare
        LandmarkObservation(ids=np.array([0, 1]), z=np.array([[2.0, 0.1]])),  # id 1 dropped
        LandmarkObservation(ids=np.array([0]), z=np.array([[2.0, 0.1, 3.0]])),  # bare
        LandmarkObservation(ids=np.array([0]), z=np.array([2.0, 0.1])),  # bare
        LandmarkObservation(ids=np.array([0]), z=np.array([[np.nan, 0.1]])),
        LandmarkObservation(ids=np.array([0]), z=np.array([[2.0 + 1j, 0.1]])),
        LandmarkObservation(ids=np.array([0]), z="ab"),  # type: ignore[arg-type]
        None,  # bare AttributeError
    ],
)
def test_bad_observations_are_refused(obs: LandmarkObservation) -> None:
    for f in (ekf(), fastslam()):
        with pytest.raises(InvalidInputError):
            f.update(obs)


def test_known_association_refuses_unknown_ids() -> None:
    # two "-1" measurements of different landmarks were merged into one landmark "-1"
    obs = LandmarkObservation(ids=np.array([-1, -1]), z=np.array([[2.0, 0.1], [3.0, -1.0]]))
    with pytest.raises(InvalidInputError, match="nearest_neighbor"):
        ekf().update(obs)
    nn = ekf(options=EKFSLAMOptions(association="nearest_neighbor"))
    nn.update(obs)
    assert nn.num_landmarks == 2


@pytest.mark.parametrize(
    "options",
    [
        EKFSLAMOptions(gate=np.nan),  # every measurement rejected silently
        EKFSLAMOptions(gate=1.5),
        EKFSLAMOptions(gate=1.0),  # infinite gate: everything associated
        EKFSLAMOptions(new_landmark=0.0),
        EKFSLAMOptions(gate=0.99, new_landmark=0.5),
        EKFSLAMOptions(gate="a"),  # type: ignore[arg-type]  # bare UFuncTypeError
    ],
)
def test_ekf_slam_gates_are_checked(options: EKFSLAMOptions) -> None:
    with pytest.raises(InvalidInputError):
        ekf(options=options)


@pytest.mark.parametrize(
    "options, kw",
    [
        (FastSLAMOptions(num_particles=2.5), {}),  # type: ignore[arg-type]  # bare TypeError
        (FastSLAMOptions(num_particles="a"), {}),  # type: ignore[arg-type]
        (FastSLAMOptions(num_particles=10**12), {}),  # bare MemoryError
        (None, {"num_landmarks": 10**12}),  # bare MemoryError (1.4 PiB)
        (None, {"num_landmarks": 2.5}),
        (FastSLAMOptions(ess_threshold=np.nan), {}),  # never resampled
        (FastSLAMOptions(ess_threshold=-1.0), {}),
        (None, {"rng": None}),  # bare AttributeError at the first predict
    ],
)
def test_fastslam_arguments_are_checked(options: FastSLAMOptions, kw: dict[str, object]) -> None:
    with pytest.raises(InvalidInputError):
        fastslam(options, **kw)


def test_range_bearing_model_checks_its_noise() -> None:
    with pytest.raises(InvalidInputError):
        RangeBearingModel(sigma_range=np.nan)  # R had a NaN entry
    with pytest.raises(InvalidInputError):
        RangeBearingModel(max_range=np.nan)
    assert RangeBearingModel(max_range=np.inf).max_range == np.inf
