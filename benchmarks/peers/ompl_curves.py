"""OMPL's Dubins and Reeds-Shepp state spaces: time per distance query, and a test fixture.

Runs in .venv-peers/ompl (pip install ompl numpy). The queries are those of
benchmarks/suites/planning2d.py (:func:`queries`, uniform poses in [-10, 10]^2 x [-pi, pi)).

``--mode time`` (default) prints one JSON line: for each space (``dubins``, ``reeds_shepp``)
the time per ``space.distance(a, b)`` call on states allocated and filled beforehand
(``distance``), and per query including filling the two states from Python floats
(``set_and_distance``): lists of samples [s], one per block of ``--block`` consecutive
queries (short enough to run between two preemptions on a loaded machine), ``--repeat``
passes over the queries; plus the sum of the distances (a check that both sides answer the
same queries).

``--mode fixture --out FILE.npz`` writes OMPL's answers for the test suite
(tests/planning/test_planning_curves_native.py, which must not need OMPL): ``--n`` queries
from ``--seed`` in a smaller box (where every word occurs), stored as float32 numbers; OMPL's
distances for two radii and its interpolated states at t = 0.3 and 0.7 (radius 1) of the first
``--n-interpolate`` queries. The file in the repository was written by::

    .venv-peers/ompl/bin/python benchmarks/peers/ompl_curves.py --mode fixture \\
        --n 2000 --seed 22 --out tests/planning/data/ompl_curves.npz
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from ompl import base as ob


def queries(n: int, seed: int = 0, half_width: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    lo, hi = [-half_width, -half_width, -np.pi], [half_width, half_width, np.pi]
    return rng.uniform(lo, hi, (n, 3)), rng.uniform(lo, hi, (n, 3))


def _space(kind: str, radius: float) -> ob.StateSpace:
    return ob.DubinsStateSpace(radius) if kind == "dubins" else ob.ReedsSheppStateSpace(radius)


def _state(space: ob.StateSpace, q: np.ndarray) -> ob.State:
    st = space.allocState()
    st.setX(float(q[0]))
    st.setY(float(q[1]))
    st.setYaw(float(q[2]))
    return st


def time_queries(n: int, repeat: int, block: int) -> dict[str, object]:
    S, G = queries(n)
    out: dict[str, object] = {"n": n, "block": block}
    for kind in ("dubins", "reeds_shepp"):
        space = _space(kind, 1.0)
        a = [_state(space, q) for q in S]
        b = [_state(space, q) for q in G]
        sl, gl = S.tolist(), G.tolist()
        dist = space.distance
        s_tmp, g_tmp = space.allocState(), space.allocState()
        only, with_set = [], []
        total = 0.0
        clock = time.perf_counter
        for _ in range(repeat):
            for lo in range(0, n, block):
                hi = min(lo + block, n)
                t0 = clock()
                for i in range(lo, hi):
                    dist(a[i], b[i])
                only.append((clock() - t0) / (hi - lo))
            total = 0.0
            for lo in range(0, n, block):
                hi = min(lo + block, n)
                t0 = clock()
                for i in range(lo, hi):
                    s, g = sl[i], gl[i]
                    s_tmp.setX(s[0])
                    s_tmp.setY(s[1])
                    s_tmp.setYaw(s[2])
                    g_tmp.setX(g[0])
                    g_tmp.setY(g[1])
                    g_tmp.setYaw(g[2])
                    total += dist(s_tmp, g_tmp)
                with_set.append((clock() - t0) / (hi - lo))
        out[kind] = {"distance": only, "set_and_distance": with_set, "sum": total}
    return out


def fixture(path: str, n: int, seed: int, n_interpolate: int) -> None:
    S, G = queries(n, seed, half_width=3.0)
    # float32 values (exact in float64): the fixture stores the queries in half the space
    S, G = S.astype(np.float32), G.astype(np.float32)
    radii = (1.0, 0.7)
    ts = (0.3, 0.7)
    data: dict[str, np.ndarray] = {
        "start": S,
        "goal": G,
        "radius": np.array(radii),
        "t": np.array(ts),
    }
    S64, G64 = S.astype(np.float64), G.astype(np.float64)
    for kind in ("dubins", "reeds_shepp"):
        dist = np.empty((len(radii), n))
        for k, r in enumerate(radii):
            space = _space(kind, r)
            for i in range(n):
                dist[k, i] = space.distance(_state(space, S64[i]), _state(space, G64[i]))
        # interpolated states of the first n_interpolate queries, radius radii[0]
        space = _space(kind, radii[0])
        out = space.allocState()
        interp = np.empty((n_interpolate, len(ts), 3))
        for i in range(n_interpolate):
            a, b = _state(space, S64[i]), _state(space, G64[i])
            for j, t in enumerate(ts):
                space.interpolate(a, b, t, out)
                interp[i, j] = (out.getX(), out.getY(), out.getYaw())
        data[f"{kind}_distance"] = dist
        data[f"{kind}_interpolate"] = interp
    np.savez_compressed(path, **data)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mode", choices=("time", "fixture"), default="time")
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--block", type=int, default=200)
    ap.add_argument("--seed", type=int, default=22)
    ap.add_argument("--n-interpolate", type=int, default=1000)
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    if args.mode == "fixture":
        fixture(args.out, args.n, args.seed, args.n_interpolate)
    else:
        print(json.dumps(time_queries(args.n, args.repeat, args.block)))


if __name__ == "__main__":
    main()
