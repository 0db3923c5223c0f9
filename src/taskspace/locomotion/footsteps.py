"""Footstep plans: where each foot lands and when (straight, curved and turning walks).

A plan starts in double support on two feet and alternates swing feet. The body moves along
poses ``(x_i, y_i, yaw_i)`` (``i = 0..n``); step ``i`` puts the swing foot at the pose's lateral
offset

    p_foot = (x_i, y_i) + R(yaw_i) (0, +-w/2),   yaw_foot = yaw_i,

(``+`` for the left foot), and a last step brings the other foot alongside so that the walk
ends in double support with the feet side by side.

Timing: an initial double support (the ZMP shifts onto the first stance foot), then per step
a single support (one foot swings) followed by a double support (the ZMP moves to the foot
that just landed), and a final double support back to the middle of the feet.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums) and
its functions keep their state local to the call, so both may be used from several threads.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar, check_int, check_positive
from taskspace.errors import InvalidInputError, UnknownNameError

SIDES = ("left", "right")


def _side(side: str) -> str:
    if side not in SIDES:
        raise UnknownNameError("side", side, SIDES)
    return side


def check_steps(n_steps: Any, what: str = "walk") -> int:
    """``n_steps`` as an int if it is an integer ``>= 2`` (``3.0`` accepted, ``True`` refused)."""
    n = check_int(n_steps, "n_steps")
    if n < 2:
        raise InvalidInputError(f"a {what} needs n_steps >= 2, got {n_steps}")
    return n


def other_side(side: str) -> str:
    """``"left"`` <-> ``"right"``."""
    return "right" if _side(side) == "left" else "left"


@dataclass(frozen=True)
class Footstep:
    """A foot on the ground.

    Attributes:
        side: ``"left"`` or ``"right"``.
        x, y: position of the foot center on the ground [m].
        yaw: heading of the foot in the world [rad] (absolute, like x and y).
    """

    side: str
    x: float
    y: float
    yaw: float = 0.0

    def __post_init__(self) -> None:
        _side(self.side)
        for name in ("x", "y", "yaw"):
            object.__setattr__(self, name, as_scalar(getattr(self, name), name))

    @property
    def position(self) -> FloatArray:
        """``(x, y)`` [m]."""
        return np.array([self.x, self.y])

    @property
    def rotation(self) -> FloatArray:
        """2x2 rotation of the foot's yaw."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s], [s, c]])

    def sole_corners(self, length: float, width: float) -> FloatArray:
        """(4, 2) corners of a ``length x width`` [m] sole centered on the footstep."""
        hl, hw = 0.5 * length, 0.5 * width
        local = np.array([[-hl, -hw], [hl, -hw], [hl, hw], [-hl, hw]])
        return np.asarray(local @ self.rotation.T + self.position)


@dataclass(frozen=True, kw_only=True)
class StepTiming:
    """Durations of the phases of a walk [s].

    Attributes:
        single_support: one foot on the ground, the other swinging.
        double_support: both feet on the ground between two steps.
        initial_double_support: before the first step; the ZMP rests between the feet, then
            shifts onto the first stance foot during the last ``weight_shift`` seconds.
        final_double_support: after the last step; the ZMP shifts back to the middle of the
            feet during the first ``weight_shift`` seconds, then rests.
        weight_shift: duration of the initial and final ZMP shifts.
    """

    single_support: float = 0.7
    double_support: float = 0.2
    initial_double_support: float = 1.6
    final_double_support: float = 1.6
    weight_shift: float = 0.4

    def __post_init__(self) -> None:
        check_positive(self.single_support, "single_support")
        check_positive(self.double_support, "double_support", strict=False)
        check_positive(self.initial_double_support, "initial_double_support")
        check_positive(self.final_double_support, "final_double_support")
        check_positive(self.weight_shift, "weight_shift")
        if self.weight_shift > min(self.initial_double_support, self.final_double_support):
            raise InvalidInputError(
                f"weight_shift ({self.weight_shift} s) must not exceed the initial and final "
                "double supports"
            )


class PhaseKind(enum.Enum):
    """Contact phase of a walk."""

    DOUBLE_SUPPORT = "double_support"
    SINGLE_SUPPORT = "single_support"


@dataclass(frozen=True)
class Phase:
    """One contact phase.

    Attributes:
        kind: single or double support.
        start, end: time interval [s].
        stance: the feet on the ground during the phase.
        swing: the swing foot's lift-off and landing footsteps (single support only).
        zmp_start, zmp_end: the ZMP reference moves linearly between these points [m].
    """

    kind: PhaseKind
    start: float
    end: float
    stance: tuple[Footstep, ...]
    swing: tuple[Footstep, Footstep] | None
    zmp_start: FloatArray
    zmp_end: FloatArray


@dataclass(frozen=True)
class FootstepPlan:
    """Initial feet, successive footsteps, and timing.

    Attributes:
        initial: the two feet at the start (double support), ``(left, right)``.
        steps: landing footsteps in order; sides alternate.
        timing: phase durations.
    """

    initial: tuple[Footstep, Footstep]
    steps: tuple[Footstep, ...]
    timing: StepTiming = StepTiming()

    def __post_init__(self) -> None:
        left, right = self.initial
        if (left.side, right.side) != ("left", "right"):
            raise InvalidInputError("initial must be (left footstep, right footstep)")
        feet = {"left": left, "right": right}
        for i, step in enumerate(self.steps):
            if i and step.side == self.steps[i - 1].side:
                raise InvalidInputError(
                    f"steps {i - 1} and {i} are both {step.side}: swing sides must alternate"
                )
            feet[step.side] = step

    @property
    def duration(self) -> float:
        """Total duration of the walk [s]."""
        t = self.timing
        return (
            t.initial_double_support
            + len(self.steps) * (t.single_support + t.double_support)
            + t.final_double_support
        )

    def phases(self) -> list[Phase]:
        """The contact phases in time order (see the module docstring)."""
        t = self.timing
        feet = {"left": self.initial[0], "right": self.initial[1]}
        middle = 0.5 * (feet["left"].position + feet["right"].position)
        phases: list[Phase] = []
        time = 0.0
        if not self.steps:
            end = time + t.initial_double_support + t.final_double_support
            return [
                Phase(
                    PhaseKind.DOUBLE_SUPPORT, 0.0, end, tuple(feet.values()), None, middle, middle
                )
            ]
        first_stance = feet[other_side(self.steps[0].side)]
        both = (feet["left"], feet["right"])
        rest = t.initial_double_support - t.weight_shift
        if rest > 0:
            phases.append(Phase(PhaseKind.DOUBLE_SUPPORT, 0.0, rest, both, None, middle, middle))
        phases.append(
            Phase(
                PhaseKind.DOUBLE_SUPPORT,
                rest,
                t.initial_double_support,
                both,
                None,
                middle,
                first_stance.position,
            )
        )
        time += t.initial_double_support
        for step in self.steps:
            stance = feet[other_side(step.side)]
            lift = feet[step.side]
            phases.append(
                Phase(
                    PhaseKind.SINGLE_SUPPORT,
                    time,
                    time + t.single_support,
                    (stance,),
                    (lift, step),
                    stance.position,
                    stance.position,
                )
            )
            time += t.single_support
            feet[step.side] = step
            if t.double_support > 0:
                phases.append(
                    Phase(
                        PhaseKind.DOUBLE_SUPPORT,
                        time,
                        time + t.double_support,
                        (feet["left"], feet["right"]),
                        None,
                        stance.position,
                        step.position,
                    )
                )
                time += t.double_support
        last = self.steps[-1].position
        middle = 0.5 * (feet["left"].position + feet["right"].position)
        both = (feet["left"], feet["right"])
        shift_end = time + t.weight_shift
        phases.append(Phase(PhaseKind.DOUBLE_SUPPORT, time, shift_end, both, None, last, middle))
        end = time + t.final_double_support
        if end > shift_end:
            phases.append(
                Phase(PhaseKind.DOUBLE_SUPPORT, shift_end, end, both, None, middle, middle)
            )
        return phases

    def final_feet(self) -> tuple[Footstep, Footstep]:
        """``(left, right)`` at the end of the walk."""
        feet = {"left": self.initial[0], "right": self.initial[1]}
        for step in self.steps:
            feet[step.side] = step
        return feet["left"], feet["right"]


def _foot_at(pose: FloatArray, side: str, step_width: float) -> Footstep:
    sign = 1.0 if side == "left" else -1.0
    c, s = math.cos(pose[2]), math.sin(pose[2])
    off = 0.5 * step_width * sign
    return Footstep(side, pose[0] - s * off, pose[1] + c * off, pose[2])


MAX_YAW_STEP = math.pi / 4
"""Default largest turn of the body per step [rad] of :func:`turn_in_place` and
:func:`arc_walk`. Turning in place by ``d`` in one step puts the swing foot's centre
``step_width cos(d / 2)`` from the stance foot's, its sole turned by ``d`` against it: 0.92
``step_width`` at 45 degrees, 0.71 at 90 degrees (0.14 m for a 0.2 m stance, less than a
humanoid's foot length: the soles overlap)."""


def _check_turn(angle: float, n_steps: int, max_yaw_step: Any, what: str) -> None:
    """Refuse a turn of more than ``max_yaw_step`` per step, naming the steps needed."""
    limit = check_positive(max_yaw_step, "max_yaw_step")
    if n_steps < 2:
        return  # check_steps / footsteps_along_poses name it
    per_step = abs(angle) / (n_steps - 1)
    if per_step > limit:
        needed = math.ceil(abs(angle) / limit - 1e-12) + 1
        raise InvalidInputError(
            f"{what} turns {angle:.4g} rad in {n_steps} steps: {per_step:.4g} rad per step, "
            f"more than max_yaw_step = {limit:.4g} rad (a foot would swing across the stance "
            f"foot); use n_steps >= {needed} or raise max_yaw_step"
        )


def footsteps_along_poses(
    poses: Any,
    *,
    step_width: float = 0.2,
    first_swing: str = "right",
    timing: StepTiming | None = None,
) -> FootstepPlan:
    """A plan that walks the body through ``poses`` (see the module docstring).

    Args:
        poses: (n + 1, 3) body poses ``(x, y, yaw)`` [m, m, rad]; the feet start at pose 0.
        step_width: lateral distance between the feet [m].
        first_swing: the side that steps first.
        timing: phase durations (default :class:`StepTiming`).
    """
    p = as_float_array(poses, "poses")
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
        raise InvalidInputError(f"poses must be (n + 1, 3) with n >= 1, got shape {p.shape}")
    if not np.isfinite(p).all():
        raise InvalidInputError("poses must be finite")
    width = check_positive(step_width, "step_width")
    side = _side(first_swing)
    initial = (_foot_at(p[0], "left", width), _foot_at(p[0], "right", width))
    steps = []
    for pose in p[1:]:
        steps.append(_foot_at(pose, side, width))
        side = other_side(side)
    steps.append(_foot_at(p[-1], side, width))
    return FootstepPlan(initial, tuple(steps), timing or StepTiming())


def straight_walk(
    n_steps: int,
    *,
    step_length: float = 0.2,
    step_width: float = 0.2,
    first_swing: str = "right",
    timing: StepTiming | None = None,
) -> FootstepPlan:
    """``n_steps`` steps forward along x (the last one brings the feet together)."""
    n_steps = check_steps(n_steps)
    xs = as_scalar(step_length, "step_length") * np.arange(n_steps)
    poses = np.column_stack([xs, np.zeros(n_steps), np.zeros(n_steps)])
    return footsteps_along_poses(
        poses, step_width=step_width, first_swing=first_swing, timing=timing
    )


def arc_walk(
    n_steps: int,
    *,
    radius: float,
    angle: float,
    step_width: float = 0.2,
    timing: StepTiming | None = None,
    max_yaw_step: float = MAX_YAW_STEP,
) -> FootstepPlan:
    """``n_steps`` steps along a circular arc of ``radius`` [m] turning by ``angle`` [rad].

    The arc starts at the origin heading along x; ``angle > 0`` turns left (center at
    ``(0, radius)``). The foot on the outside of the turn steps first. The body turns
    ``angle / (n_steps - 1)`` per step, at most ``max_yaw_step`` [rad] (an
    :class:`~taskspace.errors.InvalidInputError` names the ``n_steps`` needed).
    """
    n_steps = check_steps(n_steps)
    r = check_positive(radius, "radius")
    angle = as_scalar(angle, "angle")
    _check_turn(angle, n_steps, max_yaw_step, "arc_walk")
    phi = np.linspace(0.0, angle, n_steps)
    sign = 1.0 if angle >= 0 else -1.0
    poses = np.column_stack([r * np.sin(np.abs(phi)), sign * r * (1 - np.cos(phi)), phi])
    return footsteps_along_poses(
        poses,
        step_width=step_width,
        first_swing="right" if angle >= 0 else "left",
        timing=timing,
    )


def turn_in_place(
    angle: float,
    n_steps: int,
    *,
    step_width: float = 0.2,
    timing: StepTiming | None = None,
    max_yaw_step: float = MAX_YAW_STEP,
) -> FootstepPlan:
    """Turn on the spot by ``angle`` [rad] in ``n_steps`` steps (left turn: left foot first).

    The body turns ``angle / (n_steps - 1)`` per step, at most ``max_yaw_step`` [rad]: a
    larger turn swings a foot across the stance foot (an
    :class:`~taskspace.errors.InvalidInputError` names the ``n_steps`` needed).
    """
    n_steps = check_steps(n_steps, "turn")
    angle = as_scalar(angle, "angle")
    _check_turn(angle, n_steps, max_yaw_step, "turn_in_place")
    yaw = np.linspace(0.0, angle, n_steps)
    poses = np.column_stack([np.zeros(n_steps), np.zeros(n_steps), yaw])
    return footsteps_along_poses(
        poses,
        step_width=step_width,
        first_swing="left" if angle >= 0 else "right",
        timing=timing,
    )


def check_plan(plan: Any) -> FootstepPlan:
    """``plan`` if it is a :class:`FootstepPlan`, else a named :class:`InvalidInputError`."""
    if not isinstance(plan, FootstepPlan):
        raise InvalidInputError(
            f"plan must be a FootstepPlan (straight_walk, arc_walk, turn_in_place, "
            f"footsteps_along_poses...), got {type(plan).__name__}"
        )
    return plan


def plan_from_footsteps(
    initial: tuple[Footstep, Footstep], steps: Sequence[Footstep], timing: StepTiming | None = None
) -> FootstepPlan:
    """A plan from explicit footsteps (validated)."""
    return FootstepPlan(initial, tuple(steps), timing or StepTiming())
