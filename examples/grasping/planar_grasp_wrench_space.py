"""Friction cones and grasp wrench spaces of planar grasps, and a force-closure counter-example.

Left: two fingers with friction (mu = 0.5) squeezing a disk: their friction cones, and the
grasp wrench space ``conv{w_k}`` in (f_x, f_y, tau_z / rho) with the largest ball about the
origin inside it (the Ferrari-Canny epsilon). Right: three frictionless fingers at 120 deg,
which cannot resist a torque about the disk's center: the LP's certificate ``c`` is the normal
of a plane through the origin with every primitive wrench on one side.

Run: ``python examples/grasping/planar_grasp_wrench_space.py [--save DIR]``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

import numpy as np
from scipy.spatial import ConvexHull

from taskspace.grasping import (
    ContactType,
    GraspContact,
    closure_lp,
    epsilon_l1,
    primitive_wrenches,
)
from taskspace.viz.plots import save_or_show

PLANAR = [0, 1, 5]  # f_x, f_y, tau_z


def planar_wrenches(contacts: list[GraspContact]) -> np.ndarray:
    """The primitive wrenches of a planar grasp (4-edge cones: two edges lie in the plane)."""
    W, _ = primitive_wrenches(contacts, edges=4, torque_scale=1.0)
    return W[np.abs(W[:, 2]) < 1e-12][:, PLANAR]


def draw_disk(ax, contacts: list[GraspContact], title: str) -> None:  # type: ignore[no-untyped-def]
    t = np.linspace(0, 2 * np.pi, 200)
    ax.plot(np.cos(t), np.sin(t), color="0.3")
    for c in contacts:
        p, n = c.position[:2], c.normal[:2]
        ax.annotate("", p, p - 0.5 * n, arrowprops={"arrowstyle": "->", "color": "C3"})
        if c.type is not ContactType.FRICTIONLESS:
            tangent = np.array([-n[1], n[0]])
            for s in (1, -1):
                edge = n + s * c.mu * tangent
                ax.plot(*np.column_stack([p, p - 0.6 * edge / np.linalg.norm(edge)]), color="C0")
    ax.set_aspect("equal")
    ax.set_xlim(-1.8, 1.8)
    ax.set_ylim(-1.8, 1.8)
    ax.set_title(title)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the example (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", default=None, help="directory for the PNG figure")
    args = parser.parse_args(argv)
    import matplotlib

    if args.save:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    two = [
        GraspContact(np.array([1.0, 0, 0]), np.array([-1.0, 0, 0]), mu=0.5),
        GraspContact(np.array([-1.0, 0, 0]), np.array([1.0, 0, 0]), mu=0.5),
    ]
    angles = 2 * np.pi * np.arange(3) / 3 + np.pi / 2
    three = [
        GraspContact(
            np.array([np.cos(a), np.sin(a), 0]),
            -np.array([np.cos(a), np.sin(a), 0]),
            type=ContactType.FRICTIONLESS,
        )
        for a in angles
    ]
    W2, W3 = planar_wrenches(two), planar_wrenches(three)
    eps = epsilon_l1(W2)
    counter = closure_lp(W3)
    print(
        f"two fingers, mu 0.5: force closure {closure_lp(W2).closure}, epsilon {eps:.4f} "
        f"(analytic mu/sqrt(mu^2+2) = {0.5 / np.sqrt(2.25):.4f})"
    )
    print(
        f"three frictionless fingers: force closure {counter.closure}, certificate "
        f"c = {np.round(counter.certificate, 3)} (a pure torque)"
    )

    fig = plt.figure(figsize=(13, 6.5))
    draw_disk(fig.add_subplot(2, 2, 1), two, "two fingers with friction")
    draw_disk(fig.add_subplot(2, 2, 3), three, "three frictionless fingers")
    ax = fig.add_subplot(1, 2, 2, projection="3d")
    hull = ConvexHull(W2)
    ax.plot_trisurf(W2[:, 0], W2[:, 1], W2[:, 2], triangles=hull.simplices, alpha=0.25, color="C0")
    ax.scatter(*W2.T, color="C0", label="two fingers: primitive wrenches")
    u, v = np.mgrid[0 : 2 * np.pi : 30j, 0 : np.pi : 15j]
    ax.plot_wireframe(
        eps * np.cos(u) * np.sin(v),
        eps * np.sin(u) * np.sin(v),
        eps * np.cos(v),
        color="C2",
        linewidth=0.5,
        label=f"epsilon ball ({eps:.3f})",
    )
    ax.scatter(*W3.T, color="C3", marker="^", s=60, label="three frictionless: wrenches")
    c = counter.certificate
    span = np.linalg.svd(c[None, :])[2][1:]
    s, t = np.meshgrid(np.linspace(-1.2, 1.2, 2), np.linspace(-1.2, 1.2, 2))
    plane = s[..., None] * span[0] + t[..., None] * span[1]
    ax.plot_surface(plane[..., 0], plane[..., 1], plane[..., 2], alpha=0.2, color="C3")
    ax.quiver(0, 0, 0, *c, color="C3", label="certificate c (wrenches on its side)")
    ax.set_box_aspect((1, 1, 0.5))
    ax.set_xlabel("f_x")
    ax.set_ylabel("f_y")
    ax.set_zlabel("tau_z / rho")
    ax.set_title("grasp wrench spaces")
    ax.legend(loc="upper left", fontsize=8)
    out = save_or_show(fig, args.save, "planar_grasp_wrench_space")
    if out is not None:
        print(f"saved {out}")


if __name__ == "__main__":
    main()
