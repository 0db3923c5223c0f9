"""Shared set-up of the path-optimization tests."""

from __future__ import annotations

import numpy as np

from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.trajopt.path_optimization import PathMultipliers, PathProblem


def sphere_scene() -> tuple[Robot, np.ndarray, np.ndarray, list[tuple[str, str]]]:
    """A Panda (own instance: a sphere is added) reaching from joint 1 at -0.8 to +0.8 rad.

    Returns the robot, start, goal and every link-vs-sphere collision pair.
    """
    robot = Robot.load("panda", convex_collision=True)
    robot.add_obstacle(Obstacle.sphere("ball", 0.12, [0.35, 0.0, 0.4]))
    q0 = robot.q_default.copy()
    q0[0] = -0.8
    qg = robot.q_default.copy()
    qg[0] = 0.8
    pairs = [p for p in robot.collision_pairs if "ball" in p]
    return robot, q0, qg, pairs


def perturbed_start(
    problem: PathProblem, q0: np.ndarray, qg: np.ndarray, seed: int
) -> tuple[np.ndarray, PathMultipliers]:
    """A noisy straight path from ``q0`` to ``qg`` and random (valid-sign) multipliers."""
    rng = np.random.default_rng(seed)
    T = problem.horizon
    path = np.linspace(q0, qg, T + 1) + 0.05 * rng.normal(size=(T + 1, q0.size))
    path[0] = q0
    mult = problem.zero_multipliers()
    for lam in mult.equality:
        lam[:] = rng.normal(size=lam.size)
    for lam in mult.inequality:
        lam[:] = rng.uniform(0.0, 0.5, size=lam.size)
    return path, mult
