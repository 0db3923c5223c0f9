"""Main demo (`make demo`): Panda forward kinematics, tcp Jacobian, manipulability, meshcat scene.

Prints the tcp pose at the default posture, its 6x7 Jacobian (LOCAL_WORLD_ALIGNED, slide 2:16)
and the manipulability sqrt(det(J J^T)); writes a meshcat scene (robot, tcp triad, the tcp
trace of a joint sweep, animated) as static HTML and a PNG snapshot.

    python examples/demo_main.py --html out/demo.html --png out/demo.png
    python examples/demo_main.py --save out/          # writes out/demo_main.{html,png}
    python examples/demo_main.py                      # live meshcat viewer (browser)
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np


def fast() -> bool:
    return os.environ.get("TASKSPACE_FAST", "") not in ("", "0")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--html", help="write the scene as self-contained HTML")
    parser.add_argument("--png", help="write a PNG snapshot (headless Chromium)")
    parser.add_argument("--save", help="directory for demo_main.html and demo_main.png")
    parser.add_argument("--no-viewer", action="store_true", help="never open a live viewer")
    args = parser.parse_args(argv)

    from taskspace.model import Robot
    from taskspace.viz import Viewer

    robot = Robot.load("panda")
    tcp = robot.end_effectors[0]
    q = robot.q_default
    state = robot.state(q)
    fid = robot.frame_id(tcp)
    pose = state.frame_placement(fid)
    J = state.frame_jacobian(fid)
    manipulability = float(np.sqrt(np.linalg.det(J @ J.T)))
    np.set_printoptions(precision=3, suppress=True, linewidth=110)
    print(f"robot: {robot}")
    print(f"q = {q}")
    print(f"{tcp} position [m]: {pose.translation}")
    print(f"{tcp} rotation:\n{pose.rotation}")
    print(f"tcp Jacobian J (6 x {robot.nv}, rows: linear [m/rad], angular [rad/rad]):\n{J}")
    print(f"manipulability sqrt(det(J J^T)) = {manipulability:.5f}")

    # A joint sweep: joints 1 and 4 move sinusoidally; the tcp traces a curve.
    n = 40 if fast() else 120
    t = np.linspace(0.0, 2.0 * np.pi, n)
    qs = np.tile(q, (n, 1))
    qs[:, 0] += 0.6 * np.sin(t)
    qs[:, 3] += 0.4 * (1.0 - np.cos(t)) / 2.0
    qs = np.clip(qs, robot.lower_limits, robot.upper_limits)

    html = Path(args.html) if args.html else None
    png = Path(args.png) if args.png else None
    if args.save:
        out = Path(args.save)
        out.mkdir(parents=True, exist_ok=True)
        html = html or out / "demo_main.html"
        png = png or out / "demo_main.png"
    live = html is None and png is None and not args.no_viewer and not fast()

    viewer = Viewer(robot, q, live=live)
    viewer.add_frame("tcp", pose, scale=0.12)
    trace = viewer.add_frame_trace("tcp_trace", qs, frame=tcp)
    viewer.play(qs, dt=4.0 / n, autoplay=False)
    length = float(np.sum(np.linalg.norm(np.diff(trace, axis=0), axis=1)))
    print(f"tcp trace: {len(trace)} points, length {length:.3f} m")
    if html is not None:
        viewer.save_html(html, title="taskspace demo: Panda")
        print(f"wrote {html}")
    if png is not None:
        viewer.snapshot(png)
        print(f"wrote {png}")
    if live:
        print(f"live viewer: {viewer.url()}  (press Enter to quit)")
        viewer.static_html()  # frames the camera
        if sys.stdin.isatty():
            input()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
