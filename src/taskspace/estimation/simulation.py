"""Ground-truth simulation of a robot with noisy controls and measurements (slide 7:14).

The true pose follows ``x_{t+1} ~ P(x_{t+1} | u_t, x_t)`` (a motion model's ``sample``); the
robot reports the commanded controls ``u_t`` (the filter's input) and measures
``y_{t+1} ~ P(y | x_{t+1})``. All randomness comes from the given ``np.random.Generator``.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from taskspace._validation import FloatArray, as_matrix, as_scalar, as_vector, check_count
from taskspace.errors import InvalidInputError
from taskspace.estimation.observation_models import LandmarkObservation, RangeBearingModel


class MotionModel(Protocol):
    """What the simulator and filters need from a motion model."""

    def mean(self, x: Any, u: Any) -> FloatArray: ...  # noqa: D102

    def sample(self, x: Any, u: Any, rng: np.random.Generator) -> FloatArray: ...  # noqa: D102


class SimulationStatus(enum.Enum):
    """Outcome of a simulation."""

    SUCCESS = "success"


@dataclass(frozen=True)
class Simulation:
    """A simulated run.

    Attributes:
        success: always ``True`` when returned.
        status: outcome.
        states: ``(T + 1, 3)`` true poses (``states[0]`` is the start).
        controls: ``(T, p)`` commanded controls.
        observations: ``T`` landmark observations taken at ``states[1:]``.
        dead_reckoning: ``(T + 1, 3)`` poses integrated from the commanded controls.
        landmarks: ``(L, 2)`` true landmark positions [m].
        time_s: wall time [s].
    """

    success: bool
    status: SimulationStatus
    states: FloatArray
    controls: FloatArray
    observations: list[LandmarkObservation]
    dead_reckoning: FloatArray
    landmarks: FloatArray
    time_s: float


def simulate_landmark_world(
    motion: MotionModel,
    sensor: RangeBearingModel,
    x0: Any,
    controls: Any,
    landmarks: Any,
    rng: np.random.Generator,
) -> Simulation:
    """Simulate true poses, dead reckoning and range-bearing observations.

    Args:
        motion: motion model (sampled for the truth, mean for dead reckoning).
        sensor: range-bearing sensor.
        x0: ``(3,)`` start pose.
        controls: ``(T, p)`` commanded controls.
        landmarks: ``(L, 2)`` landmark positions [m].
        rng: random generator.

    Returns:
        The :class:`Simulation`.
    """
    if not isinstance(rng, np.random.Generator):
        raise InvalidInputError(
            f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {rng!r}"
        )
    if not isinstance(sensor, RangeBearingModel):
        raise InvalidInputError(f"sensor must be a RangeBearingModel, got {type(sensor).__name__}")
    t0 = time.perf_counter()
    x = as_vector(x0, 3, "x0")
    U = as_matrix(controls, (None, None), "controls")
    L = as_matrix(landmarks, (None, 2), "landmarks")
    T = U.shape[0]
    states = np.empty((T + 1, 3))
    dr = np.empty((T + 1, 3))
    states[0] = dr[0] = x
    obs = []
    for t in range(T):
        states[t + 1] = motion.sample(states[t], U[t], rng)
        dr[t + 1] = motion.mean(dr[t], U[t])
        obs.append(sensor.sample(states[t + 1], L, rng))
    return Simulation(
        success=True,
        status=SimulationStatus.SUCCESS,
        states=states,
        controls=U,
        observations=obs,
        dead_reckoning=dr,
        landmarks=L,
        time_s=time.perf_counter() - t0,
    )


def loop_controls(num_steps: int, speed: float = 1.0, turn_rate: float = 0.2) -> FloatArray:
    """Velocity controls ``(v, w)`` driving a closed loop: constant speed and turn rate.

    Raises:
        InvalidInputError: ``num_steps`` not an integer in ``[0, 10**8]`` (2.5 was truncated,
            NaN and negative values were bare errors), speed or turn rate not finite.
    """
    n = check_count(num_steps, "num_steps")
    if n > 100_000_000:
        raise InvalidInputError(f"num_steps must be at most 100,000,000, got {n:,}")
    v, w = as_scalar(speed, "speed"), as_scalar(turn_rate, "turn_rate")
    return np.tile([v, w], (n, 1)).astype(np.float64)
