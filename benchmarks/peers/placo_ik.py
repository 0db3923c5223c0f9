"""placo on the IK scenes of benchmarks/suites/ik.py (run in .venv-peers/placo)."""

import json
import sys
import time

import numpy as np


def hand_offset(k):
    return np.array(
        [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
    )


def main():
    spec = json.load(open(sys.argv[1]))
    import glob
    import os
    import tempfile

    import placo

    scene, steps, dt = spec["scene"], spec["steps"], spec["dt"]
    # example-robot-data's loader needs a Pinocchio newer than placo's: find the files directly
    share = glob.glob(
        os.path.join(sys.prefix, "**/share/example-robot-data/robots"), recursive=True
    )[0]
    rel = (
        "g1_description/urdf/g1_29dof_rev_1_0.urdf"
        if scene == "g1"
        else "panda_description/urdf/panda.urdf"
    )
    text = open(os.path.join(share, rel)).read()
    text = text.replace("package://example-robot-data/robots/", share + "/")
    tmp = tempfile.mkdtemp()
    urdf = os.path.join(tmp, "robot.urdf")
    open(urdf, "w").write(text)
    robot = placo.RobotWrapper(urdf, placo.Flags.ignore_collisions)
    q0 = np.array(spec["q0"])
    solver = placo.KinematicsSolver(robot)
    solver.enable_joint_limits(True)
    solver.enable_velocity_limits(True)
    solver.dt = dt
    if scene == "g1":
        # our q0: [base xyz, quat xyzw, 29 joints]; placo's state q has the same layout
        robot.state.q = q0.copy()
        feet = ["left_ankle_roll_link", "right_ankle_roll_link"]
        hands = ["left_rubber_hand", "right_rubber_hand"]
        solver.mask_fbase(False)
    else:
        q = robot.state.q.copy()
        q[7 : 7 + 7] = q0
        robot.state.q = q
        robot.set_T_world_fbase(np.eye(4))
        feet, hands = [], ["panda_hand_tcp"]
        solver.mask_fbase(True)
        for finger in ("panda_finger_joint1", "panda_finger_joint2"):
            solver.mask_dof(finger)
    robot.update_kinematics()
    for f in feet:
        t = solver.add_frame_task(f, robot.get_T_world_frame(f))
        t.configure(f, "soft", 1.0, 1.0)
    if feet:
        com = solver.add_com_task(robot.com_world())
        com.configure("com", "soft", 1.0)
    moving = []
    for h in hands:
        T0 = robot.get_T_world_frame(h).copy()
        t = solver.add_frame_task(h, T0)
        t.configure(h, "soft", 1.0, 1.0)
        moving.append((t, T0))
    posture = solver.add_joints_task()
    posture.set_joints({n: robot.get_joint(n) for n in robot.joint_names()})
    posture.configure("posture", "soft", 1e-3)
    times, failed = [], 0
    for k in range(steps):
        off = hand_offset(k)
        for t, T0 in moving:
            T = T0.copy()
            T[:3, 3] = T0[:3, 3] + off
            t.T_world_frame = T
        t0 = time.perf_counter()
        try:
            robot.update_kinematics()
            solver.solve(True)
        except Exception:
            failed += 1
        times.append(time.perf_counter() - t0)
    print(json.dumps({"times": times, "failed_steps": failed}))


if __name__ == "__main__":
    main()
