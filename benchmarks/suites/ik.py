"""Differential IK (weighted and hierarchical) and global IK, beside pink, placo and mink.

Scenes (issue 3):
* ``g1``: G1 with a free flyer (nv = 35): both feet poses fixed, both hands following
  ``[0.15 sin(0.004k), 0.1 (cos(0.004k) - 1), 0.1 sin(0.002k)]`` m, CoM, posture (1e-3),
  joint position + velocity limits, dt = 5 ms, 1500 steps.
* ``panda``: tcp pose (moving the same way) + posture, limits, 1500 steps.
* ``g1 hierarchy``: the G1 tasks as 4 strict levels (feet + CoM-in-support-box inequality;
  CoM; hands; posture). Rows: the compiled step (``native_steps``: how many steps it
  answered; the others ran the Python cascade) and the Python cascade alone.
* ``g1 hierarchy, active CoM box``: the same with the support box's front edge 2 mm behind
  the initial CoM (the CoM task's target): the level-1 inequality moves the CoM behind it and
  then holds it against the CoM level on every step, so the level QPs run (in the kernel:
  its active-set level QPs, ``native_steps``; the Python row: the Python cascade's).
* ``panda equality + rows``: Panda, tcp position following the ``panda`` offsets, the tcp
  orientation held exactly (an equality task), posture (1e-3), joint position + velocity
  limits and two joint-space half-spaces ``A q <= b`` (a user's constraint class: general
  inequality rows evaluated in Python), dt = 5 ms, 1500 steps, timed ``advance``. Rows: the
  compiled general step, the Python path (proxsuite), and placo with a ``hard`` orientation
  task and its ``JointSpaceHalfSpacesConstraint`` (the same problem: its half-space
  violation and orientation error are reported), in alternating rounds.
* ``panda global``: ``solve_ik`` on random reachable tcp poses.
* ``panda dampers``: the main demo's scene (``examples/demo_main.py``): Panda with convex
  collision geometry, a 7 cm ball in the way of a tcp pose task whose target slides 45 cm
  behind it, posture (1e-5), joint position + velocity limits and collision velocity dampers
  (every self and ball pair; safety 2 cm, influence 12 cm, gain 0.5), dt = 10 ms, 400 steps.
  Rows: the compiled kernel with the dampers, the same stack without them (the ratio of
  issue 16's target), the Python path, and placo with its self-collision constraint on the
  same scene (the ball a fixed link of its URDF), in alternating rounds.

A step is timed from the state update to the integrated configuration (build + solve +
integrate); the target update of the scene is not timed, for every library alike. The
weighted taskspace rows (``g1``, ``panda``, compiled and Python path) time
``DifferentialIK.advance(state, dt)``, which does that work in one call (on the compiled
kernel: solve, integrate, and the kinematics of the new configuration in one C++ call);
placo's timed region is unchanged (``update_kinematics(); solve(True)``). Each
taskspace row reports the largest KKT residuals of its QP solves (``max_kkt_*``, outside the
timed part) and how many solves carry none (``solves_without_kkt``: the compiled kernel's).
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from benchmarks.common import Row, Timing, run_peer
from taskspace import features as F
from taskspace._native import ik_kernel
from taskspace.constraints import (
    CollisionAvoidance,
    Constraint,
    FeatureBounds,
    JointPositionLimits,
    JointVelocityLimits,
)
from taskspace.features.rows import INF, InequalityRows
from taskspace.ik import (
    DifferentialIK,
    DifferentialIKOptions,
    HierarchicalIK,
    SolveIKOptions,
    solve_ik,
)
from taskspace.model import Obstacle, Robot
from taskspace.qp.kkt import box_kkt_residuals
from taskspace.tasks import Task

SUITE = "ik"
DT = 0.005
G1_FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
G1_HANDS = ("left_rubber_hand", "right_rubber_hand")


def hand_offset(k: int) -> np.ndarray:
    """Offset of the moving targets at step ``k`` [m]."""
    return np.array(
        [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
    )


def move_targets(moving: list[tuple[Task, pin.SE3]], k: int) -> None:
    """Set each moving task's target to its initial one shifted by :func:`hand_offset` ``(k)``."""
    off = hand_offset(k)
    for task, T0 in moving:
        T = T0.copy()
        T.translation = T0.translation + off
        task.set_target(T)


def g1_tasks(robot: Robot) -> tuple[dict[str, list[Task]], list[tuple[Task, pin.SE3]]]:
    """Tasks of the G1 scene grouped by role, and the moving ones with their initial target."""
    s = robot.state(robot.q_default)
    feet = [Task(F.FramePose(robot, f), name=f) for f in G1_FEET]
    hands = [Task(F.FramePose(robot, h), name=h) for h in G1_HANDS]
    com = [Task(F.CenterOfMass(robot), name="com")]
    for t in (*feet, *hands, *com):
        t.set_target_from_state(s)
    posture = [Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")]
    moving = [(t, t.target.copy()) for t in hands]
    return {"feet": feet, "com": com, "hands": hands, "posture": posture}, moving


def _qp_results(result: Any) -> list[Any]:
    """The QP results behind one IK step (one, or one per level of a hierarchy)."""
    if hasattr(result, "hierarchy"):
        return list(result.hierarchy.level_results)
    return [result.qp] if getattr(result, "qp", None) is not None else []


def _loop(  # type: ignore[type-arg]
    robot: Robot,
    solve: Any,
    moving: list,
    steps: int,
    kernel_qp: Any = None,
    advance: Any = None,
) -> dict[str, Any]:
    """``steps`` steps; timed: ``state.update(q); solve; q (+) dq``, or ``advance(state, DT)``.

    ``advance`` (``DifferentialIK.advance``) does the same work in one call: solve, integrate,
    and the kinematics of the new configuration (the state moves). Between timed steps only
    the targets move, as in the peers' loops; the checks (KKT residuals, limits, tracking)
    run after the loop on the recorded steps, each at the configuration and targets it was
    solved with (a Python QP build between steps evicts the caches the next timed step uses).
    """
    state = robot.state(robot.q_default)
    before = robot.state(robot.q_default)  # the state a step was solved at (KKT check)
    q = robot.q_default.copy()
    times = np.empty(steps)
    record: list[tuple[np.ndarray, np.ndarray, Any]] = []  # (q solved at, q after, result)

    for k in range(steps):
        move_targets(moving, k)
        q_at = q
        if advance is not None:
            t0 = time.perf_counter()
            result = advance(state, DT)
            times[k] = time.perf_counter() - t0
            q = state.q
        else:
            t0 = time.perf_counter()
            state.update(q)
            result = solve(state, DT)
            q = pin.integrate(robot.model, q, result.dq)
            times[k] = time.perf_counter() - t0
        record.append((q_at, q, result))
    failed = 0
    lo, hi = robot.lower_limits, robot.upper_limits
    worst_violation = 0.0
    native = 0
    kkt = {"primal": 0.0, "dual": 0.0, "complementarity": 0.0, "not_computed": 0}
    idx = robot.limited_joints_q
    for k, (q_at, q_after, result) in enumerate(record):  # the checks, after the timed loop
        move_targets(moving, k)
        before.update(q_at)
        failed += not result.success
        native += bool(getattr(result, "native", False))
        for qp in _qp_results(result):
            if not np.isfinite(qp.kkt.primal) and kernel_qp is not None and qp.backend == "native":
                # the compiled kernel returns no multipliers: residuals of its step on the QP
                # the Python path builds for the same state (box-only, multipliers recovered)
                qp.kkt = box_kkt_residuals(kernel_qp(before, DT), result.dq)
            if not np.isfinite(qp.kkt.primal):
                kkt["not_computed"] += 1
                continue
            for key in ("primal", "dual", "complementarity"):
                kkt[key] = max(kkt[key], float(getattr(qp.kkt, key)))
        worst_violation = max(
            worst_violation,
            float(np.maximum(lo[idx] - q_after[idx], q_after[idx] - hi[idx]).max()),
        )
    # at the state the last step was solved at, with its targets (as before advance existed)
    tracking = float(np.linalg.norm(moving[0][0].error(before)[:3]))
    return {
        "times": times,
        "failed": failed,
        "limit_violation": worst_violation,
        "final_hand_error_m": tracking,
        "kkt": kkt,
        "native_steps": native,
    }


def run_g1(steps: int, native: bool = True) -> dict[str, Any]:
    """Weighted G1 scene (``native``: the compiled kernel when built, else the Python path)."""
    robot = Robot.load("g1")
    groups, moving = g1_tasks(robot)
    tasks = [t for g in groups.values() for t in g]
    ik = DifferentialIK(
        robot,
        tasks,
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=native),
    )
    return _loop(robot, ik.solve, moving, steps, ik.build, ik.advance)


def run_g1_hierarchy(steps: int, native: bool = True, front: float = 0.08) -> dict[str, Any]:
    """G1 as 4 strict levels, with an inequality (CoM inside the feet's box) on level 1.

    ``native``: the compiled closed-form step first; ``front``: the box's front edge ahead
    of the feet [m] (0.08; ``run_g1_hierarchy_active``: 2 mm behind the CoM).
    """
    robot = Robot.load("g1")
    groups, moving = g1_tasks(robot)
    s = robot.state(robot.q_default)
    feet_xy = np.array([s.frame_placement(robot.frame_id(f)).translation[:2] for f in G1_FEET])
    support = FeatureBounds(
        F.CenterOfMass(robot),
        [feet_xy[:, 0].min() - 0.05, feet_xy[:, 1].min(), -np.inf],
        [feet_xy[:, 0].max() + front, feet_xy[:, 1].max(), np.inf],
        name="CoM over the feet",
    )
    levels: list[Sequence[Task | Constraint]] = [
        [*groups["feet"], support],
        groups["com"],
        groups["hands"],
        groups["posture"],
    ]
    ik = HierarchicalIK(
        robot, levels, [JointPositionLimits(robot), JointVelocityLimits(robot)], native=native
    )
    return _loop(robot, ik.solve, moving, steps)


def run_g1_hierarchy_active(steps: int, native: bool = True) -> dict[str, Any]:
    """:func:`run_g1_hierarchy` with the box's front edge 2 mm behind the initial CoM."""
    robot = Robot.load("g1")
    s = robot.state(robot.q_default)
    feet_x = max(s.frame_placement(robot.frame_id(f)).translation[0] for f in G1_FEET)
    return run_g1_hierarchy(steps, native, float(s.com()[0]) - 0.002 - feet_x)


def run_panda(steps: int, native: bool = True) -> dict[str, Any]:
    """Panda tcp pose + posture (``native`` as in :func:`run_g1`)."""
    robot = Robot.load("panda")
    s = robot.state(robot.q_default)
    tcp = Task(F.FramePose(robot, "panda_hand_tcp"), name="tcp")
    tcp.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3)
    ik = DifferentialIK(
        robot,
        [tcp, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot)],
        options=DifferentialIKOptions(native=native),
    )
    return _loop(robot, ik.solve, [(tcp, tcp.target.copy())], steps, ik.build, ik.advance)


def run_global(n: int) -> dict[str, Any]:
    """``solve_ik`` on ``n`` random reachable Panda tcp poses."""
    robot = Robot.load("panda")
    rng = np.random.default_rng(2024)
    times, success, errors = [], 0, []
    options = SolveIKOptions(restarts=10)
    for _ in range(n):
        target = robot.frame_placement(robot.random_configuration(rng), "panda_hand_tcp")
        task = Task(F.FramePose(robot, "panda_hand_tcp"), target)
        result = solve_ik(robot, [task], robot.q_default, options=options, rng=rng)
        times.append(result.solve_time)
        success += result.success
        errors.append(result.errors["pose(panda_hand_tcp)"])
    return {"times": np.array(times), "success_rate": success / n, "max_error": max(errors)}


DEMO_DT = 0.01
DEMO_BALL = (0.07, (0.0, 0.22, -0.03))  # radius [m], centre offset from the start tcp [m]
DEMO_GOAL = (0.0, 0.45, -0.05)  # goal offset from the start tcp [m]


def run_panda_dampers(steps: int, native: bool = True, dampers: bool = True) -> dict[str, Any]:
    """The main demo's scene (see the module docstring), ``steps`` steps."""
    robot = Robot.load("panda", convex_collision=True)
    tcp = robot.end_effectors[0]
    q = robot.q_default.copy()
    state = robot.state(q)
    start = state.frame_placement(robot.frame_id(tcp)).copy()
    goal = start.copy()
    goal.translation = start.translation + np.array(DEMO_GOAL)
    radius, offset = DEMO_BALL
    robot.add_obstacle(Obstacle.sphere("ball", radius, start.translation + np.array(offset)))
    pose = Task(F.FramePose(robot, tcp), weight=1.0, gain=0.5, name="tcp")
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-5, name="posture")
    avoid = CollisionAvoidance(robot, safety_distance=0.02, influence_distance=0.12, gain=0.5)
    constraints = [JointPositionLimits(robot), JointVelocityLimits(robot)]
    if dampers:
        constraints.append(avoid)
    ik = DifferentialIK(
        robot, [pose, posture], constraints, options=DifferentialIKOptions(native=native)
    )
    times = np.empty(steps)
    kkt = {"primal": 0.0, "dual": 0.0, "complementarity": 0.0, "not_computed": 0}
    failed = native_steps = 0
    smallest = np.inf
    for k in range(steps):
        s = min(1.0, k / (0.75 * steps))
        pose.set_target(pin.SE3.Interpolate(start, goal, 0.5 * (1 - np.cos(np.pi * s))))
        t0 = time.perf_counter()
        state.update(q)
        result = ik.solve(state, DEMO_DT)
        q = pin.integrate(robot.model, q, result.dq)
        times[k] = time.perf_counter() - t0
        failed += not result.success  # below: outside the timed part
        qp = result.qp
        native_steps += qp.backend == "native"
        if not np.isfinite(qp.kkt.primal) and qp.backend == "native":  # box-only kernel step
            qp.kkt = box_kkt_residuals(ik.build(state, DEMO_DT), result.dq)
        if np.isfinite(qp.kkt.primal) and qp.kkt.within(1e-9, 1e-9):
            for key in ("primal", "dual", "complementarity"):
                kkt[key] = max(kkt[key], float(getattr(qp.kkt, key)))
        else:
            kkt["not_computed"] += 1
        smallest = min(smallest, float(avoid.distances.value(state).min()))
    state.update(q)
    return {
        "times": times,
        "failed": failed,
        "native_steps": native_steps,
        "kkt": kkt,
        "min_distance_m": smallest,
        "final_tcp_error_m": float(np.linalg.norm(pose.error(state)[:3])),
        "q0": robot.q_default,
        "pairs": avoid.distances.pair_names,
    }


def panda_dampers_rows(steps: int, rounds: int = 3) -> list[Row]:
    """The demo scene: compiled with and without dampers, Python path, placo; alternating."""
    variants = {
        "taskspace": {"native": True, "dampers": True},
        "taskspace, no dampers": {"native": True, "dampers": False},
        "taskspace, Python path": {"native": False, "dampers": True},
    }
    samples: dict[str, list[np.ndarray]] = {name: [] for name in variants}
    last: dict[str, dict[str, Any]] = {}
    for _ in range(rounds):  # alternate the variants: the machine's load drifts
        for name, kwargs in variants.items():
            out = run_panda_dampers(steps, **kwargs)
            samples[name].append(out["times"])
            last[name] = out
    rows = []
    for name, out in last.items():
        extra = {
            "failed_steps": out["failed"],
            "compiled_steps": out["native_steps"],
            "min_distance_m": round(out["min_distance_m"], 5),
            "tcp_error_m": round(out["final_tcp_error_m"], 5),
            **_kkt_extra(out["kkt"]),
        }
        ratio_to = None if name == "taskspace, no dampers" else "taskspace, no dampers"
        timing = Timing.from_samples(np.concatenate(samples[name]))
        rows.append(Row(SUITE, "panda dampers", name, timing, extra, ratio_to=ratio_to))
    q0 = last["taskspace"]["q0"]
    # the scene's collision pairs by link name (geometry "<link>_<k>"; the ball is "ball")
    pairs = sorted(
        {
            tuple(g.rsplit("_", 1)[0] if g != "ball" else g for g in p)
            for p in last["taskspace"]["pairs"]
        }
    )
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "scene.json"
        spec.write_text(
            json.dumps(
                {
                    "steps": steps,
                    "dt": DEMO_DT,
                    "q0": q0.tolist(),
                    "ball": [DEMO_BALL[0], list(DEMO_BALL[1])],
                    "goal": list(DEMO_GOAL),
                    "rounds": rounds,
                    "pairs": [list(p) for p in pairs],
                }
            )
        )
        try:
            out = run_peer("placo", "placo_dampers.py", [str(spec)])
        except Exception as exc:
            rows.append(Row(SUITE, "panda dampers", "placo", None, note=f"failed: {exc!s:.200}"))
            return rows
    if out is None:
        note = "peer env missing (make bench-peers)"
        rows.append(Row(SUITE, "panda dampers", "placo", None, note=note))
    elif "error" in out:
        rows.append(Row(SUITE, "panda dampers", "placo", None, note=out["error"]))
    else:
        extra = {k: v for k, v in out.items() if k not in ("times", "note")}
        timing = Timing.from_samples(np.array(out["times"]))
        rows.append(
            Row(
                SUITE,
                "panda dampers",
                "placo",
                timing,
                extra,
                "taskspace, no dampers",
                out.get("note", ""),
            )
        )
    return rows


# ``panda equality + rows``: joint-space half-spaces A q <= q0-value + margin on the arm joints
GENERAL_A = np.array([[0, 1, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, -1, 0]], dtype=float)
GENERAL_MARGIN = np.array([0.3, 0.7])  # [rad]


class JointHalfSpaces(Constraint):
    """A user's joint-space half-spaces ``A q <= b`` (revolute joints: rows ``A dq <= b - A q``).

    A general inequality row: no compiled declaration, evaluated in Python on both paths.
    """

    def __init__(self, robot: Robot, A: np.ndarray, b: np.ndarray) -> None:
        super().__init__(robot, "joint half-spaces")
        self.A, self.b = A, b
        self._lower = np.full(len(b), -INF)

    def inequalities(self, state: Any, dt: float) -> InequalityRows:
        return InequalityRows(self.A, self._lower, self.b - self.A @ state.q)


def panda_general_scene(
    robot: Robot, state: Any
) -> tuple[Task, np.ndarray, Task, Task, list[Any], np.ndarray]:
    """The ``panda equality + rows`` scene at ``state``: the tcp position task and its initial
    target, the tcp orientation (an equality task), the posture, the constraints (limits and
    the two half-spaces ``GENERAL_A q <= b``) and ``b``."""
    tcp = "panda_hand_tcp"
    position = Task(F.Position(robot, tcp), name="tcp")
    p0 = position.feature.value(state).copy()
    orientation = Task(F.Orientation(robot, tcp), name="orientation")
    orientation.set_target_from_state(state)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-3, name="posture")
    b = GENERAL_A @ robot.q_default + GENERAL_MARGIN
    constraints = [
        JointPositionLimits(robot),
        JointVelocityLimits(robot),
        JointHalfSpaces(robot, GENERAL_A, b),
    ]
    return position, p0, orientation, posture, constraints, b


def run_panda_general(steps: int, native: bool = True) -> dict[str, Any]:
    """Panda: tcp position (the ``panda`` offsets), tcp orientation held by an equality task,
    posture (1e-3), limits and two joint-space half-spaces; timed: ``advance(state, DT)``."""
    robot = Robot.load("panda")
    state = robot.state(robot.q_default)
    position, p0, orientation, posture, constraints, b = panda_general_scene(robot, state)
    ik = DifferentialIK(
        robot,
        [position, posture],
        constraints,
        equality_tasks=[orientation],
        options=DifferentialIKOptions(native=native),
    )
    times = np.empty(steps)
    record: list[tuple[np.ndarray, Any]] = []  # (q after the step, result)
    for k in range(steps):
        position.set_target(p0 + hand_offset(k))
        t0 = time.perf_counter()
        result = ik.advance(state, DT)
        times[k] = time.perf_counter() - t0
        record.append((state.q, result))  # a new q array and a new result at each step
    # the checks, after the timed loop as in _loop and placo's loop: building result.qp, its
    # residuals and the features' errors between steps evicted the caches the next step uses
    kkt = {"primal": 0.0, "dual": 0.0, "complementarity": 0.0, "not_computed": 0}
    failed = compiled = active = 0
    declined: dict[str, int] = {}
    violation = orientation_error = 0.0
    after = robot.state(robot.q_default)
    for q_after, result in record:
        failed += not result.success
        qp = result.qp
        compiled += qp.backend == "native general"
        if result.native_declined:
            declined[result.native_declined] = declined.get(result.native_declined, 0) + 1
        active += bool(np.any(qp.z != 0.0))
        if np.isfinite(qp.kkt.primal):
            for key in ("primal", "dual", "complementarity"):
                kkt[key] = max(kkt[key], float(getattr(qp.kkt, key)))
        else:
            kkt["not_computed"] += 1
        after.update(q_after)
        violation = max(violation, float((GENERAL_A @ q_after - b).max()))
        orientation_error = max(orientation_error, float(np.linalg.norm(orientation.error(after))))
    return {
        "times": times,
        "failed": failed,
        "compiled": compiled,
        "active": active,
        "declined": declined,
        "kkt": kkt,
        "violation": violation,
        "orientation_error": orientation_error,
        "tcp_error": float(np.linalg.norm(position.error(state))),
    }


def panda_general_rows(steps: int, rounds: int = 3) -> list[Row]:
    """``panda equality + rows``: compiled general step, Python path, placo; alternating."""
    scene = "panda equality + rows"
    samples: dict[str, list[np.ndarray]] = {"taskspace": [], "taskspace, Python path": []}
    last: dict[str, dict[str, Any]] = {}
    placo_times: list[float] = []
    placo_out: Any = None
    placo_note = ""
    robot = Robot.load("panda")
    b = GENERAL_A @ robot.q_default + GENERAL_MARGIN
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "scene.json"
        spec.write_text(
            json.dumps(
                {
                    "steps": steps,
                    "dt": DT,
                    "q0": robot.q_default.tolist(),
                    "A": GENERAL_A.tolist(),
                    "b": b.tolist(),
                }
            )
        )
        for _ in range(rounds):  # alternate: the machine's load drifts
            for name, native in (("taskspace", True), ("taskspace, Python path", False)):
                out = run_panda_general(steps, native)
                samples[name].append(out["times"])
                last[name] = out
            if placo_note:
                continue
            try:
                placo_out = run_peer("placo", "placo_general.py", [str(spec)])
            except Exception as exc:
                placo_note = f"failed: {exc!s:.200}"
                continue
            if placo_out is None:
                placo_note = "peer env missing (make bench-peers)"
            elif "error" in placo_out:
                placo_note = placo_out["error"]
            else:
                placo_times += placo_out["times"]
    rows = []
    for name, out in last.items():
        extra = {
            "failed_steps": out["failed"],
            "compiled_steps": out["compiled"],
            "steps_with_active_rows": out["active"],
            "max_half_space_violation": f"{out['violation']:.1e}",
            "max_orientation_error": f"{out['orientation_error']:.1e}",
            "tcp_error_m": round(out["tcp_error"], 5),
            **_kkt_extra(out["kkt"]),
        }
        if out["declined"]:
            extra["declined"] = out["declined"]
        timing = Timing.from_samples(np.concatenate(samples[name]))
        rows.append(Row(SUITE, scene, name, timing, extra, ratio_to="placo"))
    if placo_note or placo_out is None:
        rows.append(Row(SUITE, scene, "placo", None, note=placo_note))
    else:
        extra = {k: v for k, v in placo_out.items() if k not in ("times", "note")}
        timing = Timing.from_samples(np.array(placo_times))
        rows.append(Row(SUITE, scene, "placo", timing, extra))
    return rows


def _peer_rows(scene: str, steps: int, q0: np.ndarray) -> list[Row]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "scene.json"
        spec.write_text(json.dumps({"scene": scene, "steps": steps, "dt": DT, "q0": q0.tolist()}))
        for peer in ("placo", "pink"):
            try:
                out = run_peer(peer, f"{peer}_ik.py", [str(spec)])
            except Exception as exc:
                rows.append(Row(SUITE, scene, peer, None, note=f"failed: {exc!s:.200}"))
                continue
            if out is None:
                rows.append(
                    Row(SUITE, scene, peer, None, note="peer env missing (make bench-peers)")
                )
                continue
            if "error" in out:
                rows.append(Row(SUITE, scene, peer, None, note=out["error"]))
                continue
            rows.append(
                Row(
                    SUITE,
                    scene,
                    peer,
                    Timing.from_samples(np.array(out["times"])),
                    extra={k: v for k, v in out.items() if k not in ("times", "note")},
                    note=out.get("note", ""),
                )
            )
    return rows


def _kkt_extra(kkt: dict[str, float]) -> dict[str, Any]:
    """The largest KKT residuals over a run's QP solves (``qp.kkt``), as row columns."""
    return {
        "max_kkt_primal": f"{kkt['primal']:.1e}",
        "max_kkt_dual": f"{kkt['dual']:.1e}",
        "max_kkt_complementarity": f"{kkt['complementarity']:.1e}",
        "solves_without_kkt": int(kkt["not_computed"]),
    }


def run(quick: bool) -> list[Row]:
    """All scenes; peers measured in the same run."""
    steps = 300 if quick else 1500
    rows: list[Row] = []
    for scene, fn, robot_name in (
        ("g1", run_g1, "g1"),
        ("panda", run_panda, "panda"),
        ("g1 hierarchy", run_g1_hierarchy, "g1"),
        ("g1 hierarchy, active CoM box", run_g1_hierarchy_active, "g1"),
    ):
        out = fn(steps)
        extra = {
            "failed_steps": out["failed"],
            "limit_violation": out["limit_violation"],
            "hand_error_m": out["final_hand_error_m"],
            **_kkt_extra(out["kkt"]),
        }
        hierarchy = scene.startswith("g1 hierarchy")
        if hierarchy:
            extra["native_steps"] = out["native_steps"]
        method = "taskspace" if ik_kernel() else "taskspace (no kernel)"
        rows.append(Row(SUITE, scene, method, Timing.from_samples(out["times"]), extra))
        if hierarchy and ik_kernel() is not None:  # the Python cascade alone, for reference
            py = fn(steps, native=False)  # type: ignore[call-arg]
            rows.append(
                Row(
                    SUITE,
                    scene,
                    "taskspace, Python path",
                    Timing.from_samples(py["times"]),
                    {"failed_steps": py["failed"], **_kkt_extra(py["kkt"])},
                )
            )
        if not hierarchy:
            rows[-1].ratio_to = "placo"
            if ik_kernel() is not None:  # the same stack on the Python path, for reference
                py = fn(steps, native=False)  # type: ignore[call-arg]
                rows.append(
                    Row(
                        SUITE,
                        scene,
                        "taskspace, Python path",
                        Timing.from_samples(py["times"]),
                        {"failed_steps": py["failed"], **_kkt_extra(py["kkt"])},
                        ratio_to="placo",
                    )
                )
            rows += _peer_rows(scene, steps, Robot.load(robot_name).q_default)
    rows += panda_dampers_rows(150 if quick else 400, rounds=2 if quick else 3)
    rows += panda_general_rows(300 if quick else 1500, rounds=2 if quick else 3)
    out = run_global(100 if quick else 1000)
    rows.append(
        Row(
            SUITE,
            "panda global",
            "taskspace solve_ik",
            Timing.from_samples(out["times"]),
            {"success_rate": out["success_rate"], "max_error": out["max_error"]},
        )
    )
    return rows
