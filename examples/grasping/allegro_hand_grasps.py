"""The Allegro hand closing on a sphere, a cylinder and a box until it touches (GraspIt-style).

Each object is presented in front of the palm in random orientations, moved toward the palm
until it touches, and every finger then closes until its links touch the object (or another
link). The contacts of the closed hand are tested for force closure (an LP) and scored by the
Ferrari-Canny epsilon; nothing ever penetrates (conservative advancement on coal distances).
The figure shows how many placements hold and their epsilon; ``--save DIR`` also writes
``allegro_hand_grasps.html`` (the fingers closing on the best sphere grasp) and
``allegro_hand_grasps_robot.png``.

Run: ``python examples/grasping/allegro_hand_grasps.py [--save DIR]``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin

from taskspace.grasping import Hand, box_mesh, cylinder_mesh, sample_hand_grasps, sphere_mesh
from taskspace.model import Obstacle
from taskspace.viz.plots import fast_mode as fast
from taskspace.viz.plots import parse_example_args as parse
from taskspace.viz.plots import save_figures as finish

OBJECTS = {
    "sphere r=4 cm": (sphere_mesh(0.04), lambda pose: Obstacle.sphere("object", 0.04, pose)),
    "cylinder r=3 cm": (
        cylinder_mesh(0.03, 0.12),
        lambda pose: Obstacle.cylinder("object", 0.03, 0.12, pose),
    ),
    "box 5x5x7 cm": (
        box_mesh(np.array([0.05, 0.05, 0.07])),
        lambda pose: Obstacle.box("object", [0.05, 0.05, 0.07], pose),
    ),
}


def main() -> None:
    """Run the example (see the module docstring)."""
    args = parse(__doc__.splitlines()[0])
    n = 6 if fast() else 20
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Allegro's default posture is clipped on load
        hand = Hand.allegro()
    results = {}
    for name, (mesh, _) in OBJECTS.items():
        grasps = sample_hand_grasps(hand, mesh, n, rng=np.random.default_rng(0))
        held = [g for g in grasps if g.success]
        results[name] = grasps
        best = held[0] if held else None
        print(
            f"{name}: {len(held)}/{len(grasps)} placements in force closure"
            + (
                f", best epsilon {best.epsilon:.3f} with {len(best.contacts)} contacts "
                f"({', '.join(best.touching)})"
                if best
                else ""
            )
        )

    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for k, (name, grasps) in enumerate(results.items()):
        eps = [g.epsilon for g in grasps if g.success]
        ax.scatter(np.full(len(eps), k) + np.linspace(-0.15, 0.15, len(eps)), eps, label=name)
        ax.text(k, 0.0, f"{len(eps)}/{len(grasps)} hold", ha="center", va="bottom")
    ax.set_xticks(range(len(results)), list(results))
    ax.set_ylabel("Ferrari-Canny epsilon (L1)")
    ax.set_title("Allegro hand: close-until-contact grasps in force closure")
    fig.tight_layout()

    if args.save is not None:
        from taskspace.viz import Viewer, save_robot_motion

        name = next(iter(OBJECTS))
        best = next((g for g in results[name] if g.success), results[name][0])
        robot = hand.robot
        robot.add_obstacle(OBJECTS[name][1](best.object_pose))
        closing = np.array(
            [hand.preshape + s * (best.q - hand.preshape) for s in np.linspace(0, 1, 40)]
        )
        viewer = Viewer(robot, closing[0])
        viewer.add_points(
            "contacts", np.array([best.object_pose.act(c.position) for c in best.contacts])
        )
        save_robot_motion(
            viewer,
            closing,
            args.save,
            "allegro_hand_grasps",
            dt=0.05,
            title="Allegro hand closing on a sphere until contact",
        )
    finish({"allegro_hand_grasps": fig}, args.save)


if __name__ == "__main__":
    pin.seed(0)
    main()
