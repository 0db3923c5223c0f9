"""A goal region for planners: a frame pose within tolerances, sampled by IK.

It satisfies the planners' ``GoalRegion`` protocol (``contains``, ``sample``;
:mod:`taskspace.planning.rrt_star`): a configuration is a goal when its frame lies within
``position_tolerance`` [m] and ``rotation_tolerance`` [rad] of the target pose, and goal
configurations are drawn by :func:`solve_ik` from random starts, with the target itself
perturbed uniformly inside the tolerances.

Thread safety: :meth:`PoseGoalRegion.sample` sets the target of the region's own IK task, so one
region must not be sampled from two threads at once (give each thread its own region);
:meth:`~PoseGoalRegion.contains` and :meth:`~PoseGoalRegion.errors` build their own state per call
and may run from several threads.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from taskspace import features as F
from taskspace._validation import check_count, check_positive
from taskspace.errors import InvalidInputError
from taskspace.ik.solve_ik import SolveIKOptions, solve_ik
from taskspace.model import Robot
from taskspace.model.world import as_se3
from taskspace.tasks import Task

FloatArray = npt.NDArray[np.float64]


class PoseGoalRegion:
    """The configurations that put ``frame`` within tolerances of ``pose``.

    Args:
        robot: the robot.
        frame: the frame (e.g. the tool frame).
        pose: the target pose in the world.
        position_tolerance: largest position error [m].
        rotation_tolerance: largest rotation error (angle of ``log3``) [rad].
        attempts: IK attempts per :meth:`sample` before it gives up (returns ``None``).
    """

    def __init__(
        self,
        robot: Robot,
        frame: str,
        pose: object,
        *,
        position_tolerance: float = 0.01,
        rotation_tolerance: float = 0.05,
        attempts: int = 5,
    ) -> None:
        self.robot = robot
        self.frame_id = robot.frame_id(frame)
        self.pose = as_se3(pose)
        self.position_tolerance = check_positive(position_tolerance, "position_tolerance")
        self.rotation_tolerance = check_positive(rotation_tolerance, "rotation_tolerance")
        self.attempts = check_count(attempts, "attempts", minimum=1)
        self._task = Task(F.FramePose(robot, frame))

    def errors(self, q: FloatArray) -> tuple[float, float]:
        """Position [m] and rotation [rad] errors of the frame at ``q``."""
        placement = self.robot.state(q).frame_placement(self.frame_id)
        position = float(np.linalg.norm(placement.translation - self.pose.translation))
        rotation = float(np.linalg.norm(pin.log3(self.pose.rotation.T @ placement.rotation)))
        return position, rotation

    def contains(self, q: FloatArray) -> bool:
        """Whether the frame is within both tolerances at ``q``."""
        position, rotation = self.errors(q)
        return position <= self.position_tolerance and rotation <= self.rotation_tolerance

    def sample(self, rng: np.random.Generator) -> FloatArray | None:
        """A goal configuration within the joint limits, or ``None`` after ``attempts``."""
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got "
                f"{type(rng).__name__}"
            )
        for _ in range(self.attempts):
            offset = rng.standard_normal(3)
            offset *= self.position_tolerance * rng.random() ** (1 / 3) / np.linalg.norm(offset)
            axis = rng.standard_normal(3)
            axis *= self.rotation_tolerance * rng.random() / np.linalg.norm(axis)
            target = pin.SE3(self.pose.rotation @ pin.exp3(axis), self.pose.translation + offset)
            self._task.set_target(target)
            result = solve_ik(
                self.robot,
                [self._task],
                q0=self.robot.random_configuration(rng),
                options=SolveIKOptions(restarts=0),
            )
            if result.success and self.contains(result.q):
                return np.asarray(result.q, dtype=np.float64)
        return None
