"""placo on the ``panda dampers`` scene of benchmarks/suites/ik.py (run in .venv-peers/placo).

The main demo's scene: tcp pose task sliding 45 cm behind a 7 cm ball, posture (1e-5), joint
and velocity limits, and placo's self-collision constraint (margin 2 cm, trigger 12 cm). The
ball is a fixed link of the URDF (on panda_link0, the base at the world origin), so placo's
self-collision constraint covers the robot-ball pairs too; the pairs are the scene's (the
self pairs of taskspace's Panda and every link with the ball). placo loads the URDF's
collision meshes as they are (it has no convex-hull option): noted in the output.
"""

import glob
import json
import os
import sys
import tempfile
import time

import numpy as np


def slerp_pose(T0, T1, s):
    """The translation interpolated linearly; the rotations are equal in this scene."""
    T = T0.copy()
    T[:3, 3] = (1 - s) * T0[:3, 3] + s * T1[:3, 3]
    return T


def main():
    spec = json.load(open(sys.argv[1]))
    import placo

    steps, dt = spec["steps"], spec["dt"]
    radius, offset = spec["ball"]
    share = glob.glob(
        os.path.join(sys.prefix, "**/share/example-robot-data/robots"), recursive=True
    )[0]
    text = open(os.path.join(share, "panda_description/urdf/panda.urdf")).read()
    text = text.replace("package://example-robot-data/robots/", share + "/")
    tmp = tempfile.mkdtemp()

    def load(ball_xyz):
        ball = (
            '<link name="ball"><collision><origin xyz="0 0 0"/><geometry>'
            f'<sphere radius="{radius}"/></geometry></collision></link>'
            '<joint name="ball_joint" type="fixed"><parent link="panda_link0"/>'
            f'<child link="ball"/><origin xyz="{ball_xyz[0]} {ball_xyz[1]} {ball_xyz[2]}"/>'
            "</joint></robot>"
        )
        urdf = os.path.join(tmp, "robot.urdf")
        open(urdf, "w").write(text.replace("</robot>", ball))
        return placo.RobotWrapper(urdf)

    # first the tcp's start position (the ball is placed relative to it)
    probe = load([10.0, 10.0, 10.0])
    q = probe.state.q.copy()
    q[7 : 7 + 7] = np.array(spec["q0"])[:7]
    probe.state.q = q
    probe.set_T_world_fbase(np.eye(4))
    probe.update_kinematics()
    start = probe.get_T_world_frame("panda_hand_tcp").copy()
    center = start[:3, 3] + np.array(offset)

    robot = load(center)
    # the scene's pairs, by link name (placo's load_collision_pairs)
    pairs_file = os.path.join(tmp, "pairs.json")
    json.dump(spec["pairs"], open(pairs_file, "w"))
    robot.load_collision_pairs(pairs_file)
    times_all = []
    failed = 0
    smallest = np.inf
    for _ in range(spec.get("rounds", 1)):
        q = robot.state.q.copy()
        q[7 : 7 + 7] = np.array(spec["q0"])[:7]
        robot.state.q = q
        robot.set_T_world_fbase(np.eye(4))
        robot.update_kinematics()
        solver = placo.KinematicsSolver(robot)
        solver.enable_joint_limits(True)
        solver.enable_velocity_limits(True)
        solver.dt = dt
        solver.mask_fbase(True)
        for finger in ("panda_finger_joint1", "panda_finger_joint2"):
            solver.mask_dof(finger)
        goal = start.copy()
        goal[:3, 3] = start[:3, 3] + np.array(spec["goal"])
        tcp = solver.add_frame_task("panda_hand_tcp", start.copy())
        tcp.configure("tcp", "soft", 1.0, 1.0)
        posture = solver.add_joints_task()
        posture.set_joints({n: robot.get_joint(n) for n in robot.joint_names()})
        posture.configure("posture", "soft", 1e-5)
        avoid = solver.add_avoid_self_collisions_constraint()
        avoid.self_collisions_margin = 0.02
        avoid.self_collisions_trigger = 0.12
        avoid.configure("avoid", "hard")
        for k in range(steps):
            s = min(1.0, k / (0.75 * steps))
            tcp.T_world_frame = slerp_pose(start, goal, 0.5 * (1 - np.cos(np.pi * s)))
            t0 = time.perf_counter()
            try:
                robot.update_kinematics()
                solver.solve(True)
            except Exception:
                failed += 1
            times_all.append(time.perf_counter() - t0)
            for d in robot.distances():
                smallest = min(smallest, d.min_distance)
    print(
        json.dumps(
            {
                "times": times_all,
                "failed_steps": failed,
                "min_distance_m": round(float(smallest), 5),
                "collision_pairs": len(robot.distances()),
                "note": "placo's self-collision constraint; the URDF's collision meshes as "
                "loaded by placo (no convex hulls); ball as a fixed link",
            }
        )
    )


if __name__ == "__main__":
    main()
