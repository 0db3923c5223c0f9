"""Bad and extreme inputs to the pose-graph SLAM (issue #15): a right answer or a
TaskspaceError, never a bare exception or a silently wrong "converged" result.

Reference: a chain of exact odometry edges, whose MAP is the composition of the measurements
(by hand: poses (0, 0, 0), (1, 0, 0), (2, 0, 0)).
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError, ShapeError
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
    assert res.initial_cost == pytest.approx(2.0 * scale)  # two unit residuals, in user units


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
