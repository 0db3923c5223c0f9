"""pink on the IK scenes of benchmarks/suites/ik.py (run in .venv-peers/pink)."""

import json
import sys
import time

import numpy as np
import pinocchio as pin


def hand_offset(k):
    return np.array(
        [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
    )


def main():
    spec = json.load(open(sys.argv[1]))
    import example_robot_data as erd
    import pink
    from pink.tasks import ComTask, FrameTask, PostureTask

    scene, steps, dt = spec["scene"], spec["steps"], spec["dt"]
    if scene == "g1":
        robot = erd.load("g1")
        feet = ["left_ankle_roll_link", "right_ankle_roll_link"]
        hands = ["left_rubber_hand", "right_rubber_hand"]
    else:
        robot = erd.load("panda")
        feet, hands = [], ["panda_hand_tcp"]
    model = robot.model
    if scene == "panda":  # lock the fingers like taskspace's registry entry
        ids = [model.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    else:
        lo, hi = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
        lo[:7], hi[:7] = -np.inf, np.inf
        model.lowerPositionLimit, model.upperPositionLimit = lo, hi
        vel = model.velocityLimit.copy()
        vel[:6] = np.inf
        model.velocityLimit = vel
    data = model.createData()
    q = np.array(spec["q0"])
    configuration = pink.Configuration(model, data, q)
    tasks, moving = [], []
    for f in feet:
        t = FrameTask(f, position_cost=1.0, orientation_cost=1.0)
        t.set_target(configuration.get_transform_frame_to_world(f))
        tasks.append(t)
    if feet:
        com = ComTask(cost=1.0)
        com.set_target(pin.centerOfMass(model, data, q))
        tasks.append(com)
    for h in hands:
        t = FrameTask(h, position_cost=1.0, orientation_cost=1.0)
        T0 = configuration.get_transform_frame_to_world(h).copy()
        t.set_target(T0)
        tasks.append(t)
        moving.append((t, T0))
    posture = PostureTask(cost=1e-3)
    posture.set_target(q)
    tasks.append(posture)
    times, failed = [], 0
    for k in range(steps):
        off = hand_offset(k)
        for t, T0 in moving:
            T = T0.copy()
            T.translation = T0.translation + off
            t.set_target(T)
        t0 = time.perf_counter()
        try:
            configuration.update(q)
            v = pink.solve_ik(configuration, tasks, dt, solver="daqp")
            q = configuration.integrate(v, dt)
        except Exception:
            failed += 1
        times.append(time.perf_counter() - t0)
    print(json.dumps({"times": times, "failed_steps": failed, "note": "daqp via qpsolvers"}))


if __name__ == "__main__":
    main()
