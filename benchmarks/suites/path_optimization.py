"""Path optimization (issue 7 item 4): Panda reach around a sphere, beside rai's KOMO.

Scene: the Panda (convex collision hulls) from ``q_start`` (joint 1 at -0.8 rad) to the
hand pose of ``q_goal`` (joint 1 at +0.8 rad), a sphere of radius 0.12 m at (0.35, 0, 0.4)
in between; acceleration cost (order 2), final pose equality, every link at least 2 cm from
the sphere at every slice, joint limits; initial path: ``q_start`` repeated. T = 20, 40, 80.
Only robot-vs-sphere pairs are checked (self-collision pairs dropped, as in the peer).

Measured: time to converge (one ``optimize_path`` call, problem built beforehand),
iterations, time per iteration (linear in T), final feasibility re-checked here (min
distance over the slices, final pose error, joint limits). The peer, KOMO from PyPI
``robotic``, solves the same problem on rai's own Panda model (capsule collision shapes)
in its venv (``benchmarks/peers/robotic_path_optimization.py``).
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from benchmarks.common import Row, Timing, run_peer
from taskspace import features as F
from taskspace.constraints import FeatureBounds
from taskspace.model import Robot
from taskspace.model.world import Obstacle
from taskspace.tasks import Task
from taskspace.trajopt.path_optimization import (
    PathEquality,
    PathInequality,
    PathProblem,
    optimize_path,
)

SUITE = "path_optimization"
TCP = "panda_hand_tcp"
MARGIN = 0.02
CENTER = (0.35, 0.0, 0.4)
RADIUS = 0.12
PEER_SHAPES = [f"panda_coll{i}" for i in range(1, 8)] + ["palm", "finger1", "finger2"]


def scene() -> tuple[Robot, np.ndarray, np.ndarray, list[tuple[str, str]]]:
    """The robot (world collisions only), start, goal configuration and checked pairs."""
    full = Robot.load("panda", convex_collision=True)
    collision = full.collision_model.copy()
    collision.removeAllCollisionPairs()
    robot = Robot(
        full.model,
        collision,
        full.visual_model,
        name="panda",
        end_effectors=full.end_effectors,
        default_configuration=full.q_default,
    )
    robot.add_obstacle(Obstacle.sphere("ball", RADIUS, CENTER))
    q_start = robot.q_default.copy()
    q_start[0] = -0.8
    q_goal = robot.q_default.copy()
    q_goal[0] = 0.8
    return robot, q_start, q_goal, list(robot.collision_pairs)


def problem(robot: Robot, q_start: Any, q_goal: Any, pairs: Any, T: int) -> PathProblem:
    """The path problem on T slices."""
    goal = robot.frame_placement(q_goal, TCP)
    return PathProblem(
        robot,
        q_start,
        T,
        equalities=[PathEquality(Task(F.FramePose(robot, TCP), goal), times=-1)],
        inequalities=[
            PathInequality(FeatureBounds(F.CollisionDistance(robot, pairs), MARGIN, np.inf))
        ],
    )


def feasibility(robot: Robot, q_goal: Any, pairs: Any, path: np.ndarray) -> dict[str, Any]:
    """Independent check of a path: min distance, final pose error, joint limits."""
    distance = F.CollisionDistance(robot, pairs)
    d_min = min(float(distance.value(robot.state(q)).min()) for q in path[1:])
    goal = robot.frame_placement(q_goal, TCP)
    err = pin.log6(goal.actInv(robot.frame_placement(path[-1], TCP))).vector
    idx = robot.limited_joints_q
    limit = float(
        np.max(
            np.maximum(
                robot.lower_limits[idx] - path[:, idx], path[:, idx] - robot.upper_limits[idx]
            )
        )
    )
    feasible = d_min >= MARGIN - 1e-3 and float(np.linalg.norm(err)) < 1e-3 and limit <= 1e-6
    return {
        "feasible": bool(feasible),
        "min_distance_m": d_min,
        "final_pose_error": float(np.linalg.norm(err)),
        "limit_violation": max(limit, 0.0),
    }


def run(quick: bool) -> list[Row]:
    """Time taskspace and KOMO at T = 20, 40, 80."""
    horizons = [20, 40, 80]
    repeat = 3 if quick else 10
    robot, q_start, q_goal, pairs = scene()
    rows: list[Row] = []
    ours: dict[int, Timing] = {}
    for T in horizons:
        prob = problem(robot, q_start, q_goal, pairs, T)
        optimize_path(prob)  # warm-up (imports, caches)
        times, per_iteration = [], []
        for _ in range(repeat):
            result = optimize_path(prob)
            times.append(result.solve_time)
            per_iteration.append(result.time_per_iteration)
        ours[T] = Timing.from_samples(times)
        check = feasibility(robot, q_goal, pairs, result.path)
        rows.append(
            Row(
                SUITE,
                f"panda reach T={T}",
                "taskspace",
                ours[T],
                extra={
                    "success": result.success,
                    **check,
                    "iterations": result.iterations,
                    "outer_iterations": result.outer_iterations,
                    "time_per_iteration_ms": float(np.median(per_iteration) * 1e3),
                    "time_per_iteration_per_slice_us": float(np.median(per_iteration) / T * 1e6),
                    "cost": result.cost,
                },
            )
        )
    spec = {
        "q_start": q_start.tolist(),
        "q_goal": q_goal.tolist(),
        "radius": RADIUS,
        "center": list(CENTER),
        "margin": MARGIN,
        "horizons": horizons,
        "repeat": repeat,
        "shapes": PEER_SHAPES,
    }
    with tempfile.TemporaryDirectory() as tmp:
        spec_path = Path(tmp) / "spec.json"
        spec_path.write_text(json.dumps(spec))
        try:
            peer = run_peer("robotic", "robotic_path_optimization.py", [str(spec_path)])
        except RuntimeError as exc:
            peer = None
            note = f"robotic failed: {str(exc)[-300:]}"
        else:
            note = "" if peer is not None else "robotic venv missing (make bench-peers)"
    for T in horizons:
        if peer is None:
            rows.append(Row(SUITE, f"panda reach T={T}", "robotic (KOMO)", None, note=note))
            continue
        data = peer["T"][str(T)]
        timing = Timing.from_samples(data["times"])
        rows.append(
            Row(
                SUITE,
                f"panda reach T={T}",
                "robotic (KOMO)",
                timing,
                extra={
                    "feasible": bool(
                        all(data["feasible"])
                        and data["min_distance"] >= MARGIN - 1e-3
                        and data["final_position_error"] < 1e-3
                    ),
                    "komo_feasible_flag": all(data["feasible"]),
                    "min_distance_m": data["min_distance"],
                    "final_position_error": data["final_position_error"],
                    "evals": data["evals"][-1],
                    "ratio_taskspace_to_robotic": ours[T].median_us / timing.median_us,
                },
                ratio_to="taskspace",
            )
        )
    return rows
