"""Typed rows that tasks and constraints hand to the QP layer.

Tasks, constraints and contacts describe their part of a QP with these values; the stacking
layer (:mod:`taskspace.qp.rows`) writes them into the preallocated arrays of each
consumer's QP. They live here, below ``tasks`` and ``constraints``, so that those layers can
return them without importing ``qp``. All are named tuples: they unpack like the plain
tuples they replace (``lb, ub = constraint.bounds(state, dt)``).
"""

from __future__ import annotations

from typing import NamedTuple

from taskspace._validation import FloatArray

INF = 1e20
"""Stand-in for an infinite bound (what the QP backends accept)."""


class TaskRows(NamedTuple):
    """Weighted least-squares rows ``jacobian x ~ rhs`` of one task (or a stack of tasks).

    Velocity level (:meth:`~taskspace.tasks.Task.rows`): ``sqrt(rho) J dq ~ -sqrt(rho) gain
    e``. Acceleration level (:meth:`~taskspace.tasks.Task.acceleration_rows`):
    ``sqrt(rho) J a ~ sqrt(rho) (y''* - Jdot v)``.

    Attributes:
        jacobian: (m, nv) rows, scaled by ``sqrt(rho)``.
        rhs: (m,) right-hand side, scaled by ``sqrt(rho)``.
    """

    jacobian: FloatArray
    rhs: FloatArray


class FeatureRows(NamedTuple):
    """What a task's feature gives at a state, before any control law is applied.

    Attributes:
        jacobian: (dim, nv) Jacobian of the residual.
        residual: (dim,) residual ``e = phi(q) (-) y*``.
        drift: (dim,) ``Jdot v`` (acceleration level), or ``None`` when not asked for.
        sqrt_weight: ``sqrt(rho)``, a scalar or one value per row.
    """

    jacobian: FloatArray
    residual: FloatArray
    drift: FloatArray | None
    sqrt_weight: float | FloatArray


class Box(NamedTuple):
    """Box bounds ``lower <= x <= upper`` on the step (``-INF``/``INF`` where unbounded)."""

    lower: FloatArray
    upper: FloatArray


class InequalityRows(NamedTuple):
    """Two-sided rows ``lower <= C x <= upper`` (``-INF``/``INF`` where one-sided)."""

    C: FloatArray
    lower: FloatArray
    upper: FloatArray


class EqualityRows(NamedTuple):
    """Rows ``A x = b``."""

    A: FloatArray
    b: FloatArray


__all__ = ["INF", "Box", "EqualityRows", "FeatureRows", "InequalityRows", "TaskRows"]
