import numpy as np
import pytest

from taskspace.errors import InvalidInputError, PlanningError
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    PotentialStatus,
    gradient_descent,
)

BOUNDS = (-2.0, -6.0, 12.0, 6.0)
# U-shaped cup opening towards the start: the designed local minimum (slide 3:16).
CUP = Polygon(
    np.array(
        [[4, -2], [6, -2], [6, 2], [4, 2], [4, 1.5], [5.5, 1.5], [5.5, -1.5], [4, -1.5]], float
    )
)
OPTS = PotentialFieldOptions(zeta=1.0, d_star=2.0, eta=0.5, q_star=1.0)


def test_gradient_matches_finite_differences():
    field = PotentialField(PolygonWorld((CUP, Polygon.regular((1, 3), 0.7, 9))), (9, 0), OPTS)
    rng = np.random.default_rng(0)
    pts = rng.uniform([-1, -4], [10, 4], (300, 2))
    pts = pts[field.world.signed_distance(pts) > 0.05]
    h = 1e-6
    num = np.stack(
        [(field.value(pts + h * e) - field.value(pts - h * e)) / (2 * h) for e in np.eye(2)], 1
    )
    np.testing.assert_allclose(field.gradient(pts), num, rtol=1e-5, atol=1e-6)


def test_potential_formulas_analytic_values():
    field = PotentialField(PolygonWorld((Polygon.rectangle(0, -1, 1, 1),)), (5, 0), OPTS)
    # attractive, quadratic region (r = 1 <= d* = 2): 0.5 zeta r^2
    assert field.attractive([[4, 0]])[0][0] == pytest.approx(0.5)
    # conic region (r = 4): d* zeta r - 0.5 zeta d*^2 = 8 - 2
    assert field.attractive([[1, 0]])[0][0] == pytest.approx(6.0)
    # repulsive at D = 0.5 from the box: 0.5 eta (1/0.5 - 1/1)^2 = 0.25
    assert field.repulsive([[1.5, 0]])[0][0] == pytest.approx(0.25)
    assert field.repulsive([[3.0, 0]])[0][0] == 0.0  # beyond Q*


def test_descent_gets_stuck_in_the_designed_local_minimum():
    field = PotentialField(PolygonWorld((CUP,), BOUNDS), (9, 0), OPTS)
    res = gradient_descent(field, (0, 0))
    assert not res.success and res.status is PotentialStatus.LOCAL_MINIMUM
    q = res.path[-1]
    # analytic equilibrium: conic pull d* zeta = 2 equals push eta (1/D - 1)/D^2 at D = 0.5
    assert q == pytest.approx([5.0, 0.0], abs=1e-3)
    assert np.linalg.norm(q - field.goal) > 3.0
    # it is a true local minimum: U is larger on a ring of points around it
    ang = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = q + 0.05 * np.stack([np.cos(ang), np.sin(ang)], 1)
    assert np.all(field.value(ring) > field.value(q[None])[0])
    # potential decreases along the descent
    assert np.all(np.diff(res.potential) < 1e-9)


def test_descent_reaches_goal_without_local_minimum():
    world = PolygonWorld((Polygon.regular((4.5, 1.5), 0.8, 12),), BOUNDS)
    res = gradient_descent(PotentialField(world, (9, 0), OPTS), (0, 0))
    assert res.success and res.status is PotentialStatus.REACHED
    assert np.linalg.norm(res.path[-1] - (9, 0)) <= OPTS.goal_tolerance
    assert np.all(world.signed_distance(res.path) > 0)


def test_errors():
    field = PotentialField(PolygonWorld((CUP,), BOUNDS), (9, 0), OPTS)
    with pytest.raises(PlanningError, match=r"start \(5, 1.8\) is inside obstacle 0"):
        gradient_descent(field, (5, 1.8))
    with pytest.raises(PlanningError, match="outside the world bounds"):
        gradient_descent(field, (50, 0))
    with pytest.raises(InvalidInputError, match="eta must be finite and > 0"):
        PotentialField(PolygonWorld((CUP,)), (9, 0), PotentialFieldOptions(eta=0.0))
