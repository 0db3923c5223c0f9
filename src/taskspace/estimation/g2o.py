"""Read and write pose graphs in the g2o text format.

Supported lines (angles in radians; information as the upper triangle, row by row):

* ``VERTEX_SE2 id x y theta``
* ``VERTEX_XY id x y`` (landmark)
* ``EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33``
* ``EDGE_SE2_XY i k x y I11 I12 I22`` (landmark ``k`` seen from pose ``i``)
* ``FIX id``

Vertex ids may be arbitrary integers; poses and landmarks are renumbered in file order.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from taskspace.errors import InvalidInputError
from taskspace.estimation.pose_graph import LandmarkEdge, PoseEdge, PoseGraph


def _upper(values: list[float], n: int) -> np.ndarray:
    M = np.zeros((n, n))
    M[np.triu_indices(n)] = values
    return M + np.triu(M, 1).T


def read_g2o(path: str | Path) -> PoseGraph:
    """Parse a g2o file into a :class:`PoseGraph`.

    Raises:
        InvalidInputError: on malformed lines or edges to unknown vertices (with line number).
    """
    poses: list[list[float]] = []
    lms: list[list[float]] = []
    pose_id: dict[int, int] = {}
    lm_id: dict[int, int] = {}
    raw_edges: list[tuple[int, str, list[str]]] = []
    fixed_id = None
    with open(path) as fh:
        for lineno, line in enumerate(fh, 1):
            tok = line.split()
            if not tok or tok[0].startswith("#"):
                continue
            if tok[0] not in ("VERTEX_SE2", "VERTEX_XY", "EDGE_SE2", "EDGE_SE2_XY", "FIX"):
                raise InvalidInputError(
                    f"{path}:{lineno}: unsupported g2o tag '{tok[0]}'; supported are "
                    "VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, FIX"
                )
            try:
                if tok[0] == "VERTEX_SE2":
                    pose_id[int(tok[1])] = len(poses)
                    poses.append([float(v) for v in tok[2:5]])
                elif tok[0] == "VERTEX_XY":
                    lm_id[int(tok[1])] = len(lms)
                    lms.append([float(v) for v in tok[2:4]])
                elif tok[0] in ("EDGE_SE2", "EDGE_SE2_XY"):
                    raw_edges.append((lineno, tok[0], tok[1:]))
                else:
                    fixed_id = int(tok[1])
            except (ValueError, IndexError) as exc:
                raise InvalidInputError(f"{path}:{lineno}: malformed line: {line.strip()}") from exc
    edges, ledges = [], []
    for lineno, tag, f in raw_edges:
        try:
            if tag == "EDGE_SE2":
                if len(f) != 11:
                    raise ValueError("EDGE_SE2 needs 11 fields")
                edges.append(
                    PoseEdge(
                        pose_id[int(f[0])],
                        pose_id[int(f[1])],
                        np.array([float(v) for v in f[2:5]]),
                        _upper([float(v) for v in f[5:11]], 3),
                    )
                )
            else:
                if len(f) != 7:
                    raise ValueError("EDGE_SE2_XY needs 7 fields")
                ledges.append(
                    LandmarkEdge(
                        pose_id[int(f[0])],
                        lm_id[int(f[1])],
                        np.array([float(v) for v in f[2:4]]),
                        _upper([float(v) for v in f[4:7]], 2),
                    )
                )
        except KeyError as exc:
            raise InvalidInputError(
                f"{path}:{lineno}: edge refers to unknown vertex {exc}"
            ) from exc
        except ValueError as exc:
            raise InvalidInputError(f"{path}:{lineno}: malformed {tag}: {exc}") from exc
    return PoseGraph(
        poses=np.array(poses, dtype=np.float64).reshape(-1, 3),
        landmarks=np.array(lms, dtype=np.float64).reshape(-1, 2),
        edges=edges,
        landmark_edges=ledges,
        fixed=pose_id.get(fixed_id, 0) if fixed_id is not None else 0,
    )


def write_g2o(graph: PoseGraph, path: str | Path) -> None:
    """Write a :class:`PoseGraph` (poses get ids ``0..P-1``, landmarks ``P..P+L-1``)."""
    graph.validate()
    P = len(graph.poses)
    iu3, iu2 = np.triu_indices(3), np.triu_indices(2)
    fmt = lambda vals: " ".join(repr(float(v)) for v in vals)  # noqa: E731
    lines = [f"VERTEX_SE2 {i} {fmt(p)}" for i, p in enumerate(graph.poses)]
    lines += [f"VERTEX_XY {P + k} {fmt(l)}" for k, l in enumerate(graph.landmarks)]
    lines.append(f"FIX {graph.fixed}")
    lines += [
        f"EDGE_SE2 {e.i} {e.j} {fmt(e.measurement)} {fmt(np.asarray(e.information)[iu3])}"
        for e in graph.edges
    ]
    lines += [
        f"EDGE_SE2_XY {e.i} {P + e.k} {fmt(e.measurement)} {fmt(np.asarray(e.information)[iu2])}"
        for e in graph.landmark_edges
    ]
    Path(path).write_text("\n".join(lines) + "\n")
