"""placo on the ``panda equality + rows`` scene of benchmarks/suites/ik.py (.venv-peers/placo).

The tcp position follows the ``panda`` scene's offsets (soft, weight 1), the tcp orientation
is held exactly (a ``hard`` orientation task: placo's equality constraint), posture (1e-3),
joint position and velocity limits, and the joint-space half-spaces ``A q <= b`` of the scene
(placo's ``JointSpaceHalfSpacesConstraint``, configured ``hard``; A over the Panda's 7 arm
joints, zero on the free flyer and the fingers). Reported beside the times: the largest
half-space violation and orientation error over the run (the same problem is solved).
"""

import glob
import json
import os
import sys
import tempfile
import time

import numpy as np


def hand_offset(k):
    return np.array(
        [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
    )


def main():
    spec = json.load(open(sys.argv[1]))
    import placo

    steps, dt = spec["steps"], spec["dt"]
    share = glob.glob(
        os.path.join(sys.prefix, "**/share/example-robot-data/robots"), recursive=True
    )[0]
    text = open(os.path.join(share, "panda_description/urdf/panda.urdf")).read()
    text = text.replace("package://example-robot-data/robots/", share + "/")
    tmp = tempfile.mkdtemp()
    urdf = os.path.join(tmp, "robot.urdf")
    open(urdf, "w").write(text)
    robot = placo.RobotWrapper(urdf, placo.Flags.ignore_collisions)
    q = robot.state.q.copy()
    q[7 : 7 + 7] = np.array(spec["q0"])
    robot.state.q = q
    robot.set_T_world_fbase(np.eye(4))
    solver = placo.KinematicsSolver(robot)
    solver.enable_joint_limits(True)
    solver.enable_velocity_limits(True)
    solver.dt = dt
    solver.mask_fbase(True)
    for finger in ("panda_finger_joint1", "panda_finger_joint2"):
        solver.mask_dof(finger)
    robot.update_kinematics()
    tcp = "panda_hand_tcp"
    T0 = robot.get_T_world_frame(tcp).copy()
    position = solver.add_position_task(tcp, T0[:3, 3].copy())
    position.configure("tcp", "soft", 1.0)
    orientation = solver.add_orientation_task(tcp, T0[:3, :3].copy())
    orientation.configure("orientation", "hard")
    posture = solver.add_joints_task()
    posture.set_joints({n: robot.get_joint(n) for n in robot.joint_names()})
    posture.configure("posture", "soft", 1e-3)
    arm = np.array(spec["A"])
    A = np.zeros((arm.shape[0], len(robot.state.q)))
    A[:, 7 : 7 + 7] = arm
    b = np.array(spec["b"])
    half_spaces = solver.add_joint_space_half_spaces_constraint(A, b)
    half_spaces.configure("half_spaces", "hard")  # (placo's default priority is "soft")
    times, failed = [], 0
    violation = orientation_error = 0.0
    for k in range(steps):
        position.target_world = T0[:3, 3] + hand_offset(k)
        t0 = time.perf_counter()
        try:
            robot.update_kinematics()
            solver.solve(True)
        except Exception:
            failed += 1
        times.append(time.perf_counter() - t0)
        q = robot.state.q
        violation = max(violation, float((A @ q - b).max()))
        R = robot.get_T_world_frame(tcp)[:3, :3]
        orientation_error = max(orientation_error, float(np.linalg.norm(R - T0[:3, :3])))
    print(
        json.dumps(
            {
                "times": times,
                "failed_steps": failed,
                "max_half_space_violation": violation,
                "max_orientation_error": orientation_error,
            }
        )
    )


if __name__ == "__main__":
    main()
