"""2-D planning suite: Dubins / Reeds-Shepp queries, grid search, kinodynamic RRT parking.

The Dubins and Reeds-Shepp distance rows compare with OMPL's ``DubinsStateSpace`` and
``ReedsSheppStateSpace`` in the same run (benchmarks/peers/ompl_curves.py in .venv-peers/ompl):
rounds alternate our loops over 2,000 queries (three passes) with the peer's loops over the
same queries (three passes, in its environment), one ``distance`` call per query from Python
on both sides; a sample is the mean time per query of a block of 200 consecutive queries
(short enough to run between two preemptions of this loaded 2-core machine).
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import Row, Timing, measure, run_peer
from taskspace.planning.car import CarModel
from taskspace.planning.dubins import dubins_distance, dubins_shortest
from taskspace.planning.grid import OccupancyGrid, grid_search, wavefront
from taskspace.planning.kinodynamic_rrt import KinodynamicRRTOptions, kinodynamic_rrt, parking_lot
from taskspace.planning.reeds_shepp import reeds_shepp_distance, reeds_shepp_shortest

SUITE = "planning2d"


# ----------------------------------------------------------------------------- scenes
def curve_queries(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    lo, hi = [-10, -10, -np.pi], [10, 10, np.pi]
    return rng.uniform(lo, hi, (n, 3)), rng.uniform(lo, hi, (n, 3))


def grid_scene(size: int = 500, seed: int = 0) -> OccupancyGrid:
    rng = np.random.default_rng(seed)
    occ = np.zeros((size, size), bool)
    for _ in range(size * 3 // 5):
        r, c = rng.integers(0, size - 20, 2)
        h, w = rng.integers(3, 20, 2)
        occ[r : r + h, c : c + w] = True
    occ[0, 0] = occ[-1, -1] = False
    return OccupancyGrid(occ)


def _per_call(fn, n: int, repeat: int) -> Timing:
    """Time a batched call and report per-element timings."""
    samples = []
    fn()
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        samples.append((time.perf_counter() - t0) / n)
    return Timing.from_samples(samples)


OMPL_SPACE = {"dubins": "DubinsStateSpace", "reeds_shepp": "ReedsSheppStateSpace"}


BLOCK = 200  # queries per timing sample: short enough to run between two preemptions


def _block_times(fn, sl: list, gl: list) -> list[float]:  # type: ignore[no-untyped-def, type-arg]
    """Mean time per query of each block of BLOCK consecutive queries [s]."""
    clock = time.perf_counter
    out = []
    for lo in range(0, len(sl), BLOCK):
        hi = min(lo + BLOCK, len(sl))
        t0 = clock()
        for i in range(lo, hi):
            fn(sl[i], gl[i], 1.0)
        out.append((clock() - t0) / (hi - lo))
    return out


def curves_against_ompl(quick: bool) -> list[Row]:
    """Single-query Dubins / Reeds-Shepp distance (and shortest path) against OMPL, same run."""
    n = 2000
    rounds = 2 if quick else 5
    S, G = curve_queries(n)  # the queries of ompl_curves.queries(n)
    sl = [tuple(q) for q in S.tolist()]
    gl = [tuple(q) for q in G.tolist()]
    funcs = {
        "dubins": (dubins_distance, dubins_shortest),
        "reeds_shepp": (reeds_shepp_distance, reeds_shepp_shortest),
    }
    ours: dict[tuple[str, str], list[float]] = {}
    peer: dict[tuple[str, str], list[float]] = {}
    sums: dict[str, float] = {}
    note = ""
    for _ in range(rounds):
        for kind, (dist, shortest) in funcs.items():
            for _ in range(3):
                ours.setdefault((kind, "distance"), []).extend(_block_times(dist, sl, gl))
                ours.setdefault((kind, "shortest"), []).extend(_block_times(shortest, sl, gl))
        try:
            args = ["--n", str(n), "--repeat", "3", "--block", str(BLOCK)]
            out = run_peer("ompl", "ompl_curves.py", args)
        except Exception as exc:  # a failing peer must not kill the suite
            out, note = None, f"ompl failed: {str(exc)[-300:]}"
        if out is None:
            note = note or "peer venv .venv-peers/ompl missing"
            break
        for kind in funcs:
            for variant in ("distance", "set_and_distance"):
                peer.setdefault((kind, variant), []).extend(out[kind][variant])
            sums[kind] = float(out[kind]["sum"])
    rows: list[Row] = []
    for kind, (dist, _) in funcs.items():
        scene = f"{kind.replace('_', '-')} distance, {n} random queries"
        ompl = f"ompl {OMPL_SPACE[kind]}.distance (states filled beforehand)"
        extra: dict[str, float] = {}
        if kind in sums:
            mine = float(dist(S, G, 1.0).sum())
            extra["sum_rel_diff_to_ompl"] = abs(mine - sums[kind]) / sums[kind]
        ratio_to = ompl if (kind, "distance") in peer else None
        rows.append(
            Row(
                SUITE,
                scene,
                f"taskspace {kind}_distance (single query)",
                Timing.from_samples(ours[(kind, "distance")]),
                extra,
                ratio_to=ratio_to,
                note=note,
            )
        )
        rows.append(
            Row(
                SUITE,
                scene,
                f"taskspace {kind}_shortest (single query, CurvePath)",
                Timing.from_samples(ours[(kind, "shortest")]),
                ratio_to=ratio_to,
            )
        )
        if ratio_to is not None:
            rows.append(Row(SUITE, scene, ompl, Timing.from_samples(peer[(kind, "distance")])))
            rows.append(
                Row(
                    SUITE,
                    scene,
                    f"ompl {OMPL_SPACE[kind]}.distance (filling the states + distance)",
                    Timing.from_samples(peer[(kind, "set_and_distance")]),
                    ratio_to=ompl,
                )
            )
    return rows


def run(quick: bool) -> list[Row]:
    rows: list[Row] = curves_against_ompl(quick)
    n_single = 100 if quick else 1000
    S, G = curve_queries(max(n_single, 10000))
    it = iter(range(10**9))

    def dub_one() -> None:
        i = next(it) % n_single
        dubins_shortest(S[i], G[i], 1.0)

    def rs_one() -> None:
        i = next(it) % n_single
        reeds_shepp_shortest(S[i], G[i], 1.0)

    reps = 100 if quick else 1000
    rows.append(
        Row(
            SUITE,
            "dubins shortest path",
            "taskspace (single query)",
            measure(dub_one, warmup=10, repeat=reps),
        )
    )
    rows.append(
        Row(
            SUITE,
            "dubins shortest path",
            "taskspace (batched distance, per query)",
            _per_call(lambda: dubins_distance(S, G, 1.0), len(S), 5 if quick else 20),
        )
    )
    rows.append(
        Row(
            SUITE,
            "reeds-shepp shortest path",
            "taskspace (single query)",
            measure(rs_one, warmup=10, repeat=reps),
        )
    )
    rows.append(
        Row(
            SUITE,
            "reeds-shepp shortest path",
            "taskspace (batched distance, per query)",
            _per_call(lambda: reeds_shepp_distance(S, G, 1.0), len(S), 5 if quick else 20),
        )
    )

    grid = grid_scene(500)
    res = grid_search(grid, (0, 0), (499, 499))
    rows.append(
        Row(
            SUITE,
            "grid 500x500 corner to corner",
            "taskspace A* (8-conn)",
            measure(
                lambda: grid_search(grid, (0, 0), (499, 499)), warmup=1, repeat=3 if quick else 10
            ),
            extra={"cost_cells": res.cost, "expanded": res.expanded},
        )
    )
    if not quick:
        d = grid_search(grid, (0, 0), (499, 499), method="dijkstra")
        rows.append(
            Row(
                SUITE,
                "grid 500x500 corner to corner",
                "taskspace Dijkstra (8-conn)",
                measure(
                    lambda: grid_search(grid, (0, 0), (499, 499), method="dijkstra"),
                    warmup=0,
                    repeat=3,
                ),
                extra={"cost_cells": d.cost, "expanded": d.expanded},
            )
        )
    rows.append(
        Row(
            SUITE,
            "grid 500x500 corner to corner",
            "taskspace wavefront (8-conn)",
            measure(lambda: wavefront(grid, (499, 499)), warmup=1, repeat=3 if quick else 10),
        )
    )

    model = CarModel()
    world, start, goal = parking_lot(lane_width=8.4)
    seeds = range(5 if quick else 30)
    times, lengths, nodes, ok = [], [], [], 0
    for seed in seeds:
        r = kinodynamic_rrt(
            model, world, start, goal, options=KinodynamicRRTOptions(seed=seed, max_iterations=3000)
        )
        times.append(r.time_s)
        ok += r.success
        lengths.append(r.length)
        nodes.append(r.n_nodes)
    rows.append(
        Row(
            SUITE,
            "car parking, lane 8.4 m",
            "taskspace kinodynamic RRT (Reeds-Shepp)",
            Timing.from_samples(times),
            extra={
                "success_rate": ok / len(seeds),
                "median_length_m": float(np.median(lengths)),
                "median_nodes": float(np.median(nodes)),
            },
        )
    )
    world, start, goal = parking_lot(lane_width=12.0)
    times, ok = [], 0
    for seed in seeds:
        r = kinodynamic_rrt(
            model,
            world,
            start,
            goal,
            options=KinodynamicRRTOptions(steering="dubins", seed=seed, max_iterations=3000),
        )
        times.append(r.time_s)
        ok += r.success
    rows.append(
        Row(
            SUITE,
            "car parking, lane 12 m",
            "taskspace kinodynamic RRT (Dubins)",
            Timing.from_samples(times),
            extra={"success_rate": ok / len(seeds)},
        )
    )
    return rows


if __name__ == "__main__":
    t0 = time.perf_counter()
    for row in run(quick=True):
        t = row.timing
        print(
            f"{row.scene:35s} {row.method:45s} median {t.median_us:10.1f} us  p95 "
            f"{t.p95_us:10.1f} us  {row.extra}"
        )
    print(f"total {time.perf_counter() - t0:.1f} s")
