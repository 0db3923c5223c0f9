"""Locomotion suite: LIPM preview control, ZMP MPC, compass-gait limit cycle, Raibert hopper.

Scenes:
* ``preview_10step``: Kajita's preview controller (z_c = 0.8 m, dt = 5 ms, Q_e = 1,
  R = 1e-6, preview 1.6 s) on a 10-step straight walk (0.2 m steps, 0.2 m width, single
  support 0.7 s, double support 0.2 s). Reported: RMS ZMP tracking error (target <= 1 mm),
  time per control step (the whole closed-loop run divided by its samples), gain design time.
* ``mpc_step``: one step of the ZMP MPC QP (dt = 50 ms, 32-sample horizon, both axes, support
  polygon constraints) on a 4-step walk.
* ``compass_gait_limit_cycle``: Newton on the Poincare map from ``(-0.2, 1.0, -0.4)``
  (Tedrake's parameters); the fixed point and its residual.
* ``hopper_2ms``: 20 s of the Raibert hopper ramped to 2 m/s; steady-state speed error.
* ``g1_walk``: whole-body walking of G1 (0.1 m steps; 3 steps quick, 10 otherwise): time of
  one inverse-dynamics QP control step (switching contact sets), and the real-time factor of
  the whole simulated walk (control + rigid-contact simulation + logging).

Peers: ``drake`` (``.venv-peers/drake``): Drake's own compass gait finds its fixed point by
Newton on its return map from the same start, and maps ours one step (the same fixed point
to 1e-6 is the target). ``qpmpc`` and the TSID walking loop are not wired.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from benchmarks.common import Row, Timing, measure, run_peer
from taskspace.locomotion import (
    CartTable,
    CompassGait,
    HopperParameters,
    PreviewController,
    RaibertOptions,
    StepTiming,
    ZmpMpc,
    find_limit_cycle,
    plan_from_robot,
    simulate_hopper,
    straight_walk,
    support_polygons,
    walk,
    zmp_reference,
)
from taskspace.model import Robot

SUITE = "locomotion"
TARGET_RMS_MM = 1.0


def _scale(t: Timing, factor: float) -> Timing:
    return Timing(
        median_us=t.median_us * factor,
        p95_us=t.p95_us * factor,
        p99_us=t.p99_us * factor,
        mean_us=t.mean_us * factor,
        n=t.n,
    )


def _wall(fn: Any, repeat: int) -> tuple[Timing, Any]:
    samples, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        samples.append(time.perf_counter() - t0)
    a = np.asarray(samples) * 1e6
    timing = Timing(
        median_us=float(np.median(a)),
        p95_us=float(np.percentile(a, 95)),
        p99_us=float(np.percentile(a, 99)),
        mean_us=float(np.mean(a)),
        n=int(a.size),
    )
    return timing, out


def run(quick: bool) -> list[Row]:
    """Run the suite; ``quick`` uses fewer repetitions."""
    rows: list[Row] = []
    # ------------------------------------------------------------ preview control
    model = CartTable(com_height=0.8, dt=0.005)
    plan = straight_walk(
        10,
        step_length=0.2,
        step_width=0.2,
        timing=StepTiming(single_support=0.7, double_support=0.2),
    )
    times = model.dt * np.arange(int(np.ceil(plan.duration / model.dt)) + 1)
    ref = zmp_reference(plan, times)
    ctrl = PreviewController(model)
    traj = ctrl.simulate(ref)
    rms_mm = 1000 * traj.rms_zmp_error
    run_timing = measure(lambda: ctrl.simulate(ref), warmup=1, repeat=3 if quick else 10)
    rows.append(
        Row(
            SUITE,
            "preview_10step",
            "taskspace (per control step)",
            _scale(run_timing, 1.0 / len(times)),
            extra={
                "rms_zmp_error_mm": rms_mm,
                "max_zmp_error_mm": 1000 * float(traj.zmp_error.max()),
                "target_rms_mm": TARGET_RMS_MM,
                "meets_target": rms_mm <= TARGET_RMS_MM,
                "samples": len(times),
                "walk_duration_s": plan.duration,
            },
        )
    )
    rows.append(
        Row(
            SUITE,
            "preview_gains",
            "taskspace (DARE + preview gains)",
            measure(lambda: PreviewController(model), warmup=2, repeat=5 if quick else 30),
            extra={"horizon": ctrl.horizon, "riccati_residual": ctrl.riccati.residual},
        )
    )
    # ------------------------------------------------------------ MPC
    mpc_model = CartTable(com_height=0.8, dt=0.05)
    plan4 = straight_walk(4)
    t4 = mpc_model.dt * np.arange(int(np.ceil(plan4.duration / mpc_model.dt)) + 1)
    res = ZmpMpc(mpc_model).simulate(zmp_reference(plan4, t4), support_polygons(plan4, t4))
    qp = res.solve_times * 1e6
    rows.append(
        Row(
            SUITE,
            "mpc_step",
            "taskspace (QP solve per step)",
            Timing(
                median_us=float(np.median(qp)),
                p95_us=float(np.percentile(qp, 95)),
                p99_us=float(np.percentile(qp, 99)),
                mean_us=float(np.mean(qp)),
                n=int(qp.size),
            ),
            extra={
                "horizon": ZmpMpc(mpc_model).horizon,
                "success": res.success,
                "rms_zmp_error_mm": 1000 * res.trajectory.rms_zmp_error,
            },
        )
    )
    # ------------------------------------------------------------ compass gait
    walker = CompassGait()
    timing, cycle = _wall(lambda: find_limit_cycle(walker, [-0.2, 1.0, -0.4]), 2 if quick else 5)
    rows.append(
        Row(
            SUITE,
            "compass_gait_limit_cycle",
            "taskspace (Newton on the return map)",
            timing,
            extra={
                "fixed_point": cycle.post_impact.tolist(),
                "residual": cycle.residual,
                "iterations": cycle.iterations,
                "floquet_abs": np.abs(cycle.floquet_multipliers).tolist(),
                "period_s": cycle.period,
            },
        )
    )
    # Drake's compass gait (its own witness functions and impact map) in the same run: our
    # fixed point pushed through Drake's return map, and Drake's own Newton search.
    x_ours = np.asarray(cycle.post_impact, dtype=float)
    drake = run_peer("drake", "drake_compass_gait.py", [repr(float(v)) for v in x_ours])
    if drake is None:
        rows.append(
            Row(
                SUITE,
                "compass_gait_limit_cycle",
                "drake (Newton on its return map)",
                None,
                note="peer not installed (make bench-peers)",
            )
        )
    else:
        ours_d = np.array(drake["ours_in_drake_coordinates"])
        rows.append(
            Row(
                SUITE,
                "compass_gait_limit_cycle",
                "drake (Newton on its return map)",
                Timing.from_samples([drake["seconds"]]),
                extra={
                    "fixed_point_drake_coordinates": drake["fixed_point"],
                    "max_abs_diff_to_ours": float(
                        np.max(np.abs(np.array(drake["fixed_point"]) - ours_d))
                    ),
                    "drake_return_map_residual_of_ours": float(
                        np.max(np.abs(np.array(drake["return_map_of_ours"]) - ours_d))
                    ),
                    "drake_simulator_only_residual_of_ours": float(
                        np.max(
                            np.abs(np.array(drake["simulator_only_return_map_of_ours"]) - ours_d)
                        )
                    ),
                    "residual": drake["residual"],
                    "iterations": drake["iterations"],
                },
                ratio_to="taskspace (Newton on the return map)",
            )
        )
    # ------------------------------------------------------------ hopper
    timing, hop = _wall(
        lambda: simulate_hopper(
            HopperParameters(), RaibertOptions(), lambda t: min(2.0, 0.25 * t), 20.0
        ),
        1 if quick else 3,
    )
    rows.append(
        Row(
            SUITE,
            "hopper_2ms",
            "taskspace (20 s simulated)",
            timing,
            extra={
                "success": hop.success,
                "speed_error_last5_max": float(np.abs(hop.apex_speeds[-5:] - 2.0).max()),
                "real_time_factor": 20.0 / (timing.median_us * 1e-6),
            },
        )
    )
    # ------------------------------------------------------------ whole-body walking
    robot = Robot.load("g1")
    n_steps = 3 if quick else 10
    walk_timing = StepTiming(
        single_support=0.6,
        double_support=0.2,
        initial_double_support=1.0,
        final_double_support=1.0,
        weight_shift=0.4,
    )
    plan_g1 = plan_from_robot(robot, robot.q_default, n_steps, step_length=0.1, timing=walk_timing)
    t0 = time.perf_counter()
    walked = walk(robot, plan_g1)
    wall = time.perf_counter() - t0
    ct = walked.control_times * 1e6
    rows.append(
        Row(
            SUITE,
            f"g1_walk_{n_steps}steps",
            "taskspace (inverse-dynamics QP per control step)",
            Timing(
                median_us=float(np.median(ct)),
                p95_us=float(np.percentile(ct, 95)),
                p99_us=float(np.percentile(ct, 99)),
                mean_us=float(np.mean(ct)),
                n=int(ct.size),
            ),
            extra={
                "success": walked.success,
                "simulated_s": float(walked.times[-1]),
                "wall_s": wall,
                "real_time_factor": float(walked.times[-1]) / wall,
                "min_zmp_margin_mm": 1000 * float(walked.zmp_margin.min()),
                "cone_violation_N": walked.cone_violation,
            },
        )
    )
    return rows
