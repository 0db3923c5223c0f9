"""Trajectory suite: time-optimal time parametrization (TOPP-RA) against toppra.

Scene ``topp_7dof_10wp_100grid``: a 7-DoF path through 10 random waypoints (seeded), cubic
spline with clamped ends (zero path velocity) and knots ``linspace(0, 1, 10)``, Panda joint
velocity and acceleration limits, 100 grid points, acceleration constraints with the
interpolation discretization, rest-to-rest. Both libraries are timed per call from the
waypoints to the time-parametrized trajectory. Target: taskspace <= 3.5 ms per call at a
duration no longer than toppra's.

Also timed (no peer): cubic and C4 quintic spline fits and a synchronized 7-joint S-curve.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import Row, Timing, measure, run_peer
from taskspace.trajopt.motion_profile import synchronize
from taskspace.trajopt.spline import cubic_spline, quintic_spline
from taskspace.trajopt.time_parametrization import TimeParametrizationOptions, time_parametrize

SUITE = "trajectories"
TARGET_US = 3500.0

# Franka Panda limits [rad/s], [rad/s^2]
PANDA_VMAX = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]
PANDA_AMAX = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]


def build_topp_scene(
    seed: int = 1, n_waypoints: int = 10, grid_points: int = 100
) -> dict[str, Any]:
    """The TOPP problem as plain data (shared with the toppra peer through JSON)."""
    rng = np.random.default_rng(seed)
    waypoints = rng.uniform(-1.0, 1.0, (n_waypoints, 7))
    return {
        "waypoints": waypoints.tolist(),
        "max_velocity": PANDA_VMAX,
        "max_acceleration": PANDA_AMAX,
        "grid_points": grid_points,
        "bc_type": "clamped",
    }


def _taskspace_topp(scene: dict[str, Any]) -> Any:
    opts = TimeParametrizationOptions(
        grid_points=scene["grid_points"],
        spline_boundary=scene["bc_type"],
        discretization="interpolation",
    )
    w = np.asarray(scene["waypoints"])
    vmax = np.asarray(scene["max_velocity"])
    amax = np.asarray(scene["max_acceleration"])
    return lambda: time_parametrize(w, vmax, amax, options=opts)


def run(quick: bool) -> list[Row]:
    """Run the suite; ``quick`` uses fewer repetitions (< 15 s in total)."""
    rows: list[Row] = []
    warmup, repeat = (5, 40) if quick else (20, 300)
    scene_name = "topp_7dof_10wp_100grid"
    scene = build_topp_scene()
    fn = _taskspace_topp(scene)
    result = fn()
    timing = measure(fn, warmup=warmup, repeat=repeat)
    extra: dict[str, Any] = {
        "duration_s": result.duration,
        "success": result.success,
        "target_us": TARGET_US,
        "meets_target": timing.median_us <= TARGET_US,
    }
    peer_row: Row | None = None
    try:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "scene.json"
            path.write_text(json.dumps({**scene, "warmup": warmup, "repeat": repeat}))
            peer = run_peer("toppra", "toppra_trajectories.py", [str(path)])
    except Exception as exc:  # a failing peer must not kill the suite
        peer = None
        peer_row = Row(SUITE, scene_name, "toppra", None, note=f"peer failed: {exc}"[:300])
    if peer is not None:
        peer_timing = Timing(
            median_us=peer["median_us"],
            p95_us=peer["p95_us"],
            p99_us=peer["p99_us"],
            mean_us=peer["mean_us"],
            n=peer["n"],
        )
        extra["ratio_time"] = timing.median_us / peer["median_us"]
        extra["ratio_duration"] = result.duration / peer["duration"]
        extra["duration_not_worse"] = result.duration <= peer["duration"] * (1.0 + 1e-9)
        peer_row = Row(
            SUITE,
            scene_name,
            "toppra",
            peer_timing,
            extra={"duration_s": peer["duration"], "version": peer["version"]},
        )
    elif peer_row is None:
        peer_row = Row(
            SUITE,
            scene_name,
            "toppra",
            None,
            note="peer venv .venv-peers/toppra missing (make bench-peers)",
        )
    rows.append(Row(SUITE, scene_name, "taskspace", timing, extra=extra, ratio_to="toppra"))
    rows.append(peer_row)

    w = np.asarray(scene["waypoints"])
    rows.append(
        Row(
            SUITE,
            "cubic_spline_7dof_10wp",
            "taskspace",
            measure(lambda: cubic_spline(w, boundary="clamped"), warmup=warmup, repeat=repeat),
        )
    )
    rows.append(
        Row(
            SUITE,
            "quintic_c4_spline_7dof_10wp",
            "taskspace",
            measure(lambda: quintic_spline(w), warmup=warmup, repeat=repeat),
        )
    )
    q0, q1 = w[0], w[-1]
    rows.append(
        Row(
            SUITE,
            "scurve_sync_7dof",
            "taskspace",
            measure(
                lambda: synchronize(q0, q1, PANDA_VMAX, PANDA_AMAX, 5000.0, profile="scurve"),
                warmup=warmup,
                repeat=repeat,
            ),
        )
    )
    return rows


if __name__ == "__main__":
    for row in run(quick=True):
        print(row.to_dict())
