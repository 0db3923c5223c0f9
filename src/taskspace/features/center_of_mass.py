"""Center of mass of the whole robot (slide 2:54).

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from taskspace._validation import FloatArray
from taskspace.features.compiled import CompiledTerm
from taskspace.features.feature import Feature

if TYPE_CHECKING:
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class CenterOfMass(Feature):
    """``phi(q) = sum_i m_i T_W,i c_i / M`` [m], Jacobian ``sum_i m_i J_pos(i, c_i) / M``.

    (The notes write the mass-weighted sum; taskspace normalizes by the total mass ``M`` so
    the value is the CoM position.) Computed by Pinocchio's ``jacobianCenterOfMass``.
    """

    dim = 3

    def __init__(self, robot: Robot) -> None:
        super().__init__(robot, "center_of_mass")

    def value(self, state: State) -> FloatArray:
        """Center of mass in the world [m]."""
        self._check_state(state)
        return state.com().copy()

    def jacobian(self, state: State) -> FloatArray:
        """3 x nv CoM Jacobian."""
        self._check_state(state)
        return state.com_jacobian()

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """``c(q) - c*`` and the CoM Jacobian."""
        if state.robot is not self.robot:
            self._check_state(state)
        J = state.com_jacobian()  # also computes the CoM
        return state.com() - target, J

    def compiled_term(self) -> CompiledTerm:
        """The kernel evaluates the center of mass."""
        return CompiledTerm("com")

    def drift(self, state: State) -> FloatArray:
        """CoM acceleration at zero joint acceleration [m/s^2]."""
        self._check_state(state)
        return state.com_drift()
