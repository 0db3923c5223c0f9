"""Swing-foot trajectories: from lift-off to touchdown with a ground clearance.

The horizontal position and the yaw follow a minimum-jerk point-to-point motion
(:class:`~taskspace.trajopt.MinimumJerkProfile`, zero velocity and acceleration at lift-off
and touchdown); the height is a quintic spline (:func:`~taskspace.trajopt.quintic_spline`,
continuous up to the snap) through the lift-off height, an apex ``clearance`` above the
higher of the two ends at mid-swing, and the touchdown height, with zero vertical velocity and
acceleration at both ends. With equal end heights the apex is the highest point; between
different heights the spline rises above it before (step down) or after (step up) mid-swing,
by about a tenth of the height difference (0.2 m: 1.8 cm, 0.5 m: 5.5 cm), and never dips
below the lower end.

Thread safety: a :class:`SwingTrajectory` is not changed by sampling it and may be sampled from
several threads; :class:`SwingSample` is immutable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar, check_positive
from taskspace.errors import InvalidInputError
from taskspace.locomotion.footsteps import Footstep
from taskspace.trajopt import MinimumJerkProfile, PointToPointMotion, quintic_spline


@dataclass(frozen=True)
class SwingSample:
    """A swing trajectory sampled at given times.

    Attributes:
        time: (m,) times from lift-off [s].
        position: (m, 3) foot position [m].
        velocity: (m, 3) [m/s].
        acceleration: (m, 3) [m/s^2].
        yaw: (m,) foot heading [rad].
        yaw_rate: (m,) [rad/s].
    """

    time: FloatArray
    position: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    yaw: FloatArray
    yaw_rate: FloatArray


class SwingTrajectory:
    """Swing of one foot from ``lift`` to ``land`` (see the module docstring).

    Args:
        lift: footstep the foot leaves.
        land: footstep it lands on (same side).
        duration: swing time [s].
        clearance: apex height above the higher end [m].
        lift_height, land_height: ground heights at lift-off and touchdown [m].
    """

    def __init__(
        self,
        lift: Footstep,
        land: Footstep,
        duration: float,
        *,
        clearance: float = 0.05,
        lift_height: float = 0.0,
        land_height: float = 0.0,
    ) -> None:
        if lift.side != land.side:
            raise InvalidInputError(
                f"a swing moves one foot: lift is {lift.side}, land is {land.side}"
            )
        self.lift, self.land = lift, land
        self.duration = check_positive(duration, "duration")
        self.clearance = check_positive(clearance, "clearance", strict=False)
        z0, z1 = as_scalar(lift_height, "lift_height"), as_scalar(land_height, "land_height")
        profile = MinimumJerkProfile()
        # the shortest yaw change
        dyaw = math.remainder(land.yaw - lift.yaw, 2 * math.pi)
        self._xy_yaw = [
            PointToPointMotion(lift.x, land.x, self.duration, profile),
            PointToPointMotion(lift.y, land.y, self.duration, profile),
            PointToPointMotion(lift.yaw, lift.yaw + dyaw, self.duration, profile),
        ]
        apex = max(z0, z1) + self.clearance
        T = self.duration
        self._z = quintic_spline(
            np.array([z0, apex, z1]),
            np.array([0.0, 0.5 * T, T]),
            start_velocity=0.0,
            end_velocity=0.0,
            start_acceleration=0.0,
            end_acceleration=0.0,
        )

    def sample(self, t: Any) -> SwingSample:
        """Sample at times ``t`` [s] from lift-off (clipped to ``[0, duration]``)."""
        tt = np.clip(np.atleast_1d(as_float_array(t, "t")).ravel(), 0.0, self.duration)
        if not np.isfinite(tt).all():
            raise InvalidInputError("t must be finite")
        x, y, yaw = (m.evaluate(tt) for m in self._xy_yaw)
        z = self._z.evaluate_derivatives(tt, 2)
        pos = np.column_stack([x.position, y.position, z[0].ravel()])
        vel = np.column_stack([x.velocity, y.velocity, z[1].ravel()])
        acc = np.column_stack([x.acceleration, y.acceleration, z[2].ravel()])
        return SwingSample(tt, pos, vel, acc, yaw.position, yaw.velocity)
