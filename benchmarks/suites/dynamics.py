"""Simulation step (ABA + RK4), LQR design and computed-torque step, against raw Pinocchio."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from benchmarks.common import Row, measure
from taskspace.control import ComputedTorqueController, SinusoidalReference, linearize, lqr
from taskspace.dynamics import ForwardDynamics, rk4_step
from taskspace.model import Robot

SUITE = "dynamics"


def scene(name: str) -> tuple[Robot, np.ndarray, np.ndarray, np.ndarray]:
    """Robot, a state and a torque (random, reproducible)."""
    robot = Robot.load(name)
    rng = np.random.default_rng(0)
    q = robot.random_configuration(rng, base_box=0.1)
    v = 0.1 * rng.normal(size=robot.nv)
    tau = rng.normal(size=robot.nv)
    return robot, q, v, tau


def taskspace_rk4(
    robot: Robot, q: np.ndarray, v: np.ndarray, tau: np.ndarray
) -> Callable[[], None]:
    dyn = ForwardDynamics(robot)

    def step() -> None:
        rk4_step(dyn, q, v, 1e-3, tau)

    return step


def raw_aba(robot: Robot, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> Callable[[], None]:
    model, data = robot.model, robot.model.createData()
    return lambda: pin.aba(model, data, q, v, tau)


def raw_rk4(robot: Robot, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> Callable[[], None]:
    """RK4 written directly on pin.aba / pin.integrate (the floor for our step)."""
    model, data = robot.model, robot.model.createData()
    dt = 1e-3

    def step() -> None:
        a1 = pin.aba(model, data, q, v, tau)
        v2 = v + 0.5 * dt * a1
        a2 = pin.aba(model, data, pin.integrate(model, q, 0.5 * dt * v), v2, tau)
        v3 = v + 0.5 * dt * a2
        a3 = pin.aba(model, data, pin.integrate(model, q, 0.5 * dt * v2), v3, tau)
        v4 = v + dt * a3
        a4 = pin.aba(model, data, pin.integrate(model, q, dt * v3), v4, tau)
        pin.integrate(model, q, dt / 6 * (v + 2 * v2 + 2 * v3 + v4))
        _ = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)

    return step


def run(quick: bool) -> list[Row]:
    repeat = 300 if quick else 3000
    rows: list[Row] = []
    for name in ("panda", "talos"):
        robot, q, v, tau = scene(name)
        t_aba = measure(raw_aba(robot, q, v, tau), repeat=repeat)
        t_raw = measure(raw_rk4(robot, q, v, tau), repeat=repeat)
        t_ts = measure(taskspace_rk4(robot, q, v, tau), repeat=repeat)
        scene_name = f"rk4_step_{name}_nv{robot.nv}"
        rows.append(Row(SUITE, scene_name, "raw pin.aba (1 call)", t_aba))
        rows.append(Row(SUITE, scene_name, "raw pinocchio rk4", t_raw))
        rows.append(
            Row(
                SUITE,
                scene_name,
                "taskspace",
                t_ts,
                extra={
                    "ratio_to_one_aba": t_ts.median_us / t_aba.median_us,
                    "ratio_to_raw_rk4": t_ts.median_us / t_raw.median_us,
                },
                ratio_to="raw pinocchio rk4",
            )
        )
    # LQR design for the cart-pole (linearization + Riccati), and the Riccati alone vs scipy
    cartpole = Robot.load("cartpole")
    Q, R = np.diag([1.0, 10.0, 1.0, 1.0]), 0.1

    def design() -> None:
        sys = linearize(cartpole, np.zeros(2), actuated=["slider"])
        lqr(sys.A, sys.B, Q, R)

    sys = linearize(cartpole, np.zeros(2), actuated=["slider"])
    import scipy.linalg as sla

    t_lqr = measure(lambda: lqr(sys.A, sys.B, Q, R), repeat=repeat)
    t_sp = measure(lambda: sla.solve_continuous_are(sys.A, sys.B, Q, np.eye(1) * R), repeat=repeat)
    rows.append(Row(SUITE, "lqr_cartpole", "scipy solve_continuous_are", t_sp))
    rows.append(
        Row(
            SUITE,
            "lqr_cartpole",
            "taskspace",
            t_lqr,
            extra={"ratio_to_scipy": t_lqr.median_us / t_sp.median_us},
            ratio_to="scipy solve_continuous_are",
        )
    )
    rows.append(
        Row(SUITE, "lqr_cartpole_with_linearization", "taskspace", measure(design, repeat=repeat))
    )
    # computed-torque step on the Panda vs raw rnea
    robot, q, v, _ = scene("panda")
    ref = SinusoidalReference(robot.q_default, 0.3, 0.5)
    ctrl = ComputedTorqueController(robot, ref, 100.0)
    model, data = robot.model, robot.model.createData()
    a = np.zeros(robot.nv)
    t_ct = measure(lambda: ctrl(0.1, q, v), repeat=repeat)
    t_rnea = measure(lambda: pin.rnea(model, data, q, v, a), repeat=repeat)
    rows.append(Row(SUITE, "computed_torque_panda", "raw pin.rnea", t_rnea))
    rows.append(
        Row(
            SUITE,
            "computed_torque_panda",
            "taskspace",
            t_ct,
            extra={"ratio_to_rnea": t_ct.median_us / t_rnea.median_us},
            ratio_to="raw pin.rnea",
        )
    )
    return rows
