"""The task variable (feature) abstraction of the lecture notes (slides 2:15-2:16, 2:45-2:56).

A feature is a differentiable map ``phi: q -> y`` with Jacobian ``J(q) = d phi / dq`` (columns
in Pinocchio's tangent space, size ``nv``) and drift ``Jdot v`` (for acceleration-level
control: ``y'' = J q'' + Jdot v``). Every consumer of taskspace (IK, hierarchies,
operational-space control, path optimization, planning) uses features through this class.

Thread safety: a feature keeps no per-evaluation workspace: it reads the
:class:`~taskspace.model.State` it is given (one state per thread), so one feature may be
evaluated from several threads, e.g. by solvers in different threads sharing a task list. What
it derives from the robot (limits, collision pairs) is rebuilt on the next call after a model
or world change; do not change the robot, the world or the feature's own parameters while
another thread evaluates it.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any

import numpy as np

from taskspace._validation import FloatArray, as_vector
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.features.compiled import CompiledTerm
    from taskspace.model.robot import Robot
    from taskspace.model.state import State


class Feature(abc.ABC):
    """Base class of task variables.

    Subclasses implement :meth:`value`, :meth:`jacobian` and :meth:`drift`. Features whose
    values live on a Lie group (poses, orientations, configurations) also override
    :meth:`residual` and :meth:`residual_jacobian` with the logarithmic error.

    Attributes:
        robot: the robot the feature is defined on.
        name: a descriptive name (used in error messages and results).
        dim: dimension of the feature's tangent space (rows of the Jacobian).
    """

    dim: int

    def __init__(self, robot: Robot, name: str) -> None:
        self.robot = robot
        self.name = name

    def _check_state(self, state: State) -> None:
        if state.robot is not self.robot:
            raise InvalidInputError(
                f"feature '{self.name}' is defined on robot '{self.robot.name}' but the state "
                f"belongs to robot '{state.robot.name}'"
            )

    @abc.abstractmethod
    def value(self, state: State) -> Any:
        """Feature value ``y = phi(q)``."""

    @abc.abstractmethod
    def jacobian(self, state: State) -> FloatArray:
        """Jacobian ``J = d phi / dq``, shape (dim, nv)."""

    @abc.abstractmethod
    def drift(self, state: State) -> FloatArray:
        """Drift ``Jdot v`` (the feature acceleration at zero joint acceleration), (dim,)."""

    def check_target(self, target: Any) -> Any:
        """Validate a target value for this feature and return it in canonical form."""
        return as_vector(target, self.dim, f"target of feature '{self.name}'")

    def residual(self, state: State, target: Any) -> FloatArray:
        """Error ``e = phi(q) - y*`` (a tangent vector of size dim)."""
        return np.asarray(self.value(state), dtype=float) - target

    def residual_jacobian(self, state: State, target: Any) -> FloatArray:
        """Jacobian of :meth:`residual` with respect to ``q`` (dim, nv)."""
        return self.jacobian(state)

    def residual_and_jacobian(self, state: State, target: Any) -> tuple[FloatArray, FloatArray]:
        """Both :meth:`residual` and :meth:`residual_jacobian` (shares their common work)."""
        return self.residual(state, target), self.residual_jacobian(state, target)

    def compiled_term(self) -> CompiledTerm | None:
        """How the compiled IK kernel evaluates this feature, or ``None`` (Python path).

        A feature class the kernel serves overrides this method (see
        :mod:`taskspace.features.compiled`); only a class's own override counts, so a
        subclass that changes the map is not served by the kernel unless it declares a term.
        """
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}('{self.name}', dim={self.dim})"


def require_vector_feature(feature: Feature, owner: str, hint: str) -> None:
    """Raise unless ``feature``'s value is a vector of size ``feature.dim``.

    Bounds and goal regions compare the value with ``lower``/``upper`` entry by entry, which
    has no meaning for a pose, an orientation, or a configuration with continuous or
    free-flyer joints (``nq != nv``). The value is read at the robot's default posture.

    Args:
        feature: the feature to check.
        owner: what needs the vector (named in the message), e.g. ``"FeatureBounds"``.
        hint: what to use instead (ends the message).

    Raises:
        InvalidInputError: the value is not a float vector of shape ``(feature.dim,)``.
    """
    robot = feature.robot
    value = feature.value(robot.state(robot.q_default))
    if isinstance(value, np.ndarray) and value.shape == (feature.dim,):
        return
    shape = getattr(value, "shape", None)
    what = f"shape {shape}" if isinstance(value, np.ndarray) else f"type {type(value).__name__}"
    raise InvalidInputError(
        f"{owner} needs a feature whose value is a vector of size dim; the value is not a "
        f"vector of {feature!r}: {what}, not ({feature.dim},) (dim {feature.dim}; a pose, "
        f"an orientation or the configuration of continuous or free-flyer joints is not "
        f"compared entry by entry); {hint}"
    )
