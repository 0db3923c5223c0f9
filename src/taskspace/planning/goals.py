"""Goals of the sampling-based planners: goal states, several of them, or a goal region.

Every planner with a goal takes one of (OMPL's ``GoalState``, ``GoalStates`` and
``GoalSampleableRegion``):

* one goal configuration (size d);
* several goal configurations, shape (k, d): the path ends at one of them (each planner says
  which: the first reached, or the cheapest);
* a :class:`GoalRegion`: any object with ``contains(q)`` and ``sample(rng)``, such as
  :class:`taskspace.ik.PoseGoalRegion` (a pose within tolerances, sampled by IK) or
  :class:`taskspace.ik.FeatureGoalRegion` (any feature within bounds). Its valid samples
  become goal states (:func:`region_samples`); a path ends inside the region.

:func:`goal_states` validates the goal once for every planner.

Thread safety: :class:`GoalRegion` is a protocol: implementations state their own (those of
:mod:`taskspace.ik` sample with their own IK task: one region per thread).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from taskspace._validation import as_float_array
from taskspace.errors import InvalidInputError

if TYPE_CHECKING:
    from taskspace.planning.configuration_space import ConfigurationSpace, FloatArray


@runtime_checkable
class GoalRegion(Protocol):
    """A set of goal configurations (OMPL's ``GoalSampleableRegion``).

    ``contains(q)`` says whether ``q`` reaches the goal; ``sample(rng)`` returns a goal
    configuration or ``None`` (a region that cannot be sampled is only recognised when the
    tree reaches it). A pose within tolerances sampled by IK
    (:class:`taskspace.ik.PoseGoalRegion`) or any feature within bounds fit this protocol.
    """

    def contains(self, q: FloatArray) -> bool:
        """Whether ``q`` is a goal configuration."""

    def sample(self, rng: np.random.Generator) -> FloatArray | None:
        """A goal configuration, or ``None`` when none was found."""


def is_goal_set(goal: Any) -> bool:
    """Whether ``goal`` is several goal configurations (k, d) or a goal region."""
    if type(goal) is np.ndarray:  # the common case, before the protocol check (about 10 us)
        return goal.ndim == 2
    if isinstance(goal, GoalRegion):
        return True
    try:
        return bool(np.ndim(goal) == 2)
    except (TypeError, ValueError):  # ragged: refused by the endpoint check
        return False


def goal_states(space: ConfigurationSpace, goal: Any) -> tuple[list[FloatArray], Any]:
    """Goal configurations (validated: inside the bounds, free) and the goal region (or None).

    Raises:
        PlanningError: a goal configuration outside the bounds or in collision (named
            ``goal[i]`` for several).
        InvalidInputError: an empty list of goals.
    """
    if isinstance(goal, GoalRegion):
        _check_region_robot(space, goal)
        return [], goal
    arr = np.asarray(goal, dtype=np.float64) if not isinstance(goal, np.ndarray) else goal
    if arr.ndim == 2:
        if arr.shape[0] == 0:
            raise InvalidInputError("goal: an empty list of goal configurations")
        return [space.check_endpoint(g, f"goal[{i}]") for i, g in enumerate(arr)], None
    return [space.check_endpoint(goal, "goal")], None


def locked_joints_hint(space: ConfigurationSpace) -> str:
    """What a goal region of a space with locked joints must be ("" without locked joints)."""
    locked = getattr(space, "locked", None)
    if locked is None:
        return ""
    return (
        f"this space has locked joints ({', '.join(locked.names)}, held at their values): its "
        f"points are the {space.dim} coordinates of the free joints, not the robot's "
        f"{locked.nq}, so the region must sample and test configurations of size {space.dim}: "
        "build it on the reduced robot, e.g. PoseGoalRegion(taskspace.model.Robot("
        "space.planning_model, pinocchio.GeometryModel(), pinocchio.GeometryModel(), "
        "name='reduced'), frame, pose) (space.planning_model is the robot's model with the "
        "locked joints welded; space.full_configurations lifts its points to the robot's)"
    )


def _check_region_robot(space: ConfigurationSpace, region: Any) -> None:
    """Refuse a region built on a robot whose ``nq`` is not the space's size, before sampling.

    E.g. a :class:`taskspace.ik.PoseGoalRegion` of the full robot for a space with locked
    joints (its samples were refused only after an IK solve, without naming the joints).

    Raises:
        InvalidInputError: the sizes, the locked joints and how to build the region.
    """
    nq = getattr(getattr(region, "robot", None), "nq", None)
    if not isinstance(nq, int) or nq == space.dim:
        return
    hint = locked_joints_hint(space)
    raise InvalidInputError(
        f"the goal region ({type(region).__name__}) is built on a robot with nq = {nq}, but "
        f"the configurations of this space have size {space.dim}" + (f"; {hint}" if hint else "")
    )


def region_samples(
    space: ConfigurationSpace,
    region: Any,
    rng: np.random.Generator,
    attempts: int,
    deadline: float = float("inf"),
) -> list[FloatArray]:
    """Valid configurations (inside the bounds, free, in the region) among ``attempts`` samples.

    Sampling stops at ``deadline`` (a ``time.perf_counter()`` value [s]).
    """
    out = []
    for _ in range(attempts):
        if time.perf_counter() > deadline:
            break
        q = region_sample(space, region, rng)
        if q is None:
            continue
        if space.within_bounds(q) and space.is_valid(q):
            if region.contains(q):
                out.append(q)
    return out


def region_sample(space: ConfigurationSpace, region: Any, rng: np.random.Generator) -> Any:
    """``region.sample(rng)`` as a float vector of the space's size, or ``None``.

    Raises:
        InvalidInputError: a sample that is not ``None`` nor a finite vector of size
            ``space.dim`` (such samples were skipped: the planner then ran to its limits
            without a goal state and without a word of why).
    """
    q = region.sample(rng)
    if q is None:
        return None
    who = f"the goal region's sample ({type(region).__name__}.sample)"
    arr = as_float_array(q, who)
    if arr.shape != (space.dim,) or not np.all(np.isfinite(arr)):
        hint = locked_joints_hint(space)
        raise InvalidInputError(
            f"{who} must be None or a finite configuration of the space, shape "
            f"({space.dim},); got "
            + (f"shape {arr.shape}" if arr.shape != (space.dim,) else f"{arr.tolist()}")
            + (f" ({hint})" if hint else "")
        )
    return arr


REGION_FIRST_ATTEMPTS = 20
"""Samples of a goal region drawn before planning (the valid ones become goal states)."""
