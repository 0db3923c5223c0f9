"""Drake peer for the locomotion suite (runs in .venv-peers/drake).

Drake's own compass gait (``pydrake.examples.CompassGait``: its swing dynamics, witness
function and impact map) with its default parameters, which are Tedrake's (hip 10 kg, legs
5 kg, 1 m, mass at mid-leg, slope 0.0525 rad). See ``one_step`` for how a step is integrated.

Prints one JSON line with
* ``return_map_of_ours``: Drake's state one step after taskspace's fixed point (in Drake's
  coordinates: ``(stance, swing, stancedot, swingdot)``, angles from the vertical, the swing
  angle of the opposite sign to taskspace's); ``simulator_only_return_map_of_ours``: the same
  by Drake's simulator alone (1 ms maximum step);
* ``fixed_point``: Drake's fixed point found by Newton on Drake's return map (finite-difference
  Jacobian on the 3-D section ``stance = swing - 2 slope`` just after impact), from the same
  start as taskspace's search; ``seconds`` its wall time, ``iterations``, ``residual``.
Usage: ``python drake_compass_gait.py STANCE SWING STANCEDOT SWINGDOT`` (taskspace's fixed
point, taskspace's coordinates).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
from pydrake.examples import CompassGait
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import EventStatus
from scipy.integrate import solve_ivp

HANDOFF_S = 1e-6  # Drake's simulator takes over this long before the heel strike
FINE_STEP_S = 1e-10  # ... with steps this short, so its witness isolation is exact to ~1e-9


def one_step(plant: CompassGait, x: np.ndarray) -> np.ndarray:
    """Drake's state just after the next heel strike, from ``x`` just after one.

    Drake's equations throughout: the swing phase integrates ``plant``'s own time derivatives
    (``EvalTimeDerivatives``) to 1e-12 with an event on Drake's foot-collision condition
    ``2 slope - stance - swing = 0`` (swing leg in front); 1 microsecond before it, Drake's
    simulator takes over with 0.1 ns steps and applies Drake's own impact map (its witness
    function and ``CollisionDynamics``). Drake's simulator alone isolates the heel strike only
    to within its integration step (the post-impact state then moves by ~10 x the step size).
    """
    context = plant.CreateDefaultContext()
    slope = context.get_numeric_parameter(0).slope()

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        context.SetContinuousState(y)
        return np.asarray(plant.EvalTimeDerivatives(context).CopyToVector())

    def strike(_t: float, y: np.ndarray) -> float:
        return 2.0 * slope - y[0] - y[1] if y[1] < y[0] else 1.0

    strike.terminal = True  # type: ignore[attr-defined]
    strike.direction = -1  # type: ignore[attr-defined]
    sol = solve_ivp(rhs, (0.0, 5.0), x, rtol=1e-12, atol=1e-12, events=strike, dense_output=True)
    if not sol.t_events[0].size:
        raise RuntimeError("no heel strike within 5 s (the walker fell)")
    t_hit = float(sol.t_events[0][0])
    sim_context = plant.CreateDefaultContext()
    sim_context.SetContinuousState(sol.sol(t_hit - HANDOFF_S))
    left = sim_context.get_abstract_state(0).get_value()
    simulator = Simulator(plant, sim_context)
    ResetIntegratorFromFlags(simulator, "runge_kutta2", FINE_STEP_S)

    def monitor(ctx):  # type: ignore[no-untyped-def]
        if ctx.get_abstract_state(0).get_value() != left:
            return EventStatus.ReachedTermination(plant, "heel strike")
        return EventStatus.Succeeded()

    simulator.set_monitor(monitor)
    simulator.AdvanceTo(10 * HANDOFF_S)
    if sim_context.get_abstract_state(0).get_value() == left:
        raise RuntimeError("Drake's witness did not fire at the heel strike")
    return np.asarray(sim_context.get_continuous_state_vector().CopyToVector())


def simulator_only_step(plant: CompassGait, x: np.ndarray, max_step: float) -> np.ndarray:
    """The same step by Drake's simulator alone (RK3, accuracy 1e-12, ``max_step``)."""
    context = plant.CreateDefaultContext()
    context.SetContinuousState(x)
    context.SetAccuracy(1e-12)
    left = context.get_abstract_state(0).get_value()
    simulator = Simulator(plant, context)
    simulator.get_mutable_integrator().set_target_accuracy(1e-12)
    simulator.get_mutable_integrator().set_maximum_step_size(max_step)
    simulator.set_monitor(
        lambda ctx: (
            EventStatus.ReachedTermination(plant, "heel strike")
            if ctx.get_abstract_state(0).get_value() != left
            else EventStatus.Succeeded()
        )
    )
    simulator.AdvanceTo(5.0)
    return np.asarray(context.get_continuous_state_vector().CopyToVector())


def to_drake(x_ours: np.ndarray) -> np.ndarray:
    return np.array([x_ours[0], -x_ours[1], x_ours[2], -x_ours[3]])


def main() -> None:
    plant = CompassGait()
    slope = plant.CreateDefaultContext().get_numeric_parameter(0).slope()
    ours = to_drake(np.array([float(a) for a in sys.argv[1:5]]))
    image = one_step(plant, ours)
    simulator_image = simulator_only_step(plant, ours, 1e-3)

    # Newton on the section: z = (stance, stancedot, swingdot), swing = stance + 2 slope... in
    # Drake's coordinates just after impact the hip angle is swing - stance = 2 alpha, with
    # stance = slope - alpha, swing = slope + alpha: swing = 2 slope - stance.
    def full(z: np.ndarray) -> np.ndarray:
        return np.array([z[0], 2 * slope - z[0], z[1], z[2]])

    def residual(z: np.ndarray) -> np.ndarray:
        x1 = one_step(plant, full(z))
        return np.array([x1[0], x1[2], x1[3]]) - z

    start = np.array([-0.2, 1.0, 0.4])  # taskspace's start, in Drake's signs
    t0 = time.perf_counter()
    z, iterations = start.copy(), 0
    for iterations in range(1, 15):  # noqa: B007
        r = residual(z)
        if np.linalg.norm(r) < 1e-10:
            break
        h = 1e-6
        J = np.column_stack([(residual(z + h * e) - r) / h for e in np.eye(3)])
        z = z - np.linalg.solve(J, r)
    seconds = time.perf_counter() - t0
    print(
        json.dumps(
            {
                "ours_in_drake_coordinates": ours.tolist(),
                "return_map_of_ours": image.tolist(),
                "simulator_only_return_map_of_ours": simulator_image.tolist(),
                "fixed_point": full(z).tolist(),
                "residual": float(np.linalg.norm(residual(z))),
                "iterations": iterations,
                "seconds": seconds,
                "slope": slope,
            }
        )
    )


if __name__ == "__main__":
    main()
