"""VAMP's RRT-Connect on the MotionBenchMaker Panda problems, with VAMP's own collision checking.

VAMP (Thomason, Kingston, Kavraki, ICRA 2024; PyPI ``vamp-planner``) checks its own sphere
model of the Panda (59 spheres, single precision, several configurations at once in SIMD
lanes) against sphere, box and capsule primitives; nothing of taskspace runs inside its
planner. Runs in .venv-peers/vamp (see install.sh); taskspace is imported from the checkout
for the scene loader, for the problems' validity (the same filter as the suite's: start and
goal free for taskspace's Panda) and for the checks of VAMP's paths after timing.

Obstacles: the scene's primitives as VAMP primitives, converted as VAMP's own MotionBenchMaker
loader does (``vamp.problem_dict_to_vamp``): boxes as cuboids, spheres as spheres, cylinders
as capsules (an over-approximation) except in ``box``, where they are cuboids of half-extents
(r, r, h/2) (VAMP's choice for the top-down grasps of that scenario).

Settings: VAMP's defaults for the Panda (``vamp.configure_robot_and_planner_with_kwargs``:
range 1.0 rad, 1,000,000 iterations and samples, dynamic domain, balanced trees), the Halton
sampler reset before every plan (as VAMP's ``scripts/evaluate_mbm.py``), and its compiled
resolution (``vamp.panda.resolution()`` = 32 points per radian along the L2 segment: at most
1/32 = 0.031 rad apart; taskspace: 0.03 rad, range 0.5). Variants: ``default`` (range 1.0),
``same`` (range = ``--range``, taskspace's step) and ``lean`` (below). No time limit inside
VAMP (an iteration limit): a plan counts as
solved when it returns a path within ``--time``.

Two times per plan: VAMP's own (``PlanningResult.nanoseconds``, what its paper and
``evaluate_mbm.py`` report: the planner's C++ loop) and the wall time of the Python call
(``perf_counter`` around ``vamp.panda.rrtc``: the conversion of start and goal and the
result's Python objects too). VAMP allocates its trees for ``max_samples`` configurations
(and zeroes two arrays of that length) before its clock starts: with the helper's 1,000,000
that is at least about 0.45 ms of wall time per call on this machine, even for a straight-line
plan; variant ``lean`` sets ``max_samples`` and ``max_iterations`` to 100,000 (``RRTCSettings``'
own default, about 20 us), range 1.0. A first call on a new environment also costs more than
a repeated one in wall time (not in VAMP's clock): ``--repeats`` takes the minimum
(``times``) and ``first_times`` keeps the first call's wall time; the variants plan each
problem in the order of ``--variants``, so only the first variant's first call is the first
on that environment.
The exact checks of the paths use taskspace's fingers (0.04 m; VAMP's are fixed at 0.065 m,
as in the requests), its joint limits (narrower than VAMP's for joints 4 and 6) and exact
cylinders (VAMP: capsules), so they measure the difference of the models, not only of VAMP's
sphere cover.

After timing (the problems' validity is checked before the first VAMP call of a scenario and
the paths after its last one, so that no taskspace allocation falls between two VAMP calls),
every returned path is checked by taskspace's exact checker (Pinocchio/coal,
taskspace's Panda, fingers at 0.04 m) at 0.03 rad and against taskspace's joint limits:
``exact_collisions`` counts the paths with a point in collision for that model.

``--cover`` instead checks VAMP's sphere model against taskspace's Panda: the vertices of
every collision hull of the arm and hand, placed by Pinocchio at random configurations, are
tested against the union of VAMP's 59 spheres at the same configuration (``vamp.panda.fk``);
a vertex outside every sphere shows that the spheres are not a cover of that geometry.

Prints one JSON line: {"variants": {variant: {scenario: {"valid", "solved", "times",
"first_times", "vamp_times", "lengths", "iterations", "vamp_invalid_endpoints",
"exact_collisions", "out_of_limits"}}}, "settings": {...}} (or {"cover": {...}} with
``--cover``).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

from _checkout import use_checkout

ROOT = use_checkout()  # src/ (the loader and the exact checker of the paths)

import coal  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

try:
    import vamp
except ImportError as exc:  # the suite prints the reason and goes on
    print(json.dumps({"skipped": f"vamp not importable in this environment: {exc}"}))
    raise SystemExit(0) from None

from taskspace.errors import PlanningError  # noqa: E402
from taskspace.model.world import Obstacle  # noqa: E402
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions  # noqa: E402
from taskspace.planning.scene_loader import (  # noqa: E402
    MOTIONBENCHMAKER_SCENARIOS,
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from taskspace.planning.sphere_model import surface_triangles  # noqa: E402

LEAN_SAMPLES = 100_000  # RRTCSettings' own default; the Python helper's is 1,000,000


def euler_xyz(rotation: np.ndarray) -> list[float]:
    """Angles (rho, theta, phi) with ``rotation = Rz(phi) Ry(theta) Rx(rho)`` (VAMP's order)."""
    theta = -math.asin(max(-1.0, min(1.0, float(rotation[2, 0]))))
    if abs(float(rotation[2, 0])) < 1.0 - 1e-9:
        rho = math.atan2(float(rotation[2, 1]), float(rotation[2, 2]))
        phi = math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))
    else:  # gimbal lock: phi = 0
        rho = math.atan2(-float(rotation[1, 2]), float(rotation[1, 1]))
        phi = 0.0
    return [rho, theta, phi]


def _check_axes(cuboid: Any, rotation: np.ndarray, name: str) -> None:
    axes = np.array(
        [
            [cuboid.axis_1_x, cuboid.axis_1_y, cuboid.axis_1_z],
            [cuboid.axis_2_x, cuboid.axis_2_y, cuboid.axis_2_z],
            [cuboid.axis_3_x, cuboid.axis_3_y, cuboid.axis_3_z],
        ]
    ).T
    err = float(np.abs(axes - rotation).max())
    if err > 1e-5:
        raise RuntimeError(f"cuboid '{name}': VAMP's axes differ from the scene's by {err:.2e}")


def vamp_environment(obstacles: list[Obstacle], scenario: str) -> Any:
    """The scene's primitives as a VAMP environment (VAMP's own MotionBenchMaker conversion)."""
    env = vamp.Environment()
    for obstacle in obstacles:
        geometry, pose = obstacle.geometry, obstacle.placement
        center = [float(x) for x in pose.translation]
        rotation = np.asarray(pose.rotation)
        if isinstance(geometry, coal.Sphere):
            env.add_sphere(vamp.Sphere(center, float(geometry.radius)))
        elif isinstance(geometry, coal.Box) or (
            isinstance(geometry, coal.Cylinder) and scenario == "box"
        ):
            if isinstance(geometry, coal.Box):
                half = [float(x) for x in geometry.halfSide]
            else:
                r = float(geometry.radius)
                half = [r, r, float(geometry.halfLength)]
            cuboid = vamp.Cuboid(center, euler_xyz(rotation), half)
            _check_axes(cuboid, rotation, obstacle.name)
            env.add_cuboid(cuboid)
        elif isinstance(geometry, coal.Cylinder):
            # VAMP 0.6.4's endpoints constructor crashes (it assigns to an unconstructed
            # object): the center and Euler angles, its endpoints checked against the scene's
            half = float(geometry.halfLength)
            capsule = vamp.Cylinder(center, euler_xyz(rotation), float(geometry.radius), 2 * half)
            p1 = np.array([capsule.x1, capsule.y1, capsule.z1], dtype=float)
            expected = np.asarray(pose.translation) + rotation[:, 2] * half
            err = float(np.abs(p1 - expected).max())
            if err > 1e-5:
                raise RuntimeError(f"capsule '{obstacle.name}': endpoint off by {err:.2e} m")
            env.add_capsule(capsule)
        else:
            raise RuntimeError(
                f"obstacle '{obstacle.name}' is a {type(geometry).__name__}; "
                "VAMP primitives here: Sphere, Box, Cylinder"
            )
    return env


def planner_settings(range_: float | None = None, samples: int | None = None) -> Any:
    """VAMP's default RRT-Connect settings for the Panda (range, samples overridden if given)."""
    _, _, settings, _ = vamp.configure_robot_and_planner_with_kwargs("panda", "rrtc")
    if range_ is not None:
        settings.range = range_
    if samples is not None:
        settings.max_samples = samples
        settings.max_iterations = samples
    return settings


def check_path(space: ConfigurationSpace, path: np.ndarray, resolution: float) -> tuple[bool, bool]:
    """(some point in collision for taskspace's exact checker, some point outside its limits)."""
    dense = space.interpolate_path(path, resolution)
    out = bool(np.any(dense < space.lower - 1e-6) or np.any(dense > space.upper + 1e-6))
    return not bool(np.all(space.checker.are_valid(dense))), out


def plan_scenario(
    scenario: str,
    indices: list[int],
    variants: dict[str, Any],
    args: argparse.Namespace,
    robot: Any,
    root: Path,
) -> dict[str, dict[str, Any]]:
    """Every variant on the valid problems of one scenario."""
    rows: dict[str, dict[str, Any]] = {
        v: {
            "valid": 0,
            "solved": 0,
            "times": [],
            "first_times": [],
            "vamp_times": [],
            "lengths": [],
            "iterations": [],
            "vamp_invalid_endpoints": 0,
            "exact_collisions": 0,
            "out_of_limits": 0,
        }
        for v in variants
    }
    settings = {v: planner_settings(*r) for v, r in variants.items()}
    sampler = vamp.panda.halton()
    problems = motionbenchmaker_problems(root, scenario, indices)
    # taskspace's checks (the problems' validity before, the paths' exact checks after) stay
    # out of the sequence of VAMP calls: their allocations between two calls would make the
    # next call fault in fresh pages for its trees (a first call's cost, not VAMP's)
    valid: list[tuple[Any, list[float], list[float]]] = []
    for problem in problems:
        req = problem.apply(robot)
        space = ConfigurationSpace.from_robot(
            robot, edge=EdgeCheckOptions(resolution=args.resolution)
        )
        try:
            space.check_endpoint(req.start, "start")
            space.check_endpoint(req.goal, "goal")
        except PlanningError:
            continue
        valid.append((problem, [float(x) for x in req.start], [float(x) for x in req.goal]))
    paths: list[tuple[Any, str, np.ndarray]] = []  # solved paths, checked after timing
    if valid:  # warm-up, not timed: the last problem's plan, twice per variant (the
        # process's first calls map their tree memory, the second ones grow the heap for it)
        warm = vamp_environment(valid[-1][0].obstacles, scenario)
        for v in [*variants, *variants]:
            sampler.reset()
            vamp.panda.rrtc(valid[-1][1], valid[-1][2], warm, settings[v], sampler)
    for problem, start, goal in valid:
        env = vamp_environment(problem.obstacles, scenario)
        endpoints_ok = vamp.panda.validate(start, env) and vamp.panda.validate(goal, env)
        for v in variants:
            best: tuple[float, Any] | None = None
            first = math.nan
            for repeat in range(args.repeats):
                sampler.reset()
                t0 = time.perf_counter()
                result = vamp.panda.rrtc(start, goal, env, settings[v], sampler)
                wall = time.perf_counter() - t0
                if repeat == 0:
                    first = wall
                if best is None or wall < best[0]:
                    best = (wall, result)
            assert best is not None
            wall, result = best
            row = rows[v]
            row["first_times"].append(first)
            row["valid"] += 1
            row["vamp_invalid_endpoints"] += int(not endpoints_ok)
            ok = bool(result.solved) and wall <= args.time
            row["solved"] += int(ok)
            row["times"].append(wall)
            row["vamp_times"].append(result.nanoseconds * 1e-9)
            row["iterations"].append(int(result.iterations))
            row["lengths"].append(float(result.path.cost()) if ok else None)
            if result.solved:
                paths.append((problem, v, np.array(result.path.numpy(), dtype=float)))
    applied = None
    for problem, v, path in paths:
        if problem is not applied:  # the paths of one problem are consecutive
            problem.apply(robot)
            space = ConfigurationSpace.from_robot(
                robot, edge=EdgeCheckOptions(resolution=args.resolution)
            )
            applied = problem
        collides, out = check_path(space, path[:, : space.dim], args.resolution)
        rows[v]["exact_collisions"] += int(collides)
        rows[v]["out_of_limits"] += int(out)
    return rows


def cover_check(samples: int, seed: int) -> dict[str, Any]:
    """Vertices of taskspace's Panda hulls outside every VAMP sphere, at random configurations.

    The fingers are checked on a model with them at VAMP's opening (0.065 m, fixed in its
    spherized URDF) when taskspace's model accepts it; else they are left out.
    """
    out: dict[str, Any] = {"samples": samples, "n_spheres": int(vamp.panda.n_spheres())}
    rng = np.random.default_rng(seed)
    lo = np.asarray(vamp.panda.lower_bounds(), dtype=float)
    hi = np.asarray(vamp.panda.upper_bounds(), dtype=float)
    worst: dict[str, float] = {}
    outside: dict[str, int] = {}
    counted: dict[str, int] = {}
    models = [("arm", motionbenchmaker_panda())]
    try:
        models.append(("fingers", motionbenchmaker_panda(finger_opening=0.065)))
    except Exception as exc:  # the URDF's limit is 0.04 m
        out["fingers"] = f"not checked: {str(exc)[:120]}"
    for part, robot in models:
        model, gmodel = robot.model, robot.collision_model
        data, gdata = model.createData(), gmodel.createData()
        verts = {}
        for g in gmodel.geometryObjects:
            is_finger = "finger" in g.name
            if (part == "arm") == is_finger:
                continue
            tris = surface_triangles(g.geometry, g.name)
            verts[g.name] = np.unique(tris.reshape(-1, 3), axis=0)
        for _ in range(samples):
            q = lo + rng.random(lo.size) * (hi - lo)
            q = np.clip(q, model.lowerPositionLimit, model.upperPositionLimit)
            pin.framesForwardKinematics(model, data, q)
            pin.updateGeometryPlacements(model, data, gmodel, gdata)
            spheres = vamp.panda.fk([float(x) for x in q])
            centers = np.array([[s.x, s.y, s.z] for s in spheres], dtype=float)
            radii = np.array([s.r for s in spheres], dtype=float)
            for k, g in enumerate(gmodel.geometryObjects):
                if g.name not in verts:
                    continue
                m = gdata.oMg[k]
                world = verts[g.name] @ np.asarray(m.rotation).T + np.asarray(m.translation)
                gap = (np.linalg.norm(world[:, None, :] - centers[None], axis=2) - radii).min(
                    axis=1
                )
                worst[g.name] = max(worst.get(g.name, -np.inf), float(gap.max()))
                outside[g.name] = outside.get(g.name, 0) + int((gap > 0).sum())
                counted[g.name] = counted.get(g.name, 0) + len(gap)
    out["per_geometry"] = {
        name: {
            "vertices_checked": counted[name],
            "outside": outside[name],
            "max_outside_m": worst[name],
        }
        for name in worst
    }
    return out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--problems", type=int, default=None, help="first N problems")
    parser.add_argument("--resolution", type=float, default=0.03, help="path check [rad]")
    parser.add_argument("--range", type=float, default=0.5, help="range of variant 'same'")
    parser.add_argument("--time", type=float, default=1.0)
    parser.add_argument("--repeats", type=int, default=1, help="min of N runs per problem")
    parser.add_argument("--variants", default="default,lean,same")
    parser.add_argument("--scenarios", default=",".join(MOTIONBENCHMAKER_SCENARIOS))
    parser.add_argument("--root", default=None, help="problem directory (default: taskspace's)")
    parser.add_argument("--cover", type=int, default=0, help="sphere-cover check, N samples")
    args = parser.parse_args()
    if args.cover:
        print(json.dumps({"cover": cover_check(args.cover, seed=0)}))
        return
    count = args.problems or (5 if args.quick else 50)
    indices = list(range(1, count + 1))
    robot = motionbenchmaker_panda()
    root = motionbenchmaker_dir(args.root)
    choices: dict[str, tuple[float | None, int | None]] = {
        "default": (None, None),
        "same": (args.range, None),
        "lean": (None, LEAN_SAMPLES),
    }
    variants = {v: choices[v] for v in args.variants.split(",")}
    out: dict[str, dict[str, Any]] = {v: {} for v in variants}
    for scenario in args.scenarios.split(","):
        rows = plan_scenario(scenario, indices, variants, args, robot, root)
        for v in variants:
            out[v][scenario] = rows[v]
    defaults = planner_settings()
    print(
        json.dumps(
            {
                "variants": out,
                "settings": {
                    "range_default": float(defaults.range),
                    "range_same": args.range,
                    "max_iterations": int(defaults.max_iterations),
                    "max_samples_lean": LEAN_SAMPLES,
                    "resolution_per_rad": int(vamp.panda.resolution()),
                    "sampler": "halton (reset before each plan)",
                    "vamp_version": getattr(vamp, "__version__", "0.6.4"),
                },
                "note": "VAMP RRTConnect, its own sphere model and SIMD checks",
            }
        )
    )


if __name__ == "__main__":
    main()
