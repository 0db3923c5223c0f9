"""One ForwardDynamics shared by threads (#15 Build 5): each call is ABA at its own state.

Reference: ``pin.aba`` on a fresh ``pin.Data`` per state. Four threads (the builder's and three
others, which get their own data) evaluate one object at different states with friction.
"""

from __future__ import annotations

import sys
import threading

import numpy as np
import pinocchio as pin

from taskspace.dynamics import ForwardDynamics, JointFriction
from taskspace.model import Robot


def test_forward_dynamics_shared_by_threads_matches_pinocchio() -> None:
    robot = Robot.load("panda")
    friction = JointFriction(damping=0.3, coulomb=0.2)
    fd = ForwardDynamics(robot, friction)
    rng = np.random.default_rng(2)
    cases = []
    for _ in range(4):
        q = pin.randomConfiguration(robot.model)
        v, tau = rng.normal(size=robot.nv), rng.normal(size=robot.nv)
        expected = pin.aba(robot.model, robot.model.createData(), q, v, tau + fd.friction_torque(v))
        cases.append((q, v, tau, np.asarray(expected).copy()))
    errors: list[float] = []

    def run(q: np.ndarray, v: np.ndarray, tau: np.ndarray, expected: np.ndarray) -> None:
        for _ in range(300):
            errors.append(float(np.max(np.abs(fd.acceleration(q, v, tau) - expected))))

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        pool = [threading.Thread(target=run, args=case) for case in cases[1:]]
        for th in pool:
            th.start()
        run(*cases[0])  # the builder's thread (fd.data) at the same time
        for th in pool:
            th.join(60.0)
    finally:
        sys.setswitchinterval(old)
    assert len(errors) == 4 * 300
    assert max(errors) < 1e-9
    assert fd._local.__dict__.get("data") is None  # the builder used fd.data
