"""linearize(actuated=...) takes one joint name or a list of names (#15).

``actuated="slider"`` used to iterate the string's characters (unknown joint 's').
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from taskspace.control import linearize
from taskspace.errors import InvalidInputError, UnknownNameError

M_CART, L_POLE = 1.0, 0.5
# Analytic cart-pole input column (point-mass pole, upright): x'' = F / M, th'' = -F / (M l).
B_SLIDER = np.array([[0.0], [0.0], [1.0 / M_CART], [-1.0 / (M_CART * L_POLE)]])


@pytest.mark.parametrize(
    "actuated", ["slider", ["slider"], ("slider",), np.array(["slider"]), iter(["slider"])]
)
def test_one_name_or_a_list_give_the_analytic_b(robot_loader: Any, actuated: Any) -> None:
    sys = linearize(robot_loader("cartpole"), np.zeros(2), actuated=actuated)
    np.testing.assert_allclose(sys.B, B_SLIDER, atol=1e-10)
    assert list(sys.actuated) == [0]


def test_single_hinge_name(robot_loader: Any) -> None:
    robot = robot_loader("cartpole")
    sys = linearize(robot, np.zeros(2), actuated="hinge")
    assert list(sys.actuated) == [1]
    np.testing.assert_array_equal(sys.B, linearize(robot, np.zeros(2), actuated=["hinge"]).B)


@pytest.mark.parametrize("actuated", [3, 2.5, b"slider", [3], ["slider", None], [b"slider"]])
def test_non_names_are_refused(robot_loader: Any, actuated: Any) -> None:
    with pytest.raises(InvalidInputError, match="actuated"):
        linearize(robot_loader("cartpole"), np.zeros(2), actuated=actuated)


@pytest.mark.parametrize("actuated", ["slide", ["slider", "cart"], "s"])
def test_unknown_names_list_the_joints(robot_loader: Any, actuated: Any) -> None:
    with pytest.raises(UnknownNameError, match="hinge, slider"):
        linearize(robot_loader("cartpole"), np.zeros(2), actuated=actuated)
