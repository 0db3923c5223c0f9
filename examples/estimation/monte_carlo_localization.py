"""Monte Carlo localization: particles converging from a global prior (slides 7:21-7:25).

Run: python examples/estimation/monte_carlo_localization.py [--save DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import fast, finish, parse

from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.observation_models import RangeBearingModel
from taskspace.estimation.particle_filter import ParticleFilter, ParticleFilterOptions
from taskspace.estimation.simulation import loop_controls, simulate_landmark_world
from taskspace.viz.plots_estimation import plot_particles


def main() -> None:
    args = parse(__doc__ or "")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(3)
    motion = VelocityMotionModel(dt=0.2)
    sensor = RangeBearingModel(sigma_range=0.2, sigma_bearing=0.05, max_range=15.0)
    lms = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [5.0, 12.0]])
    T = 30 if fast() else 80
    sim = simulate_landmark_world(motion, sensor, [5, 2, 0], loop_controls(T, 1.0, 0.25), lms, rng)
    N = 2000
    init = np.column_stack(
        [rng.uniform(-2, 12, N), rng.uniform(-2, 12, N), rng.uniform(-np.pi, np.pi, N)]
    )
    pf = ParticleFilter(
        init,
        motion.sample,
        lambda p, o: sensor.log_likelihood(p, o, lms),
        rng,
        options=ParticleFilterOptions(angular_dims=(2,)),
    )
    snaps = {0: pf.particles.copy()}
    for t in range(T):
        pf.predict(sim.controls[t])
        pf.update(sim.observations[t])
        if t in (1, 5, T - 1):
            snaps[t + 1] = pf.particles.copy()
    fig, axes = plt.subplots(1, len(snaps), figsize=(4 * len(snaps), 4))
    for ax, (t, p) in zip(axes, snaps.items()):
        plot_particles(ax, p, color="tab:blue")
        ax.plot(*lms.T, "k^", ms=8)
        ax.plot(*sim.states[: t + 1, :2].T, "r-")
        ax.set_title(f"t = {t}")
        ax.set_aspect("equal")
        ax.set_xlim(-3, 13)
        ax.set_ylim(-3, 13)
    fig.suptitle("Monte Carlo localization (landmarks black, truth red)")
    mean, _ = pf.estimate()
    print(f"final position error: {np.hypot(*(mean[:2] - sim.states[-1, :2])):.3f} m")
    finish({"mcl_particles": fig}, args.save)


if __name__ == "__main__":
    main()
