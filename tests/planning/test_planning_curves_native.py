"""Compiled Dubins / Reeds-Shepp curves (taskspace/_native/curves.cpp) against two references.

* the NumPy implementations (``*_numpy``, the formulas the kernel transcribes): every word of
  every query, the shortest word, the distance, the poses along a path;
* OMPL 2.0.1's ``DubinsStateSpace`` / ``ReedsSheppStateSpace``, through a fixture written by
  ``benchmarks/peers/ompl_curves.py --mode fixture`` in the OMPL peer environment: distances
  of 2,000 queries for two radii, interpolated states of 1,000 of them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from _curve_reference import rs_words

from taskspace import _native
from taskspace._native import planning_kernel, status
from taskspace.errors import InvalidInputError, NotFiniteError, ShapeError
from taskspace.planning import dubins as db
from taskspace.planning import reeds_shepp as rs
from taskspace.planning.se2 import CurvePath, to_local

FIXTURE = Path(__file__).parent / "data" / "ompl_curves.npz"

if os.environ.get("TASKSPACE_REQUIRE_NATIVE"):

    def test_kernel_is_built() -> None:
        assert planning_kernel() is not None, status()


pytestmark = pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}")

RNG_BOXES = (0.5, 3.0, 10.0)  # half-widths of the query boxes, in units of the radius


def _queries(n: int, half_width: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    lo, hi = [-half_width, -half_width, -np.pi], [half_width, half_width, np.pi]
    return rng.uniform(lo, hi, (n, 3)), rng.uniform(lo, hi, (n, 3))


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture(scope="module")
def ompl() -> dict[str, np.ndarray]:
    data = np.load(FIXTURE)
    return {k: data[k].astype(np.float64) for k in data.files}


# ------------------------------------------------------------------ word by word against NumPy
@pytest.mark.parametrize("half_width", RNG_BOXES)
def test_every_reeds_shepp_formula_equals_numpy(half_width: float) -> None:
    kernel = planning_kernel()
    S, G = _queries(300, half_width, seed=1)
    x, y, phi = to_local(S, G, 1.0)
    ref = rs.reeds_shepp_formula_lengths(x, y, phi)
    valid_counts = np.zeros(len(rs.RS_FORMULAS), int)
    for i in range(len(S)):
        words = kernel.curve_words("reeds_shepp", x[i], y[i], phi[i])
        assert len(words) == len(rs.RS_FORMULAS) == 44
        for j, (_, lengths, ok) in enumerate(ref):
            assert (words[j] is not None) == bool(ok[i]), (i, j)
            if ok[i]:
                valid_counts[j] += 1
                np.testing.assert_allclose(words[j], lengths[i], rtol=0, atol=1e-11)
    if half_width == 3.0:  # every formula evaluation exists somewhere in this box
        assert valid_counts.min() > 0


def test_every_dubins_word_equals_numpy() -> None:
    kernel = planning_kernel()
    S, G = _queries(1000, 3.0, seed=2)
    x, y, phi = to_local(S, G, 1.0)
    lengths, valid = db.dubins_word_lengths(x, y, phi)
    for i in range(len(S)):
        words = kernel.curve_words("dubins", x[i], y[i], phi[i])
        for j in range(6):
            assert (words[j] is not None) == bool(valid[j, i]), (i, j)
            if valid[j, i]:
                np.testing.assert_allclose(words[j], lengths[j, i], rtol=0, atol=1e-11)
    assert valid.all(axis=1).any() and valid.sum(axis=1).min() > 0  # all six words exist


def test_the_kernel_words_cover_the_48_signed_reeds_shepp_words() -> None:
    kernel = planning_kernel()
    S, G = _queries(1500, 3.0, seed=0)
    x, y, phi = to_local(S, G, 1.0)
    seen = set()
    for i in range(len(S)):
        for f, lengths in zip(
            rs.RS_FORMULAS, kernel.curve_words("reeds_shepp", x[i], y[i], phi[i])
        ):
            if lengths is not None:
                seen.add(rs.signed_word(f.word, lengths))
    expected = {"".join(f"{c}{'+' if s > 0 else '-'}" for c, s, _ in w) for w in rs_words()}
    assert len(expected) == 48
    assert seen == expected


# ------------------------------------------------------------------- shortest word, distance
@pytest.mark.parametrize("half_width", RNG_BOXES)
@pytest.mark.parametrize("radius", [1.0, 0.35])
def test_distances_equal_numpy(half_width: float, radius: float) -> None:
    S, G = _queries(2000, half_width * radius, seed=3)
    for fast, ref in (
        (rs.reeds_shepp_distance, rs.reeds_shepp_distance_numpy),
        (db.dubins_distance, db.dubins_distance_numpy),
    ):
        got = fast(S, G, radius)
        want = ref(S, G, radius)
        assert got.shape == want.shape == (len(S),)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
        # single queries, broadcasting (a (3,) pose or a (1, 3) array on either side), lists
        assert fast(S[7], G[7], radius).shape == (1,)
        for one, many in ((S[7], G), (S[7:8], G), (G[3:4], S)):
            np.testing.assert_allclose(fast(one, many, radius), ref(one, many, radius), atol=1e-12)
            np.testing.assert_allclose(fast(many, one, radius), ref(many, one, radius), atol=1e-12)
        assert fast(S[:0], G[:0], radius).shape == (0,)
        np.testing.assert_allclose(fast(list(S[5]), tuple(G[5]), radius), want[5:6], atol=1e-12)


def _second_gap(paths: list[CurvePath]) -> float:
    """Length gap between the shortest path and the next path of another geometry."""
    best = paths[0]
    mid = best.pose_at_numpy(0.5 * best.length)
    for p in paths[1:]:
        if np.abs(p.pose_at_numpy(0.5 * p.length) - mid).max() > 1e-7:
            return p.length - best.length
    return np.inf


@pytest.mark.parametrize(
    ("fast", "ref", "paths"),
    [
        (rs.reeds_shepp_shortest, rs.reeds_shepp_shortest_numpy, rs.reeds_shepp_paths),
        (db.dubins_shortest, db.dubins_shortest_numpy, db.dubins_paths),
    ],
)
def test_shortest_paths_equal_numpy(fast, ref, paths) -> None:  # type: ignore[no-untyped-def]
    S, G = _queries(400, 3.0, seed=4)
    families = set()
    for i in range(len(S)):
        a, b = fast(S[i], G[i], 0.8), ref(S[i], G[i], 0.8)
        assert a.length == pytest.approx(b.length, abs=1e-12)
        assert a.start == b.start and a.radius == b.radius == 0.8
        if _second_gap(paths(S[i], G[i], 0.8)) > 1e-9:  # one shortest geometry: same word
            assert (a.family, a.word) == (b.family, b.word)
            np.testing.assert_allclose(a.lengths, b.lengths, atol=1e-12)
        families.add(a.family)
    assert len(families) >= (12 if fast is rs.reeds_shepp_shortest else 6)


def test_path_poses_equal_numpy_and_end_points_are_exact() -> None:
    S, G = _queries(300, 3.0, seed=5)
    S[:, 2] = _wrap(S[:, 2])
    for i in range(len(S)):
        for shortest in (rs.reeds_shepp_shortest, db.dubins_shortest):
            p = shortest(S[i], G[i], 0.6)
            s = np.linspace(-0.1, p.length + 0.1, 23)
            np.testing.assert_allclose(p.pose_at(s), p.pose_at_numpy(s), rtol=0, atol=1e-12)
            np.testing.assert_allclose(p.pose_at(0.4 * p.length), p.pose_at_numpy(0.4 * p.length))
            # the start exactly, the goal to rounding
            assert tuple(p.pose_at(0.0)) == p.start == tuple(S[i])
            end = p.pose_at(p.length)
            assert np.abs(end[:2] - G[i, :2]).max() < 1e-12
            assert abs(_wrap(end[2] - G[i, 2])) < 1e-12
            samples = p.sample(0.05)
            assert tuple(samples[0]) == tuple(S[i])
            np.testing.assert_allclose(samples[-1], end, rtol=0, atol=0)


# --------------------------------------------------------------------------- against OMPL
@pytest.mark.parametrize("kind", ["reeds_shepp", "dubins"])
def test_distances_equal_ompl(ompl: dict[str, np.ndarray], kind: str) -> None:
    fast = rs.reeds_shepp_distance if kind == "reeds_shepp" else db.dubins_distance
    S, G = ompl["start"], ompl["goal"]
    for k, radius in enumerate(ompl["radius"]):
        got = fast(S, G, float(radius))
        np.testing.assert_allclose(got, ompl[f"{kind}_distance"][k], rtol=1e-12, atol=1e-12)
        single = [fast(S[i], G[i], float(radius))[0] for i in range(0, len(S), 10)]
        np.testing.assert_allclose(single, ompl[f"{kind}_distance"][k][::10], atol=1e-12)


@pytest.mark.parametrize("kind", ["reeds_shepp", "dubins"])
def test_interpolation_equals_ompl(ompl: dict[str, np.ndarray], kind: str) -> None:
    shortest, paths = (
        (rs.reeds_shepp_shortest, rs.reeds_shepp_paths)
        if kind == "reeds_shepp"
        else (db.dubins_shortest, db.dubins_paths)
    )
    want = ompl[f"{kind}_interpolate"]
    radius, ts = float(ompl["radius"][0]), ompl["t"]

    def matches(p: CurvePath, i: int) -> bool:
        got = p.pose_at(ts * p.length)
        err_xy = np.abs(got[:, :2] - want[i][:, :2]).max()
        return bool(err_xy < 1e-9 and np.abs(_wrap(got[:, 2] - want[i][:, 2])).max() < 1e-9)

    ties = 0
    for i in range(len(want)):
        s, g = ompl["start"][i], ompl["goal"][i]
        p = shortest(s, g, radius)
        if matches(p, i):
            continue
        # OMPL took another shortest path of the same length (C|C|C and CC|C words have
        # mirror twins): it must be one of ours within 1e-9 of the shortest length
        twins = [q for q in paths(s, g, radius) if q.length < p.length + 1e-9]
        assert any(matches(q, i) for q in twins), (i, p.family, [q.family for q in twins])
        ties += 1
    assert ties < 0.01 * len(want)


# ------------------------------------------------------------------ inputs and the fallback
def test_bad_inputs_raise_taskspace_errors_through_the_kernel() -> None:
    for shortest in (rs.reeds_shepp_shortest, db.dubins_shortest):
        with pytest.raises(NotFiniteError):
            shortest((0.0, np.nan, 0.0), (1.0, 1.0, 0.0), 1.0)
        with pytest.raises(ShapeError):
            shortest((0.0, 0.0), (1.0, 1.0, 0.0), 1.0)
        with pytest.raises(InvalidInputError, match="radius"):
            shortest((0.0, 0.0, 0.0), (1.0, 1.0, 0.0), -1.0)
        # other numeric types are converted (validated path, then the kernel)
        p = shortest(np.array([0, 0, 0]), [1, 2, np.float32(0.5)], np.int64(1))
        assert p.length == pytest.approx(shortest((0.0, 0.0, 0.0), (1.0, 2.0, 0.5), 1.0).length)
    for distance in (rs.reeds_shepp_distance, db.dubins_distance):
        with pytest.raises(ShapeError):
            distance(np.zeros((4, 2)), np.zeros(3), 1.0)
        with pytest.raises(InvalidInputError, match="radius"):
            distance(np.zeros(3), np.ones(3), 0.0)
        d = distance(np.zeros((2, 3), dtype=np.float32), np.ones(3, dtype=int), 1)
        assert d.shape == (2,) and d[0] == pytest.approx(distance(np.zeros(3), np.ones(3), 1.0)[0])


def test_without_the_kernel_the_numpy_path_answers(monkeypatch: pytest.MonkeyPatch) -> None:
    S, G = _queries(50, 3.0, seed=6)
    fast = (rs.reeds_shepp_distance(S, G, 1.0), db.dubins_distance(S, G, 1.0))
    p = rs.reeds_shepp_shortest(S[0], G[0], 1.0)
    import taskspace.planning.se2 as se2

    for module, names in ((rs, ("shortest", "distance")), (db, ("shortest", "distance"))):
        for name in names:  # as when the kernel is not built
            monkeypatch.setattr(module, f"_native_{name}", module._no_kernel)
    monkeypatch.setattr(se2, "_native_poses", se2._no_kernel)
    np.testing.assert_allclose(rs.reeds_shepp_distance(S, G, 1.0), fast[0], atol=1e-12)
    np.testing.assert_allclose(db.dubins_distance(S, G, 1.0), fast[1], atol=1e-12)
    q = rs.reeds_shepp_shortest(S[0], G[0], 1.0)
    assert q.family == p.family and q.length == pytest.approx(p.length, abs=1e-12)
    np.testing.assert_allclose(q.pose_at([0.0, 0.3]), p.pose_at(np.array([0.0, 0.3])))
    assert _native.planning_kernel() is not None  # only the curves modules were patched
