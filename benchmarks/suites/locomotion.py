"""Locomotion suite: LIPM preview control, ZMP MPC, compass-gait limit cycle, Raibert hopper.

Scenes:
* ``preview_10step``: Kajita's preview controller (z_c = 0.8 m, dt = 5 ms, Q_e = 1,
  R = 1e-6, preview 1.6 s) on a 10-step straight walk (0.2 m steps, 0.2 m width, single
  support 0.7 s, double support 0.2 s). Reported: RMS ZMP tracking error (target <= 1 mm),
  time per control step (the whole closed-loop run divided by its samples), gain design time.
* ``mpc_step``: one step of the ZMP MPC QP (dt = 50 ms, 32-sample horizon, both axes, support
  polygon constraints) on a 4-step walk.
  Also the whole closed-loop step (QP build + solve) beside qpmpc's.
* ``compass_gait_limit_cycle``: Newton on the Poincare map from ``(-0.2, 1.0, -0.4)``
  (Tedrake's parameters); the fixed point and its residual.
* ``kneed_walker_limit_cycle``: the passive walker with knees (Hsu Chen's parameters), Newton
  on its Poincare map from her published gait; the fixed point, residual and multipliers.
* ``hopper_2ms``: 20 s of the Raibert hopper ramped to 2 m/s; steady-state speed error.
* ``g1_walk``: whole-body walking of G1 (0.1 m steps; 3 steps quick, 10 otherwise): time of
  one inverse-dynamics QP control step (switching contact sets), and the real-time factor of
  the whole simulated walk (control + rigid-contact simulation + logging).

Peers: ``drake`` (``.venv-peers/drake``): Drake's own compass gait finds its fixed point by
Newton on its return map from the same start, and maps ours one step (the same fixed point
to 1e-6 is the target). ``tsid`` (``.venv-peers/tsid``): benchmarks/peers/tsid_walking.py
tracks the same CoM, swing-foot and pelvis references of the G1 walk
(:func:`~taskspace.locomotion.walking_reference`) with TSID's formulation and its contact
transitions; its time per control step beside ours (target: ours <= 0.5x TSID) and the
tracking errors of both (TSID integrates its own accelerations, as its demos do; ours is the
rigid-contact simulation). ``qpmpc`` (``.venv-peers/qpmpc``): benchmarks/peers/qpmpc_zmp.py
poses the ``mpc_step`` walk (same plan, model, horizon, weights, support polygons) as a qpmpc
``MPCProblem`` (ZMP error and jerk costs, Wieber 2006) solved by ProxQP in closed loop; its
step and QP times beside ours and the ZMP tracking errors of both.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import Row, Timing, measure, run_peer
from taskspace.locomotion import (
    CartTable,
    CompassGait,
    HopperParameters,
    KneedWalker,
    PreviewController,
    RaibertOptions,
    StepTiming,
    WalkingOptions,
    ZmpMpc,
    find_kneed_limit_cycle,
    find_limit_cycle,
    plan_from_robot,
    simulate_hopper,
    straight_walk,
    support_polygons,
    walk,
    walking_reference,
    zmp_reference,
)
from taskspace.model import Robot
from taskspace.qp import QPStatus

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
                "qp_solver_steps": sum(s is not QPStatus.UNCONSTRAINED for s in res.statuses),
                **{f"max_kkt_{k}": v for k, v in res.max_kkt.items()},
            },
            note="a step whose unconstrained minimizer meets the polygon rows (and whose KKT "
            "residuals meet the tolerances) is one solve with the kept Cholesky factor of H "
            "(no QP solver call)",
        )
    )
    mpc = ZmpMpc(mpc_model)
    polys4 = support_polygons(plan4, t4)
    ref4 = zmp_reference(plan4, t4)
    whole = measure(lambda: mpc.simulate(ref4, polys4), warmup=1, repeat=3 if quick else 10)
    rows.append(
        Row(
            SUITE,
            "mpc_step",
            "taskspace (whole step: build + QP)",
            _scale(whole, 1.0 / len(t4)),
            extra={
                "samples": len(t4),
                "rms_zmp_error_mm": 1000 * res.trajectory.rms_zmp_error,
                **{f"max_kkt_{k}": v for k, v in res.max_kkt.items()},
            },
        )
    )
    rows.extend(_qpmpc_rows(mpc_model, mpc, ref4, polys4, res))
    # ------------------------------------------------------------ kneed walker
    kneed = KneedWalker()
    timing, kcycle = _wall(
        lambda: find_kneed_limit_cycle(kneed, [-0.1877, 1.1014, -0.0399]), 2 if quick else 5
    )
    rows.append(
        Row(
            SUITE,
            "kneed_walker_limit_cycle",
            "taskspace (Newton on the return map)",
            timing,
            extra={
                "fixed_point": kcycle.fixed_point.tolist(),
                "published_hsu_chen_2007": [-0.1877, 1.1014, -0.0399],
                "residual": kcycle.residual,
                "iterations": kcycle.iterations,
                "floquet_abs": np.abs(kcycle.floquet_multipliers).tolist(),
                "period_s": kcycle.period,
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
                **_tracking_errors(robot, plan_g1, walked),
                **{k: v for k, v in walked.solves.items() if k != "paths"},
            },
            ratio_to="tsid (same references)",
            note="QP includes joint-limit rows (TSID's loop has none); rigid-contact simulation; "
            f"steps per path {walked.solves.get('paths', {})}",
        )
    )
    rows.append(_tsid_walking_row(robot, plan_g1, n_steps, ct))
    return rows


def _qpmpc_rows(model: CartTable, mpc: ZmpMpc, ref: Any, polys: Any, ours: Any) -> list[Row]:
    """qpmpc on the ``mpc_step`` walk (benchmarks/peers/qpmpc_zmp.py), beside our two rows."""
    N = mpc.horizon
    held = list(polys) + [polys[-1]] * (N + 2)
    halfspaces = [[a.tolist(), b.tolist()] for a, b in (p.halfspaces() for p in held)]
    opts = mpc.options.preview
    data = {
        "dt": model.dt,
        "com_height": model.com_height,
        "gravity": model.gravity,
        "horizon": N,
        "error_weight": opts.error_weight,
        "input_weight": opts.input_weight,
        "A": model.A.tolist(),
        "B": model.B[:, 0].tolist(),
        "reference": np.asarray(ref).tolist(),
        "halfspaces": halfspaces,
    }
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "zmp_mpc.json"
        path.write_text(json.dumps(data), encoding="utf-8")
        out = run_peer("qpmpc", "qpmpc_zmp.py", [str(path)])
    names = ("qpmpc (whole step: MPCQP + ProxQP)", "qpmpc (QP solve per step)")
    if out is None:
        return [
            Row(SUITE, "mpc_step", n, None, note="peer not installed (make bench-peers)")
            for n in names
        ]
    extra = {
        "rms_zmp_error_mm": out["rms_zmp_error_mm"],
        "max_zmp_error_mm": out["max_zmp_error_mm"],
        "max_polygon_violation_mm": out["max_polygon_violation_mm"],
        "success": out["success"],
        "samples": out["samples"],
        "ours_rms_zmp_error_mm": 1000 * ours.trajectory.rms_zmp_error,
        "ours_max_zmp_error_mm": 1000 * float(ours.trajectory.zmp_error.max()),
    }
    note = "same plan, model, horizon, weights, polygons; qpmpc penalizes jerk, ours its increments"
    return [
        Row(
            SUITE,
            "mpc_step",
            names[0],
            Timing.from_samples(np.asarray(out["step_us"]) * 1e-6),
            extra=extra,
            ratio_to="taskspace (whole step: build + QP)",
            note=note,
        ),
        Row(
            SUITE,
            "mpc_step",
            names[1],
            Timing.from_samples(np.asarray(out["qp_us"]) * 1e-6),
            extra={"solver": "proxqp (qpsolvers), eps_abs 1e-9"},
            ratio_to="taskspace (QP solve per step)",
        ),
    ]


def _tracking_errors(robot: Robot, plan: Any, walked: Any) -> dict[str, float]:
    """CoM and swing-foot tracking errors of our simulated walk against its references."""
    opts = WalkingOptions()
    ref = walking_reference(robot, plan, opts)
    com_err = np.linalg.norm(walked.com - walked.com_reference, axis=1)
    foot_err = []
    for side, frame in zip(("left", "right"), opts.feet):
        swinging = walked.wrenches[side][:, 2] == 0.0
        for k in np.flatnonzero(swinging):
            g = min(round(walked.times[k] / opts.dt), len(ref.times) - 1)
            if not ref.swinging[side][g]:
                continue  # the one-sample phase-boundary offset of the simulated phases
            p = robot.frame_placement(walked.q[k], frame).translation
            foot_err.append(float(np.linalg.norm(p - ref.foot_position[side][g])))
    return {
        "com_error_max_mm": 1000 * float(com_err.max()),
        "com_error_rms_mm": 1000 * float(np.sqrt(np.mean(com_err**2))),
        "swing_foot_error_max_mm": 1000 * max(foot_err, default=0.0),
    }


def _tsid_walking_row(robot: Robot, plan: Any, n_steps: int, ours_us: Any) -> Row:
    """TSID's formulation tracking the same references (benchmarks/peers/tsid_walking.py)."""
    opts = WalkingOptions()
    ref = walking_reference(robot, plan, opts)
    weight = robot.mass * float(np.linalg.norm(robot.model.gravity.linear))
    spec = {
        "dt": opts.dt,
        "feet": list(opts.feet),
        "pelvis": opts.pelvis,
        "sole_half_length": opts.sole_half_length,
        "sole_half_width": opts.sole_half_width,
        "friction": opts.friction,
        "min_force": opts.min_force,
        "max_force": 10.0 * weight,
        "com_kp": opts.com_kp,
        "foot_kp": opts.foot_kp,
        "pelvis_kp": opts.pelvis_kp,
        "posture_kp": opts.posture_kp,
        "foot_weight": opts.foot_weight,
        "pelvis_weight": opts.pelvis_weight,
        "posture_weight": opts.posture_weight,
        "transition_time": opts.transition_time,
        "phases": ref.phases,
    }
    # Any: a dict[str, ndarray] splatted into np.savez could hit its allow_pickle: bool (mypy)
    arrays: dict[str, Any] = {
        "times": ref.times,
        "com": ref.com,
        "com_velocity": ref.com_velocity,
        "com_acceleration": ref.com_acceleration,
        "pelvis_rotation": ref.pelvis_rotation,
        "q0": ref.q0,
    }
    for side in ("left", "right"):
        arrays[f"{side}_position"] = ref.foot_position[side]
        arrays[f"{side}_velocity"] = ref.foot_velocity[side]
        arrays[f"{side}_acceleration"] = ref.foot_acceleration[side]
        arrays[f"{side}_rotation"] = ref.foot_rotation[side]
    method = "tsid (same references)"
    scene = f"g1_walk_{n_steps}steps"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "walk.npz"
        np.savez(path, spec=json.dumps(spec), **arrays)
        try:
            peer = run_peer("tsid", "tsid_walking.py", [str(path)])
        except RuntimeError as exc:
            return Row(SUITE, scene, method, None, note=f"peer failed: {exc!s:.300}")
    if peer is None:
        return Row(SUITE, scene, method, None, note="peer not installed (make bench-peers)")
    tsid_us = np.asarray(peer["times"]) * 1e6
    return Row(
        SUITE,
        scene,
        method,
        Timing.from_samples(np.asarray(peer["times"])),
        extra={
            "failed_steps": peer["failed_steps"],
            "com_error_max_mm": 1000 * peer["com_error_max_m"],
            "com_error_rms_mm": 1000 * peer["com_error_rms_m"],
            "swing_foot_error_max_mm": 1000 * peer["swing_foot_error_max_m"],
            "ours_over_tsid_median": float(np.median(ours_us) / np.median(tsid_us)),
            "target_ratio": 0.5,
        },
        note=peer["note"],
    )
