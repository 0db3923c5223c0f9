import numpy as np
import pytest
from _curve_reference import brute_force_length, dubins_words, integrate_car
from hypothesis import given, settings
from hypothesis import strategies as st

from taskspace.errors import InvalidInputError, ShapeError
from taskspace.planning.dubins import (
    DUBINS_WORDS,
    dubins_distance,
    dubins_paths,
    dubins_shortest,
)
from taskspace.planning.se2 import to_local

coord = st.floats(-6.0, 6.0, allow_nan=False)
angle = st.floats(-np.pi, np.pi, allow_nan=False)
pose = st.tuples(coord, coord, angle)
radius = st.floats(0.2, 3.0)


def pose_err(a, b):
    d = np.asarray(a) - np.asarray(b)
    return max(abs(d[0]), abs(d[1]), abs((d[2] + np.pi) % (2 * np.pi) - np.pi))


QUERIES = [
    ((0.0, 0.0, 0.0), (4.0, 0.0, 0.0), 1.0),  # straight: LSL/RSR with zero arcs
    ((0.0, 0.0, 0.0), (0.5, 0.2, np.pi), 1.0),  # close: CCC
    ((1.0, -2.0, 0.3), (-3.0, 1.5, -2.0), 0.7),
    ((0.0, 0.0, np.pi / 2), (1.0, 1.0, -np.pi / 2), 1.3),
    ((2.0, 2.0, 1.0), (2.5, 1.0, 2.5), 0.5),
    ((0.0, 0.0, 0.0), (-1.0, 0.3, 0.1), 1.0),
]


@pytest.mark.parametrize(("start", "goal", "r"), QUERIES)
def test_shortest_equals_brute_force_minimum_over_all_words(start, goal, r):
    x, y, phi = to_local(np.array(start), np.array(goal), 1.0)
    ref = min(brute_force_length(w, (x, y, phi), r) for w in dubins_words())
    assert dubins_shortest(start, goal, r).length == pytest.approx(ref, abs=1e-7)


def test_straight_line_and_full_turn_lengths():
    # analytic: straight ahead = distance; goal behind on the same line needs a U-turn.
    assert dubins_shortest((0, 0, 0), (4, 0, 0), 1.0).length == pytest.approx(4.0, abs=1e-12)
    # goal at (0, 2r) facing back: exactly a half circle, length pi r.
    p = dubins_shortest((0, 0, 0), (0, 2.0, np.pi), 1.0)
    assert p.length == pytest.approx(np.pi, abs=1e-9)
    assert p.family in ("LSL", "LRL")


@pytest.mark.parametrize(("start", "goal", "r"), QUERIES)
def test_every_word_integrates_to_goal_with_the_car_ode(start, goal, r):
    wheelbase = 0.8
    paths = dubins_paths(start, goal, r)
    assert 4 <= len(paths) <= 6
    for p in paths:
        q = integrate_car(start, p.controls(wheelbase), wheelbase)
        assert pose_err(q, goal) < 1e-9, p.family
        assert pose_err(p.end, goal) < 1e-9


def test_curvature_bound_respected_by_samples_and_controls():
    r, wheelbase = 0.9, 0.5
    phi_max = np.arctan(wheelbase / r)
    for p in dubins_paths((0, 0, 0.4), (1.0, -2.0, 2.0), r):
        assert np.all(p.controls(wheelbase)[:, 0] > 0)  # forward only
        assert np.all(np.abs(p.controls(wheelbase)[:, 1]) <= phi_max + 1e-12)
        s = p.sample(0.01)
        # Menger curvature of consecutive sample triples
        a, b, c = s[:-2, :2], s[1:-1, :2], s[2:, :2]
        cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
        den = (
            np.linalg.norm(b - a, axis=1)
            * np.linalg.norm(c - b, axis=1)
            * np.linalg.norm(c - a, axis=1)
        )
        kappa = 2 * cross / np.maximum(den, 1e-300)
        assert np.all(kappa[den > 1e-12] <= 1 / r * (1 + 1e-4))
        # step between samples equals the arc spacing (path is parametrized by length)
        assert np.all(np.linalg.norm(np.diff(s[:, :2], axis=0), axis=1) <= 0.01 + 1e-12)


def test_words_are_the_six_of_slide_3_59():
    assert set(DUBINS_WORDS) == {"LRL", "RLR", "LSL", "LSR", "RSL", "RSR"}
    for p in dubins_paths((0, 0, 0), (0.5, 0.2, np.pi), 1.0):
        if p.family in ("LRL", "RLR"):
            assert np.pi < p.lengths[1] < 2 * np.pi  # beta in (pi, 2 pi)


@settings(max_examples=60, deadline=None)
@given(pose, pose, radius, st.floats(0.1, 10.0))
def test_length_scales_linearly_with_radius(s, g, r, k):
    a = dubins_shortest(s, g, r).length
    s2 = (s[0] * k, s[1] * k, s[2])
    g2 = (g[0] * k, g[1] * k, g[2])
    assert dubins_shortest(s2, g2, r * k).length == pytest.approx(k * a, rel=1e-9, abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(pose, pose, radius, pose)
def test_invariances_and_bounds(s, g, r, m):
    a = dubins_shortest(s, g, r).length
    # rigid motion of both poses
    c, sn = np.cos(m[2]), np.sin(m[2])

    def move(q):
        return (m[0] + c * q[0] - sn * q[1], m[1] + sn * q[0] + c * q[1], q[2] + m[2])

    assert dubins_shortest(move(s), move(g), r).length == pytest.approx(a, rel=1e-9, abs=1e-9)
    # driving the path backwards in time with flipped headings
    rev = dubins_shortest((g[0], g[1], g[2] + np.pi), (s[0], s[1], s[2] + np.pi), r).length
    assert rev == pytest.approx(a, rel=1e-9, abs=1e-9)
    assert a >= np.hypot(g[0] - s[0], g[1] - s[1]) - 1e-9
    assert a <= np.hypot(g[0] - s[0], g[1] - s[1]) + 4 * np.pi * r + 1e-9  # crude upper bound


def test_vectorised_distance_matches_single_queries():
    rng = np.random.default_rng(3)
    S = rng.uniform(-4, 4, (50, 3))
    G = rng.uniform(-4, 4, (50, 3))
    d = dubins_distance(S, G, 0.8)
    assert d.shape == (50,)
    for i in range(50):
        assert d[i] == pytest.approx(dubins_shortest(S[i], G[i], 0.8).length, abs=1e-12)


def test_pose_sampler_hits_segment_boundaries():
    p = dubins_shortest((0, 0, 0), (3, 3, np.pi / 2), 1.0)
    cuts = np.cumsum(np.abs(p.lengths))
    starts = p.segment_starts()
    for k, s in enumerate(cuts):
        assert pose_err(p.pose_at(s), starts[k + 1]) < 1e-12


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(InvalidInputError, match="radius must be finite and > 0"):
        dubins_shortest((0, 0, 0), (1, 1, 0), 0.0)
    with pytest.raises(ShapeError, match=r"start must have shape \(3,\)"):
        dubins_shortest((0, 0), (1, 1, 0), 1.0)
    with pytest.raises(InvalidInputError, match="goal has non-finite"):
        dubins_shortest((0, 0, 0), (np.nan, 1, 0), 1.0)
