"""Sampling-based planning suite: MotionBenchMaker Panda problems (7 scenarios x 50).

Scenes (obstacle worlds, start/goal) are loaded before timing. For every problem: is it valid
(start and goal inside the limits and collision-free for example-robot-data's Panda, fingers
locked at 0.04 m, convex-hull collision geometry)? Then, with a 1 s limit:

* taskspace RRT-Connect (default options: step 0.5 rad, lazy fine checking with eager coarse
  checks at 0.15 rad, full resolution 0.03 rad on candidate paths, local sampling and turns
  for a trapped tree), run by the compiled planner
  (``taskspace/_native/planning_kernel.cpp``) when it is built, and the same algorithm in
  Python (``rrt_connect_python``, ``native=False``);
* the compiled RRT-Connect with the sphere checkers (``checker="spheres"``: the robot's
  conservative spheres as the broad phase and coal's exact narrow phase where they touch,
  the same answers; ``"spheres_only"``: spheres only, conservative, going on with
  ``"spheres"`` after 200 iterations without a path), every point of each returned
  path validated at the full resolution (the exact checker's lazy fine pass, the certified
  spheres elsewhere: see "Certified spheres" below; in the time);
  per-configuration check times of the three checkers on random configurations;
* taskspace RRT-Connect "classic" (every tree edge checked at 0.03 rad, uniform sampling and
  alternate turns only: Kuffner and LaValle's algorithm, the same checks as OMPL's RRTConnect
  at the same range; compiled when built) to show where the collision checks and the time go;
* taskspace Lazy PRM (single query: roadmap of 300 nodes, k = 12, 20 % of them near start and
  goal, grown by 300 nodes until connected, all inside the 1 s) and, in the quick run, PRM
  (200 nodes, k = 8, every edge checked).

First plans and repeated plans: ``rrt_connect_spheres_only_validator_spheres_first_plan`` is
the first plan on each problem's scene, right after its set-up (row ``scene_setup``: the
problem applied to the robot, the configuration space, the endpoint checks and the compiled
sphere checker, wall time; the robot's sphere model is built once per process, before); every
other row of ours is a repeated plan on the same scene, the headline
``rrt_connect_spheres_only_validator_spheres`` (the first plan's options and seed) after the
exact and sphere checkers' rows, one call. VAMP's rows are the minimum of 3 runs of its plan,
but for its "wall first call", its first plan on each problem's environment; the row
``rrt_connect_spheres_only_validator_spheres_min3`` times the headline's plan the same way
(the minimum of its single call and 2 more calls right after it), the peer of VAMP's
minimum rows; ``..._min3_3seeds`` the same with the seeds k, k + 1000 and k + 2000 (per
problem the median of the three seeds' least times): a change of the random stream alone
moves the one-seed row by up to 10 %; ``..._new_seed`` the first call of each of the seeds
k + 1000 and k + 2000 (per problem their median): a new plan on a scene already planned on,
without the speed-up of an identical plan repeated (the branch predictors learn it).

Peers in the same run, after ours: OMPL's RRTConnect calling OUR collision checker as its
validity callback (same resolution; range = our step, and OMPL's default range),
pyroboplan's RRT-Connect with its own collision checking, and VAMP's RRT-Connect with its own
sphere model and SIMD checks (its defaults: range 1.0, 32 points per rad; the wall time of the
Python call and VAMP's own clock; its paths checked afterwards by our exact checker). Per
scenario and over all scenarios ("all"): valid problems, solved within 1 s, median / p95 time,
collision checks, path length (raw and, for taskspace RRT-Connect, after shortcutting), ratios
to OMPL.
Our times are the wall time of each planner call (the options' validation, the result's
construction included), as the peers' times are of their solve calls; ``PlannerResult.time_s``
(from the call's entry to just before its result is built) is kept beside it as ``time_s``.

Measurements formerly kept in ``taskspace.planning.rrt_connect``'s docstring (oldest first)::

    Trapped trees: in pick problems the goal often lies in a tight region (fingers around an
    object in a shelf) from which steps towards uniform samples nearly always collide; the goal
    tree then stays at a few nodes while the start tree grows to thousands. When a tree has fewer
    than a quarter of the other's nodes, its target is, with probability ``local_sampling``, drawn
    around one of its own nodes (a Gaussian of standard deviation ``local_sigma``), which lets it
    grow out of the region (on the 313 valid MotionBenchMaker Panda problems: 313 instead of 309
    solved within 1 s). Such a tree also takes the other tree's turn with probability
    ``trapped_priority`` (the other tree then CONNECTs towards its new node): the free tree, whose
    EXTEND nearly always succeeds, would otherwise spend most of the collision checks on growing
    (cage: 86 % of the start tree's EXTEND succeed, 11-16 % of the goal tree's; half the checks
    went into the start tree's steps). Measured for the compiled planner against alternate turns
    (0) in the same runs, interleaved, on the 313 problems with three sets of 20 seeds: median time
    per scenario 2-15 % lower (cage 11-13 %) but box's in one set (+2 %), mean time 1-29 % lower
    but box's in one set (+5 %), all solved; for this module (3 seeds) 0.81x the total time.

    Compiled planner: ``RRTConnectOptions.native`` (default) runs this algorithm in C++
    (``taskspace/_native/planning_kernel.cpp``, compiled when taskspace is pip-installed)
    when the space's checker is a :class:`~taskspace.planning.CollisionChecker`; the collision
    checks call Pinocchio and coal directly (about 1.35 us per configuration inside the planner on
    the MotionBenchMaker Panda scenes, against 10-13 us through Python). Its random stream is its
    own (seeded by ``seed`` or by the ``rng`` passed), so its trees differ from this module's; its
    paths carry the same guarantee. Options are validated here before the call; the kernel
    checks the start and goal (finite, inside the bounds, free for the exact checker) and computes
    the path's length in the same call (a failed endpoint is then re-checked here for the error
    message), so a plan is one kernel call and a few Python objects (about 25-40 us of Python per
    plan, was 70-110 us). Measured on the 313
    valid MotionBenchMaker Panda problems (2026-11-25; ``benchmarks/results/planning_full.json``
    now holds the latest full run):
    313 solved within 1 s, median 0.56 ms (per scenario 0.35-0.75 ms, cage 3.3 ms); this module
    with the same compiled checker 1.70 ms; OMPL's RRTConnect at the same range calling the same
    checker through Python 3.29 ms (0.17x; per scenario 0.11-0.23x, cage 0.24x). OMPL's time is
    about 1 ms per query plus 2.7-2.9 us per check (fit of the scenario medians), ours about
    1.1-1.5 us per check: the ratio is lowest on the easy problems and tends to the ratio of the
    costs per check times that of the checks on the long ones (cage: 2,250 against 4,560 checks,
    median).

    Sphere checkers (``RRTConnectOptions.checker``, compiled planner only; #22 item 4): the
    robot's conservative spheres (:meth:`~taskspace.planning.CollisionChecker.sphere_model`,
    204 on the Panda) checked per link, per object and per sphere against the obstacles'
    primitives and the self pairs' spheres, with kinematics only (no geometry placements), see
    the kernel's header. ``"spheres"`` runs coal's exact narrow phase where spheres touch: the
    same answers as ``"mesh"`` (the same trees and paths, tested) at 0.86-1.3 us per
    configuration near the trees against 1.0-1.5 us (random configurations, which collide
    more often: 2.1-2.6 against 1.6-1.9 us); ``"spheres_only"`` stops at the spheres
    (0.73-0.9 us; 1.4-1.7 us on random configurations) and is conservative: 10-16 % of the
    random free configurations are refused, so tight goals (cage, the grasps of table_pick)
    become hard. The exact checker stays the final validator: with a sphere checker the lazy
    fine pass uses it, and the returned path's nodes and coarse points (all its points for the
    straight start-goal line) are re-checked with it, so every point of the path at the
    resolution is checked exactly once (a median of 60 re-check calls). Measured on the 313
    problems, seed 0, alternating with main's kernel in three rounds on a loaded 2-core machine
    (medians over the problems): ``"mesh"`` 0.98-1.18 ms, ``"spheres"`` 0.94-1.23 ms (per problem
    0.96-1.00x ``"mesh"``), ``"spheres_only"`` 0.89-1.11 ms with 292-293 of 313 solved (per
    solved problem 0.91-0.98x); OMPL's RRTConnect in the suite's run 5.24 ms. Since then
    ``"spheres_only"`` falls back to ``"spheres"`` after ``fallback_iterations`` (200) iterations
    without a path, inside the kernel (the trees stay: their nodes and coarse points are free for
    the spheres, hence free): on the 313 problems (seed = problem number, 1 s limit) 313 solved
    with the fallback (with a threshold of 100 or 300 too; 142 and 72 of them fell back), 295
    (94.3 %) without it. With the endpoint checks and the path length in the kernel and the
    link-level box tests in SSE2 lanes (2026-11-27; per problem the minimum of 5 runs of the
    seeded plan, two rounds alternating with main's kernel on a loaded 2-core machine, medians
    over the 313 problems): ``"mesh"`` 0.640-0.657 ms (main 0.702-0.748), ``"spheres"``
    0.669-0.687 ms (main 0.779-0.809), ``"spheres_only"`` 0.652-0.655 ms with 313 solved (main
    0.741-0.761 ms, 295-296 solved; mean 3.3-7.7 ms against 71 ms). Not the issue's
    0.1 ms: VAMP's tens of microseconds need the checks of many configurations at once in SIMD
    lanes (single precision, structure of arrays) and far fewer checks per plan, which this
    checker does not do; the kinematics alone cost about 0.22 us per configuration here.

    Batched sphere checks and the validator (2026-11-27, branch plan3): the sphere checkers
    check an edge's points four at a time (joint placements in structure-of-arrays lanes,
    sines and cosines in vector operations, then the sphere tests configuration by
    configuration with early exit): ``collisions_with`` 10-15 % cheaper per configuration, a
    plan's median 0-5 % (on the 313 problems, min of 5 runs per problem, two rounds
    alternating with main: ``"spheres_only"`` 0.612-0.639 ms against 0.642-0.654, ``"spheres"``
    0.649-0.684 against 0.669-0.683, ``"mesh"`` 0.635-0.655 against 0.645-0.648; 313 solved).
    The plan is bounded by the exact re-validation: a median returned path has 262 points at
    the 0.03 rad resolution, and the mesh checker takes 1.16 us per path point (310 us per
    plan, median over 63 problems), the ``"spheres"`` checker 0.69 us. The
    ``rrt_connect_spheres_only_validator_spheres`` row validates with ``"spheres"``
    (``RRTConnectOptions.validator``: the same answers, tested against Pinocchio, but "free"
    rests on the sphere model where no spheres touch) and skips the re-check that would
    repeat it: ``"spheres_only"`` 0.431-0.433 ms, ``"spheres"`` 0.462-0.465 ms (313 solved);
    with the quadrant of the vector sines chosen without branches, one more round against
    main: 0.404 and 0.446 ms (``"spheres_only"`` with the mesh validator 0.606, main 0.647).
    The issue's 0.1 ms stays out of reach: even the sphere checks of the path's points alone
    (0.65 us each) exceed it.

    Certified spheres, no re-check (2026-11-27, branch plan01): the sphere model carries a
    proved volume certificate (``sphere_model.certify_cover``: every point of each link's
    convex hull lies 10 um inside its spheres), so a sphere checker's "free" implies the
    exact checker's and the returned path is no longer re-checked with the mesh checker
    (every point of it was validated once: endpoints and fine pass by the validator, nodes
    and coarse points by the sphere checker). Per problem the minimum of 3 runs of the
    seeded plan, four rounds alternating with main on a loaded 2-core machine (load 10-16),
    medians over the 313 problems, all solved: ``"spheres_only"`` 0.554-0.600 ms (main
    0.643-0.736), with ``validator="spheres"`` 0.435-0.459 ms (main, which re-checked every
    point: 0.769-0.891), ``"mesh"`` unchanged (0.72-0.79 against 0.71-0.83). Kernel phases
    (``log["kernel_<phase>_us"]``, medians over the problems) with ``"spheres_only"`` and
    ``validator="spheres"``: 435-459 us = Python and call 31-38 + endpoints 5 + straight line
    4-5 + nearest 8 + tree growth 215-231 + fine pass 155 + re-check 0 (it was 325 us for
    257 path points); 475 checks of about 0.75 us. The issue's 0.1 ms needs the checks
    themselves several times cheaper (VAMP: float lanes over many configurations) or
    fewer of them (a clearance certificate over whole edges).

    Edge clearance certificates (2026-11-27, branch plan02; row ``rrt_connect_clearance``,
    ``checker="clearance"``): a sphere check returns a certified radius along the edge (the
    spheres' clearances over a per-link bound on their speed per radian) and every tree edge
    is covered by such intervals, so the edges are free everywhere, not only at their
    points, and there is no fine pass. Slower, not faster: median 0.806-0.817 ms (two
    rounds, measure_min.py in /work/notes/s22/H4-plan02, same method as above, load about
    10), 131 of the 313 paths certified whole (the others start or end closer to an obstacle
    than the spheres' margin, or fell back to ``"spheres"``: 96 fallbacks against 90), all
    solved; phases: tree growth 701-708 us, fine pass 15, 518 checks. With
    ``validator="spheres"`` ``"spheres_only"`` took 0.458-0.463 ms in the same rounds (main
    0.488-0.494: 12 us less Python per plan in this branch). A clearance check costs about
    twice a point check and its radius is about 7x below the first contact along the edge
    (a worst-case bound, a Euclidean clearance), so it certifies about as much edge per check
    as the coarse points and the fine pass check: fewer checks needs tighter, configuration-
    dependent bounds; cheaper checks need float lanes.

    Single-precision sphere filter (2026-11-27, branch simd; ``sphere_batch.hpp``, default;
    row ``rrt_connect_spheres_only_validator_spheres_no_filter``: the batched double path
    before it): the 4 configurations of a batch tested at once in float (links' bounding
    spheres, objects', spheres against the primitives and self pairs, radii inflated by a
    derived rounding bound, 23-31 um here), the double test only on the lanes it cannot
    clear ("spheres only" edges trust its sphere overlaps); the batched kinematics compiled
    for SSE2 and AVX2, chosen at run time (an earlier build, SSE2 forced: 0.346-0.363 ms
    against 0.314-0.332 with AVX2). ``"spheres_only"`` with ``validator="spheres"``,
    medians over the 313 problems (measure_min.py, two rounds alternating with main, load
    3-4): 0.280-0.288 ms against 0.444-0.452, all solved, the same median checks (475);
    phases: growth 140 us (220-222), fine pass 78-79 (154-156), Python and call 35-38.
    Instructions inside ``rrt_connect`` on 14 problems (callgrind, 7,986 checks): 111.1 M ->
    84.8 M, the filter 40.9 M of them: 0.1 ms needs the filter cheaper (8 lanes with AVX2 and
    fuller batches, the self pairs), fewer checks and fewer Python microseconds.

    SIMD levels (2026-11-29, stop 36): the filter compiled for SSE2, x86-64-v3 (AVX2, FMA, BMI)
    and x86-64-v4 (AVX-512), chosen at run time, and the trees' nearest-neighbour scan in
    SSE2/AVX2 intrinsics (GCC kept the 8-lane vector of doubles in memory). All 313 problems,
    least of 3 calls, alternating builds (three rounds): kernel median 106-108 -> 92-93 us (a
    ``-march=native`` build: 92-93), wall 121 -> 106 us, mean 1,057 -> 830-870 us, same paths. Each
    part alone: "avx2" without FMA -3.5 %, with FMA -7 %, with BMI (tzcnt) and AVX-512 the rest.
    Not adopted: 8 configurations per batch in the AVX builds (kernel median +7-12 %: the
    hierarchy prunes less per batch; 147,586 of 152,673 edge checks have exactly 4 points).

    Per-plan constants (2026-11-29, stop 37): check orders kept per thread across plans, trees
    with room for 64 nodes, ``-fno-math-errno``, the log's numbers as one tuple: all 313
    problems, least of 24 calls (8 alternating rounds), kernel median 91.9 -> 88.8 us, wall
    106.1 -> 101.8 us, same checks; the flag alone -1 % (6 rounds). Python per plan (a kernel
    that returns at once): 10.1 -> 7.9 us; a trivial plan's call costs 2 us in the binding
    (18 arguments, the planner's set-up, the arrays returned). Not adopted (no change in the
    filter's time per row on the planner's batches, 25,932 rows): the joint placements of
    ``load_q`` in locals (runtime column indices put them on the stack: +30 %; compile-time
    ones: same time) and the obstacle boxes 8 / 16 per vector operation in the AVX2 / AVX-512
    builds (``link_reach_`` leaves one or two blocks of 4 per link); each lane's own obstacle
    bits once when the union sphere of a batch's lanes touches several obstacles, instead of one
    lane test per obstacle (same answers; 6 alternating rounds: median +1.6 %, mean -5 %; from 3
    obstacles on: median +4.6 %).
    The lazy fine pass's points in increasing order along each edge instead of bisection order
    (a batch's four configurations 0.03 rad apart: the filter's union spheres are tight): the
    same plans (iterations, nodes, edges identical on all 313; checks differ in the 117 with a
    rejected candidate path), fine pass median 27.7 -> 24.2 us, with the flag kernel median
    97.7 -> 90.0 us and wall 115.6 -> 106.6 us (4 alternating rounds, loaded machine).

    Measured for the Python path (same problems, same checker, 2-core machine; see
    ``benchmarks/suites/planning.py``):
    the lazy coarse-to-fine checks need about 35 % fewer collision checks than checking every
    edge at ``delta`` (which needs the same checks as OMPL's RRTConnect at the same range and
    resolution), and the batched calls cost about 10 us per configuration instead of about 15 us
    one by one.
"""

from __future__ import annotations

import dataclasses
import os
import time
from typing import Any

import numpy as np

from benchmarks.common import Row, Timing, run_peer
from taskspace.batch import BatchOptions, Executor
from taskspace.errors import PlanningError
from taskspace.planning.collision_checker import CollisionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.lazy_prm import lazy_prm
from taskspace.planning.prm import PRMOptions, prm
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_SCENARIOS,
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from taskspace.planning.shortcut import shortcut_path

SUITE = "planning"
ROOT = motionbenchmaker_dir()
RESOLUTION = 0.03  # local-planner resolution delta [rad], shared with the peers
STEP_SIZE = RRTConnectOptions().step_size  # RRT-Connect range alpha [rad], shared with OMPL
TIME_LIMIT = 1.0  # [s]
LAZY_PRM = PRMOptions(max_iterations=None, batch_size=300, k_neighbors=12)
METHODS = (
    "rrt_connect",
    "rrt_connect_spheres",
    "rrt_connect_spheres_only",
    "rrt_connect_spheres_only_validator_spheres",
    "scene_setup",
    "rrt_connect_spheres_only_validator_spheres_first_plan",
    "rrt_connect_spheres_only_validator_spheres_min3",
    "rrt_connect_spheres_only_validator_spheres_min3_3seeds",
    "rrt_connect_spheres_only_validator_spheres_new_seed",
    "rrt_connect_spheres_only_validator_spheres_no_filter",
    "rrt_connect_clearance",
    "rrt_connect_python",
    "rrt_connect_classic",
    "lazy_prm",
    "prm",
)
OURS_RRT = (
    "taskspace rrt_connect",
    "taskspace rrt_connect_spheres",
    "taskspace rrt_connect_spheres_only",
    "taskspace rrt_connect_spheres_only_validator_spheres",
    "taskspace rrt_connect_spheres_only_validator_spheres_first_plan",
    "taskspace rrt_connect_spheres_only_validator_spheres_min3",
    "taskspace rrt_connect_spheres_only_validator_spheres_min3_3seeds",
    "taskspace rrt_connect_spheres_only_validator_spheres_new_seed",
    "taskspace rrt_connect_spheres_only_validator_spheres_no_filter",
    "taskspace rrt_connect_clearance",
    "taskspace rrt_connect_python",
    "taskspace rrt_connect_classic",
)
SCENE_SETUP = "taskspace scene_setup"  # a row of ours that is not a planner (not in OURS_RRT)
OMPL_SAME = f"ompl RRTConnect range={STEP_SIZE:g} (our checker)"
PYROBOPLAN = "pyroboplan RRTConnect (own checker)"
# VAMP (benchmarks/peers/vamp_planning.py): its own sphere model and SIMD checks, range 1.0;
# the wall time of the Python call, VAMP's own clock (its trees allocated before it starts),
# and the wall time with trees for 100,000 samples instead of 1,000,000. Each the minimum of
# VAMP_REPEATS runs of the same (deterministic) plan: a first call on a new environment costs
# more than a repeated one in wall time (not in VAMP's clock). The "first call" row is the
# wall time of the first of them with 100,000 samples, the first VAMP plan on each problem's
# environment (variant "lean" plans before "default"): the peer of our first plan
VAMP_REPEATS = 3
VAMP_VARIANTS = "lean,default"  # in this order on each problem
VAMP_ROWS = (
    ("default", "times", f"vamp RRTConnect range=1 (own spheres), wall min of {VAMP_REPEATS}"),
    ("default", "vamp_times", "vamp RRTConnect range=1 (own spheres), VAMP's clock"),
    (
        "lean",
        "times",
        f"vamp RRTConnect range=1 max_samples=1e5 (own spheres), wall min of {VAMP_REPEATS}",
    ),
    (
        "lean",
        "first_times",
        "vamp RRTConnect range=1 max_samples=1e5 (own spheres), wall first call",
    ),
)


def problem_indices(quick: bool) -> list[int]:
    """Problem numbers per scenario (quick: the first five)."""
    count = int(os.environ.get("TASKSPACE_PLANNING_PROBLEMS", "5" if quick else "50"))
    return list(range(1, count + 1))


def scenarios() -> list[str]:
    """Scenarios to run (env ``TASKSPACE_PLANNING_SCENARIOS``, comma-separated)."""
    chosen = os.environ.get("TASKSPACE_PLANNING_SCENARIOS")
    return chosen.split(",") if chosen else list(MOTIONBENCHMAKER_SCENARIOS)


def checker_cost(robot: Any, rng: np.random.Generator) -> dict[str, float]:
    """Per-configuration cost of the collision check on random configurations [us]."""
    checker = CollisionChecker(robot)
    qs = np.array([robot.random_configuration(rng) for _ in range(2000)])
    checker.are_valid(qs[:100])
    batch = []
    for _ in range(3):
        t0 = time.perf_counter()
        free = checker.are_valid(qs)
        batch.append((time.perf_counter() - t0) / len(qs))
    t0 = time.perf_counter()
    for q in qs[:500]:
        checker.is_valid(q)
    single = (time.perf_counter() - t0) / 500
    out = {
        "check_batch_us": min(batch) * 1e6,
        "check_single_us": single * 1e6,
        "free_fraction": float(free.mean()),
    }
    kernel = checker.native_kernel()
    if kernel is not None:  # the compiled checker used by the compiled planner
        native = []
        for _ in range(3):
            t0 = time.perf_counter()
            kernel.collisions(qs)
            native.append((time.perf_counter() - t0) / len(qs))
        out["check_native_us"] = min(native) * 1e6
    kernel = checker.sphere_kernel()
    if kernel is not None:  # the sphere checkers (1: then exact, 2: spheres only)
        for code, key in (
            (0, "check_mesh_us"),
            (1, "check_spheres_us"),
            (2, "check_spheres_only_us"),
        ):
            times = []
            for _ in range(5):
                t0 = time.perf_counter()
                kernel.collisions_with(qs, code)
                times.append((time.perf_counter() - t0) / len(qs))
            out[key] = min(times) * 1e6
    return out


def _stats(rows: list[dict[str, float]], valid: int) -> dict[str, Any]:
    times = [r["time"] for r in rows]
    ok = [r["ok"] for r in rows]
    lengths = [r["length"] for r in rows if np.isfinite(r["length"])]
    out: dict[str, Any] = {
        "valid": valid,
        "solved_1s": int(sum(ok)),
        "success_rate": float(np.mean(ok)) if ok else None,
        "median_ms": float(np.median(times) * 1e3) if times else None,
        "p95_ms": float(np.percentile(times, 95) * 1e3) if times else None,
        "median_checks": float(np.median([r["checks"] for r in rows])) if rows else None,
        "mean_checks": float(np.mean([r["checks"] for r in rows])) if rows else None,
        "median_path_length_rad": float(np.median(lengths)) if lengths else None,
    }
    short = [r["short"] for r in rows if np.isfinite(r.get("short", np.nan))]
    if short:
        out["median_shortcut_length_rad"] = float(np.median(short))
    return out


# Our RRT-Connect configurations, in the order they plan each problem: (method, coarse
# resolution, local sampling, compiled, checker, validator). The headline configuration
# (checker "spheres_only", validator "spheres") plans first, right after the scene is set
# up: the plan a user pays after loading a new scene. The rows after it plan the same scene
# again, the headline's own repeated row (same options, same seed) among them.
FIRST_PLAN = "rrt_connect_spheres_only_validator_spheres_first_plan"
HEADLINE = "rrt_connect_spheres_only_validator_spheres"
# The headline's plan also as VAMP's rows are timed: the minimum wall time of MIN_OF runs of
# the same (deterministic, seeded) plan in a row, its single call (the row HEADLINE) the first
MIN_OF = VAMP_REPEATS
HEADLINE_MIN = f"{HEADLINE}_min{MIN_OF}"
# The same measure over more random streams: a planner's seeded plans are one draw of its
# randomness, and a change of the random stream alone moves the median of the 313 plans by up
# to 10 % (their iteration counts: seeds k gave a median of 61 or 66 iterations with two
# streams, equal over other seed sets). Per problem, the median over the seeds k, k + 1000 and
# k + 2000 of the least of MIN_OF calls of each.
SEED_OFFSETS = (0, 1000, 2000)
HEADLINE_SEEDS = f"{HEADLINE}_min{MIN_OF}_{len(SEED_OFFSETS)}seeds"
# The first call of each of those other seeds: a new query on a scene already planned on (a
# user's next plan). The same seeded plan repeated gets faster for 4-5 calls (the branch
# predictors learn the identical run: about 25 % per check), which the least-of-3 rows include.
HEADLINE_NEW_SEED = f"{HEADLINE}_new_seed"
RRT_CONFIGURATIONS: tuple[tuple[str, float | None, float, bool, str, str], ...] = (
    (FIRST_PLAN, 0.15, 0.5, True, "spheres_only", "spheres"),
    ("rrt_connect", 0.15, 0.5, True, "mesh", "mesh"),
    ("rrt_connect_spheres", 0.15, 0.5, True, "spheres", "mesh"),
    ("rrt_connect_spheres_only", 0.15, 0.5, True, "spheres_only", "mesh"),
    ("rrt_connect_spheres_only_validator_spheres", 0.15, 0.5, True, "spheres_only", "spheres"),
    (
        "rrt_connect_spheres_only_validator_spheres_no_filter",
        0.15,
        0.5,
        True,
        "spheres_only",
        "spheres",
    ),
    ("rrt_connect_clearance", 0.15, 0.5, True, "clearance", "spheres"),
    ("rrt_connect_python", 0.15, 0.5, False, "mesh", "mesh"),
    ("rrt_connect_classic", None, 0.0, True, "mesh", "mesh"),
)


def _plan_problem(item: tuple[Any, ...], rng: np.random.Generator, robot: Any) -> dict[str, Any]:
    """Our planners on one problem (a task of ``taskspace.batch``): per-method samples.

    ``samples["scene_setup"]`` is the wall time of the set-up a user waits for before the
    first plan on a new scene (the problem applied to the robot, the configuration space, the
    endpoint checks, the compiled sphere checker); the first method then plans on it.
    """
    scenario, index, k, quick = item
    problem = motionbenchmaker_problems(ROOT, scenario, [index])[0]  # files read before timing
    out: dict[str, Any] = {"samples": {}}
    # The robot's sphere model is cached per robot (built once per process: fitted, or loaded
    # from the on-disk cache, about 20 ms here): a new robot's cost, not a new scene's. Built
    # before timing so that every problem's set-up times the same work.
    CollisionChecker(robot).sphere_model()
    t0 = time.perf_counter()
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=RESOLUTION))
    try:
        space.check_endpoint(req.start, "start")
        space.check_endpoint(req.goal, "goal")
    except PlanningError as exc:
        out["invalid"] = f"{problem.index}: {str(exc)[:90]}"
        out["cost"] = checker_cost(robot, rng) if k == 0 else {}
        return out
    assert isinstance(space.checker, CollisionChecker)
    kernel = space.checker.sphere_kernel()  # the compiled checker on this scene, spheres set
    setup = time.perf_counter() - t0
    per = out["samples"]
    per["scene_setup"] = {"time": setup, "ok": 1.0, "checks": np.nan, "length": np.nan}
    for method, coarse, local, native, checker, validator in RRT_CONFIGURATIONS:
        opts = RRTConnectOptions(
            step_size=STEP_SIZE,
            coarse_resolution=coarse,
            local_sampling=local,
            trapped_priority=0.75 if local > 0.0 else 0.0,
            time_limit_s=TIME_LIMIT,
            seed=k,
            native=native,
            checker=checker,
            validator=validator,
        )
        # the batched sphere checks without the single-precision filter (the path before it)
        no_filter = method.endswith("_no_filter") and hasattr(kernel, "set_sphere_filter")
        if no_filter:
            mode = kernel.sphere_filter_mode
            kernel.set_sphere_filter(0)
        try:
            t0 = time.perf_counter()  # the wall time of the call, as the peers' (not time_s)
            res = rrt_connect(space, req.start, req.goal, opts)
            wall = time.perf_counter() - t0
        finally:
            if no_filter:
                kernel.set_sphere_filter(mode)
        row = {
            "time": wall,
            "time_s": res.time_s,
            "ok": float(res.success and wall <= TIME_LIMIT),
            "checks": float(res.collision_checks),
            "length": res.path_length,
            "short": np.nan,
        }
        if res.success and method == "rrt_connect":
            row["short"] = shortcut_path(space, res.path).length_after
        per[method] = row
        if method == HEADLINE:
            walls, times = [wall], [res.time_s]
            for _ in range(MIN_OF - 1):
                t0 = time.perf_counter()
                again = rrt_connect(space, req.start, req.goal, opts)
                walls.append(time.perf_counter() - t0)
                times.append(again.time_s)
            per[HEADLINE_MIN] = row | {"time": min(walls), "time_s": min(times)}
            least = [min(walls)]
            solved = [float(res.success)]
            first_calls, first_solved = [], []
            for offset in SEED_OFFSETS[1:]:
                other = dataclasses.replace(opts, seed=k + offset)
                seed_walls = []
                for _ in range(MIN_OF):
                    t0 = time.perf_counter()
                    again = rrt_connect(space, req.start, req.goal, other)
                    seed_walls.append(time.perf_counter() - t0)
                least.append(min(seed_walls))
                solved.append(float(again.success and min(seed_walls) <= TIME_LIMIT))
                first_calls.append(seed_walls[0])
                first_solved.append(float(again.success and seed_walls[0] <= TIME_LIMIT))
            unknown = {"time_s": np.nan, "checks": np.nan, "length": np.nan}
            seeds_row = {"time": float(np.median(least)), "ok": min(solved)}
            per[HEADLINE_SEEDS] = row | unknown | seeds_row
            per[HEADLINE_NEW_SEED] = (
                row | unknown | {"time": float(np.median(first_calls)), "ok": min(first_solved)}
            )
    # random configurations on the first problem, after the plans (not between set-up and plan)
    out["cost"] = checker_cost(robot, rng) if k == 0 else {}
    t0 = time.perf_counter()
    lres, _ = lazy_prm(
        space, req.start, req.goal, LAZY_PRM, time_limit_s=TIME_LIMIT, rng=np.random.default_rng(k)
    )
    wall = time.perf_counter() - t0
    per["lazy_prm"] = {
        "time": wall,
        "time_s": lres.time_s,
        "ok": float(lres.success and wall <= TIME_LIMIT),
        "checks": float(lres.collision_checks),
        "length": lres.path_length,
    }
    if quick and k < 2:  # quick runs: PRM on the first two problems
        t0 = time.perf_counter()
        pres, _ = prm(
            space, req.start, req.goal, PRMOptions(max_iterations=200, k_neighbors=8, seed=k)
        )
        wall = time.perf_counter() - t0
        per["prm"] = {
            "time": wall,
            "time_s": pres.time_s,
            "ok": float(pres.success and wall <= TIME_LIMIT),
            "checks": float(pres.collision_checks),
            "length": pres.path_length,
        }
    return out


def _executor() -> Executor:
    """The executor of ``--executor`` (serial by default: one problem after another)."""
    backend = os.environ.get("TASKSPACE_BENCH_EXECUTOR", "serial")
    return Executor(BatchOptions(backend=backend, chunk_size=1, progress=False))  # type: ignore[arg-type]


def _run_ours(
    executor: Executor, scenario: str, quick: bool
) -> tuple[dict[str, list[dict[str, float]]], dict[str, Any]]:
    """Our planners on one scenario: per-method samples and scenario information."""
    indices = problem_indices(quick)
    items = [(scenario, index, k, quick) for k, index in enumerate(indices)]
    outs = executor.map(_plan_problem, items, context=motionbenchmaker_panda).values
    per: dict[str, list[dict[str, float]]] = {m: [] for m in METHODS}
    for out in outs:
        for method, row in out["samples"].items():
            per[method].append(row)
    invalid = [out["invalid"] for out in outs if "invalid" in out]
    return per, {"problems": len(indices), "invalid": invalid, **outs[0]["cost"]}


def _peer_samples(res: dict[str, Any]) -> list[dict[str, float]]:
    """Samples (time, ok, checks, length) of one peer scenario result."""
    times = res["times"]
    checks = res.get("checks", [np.nan] * len(times))
    lengths = [np.nan if x is None else float(x) for x in res["lengths"]]
    return [
        {"time": t, "ok": float(np.isfinite(length)), "checks": float(c), "length": length}
        for t, c, length in zip(times, checks, lengths)
    ]


def _run_peers(scenario: str, quick: bool) -> tuple[dict[str, list[dict[str, float]]], list[str]]:
    """OMPL (two range settings), pyroboplan and VAMP on one scenario, right after ours."""
    common = ["--quick"] if quick else []
    common += ["--resolution", str(RESOLUTION), "--time", str(TIME_LIMIT), "--scenarios", scenario]
    if "TASKSPACE_PLANNING_PROBLEMS" in os.environ:
        common += ["--problems", os.environ["TASKSPACE_PLANNING_PROBLEMS"]]
    peers = (
        ("ompl", "ompl_planning.py", [*common, "--range", str(STEP_SIZE)]),
        ("pyroboplan", "pyroboplan_planning.py", common),
        (
            "vamp",
            "vamp_planning.py",
            [*common, "--variants", VAMP_VARIANTS, "--repeats", str(VAMP_REPEATS)],
        ),
    )
    samples: dict[str, list[dict[str, float]]] = {}
    notes: list[str] = []
    for peer, script, args in peers:
        try:
            out = run_peer(peer, script, args, timeout=7200)
        except Exception as exc:  # a failing peer must not kill the suite
            notes.append(f"{peer} failed: {str(exc)[-300:]}")
            continue
        if out is None:
            notes.append(f"peer venv .venv-peers/{peer} missing")
            continue
        if peer == "ompl":
            samples[OMPL_SAME] = _peer_samples(out["variants"]["same"][scenario])
            default = f"ompl RRTConnect default range={out['range_default']:.2f} (our checker)"
            samples[default] = _peer_samples(out["variants"]["default"][scenario])
        elif peer == "vamp":
            if "skipped" in out:
                notes.append(f"vamp skipped: {out['skipped']}")
                continue
            for variant, key, label in VAMP_ROWS:
                res = out["variants"][variant][scenario]
                if key not in res:  # an older vamp_planning.py (no first_times)
                    notes.append(f"vamp: no '{key}' in its output")
                    continue
                rows = _peer_samples({**res, "times": res[key]})
                for row in rows:  # solved within the limit in this call's time too
                    row["ok"] = float(row["ok"] and row["time"] <= TIME_LIMIT)
                samples[label] = rows
            res = out["variants"]["default"][scenario]
            notes.append(
                f"vamp {scenario}: {res['exact_collisions']} of {res['valid']} paths collide for "
                f"taskspace's exact checker at {RESOLUTION} rad; endpoints VAMP finds in "
                f"collision: {res['vamp_invalid_endpoints']}"
            )
        else:
            samples[PYROBOPLAN] = _peer_samples(out["scenarios"][scenario])
    return samples, notes


def run(quick: bool) -> list[Row]:
    if not ROOT.is_dir():
        return [Row(SUITE, "motionbenchmaker", "taskspace", None, note=f"{ROOT} missing")]
    executor = _executor()
    # Scenario by scenario: ours, then the peers, so that all see the same machine load.
    per_scenario: dict[str, dict[str, list[dict[str, float]]]] = {}
    info: dict[str, dict[str, Any]] = {}
    notes: list[str] = []
    for scenario in scenarios():
        ours, info[scenario] = _run_ours(executor, scenario, quick)
        peers, peer_notes = _run_peers(scenario, quick)
        notes += peer_notes
        per_scenario[scenario] = {f"taskspace {m}": v for m, v in ours.items()} | peers
    rows: list[Row] = []
    labels = list(dict.fromkeys(k for per in per_scenario.values() for k in per))
    medians: dict[tuple[str, str], float] = {}
    for scene in [*per_scenario, "all"]:
        for label in labels:
            if scene == "all":
                samples = [s for per in per_scenario.values() for s in per.get(label, [])]
            else:
                samples = per_scenario[scene].get(label, [])
            if not samples:
                continue
            extra = _stats(samples, len(samples))
            if label == "taskspace rrt_connect" and scene != "all":
                extra.update(info[scene])
            if label.startswith("pyroboplan"):
                extra.pop("median_checks")
                extra.pop("mean_checks")
            if label == SCENE_SETUP:  # not a planner: its time only (no ratios either)
                extra = {key: extra[key] for key in ("valid", "median_ms", "p95_ms")}
            medians[(scene, label)] = extra["median_ms"]
            peer = not label.startswith("taskspace")
            if peer:
                for mine in OURS_RRT:
                    if medians.get((scene, mine)) and extra["median_ms"]:
                        key = f"ratio_median_{mine.split()[1]}_over_peer"
                        extra[key] = medians[(scene, mine)] / extra["median_ms"]
            rows.append(
                Row(
                    SUITE,
                    scene,
                    label,
                    Timing.from_samples([s["time"] for s in samples]),
                    extra,
                    ratio_to="taskspace rrt_connect" if peer else None,
                )
            )
    for note in dict.fromkeys(notes):
        rows.append(Row(SUITE, "all", "peers", None, note=note))
    return rows
