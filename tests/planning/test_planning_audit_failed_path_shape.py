"""A failed plan on a joint manifold returns an empty path of the space's coordinates.

On a continuous joint (``nq = 2``: cos, sin; ``nv = 1``) RRT* gave a failed result whose
empty path had ``nv`` columns, ``(0, 1)``, where every other planner gives ``(0, nq)``:
``space.full_configurations(result.path)`` then refused it. Here the start and the goal
are separated by two walls on the circle: no planner can succeed, every one must say so
with an empty ``(0, 2)`` path.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.planner_result import PlannerStatus
from tests.planning._planning_worlds import PLANNERS


def _walled_wheel() -> ConfigurationSpace:
    """One continuous joint, free only for angles within 1 rad of 0 or of pi."""
    model = pin.Model()
    model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    manifold = JointManifold(model)

    def free(q: np.ndarray) -> np.ndarray:
        angle = np.abs(np.arctan2(q[:, 1], q[:, 0]))
        return (angle < 1.0) | (angle > math.pi - 1.0)

    return ConfigurationSpace(
        manifold.lower, manifold.upper, FunctionChecker(free), manifold=manifold
    )


@pytest.mark.parametrize("name", PLANNERS)
def test_no_path_is_an_empty_path_of_nq_columns(name: str) -> None:
    fn, options = PLANNERS[name]
    space = _walled_wheel()
    start, goal = np.array([1.0, 0.0]), np.array([-1.0, 0.0])  # angles 0 and pi
    result = fn(space, start, goal, options(max_iterations=60, time_limit_s=None, seed=1))
    if isinstance(result, tuple):  # the PRMs return their roadmap too
        result = result[0]
    assert not result.success
    assert result.status is not PlannerStatus.SOLVED
    assert result.path.shape == (0, space.dim)
    assert space.full_configurations(result.path).shape == (0, 2)
