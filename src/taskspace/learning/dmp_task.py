"""A discrete DMP integrated online that drives a :class:`~taskspace.tasks.Task`'s target.

At every control step the DMP of :mod:`taskspace.learning.dmp` advances by ``dt`` (the
semi-implicit Euler step of :meth:`DiscreteDMP.rollout`) with coupling terms ``C_i(y, y')``
added to its transformation system,

``tau z' = alpha_z (beta_z (g - y) - z) + f(x) + sum_i C_i(y, y')``,   ``tau y' = z``,

and its position ``y`` becomes the task's target: a position target for a
:class:`~taskspace.features.Position` (or any feature whose target is a vector of the DMP's
dimension, e.g. a :class:`~taskspace.features.JointConfiguration`), the translation of a pose
target for a :class:`~taskspace.features.FramePose` (the orientation held). For vector targets
the DMP's velocity and acceleration are the task's feed-forward reference
(:meth:`Task.set_reference`), used by the acceleration-level controllers.

Obstacle coupling (:class:`SphereRepulsion`): the gradient of a repulsive potential of the
distance ``d`` from ``y`` to a sphere's surface (Khatib's FIRAS function),

``U(y) = gain / 2 (1/d - 1/d_0)^2`` for ``d < d_0``, 0 beyond,   ``C = -grad U``,

which grows without bound at the surface, so the DMP's path stays out of the sphere while the
attractor still pulls it to the goal around it.

Thread safety: :class:`DMPTaskTarget` serializes its steps with a lock (see there);
:class:`SphereRepulsion` is immutable and :class:`DMPStep` plain result data. A user
:class:`Coupling` is called under the target's lock.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import coal
import numpy as np
import pinocchio as pin

from taskspace._validation import FloatArray, as_vector, check_positive
from taskspace.errors import InvalidInputError
from taskspace.features import FramePose
from taskspace.learning.dmp import DiscreteDMP, _check_step
from taskspace.model.world import Obstacle
from taskspace.tasks import Task


class Coupling(Protocol):
    """A coupling term ``C(y, y')`` (d,) of the DMP's transformation system."""

    def term(self, y: FloatArray, yd: FloatArray) -> FloatArray:
        """The term at position ``y`` and velocity ``yd`` (d,)."""
        ...


@dataclass(frozen=True, kw_only=True)
class SphereRepulsion:
    """Repulsion of the DMP's position from a sphere (see the module docstring).

    Attributes:
        center: sphere centre (d,) [m].
        radius: [m].
        influence: distance ``d_0`` [m] from the surface beyond which the term is zero.
        gain: ``gain`` of the potential [m^3] (in the units of ``tau z'``: the term is
            ``gain (1/d - 1/d_0) / d^2`` along the outward normal).
    """

    center: Any
    radius: float
    influence: float = 0.1
    gain: float = 1e-3

    def __post_init__(self) -> None:
        c = as_vector(self.center, None, "sphere center")
        object.__setattr__(self, "center", c)
        check_positive(self.radius, "radius [m]", strict=False)
        check_positive(self.influence, "influence distance [m]")
        check_positive(self.gain, "gain", strict=False)

    @classmethod
    def from_obstacle(
        cls, obstacle: Obstacle, *, influence: float = 0.1, gain: float = 1e-3
    ) -> SphereRepulsion:
        """The repulsion of a sphere :class:`~taskspace.model.world.Obstacle`.

        Raises:
            InvalidInputError: the obstacle is not a sphere.
        """
        if not isinstance(obstacle, Obstacle) or not isinstance(obstacle.geometry, coal.Sphere):
            raise InvalidInputError(
                "SphereRepulsion.from_obstacle needs a sphere Obstacle (Obstacle.sphere(...)); "
                f"got {getattr(obstacle, 'geometry', obstacle)!r}"
            )
        return cls(
            center=obstacle.placement.translation.copy(),
            radius=float(obstacle.geometry.radius),
            influence=influence,
            gain=gain,
        )

    def distance(self, y: Any) -> float:
        """Distance from ``y`` to the sphere's surface [m] (negative inside)."""
        return float(np.linalg.norm(np.asarray(y, dtype=float) - self.center) - self.radius)

    def potential(self, y: Any) -> float:
        """``U(y)`` (infinite inside the sphere)."""
        d = self.distance(y)
        if d <= 0.0:
            return float("inf")
        if d >= self.influence:
            return 0.0
        return 0.5 * self.gain * (1.0 / d - 1.0 / self.influence) ** 2

    def term(self, y: FloatArray, yd: FloatArray) -> FloatArray:
        """``-grad U(y)`` (d,); inside the sphere, the value at its surface."""
        r = np.asarray(y, dtype=float) - self.center
        norm = float(np.linalg.norm(r))
        if norm == 0.0:
            return np.zeros_like(r)
        d = max(norm - self.radius, 1e-6 * max(self.influence, 1e-12))
        if d >= self.influence:
            return np.zeros_like(r)
        return np.asarray(self.gain * (1.0 / d - 1.0 / self.influence) / d**2 * r / norm)


@dataclass
class DMPStep:
    """The DMP's state after a step of :meth:`DMPTaskTarget.step`.

    Attributes:
        time: time since the start [s]; y, yd, ydd: position, velocity, acceleration (d,);
        phase: ``x``; goal: the (filtered) goal (d,); coupling: the sum of the coupling terms.
    """

    time: float
    y: FloatArray
    yd: FloatArray
    ydd: FloatArray
    phase: float
    goal: FloatArray
    coupling: FloatArray


class DMPTaskTarget:
    """Integrate a :class:`DiscreteDMP` online and write its position into a task's target.

    Args:
        dmp: the learned DMP (dimension ``d``).
        task: the task to drive: a :class:`~taskspace.features.FramePose` task (``d = 3``,
            the translation) or a task whose target is a ``d``-vector (e.g. ``Position``).
        y0: start (default: the DMP's demonstrated start); goal: goal (default:
            demonstrated); tau: temporal scale [s] (default: demonstrated); yd0: start
            velocity (default: zero, a start at rest).
        couplings: coupling terms added to the transformation system (e.g.
            :class:`SphereRepulsion`).

    Raises:
        InvalidInputError: dimensions that do not match or a non-positive ``tau``.

    Thread safety: :meth:`step` and :meth:`set_goal` may be called from several threads (a
    control loop stepping while another thread moves the goal): they hold the target's lock,
    so each step integrates the state left by the previous one and none is lost. The task it
    drives is written under the same lock; do not step a solver on that task concurrently
    with :meth:`step` unless the solver serializes its own calls.
    """

    def __init__(
        self,
        dmp: DiscreteDMP,
        task: Task,
        *,
        y0: Any = None,
        goal: Any = None,
        tau: float | None = None,
        yd0: Any = None,
        couplings: Sequence[Coupling] = (),
    ) -> None:
        if not isinstance(dmp, DiscreteDMP):
            raise InvalidInputError(f"dmp must be a DiscreteDMP, got {type(dmp).__name__}")
        if not isinstance(task, Task):
            raise InvalidInputError(f"task must be a Task, got {type(task).__name__}")
        d = dmp.weights.shape[0]
        self._pose = isinstance(task.feature, FramePose)
        if self._pose and d != 3:
            raise InvalidInputError(f"a FramePose task needs a 3-D DMP (translation), got {d}-D")
        if not self._pose and task.dim != d:
            raise InvalidInputError(
                f"the task '{task.name}' has {task.dim} dimensions but the DMP {d}; use a "
                "Position/FramePose task for a 3-D DMP or a DMP of the task's dimension"
            )
        for c in couplings:
            if not callable(getattr(c, "term", None)):
                raise InvalidInputError(
                    f"couplings need a term(y, yd) method (e.g. SphereRepulsion), got {c!r}"
                )
        self.dmp = dmp
        self.task = task
        self.couplings = tuple(couplings)
        self.tau = dmp.tau if tau is None else check_positive(tau, "tau [s]")
        self.start = dmp.y0.copy() if y0 is None else as_vector(y0, d, "y0")
        self.goal_target = dmp.goal.copy() if goal is None else as_vector(goal, d, "goal")
        self.goal = self.goal_target.copy()
        v0 = np.zeros(d) if yd0 is None else as_vector(yd0, d, "yd0")
        self.y = self.start.copy()
        self.z = self.tau * v0
        self.phase = 1.0
        self.time = 0.0
        self._unscaled = np.abs(dmp.goal - dmp.y0) < 1e-10
        self._any_unscaled = bool(np.any(self._unscaled))
        if self._pose:
            target = task.target if task.target is not None else pin.SE3.Identity()
            self._rotation = np.array(target.rotation, copy=True)
        self._lock = threading.Lock()
        self._write(np.zeros(d), np.zeros(d))

    def set_goal(self, goal: Any) -> None:
        """Move the goal; the DMP's goal follows it through its filter (no jump)."""
        goal = as_vector(goal, self.y.size, "goal")
        with self._lock:
            self.goal_target = goal

    def acceleration(self) -> tuple[FloatArray, FloatArray]:
        """``(tau z', sum C)`` at the current state."""
        o, dmp, x = self.dmp.options, self.dmp, self.phase
        psi = np.exp(-dmp.widths * (x - dmp.centers) ** 2)
        scale = self.goal - self.start
        if self._any_unscaled:
            scale = np.where(self._unscaled, 1.0, scale)
        f = (dmp.weights @ psi) * (x / (psi.sum() + 1e-300)) * scale
        zd = o.alpha_z * (dmp.beta_z * (self.goal - self.y) - self.z) + f
        C = np.zeros_like(self.y)
        if self.couplings:
            yd = self.z / self.tau
            for c in self.couplings:
                C = C + np.asarray(c.term(self.y, yd), dtype=float)
            zd = zd + C
        return zd, C

    def step(self, dt: float) -> DMPStep:
        """Advance the DMP by ``dt`` [s] and set the task's target (and reference) to it.

        The reported (and feed-forward) acceleration is the one integrated over the step.
        """
        check_positive(dt, "dt [s]")
        _check_step(float(dt), self.tau, self.dmp.options)  # larger steps diverge silently
        with self._lock:
            return self._step(dt)

    def _step(self, dt: float) -> DMPStep:
        o = self.dmp.options
        zd, C = self.acceleration()
        ydd = zd / self.tau**2
        self.z = self.z + dt * zd / self.tau
        self.y = self.y + dt * self.z / self.tau
        self.goal = self.goal + dt * o.alpha_g * (self.goal_target - self.goal) / self.tau
        self.phase *= 1.0 - dt * o.alpha_x / self.tau
        self.time += dt
        yd = self.z / self.tau
        self._write(yd, ydd)
        return DMPStep(
            time=self.time,
            y=self.y.copy(),
            yd=yd,
            ydd=ydd,
            phase=self.phase,
            goal=self.goal.copy(),
            coupling=C,
        )

    def _write(self, yd: FloatArray, ydd: FloatArray) -> None:
        if self._pose:
            self.task.set_target(pin.SE3(self._rotation, self.y.copy()))
        else:
            self.task.set_target(self.y.copy())
            self.task.set_reference(yd, ydd)
