"""Named problems shared by tests (STYLE rule 16)."""

from __future__ import annotations

import numpy as np

from taskspace.model import Robot


def random_configurations(robot: Robot, n: int, seed: int = 0) -> list[np.ndarray]:
    """``n`` random configurations inside the limits (floating base near the origin)."""
    rng = np.random.default_rng(seed)
    return [robot.random_configuration(rng, base_box=0.5) for _ in range(n)]


def random_velocity(robot: Robot, seed: int = 0) -> np.ndarray:
    """A random velocity of unit-order magnitude."""
    return np.random.default_rng(seed + 1000).normal(size=robot.nv)
