"""Solo-12 trots on point feet: one inverse-dynamics controller whose contacts change at run
time (a pair removed with a force ramp before it lifts, added back at touchdown), simulated
with Pinocchio's constraint dynamics and 3-D point contacts.

Figures: the CoM and its reference and the feet seen from above; the normal forces of the
feet over time (each ramps to 0 before its lift-off and up from ``min_force`` after touchdown).
With ``--save`` the trot is also written as an animated meshcat scene (HTML) and a PNG of the
robot in mid-swing.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from _common import fast, finish, parse

from taskspace.locomotion import TrotOptions, trot
from taskspace.model import Robot


def main() -> None:
    args = parse(__doc__ or "")
    robot = Robot.load("solo12")
    opts = TrotOptions()
    res = trot(robot, 2 if fast() else 8, opts)
    error = 1000 * np.abs(res.com - res.com_reference).max()
    print(
        f"{res.times[-1]:.2f} s simulated: success={res.success} {res.message}; CoM within "
        f"{error:.2f} mm of its reference, worst cone violation {res.cone_violation:.2g} N, "
        f"{res.contact_changes} contact changes on one controller, median QP step "
        f"{1e6 * np.median(res.control_times):.0f} us"
    )
    fig_top, ax = plt.subplots(figsize=(8, 5))
    for frame, path in res.feet.items():
        ax.plot(path[:, 0], path[:, 1], ".", ms=2, label=frame)
    ax.plot(*res.com_reference[:, :2].T, "k--", lw=1, label="CoM reference")
    ax.plot(*res.com[:, :2].T, "m", lw=2, label="CoM")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Solo-12 trot: feet and CoM seen from above")
    ax.legend(fontsize=8)
    fig_top.tight_layout()
    fig_f, axf = plt.subplots(figsize=(9, 4))
    for frame, force in res.forces.items():
        axf.plot(res.times, force[:, 2], label=frame)
    axf.set_xlabel("t [s]")
    axf.set_ylabel("normal force [N]")
    axf.legend(fontsize=8)
    fig_f.tight_layout()
    finish({"solo12_trot_top": fig_top, "solo12_trot_forces": fig_f}, args.save)
    if args.save:
        from taskspace.viz import Viewer, save_robot_motion

        stride = 10
        qs = res.q[::stride]
        swinging = res.swinging[opts.feet[0]][::stride]
        middle = int(np.flatnonzero(swinging)[swinging.sum() // 2]) if swinging.any() else -1
        viewer = Viewer(robot, qs[middle])
        viewer.add_path("com", res.com[::stride], color=0xD62728)
        save_robot_motion(
            viewer,
            qs,
            args.save,
            "solo12_trot",
            dt=stride * opts.dt,
            title="Solo-12 trot",
            picture=middle,
        )


if __name__ == "__main__":
    main()
