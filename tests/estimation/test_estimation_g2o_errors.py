"""read_g2o: every malformed file gives an InvalidInputError naming the file and line (#15)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation.g2o import read_g2o, write_g2o
from taskspace.estimation.pose_graph import LandmarkEdge, PoseEdge, PoseGraph

GOOD = (
    "VERTEX_SE2 10 0 0 0\n"
    "VERTEX_SE2 11 1 0 0.1\n"
    "VERTEX_XY 20 2 1\n"
    "FIX 11\n"
    "EDGE_SE2 10 11 1 0 0.1 1 0 0 1 0 1\n"
    "EDGE_SE2_XY 11 20 1 1 4 1 3\n"
)


def test_good_file_is_read(tmp_path: Path) -> None:
    p = tmp_path / "good.g2o"
    p.write_text(GOOD)
    g = read_g2o(p)
    np.testing.assert_array_equal(g.poses, [[0, 0, 0], [1, 0, 0.1]])
    np.testing.assert_array_equal(g.landmarks, [[2, 1]])
    assert g.fixed == 1  # FIX 11 is the second pose
    assert (g.edges[0].i, g.edges[0].j) == (0, 1)
    np.testing.assert_array_equal(g.landmark_edges[0].information, [[4, 1], [1, 3]])


def test_round_trip_keeps_the_graph(tmp_path: Path) -> None:
    g = PoseGraph(
        poses=np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.2]]),
        landmarks=np.array([[3.0, 1.0]]),
        edges=[PoseEdge(0, 1, np.array([1.0, 0.5, 0.2]), np.diag([1.0, 2.0, 3.0]))],
        landmark_edges=[LandmarkEdge(1, 0, np.array([2.0, 0.5]), np.eye(2))],
        fixed=1,
    )
    p = tmp_path / "g.g2o"
    write_g2o(g, p)
    h = read_g2o(p)
    np.testing.assert_array_equal(h.poses, g.poses)
    assert h.fixed == 1


def test_missing_file_names_it(tmp_path: Path) -> None:
    p = tmp_path / "absent.g2o"
    with pytest.raises(InvalidInputError, match=r"absent\.g2o: cannot read the g2o file"):
        read_g2o(p)
    with pytest.raises(InvalidInputError, match="cannot read the g2o file"):
        read_g2o(tmp_path)  # a directory


def test_binary_file_is_refused(tmp_path: Path) -> None:
    p = tmp_path / "bin.g2o"
    p.write_bytes(b"\xff\xfe\x00VERTEX")
    with pytest.raises(InvalidInputError, match=r"bin\.g2o: not a g2o text file"):
        read_g2o(p)


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.0", 2, "VERTEX_SE2 needs 4 fields"),
        ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0", 3, "EDGE_SE2 needs 11"),
        ("VERTEX_SE2 0 0 0 0\nVERTEX_XY 5 1", 2, "VERTEX_XY needs 3 fields"),
        ("VERTEX_SE2 0 0 0 0\nFIX", 2, "FIX needs 1 fields"),
        ("VERTEX_SE2 zero 0 0 0", 1, "ids must be integers"),
        ("VERTEX_SE2 0 0 x 0", 1, "values must be numbers"),
        ("VERTEX_SE2 0 0 nan 0", 1, "values must be finite"),
        ("VERTEX_SE2 0 0 0 0\nVERTEX_XY 0 1 1", 2, "vertex id 0 is defined twice"),
        ("VERTEX_SE2 0 0 0 0\nFIX 3", 2, "FIX refers to unknown pose vertex 3"),
        ("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 0 1 0 0 1 0 0 1 0 1", 2, "joins vertex 0 to itself"),
        ("VERTEX_SE2 0 0 0 0\nEDGE_SE2_XY 0 4 1 1 1 0 1", 2, "unknown vertex 4"),
        ("VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1", 2, "unsupported g2o tag"),
    ],
)
def test_malformed_lines_name_the_file_and_line(
    tmp_path: Path, text: str, line: int, words: str
) -> None:
    p = tmp_path / "bad.g2o"
    p.write_text(text + "\n")
    with pytest.raises(InvalidInputError, match=rf"bad\.g2o:{line}: .*{words}"):
        read_g2o(p)


def test_file_without_poses_is_refused(tmp_path: Path) -> None:
    p = tmp_path / "empty.g2o"
    p.write_text("# nothing\n\n")
    with pytest.raises(InvalidInputError, match=r"empty\.g2o: no VERTEX_SE2 line"):
        read_g2o(p)


def test_every_truncation_of_a_good_file_is_read_or_refused(tmp_path: Path) -> None:
    """A file cut at any byte: a valid (smaller) graph or an InvalidInputError, nothing else."""
    p = tmp_path / "cut.g2o"
    for n in range(len(GOOD)):
        p.write_text(GOOD[:n])
        try:
            g = read_g2o(p)
        except InvalidInputError as exc:
            assert "cut.g2o" in str(exc)
            continue
        g.validate()
