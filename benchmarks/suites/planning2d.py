"""2-D planning suite: Dubins / Reeds-Shepp queries, grid search, kinodynamic RRT parking."""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import Row, Timing, measure
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


def run(quick: bool) -> list[Row]:
    rows: list[Row] = []
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
