"""Issue #22 audit: every segment a shortcut returns is checked at the checker's resolution.

``shortcut_path`` cuts a path at two random points ``p1`` (on segment ``i1``) and ``p2`` and
keeps ``q_i1 -> p1 -> p2 -> q_(i2+1)``. The pieces ``q_i1 -> p1`` and ``p2 -> q_(i2+1)`` lie on
segments that were free *at the resolution*, but their own points (``k / n`` of each piece)
were never checked. Here a thin wall sits between the points the resolution samples on the
input's first segment, so the input is valid at the resolution while pieces of that segment
are not. The reference is the space's own local planner on each returned segment, which is
the issue's definition ("checked at the checker's resolution"), plus the exact segment-wall
intersection to show the wall is really there. Dropping the piece checks in
``shortcut_path`` makes this test fail (audit, stop 23).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.shortcut import ShortcutOptions, shortcut_path
from taskspace.planning.smoothing import SmoothingOptions, smooth_bspline

WALL_X = (0.33, 0.37)  # a thin wall across y = 0, between the samples 0.3 and 0.4
WALL_Y = (-0.02, 0.02)
RESOLUTION = 0.1


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
        [-0.5, -0.5],
        [1.5, 1.5],
        FunctionChecker(_free),
        edge=EdgeCheckOptions(resolution=RESOLUTION),
    )


def _crosses_wall(a: np.ndarray, b: np.ndarray) -> bool:
    """Exact: does the segment a -> b meet the open wall rectangle (Liang-Barsky clipping)?"""
    t0, t1 = 0.0, 1.0
    d = b - a
    for k, (lo, hi) in enumerate((WALL_X, WALL_Y)):
        if abs(d[k]) < 1e-15:
            if not lo < a[k] < hi:
                return False
            continue
        ta, tb = sorted(((lo - a[k]) / d[k], (hi - a[k]) / d[k]))
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 >= t1:
            return False
    return True


PATH = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])


def test_the_input_is_valid_at_the_resolution_but_crosses_the_wall() -> None:
    space = _space()
    assert space.path_valid(PATH)  # samples at x = 0.1 k miss the wall
    assert _crosses_wall(PATH[0], PATH[1])  # ... which the first segment crosses
    # and a piece of that segment, sampled at its own k / n, meets it (n = 8: x = 0.36)
    assert not space.motion_valid(PATH[0], np.array([0.72, 0.0]))


@pytest.mark.parametrize(("seed", "iterations"), [(s, 1) for s in range(40)] + [(0, 200)])
def test_every_shortcut_segment_is_valid_at_the_resolution(seed: int, iterations: int) -> None:
    # one random shortcut per seed: its pieces q_0 -> p1 often cross the wall (later
    # shortcuts would replace them by the diagonal, which misses it)
    space = _space()
    opts = ShortcutOptions(max_iterations=iterations, time_limit_s=None, greedy=False, seed=seed)
    out = shortcut_path(space, PATH, opts)
    path = out.path
    np.testing.assert_array_equal(path[0], PATH[0])
    np.testing.assert_array_equal(path[-1], PATH[-1])
    for a, b in itertools.pairwise(path):
        assert space.motion_valid(a, b), (seed, a, b)
    assert out.length_after <= out.length_before + 1e-12


@pytest.mark.parametrize("max_step", [0.05, 0.2])
def test_every_smoothed_segment_is_valid_at_the_resolution(max_step: float) -> None:
    space = _space()
    out = smooth_bspline(space, PATH, SmoothingOptions(max_step=max_step))
    path = out.path
    np.testing.assert_allclose(path[[0, -1]], PATH[[0, -1]])
    for a, b in itertools.pairwise(path):
        assert space.motion_valid(a, b), (max_step, a, b)


def test_no_shortcut_waypoint_is_in_collision() -> None:
    # The new waypoints p1 and p2 lie between the checked points of their edges: the local
    # planner's segment check assumes its start valid and skips its end, so shortcut_path
    # must check them itself (it kept a Panda finger in a can on a MotionBenchMaker path).
    space = _space()
    in_wall = 0  # runs whose cut points (shortcut_path's first draw) fell in the wall
    for seed in range(200):
        opts = ShortcutOptions(max_iterations=1, time_limit_s=None, greedy=False, seed=seed)
        cuts = np.random.default_rng(seed).uniform(0.0, 2.0, 2)  # arc lengths on PATH
        in_wall += int(any(WALL_X[0] < x < WALL_X[1] for x in cuts))
        path = shortcut_path(space, PATH, opts).path
        np.testing.assert_array_equal(path[[0, -1]], PATH[[0, -1]])
        assert _free(path).all(), (seed, path)  # every waypoint free
        for a, b in itertools.pairwise(path):
            assert space.motion_valid(a, b), (seed, a, b)
    assert in_wall >= 3  # the case was drawn (else the test would prove nothing)
