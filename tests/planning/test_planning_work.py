"""MechanicalWork objective: absolute work against gravity, midpoint rule on each segment.

References: the analytic work of a pendulum (``tau_g = m g l sin q``, so
``integral |tau_g| dq = m g l |cos a - cos b|`` on each side of the bottom), scipy's adaptive
quadrature of ``|tau_g(q(t)) . (b - a)|`` on a two-link pendulum, and the potential energy
(``pinocchio.computePotentialEnergy``): no path from ``a`` to ``b`` does less absolute work
than ``|U(b) - U(a)|``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import quad

from taskspace.errors import InvalidInputError
from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.objectives import MechanicalWork, PathLength
from taskspace.planning.prm_star import PRMStarOptions, prm_star
from taskspace.planning.rrt_star import RRTStarOptions, rrt_star

MASS, LENGTH = 2.0, 0.5


def pendulum(links: int) -> pin.Model:
    """``links`` revolute joints about y, each carrying a point-like mass LENGTH below it."""
    model = pin.Model()
    joint = 0
    for k in range(links):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.0 if k == 0 else -LENGTH]))
        joint = model.addJoint(joint, pin.JointModelRY(), placement, f"j{k}")
        inertia = pin.Inertia(MASS, np.array([0.0, 0.0, -LENGTH]), np.eye(3) * 1e-6)
        model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
    return model


def test_pendulum_work_is_the_analytic_integral() -> None:
    work = MechanicalWork(pendulum(1), resolution=1e-3)
    mgl = MASS * 9.81 * LENGTH
    a, b = np.array([-1.0]), np.array([1.5])  # down through the bottom, then up
    exact = mgl * ((1 - math.cos(1.0)) + (1 - math.cos(1.5)))
    assert work.motion_cost(a, b) == pytest.approx(exact, rel=1e-6)
    assert work.motion_cost(b, a) == pytest.approx(exact, rel=1e-6)  # symmetric
    # One piece per segment: |tau_g(midpoint) . (b - a)|.
    coarse = MechanicalWork(pendulum(1), resolution=math.inf)
    assert coarse.motion_cost(a, b) == pytest.approx(mgl * abs(math.sin(0.25)) * 2.5, rel=1e-12)
    # Moving where gravity does no work costs nothing; a path sums its segments.
    path = np.array([[-1.0], [0.2], [1.5]])
    assert work.path_cost(path) == pytest.approx(exact, rel=1e-6)


def test_two_link_work_matches_adaptive_quadrature() -> None:
    model = pendulum(2)
    data = model.createData()
    work = MechanicalWork(model, resolution=2e-3)
    rng = np.random.default_rng(0)
    for _ in range(5):
        a, b = rng.uniform(-2, 2, 2), rng.uniform(-2, 2, 2)

        def integrand(t: float, a: np.ndarray = a, b: np.ndarray = b) -> float:
            tau = pin.computeGeneralizedGravity(model, data, a + t * (b - a))
            return abs(float(tau @ (b - a)))

        reference, _ = quad(integrand, 0.0, 1.0, limit=200, epsabs=1e-12)
        assert work.motion_cost(a, b) == pytest.approx(reference, rel=1e-4)
        energy = [pin.computePotentialEnergy(model, data, q) for q in (a, b)]
        assert work.motion_cost(a, b) >= abs(energy[1] - energy[0]) * (1 - 1e-4)


def test_optimal_planners_take_less_work_than_the_shortest_path() -> None:
    model = pendulum(2)
    space = ConfigurationSpace(
        [-math.pi, -math.pi], [math.pi, math.pi], FunctionChecker(lambda Q: np.ones(len(Q), bool))
    )
    work = MechanicalWork(model, resolution=0.05)
    start, goal = np.array([-1.2, 0.0]), np.array([1.2, 0.0])  # swing across the bottom
    data = model.createData()
    floor = abs(
        pin.computePotentialEnergy(model, data, goal)
        - pin.computePotentialEnergy(model, data, start)
    )  # 0: same height, yet the straight swing goes down and up again
    straight = work.motion_cost(start, goal)
    assert straight > 10.0
    results = {
        "rrt_star": rrt_star(
            space, start, goal, RRTStarOptions(max_iterations=1500, time_limit_s=None, seed=1),
            objective=work,
        ),
        "prm_star": prm_star(
            space, start, goal, PRMStarOptions(max_iterations=600, time_limit_s=None, seed=1),
            objective=work,
        )[0],
        "bit_star": bit_star(
            space, start, goal, BITStarOptions(max_iterations=600, time_limit_s=None, seed=1),
            objective=work,
        ),
    }  # fmt: skip
    for name, res in results.items():
        assert res.success, name
        assert res.cost == pytest.approx(work.path_cost(res.path), rel=1e-9), name
        assert floor - 1e-9 <= res.cost < 0.7 * straight, (name, res.cost, straight)
    # The length-optimal path does more work than the work-optimal one.
    options = RRTStarOptions(max_iterations=1500, time_limit_s=None, seed=1)
    short = rrt_star(space, start, goal, options, objective=PathLength())
    assert work.path_cost(short.path) > results["rrt_star"].cost


def test_what_mechanical_work_refuses() -> None:
    floating = pin.Model()
    floating.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    with pytest.raises(InvalidInputError, match="size 7"):  # a floating base: nq 7, nv 6
        MechanicalWork(floating).motion_cost(np.zeros(6), np.ones(6))
    with pytest.raises(InvalidInputError, match=r"Robot or a pinocchio\.Model"):
        MechanicalWork("panda")
    with pytest.raises(InvalidInputError, match="resolution"):
        MechanicalWork(pendulum(1), resolution=0.0)
    with pytest.raises(InvalidInputError, match="size 1"):
        MechanicalWork(pendulum(1)).motion_cost(np.zeros(2), np.ones(2))
