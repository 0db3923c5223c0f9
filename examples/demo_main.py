"""Main demo (`make demo`): the Panda reaches around an obstacle with QP-based inverse kinematics.

The headline of taskspace in one script:

1. kinematics: the tcp pose, its Jacobian (slide 2:16) and the manipulability at the default
   posture;
2. weighted multi-task differential IK solved as a QP (slides 2:25-2:41): a tcp pose task whose
   target slides through a sphere obstacle, a posture task of weight 1e-5 (weighted tasks
   trade off: with 1e-3 the tcp would stop 12 mm short of its goal), joint position and
   velocity limits, and collision avoidance as velocity dampers on coal distances;
3. a meshcat scene of the motion (robot, obstacle, target triads, the tcp trace, animated)
   written as self-contained HTML and as a PNG rendered in headless Chromium.

    python examples/demo_main.py --html out/demo.html --png out/demo.png
    python examples/demo_main.py --save out/          # out/demo_main.html, demo_main_robot.png
    python examples/demo_main.py                      # live meshcat viewer (browser)
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
import pinocchio as pin


def fast() -> bool:
    return os.environ.get("TASKSPACE_FAST", "") not in ("", "0")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--html", help="write the scene as self-contained HTML")
    parser.add_argument("--png", help="write a PNG snapshot (headless Chromium)")
    parser.add_argument("--save", help="directory for demo_main.html and demo_main_robot.png")
    parser.add_argument("--no-viewer", action="store_true", help="never open a live viewer")
    args = parser.parse_args(argv)

    from taskspace import features as F
    from taskspace.constraints import (
        CollisionAvoidance,
        JointPositionLimits,
        JointVelocityLimits,
    )
    from taskspace.ik import DifferentialIK
    from taskspace.model import Obstacle, Robot
    from taskspace.tasks import Task
    from taskspace.viz import Viewer

    np.set_printoptions(precision=3, suppress=True, linewidth=110)
    robot = Robot.load("panda", convex_collision=True)
    tcp = robot.end_effectors[0]
    q = robot.q_default.copy()
    state = robot.state(q)
    fid = robot.frame_id(tcp)
    start = state.frame_placement(fid).copy()
    J = state.frame_jacobian(fid)
    print(f"robot: {robot}")
    print(f"{tcp} position at the default posture [m]: {start.translation}")
    print(f"tcp Jacobian (6 x {robot.nv}, LOCAL_WORLD_ALIGNED):\n{J}")
    print(f"manipulability sqrt(det(J J^T)) = {np.sqrt(np.linalg.det(J @ J.T)):.5f}")

    # A sphere in the way of a straight tcp motion 40 cm to the side.
    goal = start.copy()
    goal.translation = start.translation + np.array([0.0, 0.45, -0.05])
    ball_center = start.translation + np.array([0.0, 0.22, -0.03])
    robot.add_obstacle(Obstacle.sphere("ball", 0.07, ball_center, color=[0.85, 0.3, 0.2, 1.0]))

    pose = Task(F.FramePose(robot, tcp), weight=1.0, gain=0.5, name="tcp")
    posture = Task(F.JointConfiguration(robot), robot.q_default, weight=1e-5, name="posture")
    avoid = CollisionAvoidance(robot, safety_distance=0.02, influence_distance=0.12, gain=0.5)
    ik = DifferentialIK(
        robot,
        [pose, posture],
        [JointPositionLimits(robot), JointVelocityLimits(robot), avoid],
    )

    dt = 0.01
    steps = 150 if fast() else 400
    qs, times, min_distance = [q.copy()], [], np.inf
    for k in range(steps):
        s = min(1.0, k / (0.75 * steps))
        pose.set_target(pin.SE3.Interpolate(start, goal, 0.5 * (1 - np.cos(np.pi * s))))
        t0 = time.perf_counter()
        state.update(q)
        result = ik.solve(state, dt)
        q = pin.integrate(robot.model, q, result.dq)
        times.append(time.perf_counter() - t0)
        if not result.success:
            print(f"step {k}: {result.status.value}, culprits {result.culprits}")
        min_distance = min(min_distance, float(avoid.distances.value(state).min()))
        qs.append(q.copy())
    state.update(q)
    error = np.linalg.norm(pose.error(state)[:3])
    print(
        f"IK: {steps} steps of {dt * 1e3:.0f} ms, median {np.median(times) * 1e6:.0f} us per step "
        f"(build + QP solve + integrate), final tcp error {error * 1e3:.2f} mm, "
        f"smallest robot-obstacle distance {min_distance * 1e3:.1f} mm (safety 20 mm)"
    )
    robot.check_limits(q)  # raises if a joint left its limits

    # --save DIR gets both files; --html/--png write (also) where they say
    htmls = [Path(p) for p in (args.html, args.save and Path(args.save) / "demo_main.html") if p]
    saved_png = args.save and Path(args.save) / "demo_main_robot.png"  # as every robot example
    pngs = [Path(p) for p in (args.png, saved_png) if p]
    live = not htmls and not pngs and not args.no_viewer and not fast()

    viewer = Viewer(robot, qs[-1], live=live)
    viewer.add_obstacles()
    viewer.add_frame("start", start, scale=0.08)
    viewer.add_frame("goal", goal, scale=0.12)
    viewer.add_frame_trace("tcp_trace", np.array(qs[::2]), frame=tcp)
    viewer.play(np.array(qs[::2]), dt=2 * dt, autoplay=False)
    page = viewer.static_html(title="taskspace demo: Panda IK around an obstacle") if htmls else ""
    for html in htmls:
        html.parent.mkdir(parents=True, exist_ok=True)
        html.write_text(page, encoding="utf-8")
        print(f"wrote {html.resolve()} ({len(page) / 1e6:.1f} MB)")
    if pngs:
        print("rendering the PNG snapshot in headless Chromium (a few seconds)...", flush=True)
        image = viewer.snapshot(pngs[0])
        for png in pngs[1:]:
            png.parent.mkdir(parents=True, exist_ok=True)
            png.write_bytes(image)
        for png in pngs:
            print(f"wrote {png.resolve()}")
    if live:
        viewer.open()
        print(f"meshcat viewer: {viewer.url} (press Ctrl-C to stop)", flush=True)
        viewer.wait_until_interrupted()
        print("viewer stopped")
    return 0


if __name__ == "__main__":
    if (code := main()) != 0:  # no SystemExit on success: the docs gallery runs it in-process
        raise SystemExit(code)
