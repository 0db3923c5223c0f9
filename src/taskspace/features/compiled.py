"""How a feature declares that the compiled kernels (``taskspace/_native``) can evaluate it.

A feature class the kernels serve overrides :meth:`Feature.compiled_term
<taskspace.features.feature.Feature.compiled_term>` and returns a :class:`CompiledTerm`
naming the kernels' evaluation of that feature; the IK solver then runs the stack on the
IK kernel when every task's feature has a term of :data:`IK_KINDS`, and the inverse-dynamics
QP runs on its kernel when every task's feature has one of :data:`KINDS` (at the acceleration
level: the same residual and Jacobian, and the feature's drift). Adding a feature the kernel
serves is code in the feature's class only. Only the class's own declaration counts
(:func:`compiled_term`): a subclass may change the map, so it is served only if it declares a
term itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

if TYPE_CHECKING:
    from taskspace.constraints.constraint import Constraint
    from taskspace.features.feature import Feature

KINDS = ("pose", "position", "com", "posture", "orientation")
"""The feature evaluations the compiled kernels implement (the inverse-dynamics kernel: all)."""

IK_KINDS = ("pose", "position", "com", "posture")
"""The kinds the compiled IK kernel (``_ik_kernel``) implements."""


class CompiledTerm(NamedTuple):
    """A feature as the compiled kernel evaluates it.

    Attributes:
        kind: one of :data:`KINDS`: ``pose`` (``log6`` frame error, LOCAL Jacobian),
            ``position`` (frame origin, LOCAL_WORLD_ALIGNED Jacobian), ``com`` (center of
            mass), ``posture`` (``difference(q*, q)`` over all or ``rows`` of the joints),
            ``orientation`` (``log3`` frame rotation error, angular LOCAL Jacobian).
        frame_id: Pinocchio frame index (``pose``, ``position``, ``orientation``).
        rows: selected tangent rows (``posture``; ``None`` for all).
    """

    kind: str
    frame_id: int = -1
    rows: tuple[int, ...] | None = None


CONSTRAINT_KINDS = ("dampers", "bounds")
"""The constraint rows a compiled IK kernel may evaluate itself (each consumer serves the
kinds it implements; the rows of the others are evaluated in Python and passed to it)."""


class CompiledConstraint(NamedTuple):
    """Inequality rows of a constraint as the compiled kernel evaluates them.

    Attributes:
        kind: one of :data:`CONSTRAINT_KINDS`: ``dampers`` (collision velocity dampers
            ``J_d dq >= -gain (d - safety_distance)`` for the collision pairs closer than
            ``influence_distance``, distances and witness points from coal in the kernel);
            ``bounds`` (``lower - phi <= J dq <= upper - phi`` on a feature the kernel
            evaluates, ``term``; a violated bound relaxed to the fraction ``gain`` of the way
            back, as :class:`~taskspace.constraints.FeatureBounds`).
        pairs: indices into ``robot.collision_model.collisionPairs`` (``dampers``).
        safety_distance, influence_distance: [m] (``dampers``).
        gain: damper or bounds gain in (0, 1].
        term: the bounded feature's compiled term (``bounds``).
        lower, upper: the bounds (``bounds``; arrays of the feature's dimension).
    """

    kind: str
    pairs: tuple[int, ...] = ()
    safety_distance: float = 0.0
    influence_distance: float = 0.0
    gain: float = 0.0
    term: CompiledTerm | None = None
    lower: Any = None
    upper: Any = None


def compiled_constraint(constraint: Constraint) -> CompiledConstraint | None:
    """The rows ``type(constraint)`` itself declares, or ``None`` (the Python path serves it)."""
    method = type(constraint).__dict__.get("compiled_constraint")
    if method is None:
        return None
    rows = method(constraint)
    if rows is not None and rows.kind not in CONSTRAINT_KINDS:
        return None
    return rows  # type: ignore[no-any-return]


def compiled_term(feature: Feature) -> CompiledTerm | None:
    """The term ``type(feature)`` itself declares, or ``None`` (the Python path serves it)."""
    method = type(feature).__dict__.get("compiled_term")
    if method is None:
        return None
    term = method(feature)
    if term is not None and term.kind not in KINDS:
        return None
    return term  # type: ignore[no-any-return]


__all__ = [
    "CONSTRAINT_KINDS",
    "IK_KINDS",
    "KINDS",
    "CompiledConstraint",
    "CompiledTerm",
    "compiled_constraint",
    "compiled_term",
]
