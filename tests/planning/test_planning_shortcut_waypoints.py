"""``shortcut_path``'s new waypoints are checked themselves, not only the segments between them.

A shortcut cuts the path at two random points ``p1`` and ``p2`` and keeps ``q_i1 -> p1 -> p2 ->
q_(i2+1)``. ``p1`` and ``p2`` lie on edges that are free *at the resolution* (their points
``k / n``), so they may fall between those points, inside an obstacle the edge grazes; the
local planner's segment check assumes its start valid and skips its end, so the new waypoints
were never checked and a result could stop inside an obstacle (found on a MotionBenchMaker
path: a shortcut waypoint with the Panda's finger in the can). Reference: the checker's own
verdict on every returned waypoint, and the exact segment-wall intersection for the input.
"""

from __future__ import annotations

import itertools

import numpy as np

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.shortcut import ShortcutOptions, shortcut_path

# A wall across y = 0 between the samples x = 0.3 and x = 0.4 of the first edge (resolution
# 0.1): the input is valid at the resolution, yet 9 % of that edge lies in the wall.
WALL_X = (0.305, 0.395)
WALL_Y = (-0.02, 0.02)
PATH = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])


def _free(Q: np.ndarray) -> np.ndarray:
    inside = (
        (Q[:, 0] > WALL_X[0])
        & (Q[:, 0] < WALL_X[1])
        & (Q[:, 1] > WALL_Y[0])
        & (Q[:, 1] < WALL_Y[1])
    )
    return ~inside


def _space() -> ConfigurationSpace:
    return ConfigurationSpace(
        [-0.5, -0.5], [1.5, 1.5], FunctionChecker(_free), edge=EdgeCheckOptions(resolution=0.1)
    )


def test_the_input_is_valid_at_the_resolution() -> None:
    space = _space()
    assert space.path_valid(PATH)
    # the first edge passes through the wall (x in (0.305, 0.395) at y = 0)
    assert not _free(np.array([[0.35, 0.0]]))[0]


def test_no_returned_waypoint_is_in_collision() -> None:
    space = _space()
    cut_in_wall = 0  # runs whose first cut point fell in the wall (the draw of shortcut_path)
    for seed in range(80):
        opts = ShortcutOptions(max_iterations=1, time_limit_s=None, greedy=False, seed=seed)
        # shortcut_path's first draw: two arc lengths on the path of length 2
        s = np.sort(np.random.default_rng(seed).uniform(0.0, 2.0, 2))
        cut_in_wall += int(any(WALL_X[0] < x < WALL_X[1] for x in s))
        out = shortcut_path(space, PATH, opts)
        path = out.path
        np.testing.assert_array_equal(path[[0, -1]], PATH[[0, -1]])
        assert _free(path).all(), (seed, path)  # every waypoint free
        for a, b in itertools.pairwise(path):
            assert space.motion_valid(a, b), (seed, a, b)
    assert cut_in_wall >= 3  # the case was drawn (else the test would prove nothing)
