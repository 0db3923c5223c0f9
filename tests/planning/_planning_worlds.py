"""Shared 2-D point-robot worlds for the sampling-planner tests."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace.planning import (
    BITStarOptions,
    PRMOptions,
    PRMStarOptions,
    RRTConnectOptions,
    RRTOptions,
    RRTStarOptions,
    bit_star,
    lazy_prm,
    lazy_prm_star,
    prm,
    prm_star,
    rrt,
    rrt_connect,
    rrt_star,
)
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions

# Axis-aligned boxes (xmin, ymin, xmax, ymax) in [0, 10]^2: a wall with a gap at y in [4, 6].
WALL = np.array([[4.5, 0.0, 5.5, 4.0], [4.5, 6.0, 5.5, 10.0]])


def box_free(boxes: np.ndarray):  # type: ignore[no-untyped-def]
    def free(q: np.ndarray) -> np.ndarray:
        x, y = q[:, 0:1], q[:, 1:2]
        inside = (x >= boxes[:, 0]) & (x <= boxes[:, 2]) & (y >= boxes[:, 1]) & (y <= boxes[:, 3])
        return ~inside.any(axis=1)

    return free


def wall_space(resolution: float = 0.05, boxes: np.ndarray = WALL) -> ConfigurationSpace:
    return ConfigurationSpace(
        [0.0, 0.0],
        [10.0, 10.0],
        FunctionChecker(box_free(boxes), lambda q: f"point {q} is inside a box"),
        edge=EdgeCheckOptions(resolution=resolution),
    )


def free_densely(path: np.ndarray, boxes: np.ndarray = WALL, step: float = 1e-3) -> bool:
    """Every point of every edge of ``path`` outside the boxes, checked every ``step``.

    The boxes themselves are the reference (not a planner's checker).
    """
    free = box_free(boxes)
    for a, b in itertools.pairwise(path):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        if not free(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)).all():
            return False
    return True


# Every sampling planner with its options class: name -> (planner, options).
PLANNERS: dict[str, tuple[Any, Any]] = {
    "rrt": (rrt, RRTOptions),
    "rrt_connect": (rrt_connect, RRTConnectOptions),
    "rrt_star": (rrt_star, RRTStarOptions),
    "bit_star": (bit_star, BITStarOptions),
    "prm": (prm, PRMOptions),
    "lazy_prm": (lazy_prm, PRMOptions),
    "prm_star": (prm_star, PRMStarOptions),
    "lazy_prm_star": (lazy_prm_star, PRMStarOptions),
}


def pinocchio_collision_flags(robot: Any, qs: np.ndarray) -> np.ndarray:
    """Collision flags of every row: Pinocchio's narrow phase on every pair, fresh data."""
    model, geom = robot._model, robot._collision_model
    flags = []
    for q in qs:
        gdata = geom.createData()
        flags.append(pin.computeCollisions(model, model.createData(), geom, gdata, q, True))
    return np.array(flags, dtype=bool)
