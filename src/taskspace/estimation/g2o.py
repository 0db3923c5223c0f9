"""Read and write pose graphs in the g2o text format.

Supported lines (angles in radians; information as the upper triangle, row by row):

* ``VERTEX_SE2 id x y theta``
* ``VERTEX_XY id x y`` (landmark)
* ``EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33``
* ``EDGE_SE2_XY i k x y I11 I12 I22`` (landmark ``k`` seen from pose ``i``)
* ``FIX id`` (at most one fixed pose: FIX lines naming other vertices are refused)

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


_FIELDS = {"VERTEX_SE2": 4, "VERTEX_XY": 3, "EDGE_SE2": 11, "EDGE_SE2_XY": 7, "FIX": 1}
"""Number of fields after the tag of each supported line."""


def _numbers(where: str, tag: str, fields: list[str]) -> tuple[list[int], list[float]]:
    """The two ids (one for vertices and FIX) and the finite values of a line's fields."""
    n_ids = 2 if tag.startswith("EDGE") else 1
    if len(fields) != _FIELDS[tag]:
        raise InvalidInputError(
            f"{where}: {tag} needs {_FIELDS[tag]} fields after the tag, got {len(fields)} "
            "(truncated line?)"
        )
    try:
        ids = [int(v) for v in fields[:n_ids]]
    except ValueError:
        raise InvalidInputError(
            f"{where}: {tag} ids must be integers, got {' '.join(fields[:n_ids])}"
        ) from None
    try:
        values = [float(v) for v in fields[n_ids:]]
    except ValueError as exc:
        raise InvalidInputError(f"{where}: {tag} values must be numbers: {exc}") from None
    if not all(np.isfinite(values)):
        raise InvalidInputError(f"{where}: {tag} values must be finite, got {fields[n_ids:]}")
    return ids, values


def read_g2o(path: str | Path) -> PoseGraph:
    """Parse a g2o file into a :class:`PoseGraph`.

    Raises:
        InvalidInputError: the file cannot be read (missing, a directory, not text), or a
            line is malformed or truncated, repeats a vertex id, or refers to an unknown
            vertex, or the file has no ``VERTEX_SE2``; the message names the file and the
            line.
    """
    poses: list[list[float]] = []
    lms: list[list[float]] = []
    pose_id: dict[int, int] = {}
    lm_id: dict[int, int] = {}
    raw_edges: list[tuple[str, str, list[int], list[float]]] = []
    fixed: tuple[str, int] | None = None
    try:
        with open(path, encoding="utf-8") as fh:
            lines = fh.readlines()
    except OSError as exc:
        raise InvalidInputError(
            f"{path}: cannot read the g2o file ({exc.strerror or exc})"
        ) from exc
    except UnicodeDecodeError as exc:
        raise InvalidInputError(f"{path}: not a g2o text file ({exc})") from exc
    for lineno, line in enumerate(lines, 1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        where = f"{path}:{lineno}"
        tag = tok[0]
        if tag not in _FIELDS:
            raise InvalidInputError(
                f"{where}: unsupported g2o tag '{tag}'; supported are "
                "VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, FIX"
            )
        ids, values = _numbers(where, tag, tok[1:])
        if tag in ("VERTEX_SE2", "VERTEX_XY"):
            if ids[0] in pose_id or ids[0] in lm_id:
                raise InvalidInputError(f"{where}: vertex id {ids[0]} is defined twice")
            if tag == "VERTEX_SE2":
                pose_id[ids[0]] = len(poses)
                poses.append(values)
            else:
                lm_id[ids[0]] = len(lms)
                lms.append(values)
        elif tag == "FIX":
            if fixed is not None and fixed[1] != ids[0]:  # the last FIX was kept silently
                raise InvalidInputError(
                    f"{where}: a second FIX (vertex {ids[0]}; line {fixed[0].rsplit(':', 1)[1]} "
                    f"fixes vertex {fixed[1]}): a PoseGraph holds one pose fixed, keep one FIX line"
                )
            fixed = (where, ids[0])
        else:
            raw_edges.append((where, tag, ids, values))
    if not poses:
        raise InvalidInputError(f"{path}: no VERTEX_SE2 line (a pose graph needs poses)")
    edges, ledges = [], []
    for where, tag, ids, values in raw_edges:
        landmark = tag == "EDGE_SE2_XY"
        second, kind = (lm_id, "landmark (VERTEX_XY)") if landmark else (pose_id, "pose")
        if ids[0] not in pose_id:
            raise InvalidInputError(
                f"{where}: edge refers to unknown vertex {ids[0]} ({tag} starts at a pose)"
            )
        if ids[1] not in second:
            raise InvalidInputError(
                f"{where}: edge refers to unknown vertex {ids[1]} ({tag} ends at a {kind})"
            )
        if not landmark and ids[0] == ids[1]:
            raise InvalidInputError(f"{where}: EDGE_SE2 joins vertex {ids[0]} to itself")
        if landmark:
            ledges.append(
                LandmarkEdge(
                    pose_id[ids[0]], lm_id[ids[1]], np.array(values[:2]), _upper(values[2:], 2)
                )
            )
        else:
            edges.append(
                PoseEdge(
                    pose_id[ids[0]], pose_id[ids[1]], np.array(values[:3]), _upper(values[3:], 3)
                )
            )
    fixed_index = 0
    if fixed is not None:
        if fixed[1] not in pose_id:
            raise InvalidInputError(f"{fixed[0]}: FIX refers to unknown pose vertex {fixed[1]}")
        fixed_index = pose_id[fixed[1]]
    return PoseGraph(
        poses=np.array(poses, dtype=np.float64).reshape(-1, 3),
        landmarks=np.array(lms, dtype=np.float64).reshape(-1, 2),
        edges=edges,
        landmark_edges=ledges,
        fixed=fixed_index,
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
