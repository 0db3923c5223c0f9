"""TSID tracking taskspace's G1 walking references (.venv-peers/tsid).

Input: an ``.npz`` written by benchmarks/suites/locomotion.py from
``taskspace.locomotion.walking_reference`` (CoM, foot and pelvis references on the control
grid, the phase schedule, the initial configuration, the gains and weights of
``WalkingOptions``). TSID's formulation of the same walk:

* ``TaskComEquality`` (weight 1), ``TaskSE3Equality`` on the pelvis masked to its orientation
  (weight ``pelvis_weight``), ``TaskJointPosture`` (weight ``posture_weight``), gains as ours
  (``kd = 2 sqrt(kp)``);
* the feet: ``Contact6d`` (the 4 corners of the same sole rectangle, same friction, minimum
  and maximum force, ``kp = 0``, ``kd = 20``) while on the ground; a swinging foot is a
  ``TaskSE3Equality`` (world-aligned errors, weight ``foot_weight``) fed the swing
  trajectory's position, velocity and acceleration;
* lift-off: ``removeRigidContact(foot, transition_time)`` ``transition_time`` before the
  single support starts (TSID ramps the foot's maximum normal force down from its current
  force and removes the contact then); touchdown: ``addRigidContact`` at the footstep
  (its max force restored: the transition left it at the ramp's end);
* ``TaskActuationBounds`` on the effort limits; solver ``SolverHQuadProgFast``.

As TSID's own demos do, the loop integrates TSID's accelerations (semi-implicit Euler), with
no physics simulator; ours runs the rigid-contact simulation. A step is timed from
``computeProblemData`` to the torques (resizing the solver when the contact set changed the
problem's size is not timed). Output (JSON): per-step times, failed steps, CoM and swing-foot
tracking errors, the final CoM.
"""

import glob
import json
import math
import os
import sys
import time

import numpy as np


def main():
    import pinocchio as pin
    import tsid

    if not hasattr(tsid, "RobotWrapper"):
        # the tsid 1.7.1 wheel nests its extension one directory down
        for path in tsid.__path__:
            sys.path.insert(0, path)
        import tsid_pywrap as tsid  # type: ignore[import-not-found,no-redef]

    with np.load(sys.argv[1]) as npz:  # an NpzFile re-reads an array at each access
        ref = {key: npz[key] for key in npz.files}
    spec = json.loads(str(ref["spec"]))
    dt = spec["dt"]
    feet = {"left": spec["feet"][0], "right": spec["feet"][1]}
    alive: list = []  # TSID holds C++ references to these

    def keep(obj):  # type: ignore[no-untyped-def]
        alive.append(obj)
        return obj

    pattern = os.path.join(sys.prefix, "**/share/example-robot-data/robots")
    share = glob.glob(pattern, recursive=True)[0]
    urdf = os.path.join(share, "g1_description/urdf/g1_29dof_rev_1_0.urdf")
    model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    robot = tsid.RobotWrapper(model, tsid.FLOATING_BASE_SYSTEM, False)
    q = np.array(ref["q0"])
    v = np.zeros(robot.nv)
    formulation = tsid.InverseDynamicsFormulationAccForce("tsid", robot, False)
    formulation.computeProblemData(0.0, q, v)
    data = formulation.data()

    def gains(task, kp, n):  # type: ignore[no-untyped-def]
        task.setKp(kp * np.ones(n))
        task.setKd(2.0 * np.sqrt(kp) * np.ones(n))

    lx, ly = spec["sole_half_length"], spec["sole_half_width"]
    corners = np.array([[lx, lx, -lx, -lx], [ly, -ly, ly, -ly], [0.0, 0.0, 0.0, 0.0]])
    contacts = {}
    for side, frame in feet.items():
        c = keep(
            tsid.Contact6d(
                f"contact_{side}",
                robot,
                frame,
                corners,
                np.array([0.0, 0.0, 1.0]),
                spec["friction"],
                spec["min_force"],
                spec["max_force"],
            )
        )
        c.setKp(np.zeros(6))
        c.setKd(20.0 * np.ones(6))
        c.setReference(keep(robot.framePosition(data, model.getFrameId(frame))))
        formulation.addRigidContact(c, 1e-5, 1.0, 0)
        contacts[side] = c
    com = keep(tsid.TaskComEquality("com", robot))
    gains(com, spec["com_kp"], 3)
    formulation.addMotionTask(com, 1.0, 1, 0.0)
    pelvis = keep(tsid.TaskSE3Equality("pelvis", robot, spec["pelvis"]))
    gains(pelvis, spec["pelvis_kp"], 6)
    pelvis.setMask(np.array([0.0, 0, 0, 1, 1, 1]))
    pelvis.useLocalFrame(False)
    formulation.addMotionTask(pelvis, spec["pelvis_weight"], 1, 0.0)
    posture = keep(tsid.TaskJointPosture("posture", robot))
    gains(posture, spec["posture_kp"], robot.nv - 6)
    formulation.addMotionTask(posture, spec["posture_weight"], 1, 0.0)
    posture.setReference(
        keep(tsid.TrajectoryEuclidianConstant("posture", q[7:].copy())).computeNext()
    )
    swing_tasks = {}
    for side, frame in feet.items():
        task = keep(tsid.TaskSE3Equality(f"swing_{side}", robot, frame))
        gains(task, spec["foot_kp"], 6)
        task.useLocalFrame(False)
        swing_tasks[side] = task
    bounds = keep(tsid.TaskActuationBounds("torques", robot))
    tau_max = model.effortLimit[6:]
    bounds.setBounds(-tau_max, tau_max)
    formulation.addActuationTask(bounds, 1.0, 0, 0.0)
    solver = tsid.SolverHQuadProgFast("qp")

    times = ref["times"]
    n = len(times)
    com_sample = tsid.TrajectorySample(3)
    se3 = {name: tsid.TrajectorySample(12, 6) for name in ("pelvis", "left", "right")}
    transition = spec["transition_time"]
    # events on the grid: lift-off ramps start, single supports start and end
    lift_starts, swing_starts, swing_ends = {}, {}, {}
    for kind, start, end, side in spec["phases"]:
        if kind == "single_support":
            # the first grid sample at or after each instant (as walking_reference assigns)
            lift_starts[math.ceil((start - transition) / dt - 1e-6)] = side
            swing_starts[math.ceil(start / dt - 1e-6)] = side
            swing_ends[math.ceil(end / dt - 1e-6)] = side
    step_times, failed = [], 0
    com_err, foot_err = [], []
    swinging = {"left": False, "right": False}
    last_sizes = None
    for k in range(n):
        t = k * dt
        if k in lift_starts:
            formulation.removeRigidContact(f"contact_{lift_starts[k]}", transition)
        if k in swing_starts:
            side = swing_starts[k]
            formulation.addMotionTask(swing_tasks[side], spec["foot_weight"], 1, 0.0)
            swinging[side] = True
        if k in swing_ends:
            side = swing_ends[k]
            formulation.removeTask(f"swing_{side}", 0.0)
            frame_id = model.getFrameId(feet[side])
            contacts[side].setReference(keep(robot.framePosition(data, frame_id)))
            # the lift-off transition left the contact's max force at its ramp's end
            contacts[side].setMaxNormalForce(spec["max_force"])
            formulation.addRigidContact(contacts[side], 1e-5, 1.0, 0)
            swinging[side] = False
        com_sample.value(ref["com"][k])
        com_sample.derivative(ref["com_velocity"][k])
        com_sample.second_derivative(ref["com_acceleration"][k])
        com.setReference(com_sample)
        s = se3["pelvis"]
        s.value(np.concatenate([np.zeros(3), ref["pelvis_rotation"][k].flatten("F")]))
        s.derivative(np.zeros(6))
        s.second_derivative(np.zeros(6))
        pelvis.setReference(s)
        for side in ("left", "right"):
            if swinging[side]:
                s = se3[side]
                pos = ref[f"{side}_position"][k]
                s.value(np.concatenate([pos, ref[f"{side}_rotation"][k].flatten("F")]))
                s.derivative(np.concatenate([ref[f"{side}_velocity"][k], np.zeros(3)]))
                s.second_derivative(np.concatenate([ref[f"{side}_acceleration"][k], np.zeros(3)]))
                swing_tasks[side].setReference(s)
        t0 = time.perf_counter()
        problem = formulation.computeProblemData(t, q, v)
        t1 = time.perf_counter()
        # the problem's size changes with the contact set: resize then (untimed)
        sizes = (formulation.nVar, formulation.nEq, formulation.nIn)
        if sizes != last_sizes:
            solver.resize(*sizes)
            last_sizes = sizes
        t2 = time.perf_counter()
        sol = solver.solve(problem)
        tau = formulation.getActuatorForces(sol)
        dv = formulation.getAccelerations(sol)
        step_times.append(time.perf_counter() - t0 - (t2 - t1))
        if sol.status != 0:
            failed += 1
            if failed > 10:  # diverged: stop (the row reports it)
                break
        com_err.append(float(np.linalg.norm(robot.com(formulation.data()) - ref["com"][k])))
        for side in ("left", "right"):
            if swinging[side]:
                p = robot.framePosition(formulation.data(), model.getFrameId(feet[side]))
                foot_err.append(float(np.linalg.norm(p.translation - ref[f"{side}_position"][k])))
        v = v + dt * dv
        q = pin.integrate(model, q, dt * v)
    print(
        json.dumps(
            {
                "times": step_times,
                "failed_steps": failed,
                "com_error_max_m": max(com_err),
                "com_error_rms_m": float(np.sqrt(np.mean(np.square(com_err)))),
                "swing_foot_error_max_m": max(foot_err) if foot_err else 0.0,
                "final_com": robot.com(formulation.data()).tolist(),
                "final_tau_norm": float(np.linalg.norm(tau)),
                "note": "TSID integrates its own accelerations (no physics), HQuadProgFast",
            }
        )
    )


if __name__ == "__main__":
    main()
