"""Inverse-dynamics QP on G1 standing (two 6-D contacts, cones, torque bounds), beside TSID.

Tasks: CoM (swaying 4 cm sideways at 0.5 Hz), both hands, posture. Both libraries integrate
their own accelerations (as TSID's demos do); a step is timed from the problem build to the
torques. Tracking quality of both in the same run (issue 16: CoM error over the run no worse
than TSID's): the largest and RMS distance between the CoM and its reference at each step,
before that step's solve, from Pinocchio's ``centerOfMass`` outside the timed region.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from benchmarks.common import Row, Timing, run_peer
from taskspace import features as F
from taskspace.constraints import Contact6D
from taskspace.control.inverse_dynamics_qp import InverseDynamicsOptions, InverseDynamicsQP
from taskspace.model import Robot
from taskspace.tasks import Task

SUITE = "inverse_dynamics"
DT = 0.002
FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
HANDS = ("left_rubber_hand", "right_rubber_hand")


def scene(hierarchical: bool = False) -> tuple[Robot, InverseDynamicsQP, Task]:
    """The G1 controller and its CoM task."""
    robot = Robot.load("g1")
    s = robot.state(robot.q_default, np.zeros(robot.nv))
    contacts = [Contact6D(robot, f, half_length=0.1, half_width=0.03) for f in FEET]
    com = Task(F.CenterOfMass(robot), kp=50.0, priority=0)
    com.set_target_from_state(s)
    hands = [Task(F.FramePose(robot, h), kp=50.0, weight=0.1, priority=1) for h in HANDS]
    for t in hands:
        t.set_target_from_state(s)
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-2, kp=30.0, priority=2)
    options = InverseDynamicsOptions(hierarchical=hierarchical)
    return robot, InverseDynamicsQP(robot, [com, *hands, posture], contacts, options), com


def run_taskspace(steps: int, hierarchical: bool = False) -> dict[str, Any]:
    """Time ``steps`` control steps."""
    robot, ctrl, com = scene(hierarchical)
    c0 = com.target.copy()
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    state = robot.state(q, v)
    times = np.empty(steps)
    failed = 0
    statuses: dict[str, int] = {}
    paths = {"compiled": 0, "python": 0}
    kkt = {"primal": 0.0, "dual": 0.0, "complementarity": 0.0, "not_computed": 0}
    com_errors = np.empty(steps)
    data = robot.model.createData()
    for k in range(steps):
        com.set_target(c0 + np.array([0.0, 0.04 * np.sin(np.pi * k * DT), 0.0]))
        com_errors[k] = np.linalg.norm(pin.centerOfMass(robot.model, data, q) - com.target)
        t0 = time.perf_counter()
        state.update(q, v)
        res = ctrl.solve(state)
        times[k] = time.perf_counter() - t0
        failed += not res.success
        key = f"{res.qp.status.value} ({res.qp.backend})" if res.qp is not None else "cascade"
        statuses[key] = statuses.get(key, 0) + 1
        paths["compiled" if res.compiled else "python"] += 1
        for qp in [res.qp] if res.qp is not None else res.level_results:
            if not np.isfinite(qp.kkt.primal):
                kkt["not_computed"] += 1
                continue
            for name in ("primal", "dual", "complementarity"):
                kkt[name] = max(kkt[name], float(getattr(qp.kkt, name)))
        v = v + DT * res.a
        q = pin.integrate(robot.model, q, DT * v)
    return {
        "times": times,
        "failed": failed,
        "statuses": statuses,
        "paths": paths,
        "variables": ctrl.n,
        "com_error": com_error_columns(com_errors),
        "kkt": {
            "max_kkt_primal": f"{kkt['primal']:.1e}",
            "max_kkt_dual": f"{kkt['dual']:.1e}",
            "max_kkt_complementarity": f"{kkt['complementarity']:.1e}",
            "solves_without_kkt": int(kkt["not_computed"]),
        },
    }


def com_error_columns(errors: np.ndarray) -> dict[str, float]:
    """Largest and RMS CoM tracking error [mm] over a run."""
    return {
        "com_error_max_mm": round(1000 * float(np.max(errors)), 4),
        "com_error_rms_mm": round(1000 * float(np.sqrt(np.mean(errors**2))), 4),
    }


def run(quick: bool) -> list[Row]:
    """taskspace (weighted and 3-level hierarchy) and TSID in the same run."""
    steps = 300 if quick else 2000
    rows = []
    out = run_taskspace(steps)
    rows.append(
        Row(
            SUITE,
            "g1 standing",
            "taskspace",
            Timing.from_samples(out["times"]),
            {
                "failed_steps": out["failed"],
                "variables": out["variables"],
                "compiled_steps": out["paths"]["compiled"],
                "python_steps": out["paths"]["python"],
                **out["kkt"],
                **out["com_error"],
            },
            ratio_to="tsid",
            note=f"QP statuses (backend) {out['statuses']}",
        )
    )
    out = run_taskspace(steps, hierarchical=True)
    rows.append(
        Row(
            SUITE,
            "g1 standing",
            "taskspace hierarchy",
            Timing.from_samples(out["times"]),
            {
                "failed_steps": out["failed"],
                "compiled_steps": out["paths"]["compiled"],
                "python_steps": out["paths"]["python"],
                **out["kkt"],
                **out["com_error"],
            },
            ratio_to="tsid",
            note="4 strict levels (dynamics+contacts, CoM, hands, posture)",
        )
    )
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "scene.json"
        q0 = Robot.load("g1").q_default
        spec.write_text(json.dumps({"steps": steps, "dt": DT, "q0": q0.tolist()}))
        try:
            peer = run_peer("tsid", "tsid_inverse_dynamics.py", [str(spec)])
        except Exception as exc:
            peer = {"error": f"failed: {exc!s:.200}"}
    published = "published on a 2-core machine: 0.31 ms/step (59 variables)"
    if peer is None:
        rows.append(Row(SUITE, "g1 standing", "tsid", None, note=f"peer env missing; {published}"))
    elif "error" in peer:
        rows.append(Row(SUITE, "g1 standing", "tsid", None, note=f"{peer['error']}; {published}"))
    else:
        rows.append(
            Row(
                SUITE,
                "g1 standing",
                "tsid",
                Timing.from_samples(np.array(peer["times"])),
                {
                    "failed_steps": peer["failed_steps"],
                    "variables": peer["variables"],
                    **(
                        com_error_columns(np.array(peer["com_errors"]))
                        if "com_errors" in peer
                        else {}
                    ),
                },
            )
        )
    return rows
