"""Result of the sampling-based planners (PRM, Lazy PRM, RRT, RRT-Connect).

Thread safety: :class:`PlannerStatus` is immutable; :class:`PlannerResult` and :class:`Tree` are
plain result data (arrays), not locked: do not modify them while another thread reads them.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class PlannerStatus(enum.Enum):
    """Why a sampling-based planner stopped."""

    SOLVED = "solved"
    """A collision-free path from start to goal was found."""
    TIME_LIMIT = "time_limit"
    """The wall-clock budget ran out before a path was found (also when a goal region gave
    no valid sample: ``log["goal_states"] == 0``; more time may find one)."""
    ITERATION_LIMIT = "iteration_limit"
    """The iteration (sample) budget ran out before a path was found (also when a goal
    region gave no valid sample: ``log["goal_states"] == 0``)."""
    NO_PATH = "no_path"
    """A query on a given roadmap (:func:`~taskspace.planning.prm_query`,
    :func:`~taskspace.planning.lazy_prm_query`): the roadmap does not connect start and goal
    (nor reaches a goal region's valid samples)."""
    UNCERTIFIED = "uncertified"
    """Paths were found but none could be certified free between its checked points
    (``certify=True``); ``path`` holds the last one and ``log`` the failing segment."""


@dataclass
class Tree:
    """A search tree: node configurations and parent indices (-1 for the root).

    Attributes:
        nodes: configurations, shape (n, d).
        parents: parent index of each node, shape (n,).
    """

    nodes: FloatArray
    parents: npt.NDArray[np.int64]

    @property
    def size(self) -> int:
        """Number of nodes."""
        return int(self.nodes.shape[0])

    def edges(self) -> FloatArray:
        """Edges as segments, shape (n - 1, 2, d) (for plots)."""
        child = np.flatnonzero(self.parents >= 0)
        return np.stack([self.nodes[self.parents[child]], self.nodes[child]], axis=1)

    def path_to(self, index: int) -> FloatArray:
        """Configurations from the root to node ``index``, shape (m, d)."""
        idx = [index]
        while self.parents[idx[-1]] >= 0:
            idx.append(int(self.parents[idx[-1]]))
        return self.nodes[idx[::-1]]


@dataclass
class PlannerResult:
    """Outcome of a planning query.

    Attributes:
        success: a path was found.
        status: why the planner stopped.
        path: waypoints from start to goal, shape (m, d); shape (0, d) on failure.
        path_length: length of ``path`` in the space's metric, ``space.path_length(path)``
            [rad or m] (``inf`` on failure).
        iterations: samples drawn (RRT iterations, PRM samples).
        collision_checks: configurations evaluated by the validity checker.
        edge_checks: local-planner (straight-line) queries.
        time_s: wall-clock planning time [s].
        trees: search trees (RRT: one, RRT-Connect: start and goal trees; PRM: none).
        log: extra diagnostics (roadmap sizes, shortcut statistics, ...).
        cost: the optimal planners' objective cost of ``path`` (``inf`` on failure; ``None``
            for planners without an objective).
    """

    success: bool
    status: PlannerStatus
    path: FloatArray
    path_length: float
    iterations: int
    collision_checks: int
    edge_checks: int
    time_s: float
    trees: list[Tree] = field(default_factory=list, repr=False)
    log: dict[str, Any] = field(default_factory=dict)
    cost: float | None = None
