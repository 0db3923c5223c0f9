"""PD control of a 1-D point mass: overdamped, critically damped, underdamped (slide 5:13).

The closed-form responses are drawn together with a Pinocchio simulation of the same
point mass (markers).
"""

from __future__ import annotations

import numpy as np
from _common import fast, finish, parse

from taskspace.control import PIDController, PIDGains, pd_response, point_mass_robot
from taskspace.dynamics import SimulationOptions, simulate
from taskspace.viz.plots_control import plot_point_mass_responses


def main() -> None:
    args = parse(__doc__ or "")
    mass, wavelength, q0, target = 1.0, 0.5, 1.0, 0.0
    T = 2.0 if fast() else 5.0
    t = np.linspace(0.0, T, 400)
    responses = {}
    robot = point_mass_robot(mass)
    sims = {}
    for label, xi in (("overdamped", 3.0), ("critically damped", 1.0), ("underdamped", 0.2)):
        gains = PIDGains.from_wavelength(mass, wavelength, xi)  # Kp = m/l^2, Kd = 2 m xi/l
        responses[label] = pd_response(t, mass=mass, kp=gains.kp, kd=gains.kd, q0=q0, target=target)
        pd = PIDController(gains, target)
        sims[label] = simulate(
            robot,
            pd,
            (np.array([q0]), np.zeros(1)),
            T,
            1e-3,
            SimulationOptions(hold_control=False),
        )
    fig = plot_point_mass_responses(responses, target)
    ax = fig.axes[0]
    for traj in sims.values():
        ax.plot(traj.t[::100], traj.q[::100, 0], "k.", ms=3)
    err = max(
        float(np.max(np.abs(np.interp(t, s.t, s.q[:, 0]) - r.q)))
        for s, r in zip(sims.values(), responses.values())
    )
    ax.set_title(f"PD on a point mass (dots: Pinocchio RK4, max deviation {err:.1e} m)")
    finish({"point_mass_pd_regimes": fig}, args.save)


if __name__ == "__main__":
    main()
