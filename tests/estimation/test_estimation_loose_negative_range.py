"""A measured range is a distance (>= 0): every estimator taking range-bearing measurements
refuses a negative one with an InvalidInputError naming the row and the value (audit4 found
RangeBearingModel and EKF-SLAM placing the landmark behind the robot instead).

Reference for the valid side: ``RangeBearingModel.inverse`` of a zero range is the robot's
position, by hand; simulated ranges of a landmark on the robot's path are never negative.
"""

from __future__ import annotations

import numpy as np
import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation.ekf_slam import EKFSLAM
from taskspace.estimation.fastslam import FastSLAM
from taskspace.estimation.motion_models import VelocityMotionModel
from taskspace.estimation.observation_models import LandmarkObservation, RangeBearingModel
from taskspace.estimation.simulation import loop_controls, simulate_landmark_world

SENSOR = RangeBearingModel()
MOTION = VelocityMotionModel(dt=0.1)


def obs(z: list[list[float]]) -> LandmarkObservation:
    return LandmarkObservation(ids=np.arange(len(z)), z=np.array(z))


BAD = obs([[2.0, 0.1], [-0.3, 0.5]])


def test_ekf_slam_refuses_negative_range() -> None:
    slam = EKFSLAM(MOTION, SENSOR, np.zeros(3), 1e-6 * np.eye(3))
    with pytest.raises(InvalidInputError, match=r"obs\.z\[1, 0\].*>= 0.*-0\.3"):
        slam.update(BAD)
    assert slam.num_landmarks == 0  # nothing half-applied


def test_fastslam_refuses_negative_range() -> None:
    fs = FastSLAM(MOTION, SENSOR, np.zeros(3), 2, np.random.default_rng(0))
    with pytest.raises(InvalidInputError, match=r"obs\.z\[1, 0\].*>= 0.*-0\.3"):
        fs.update(BAD)
    assert not fs.seen.any()


def test_particle_log_likelihood_refuses_negative_range() -> None:
    particles = np.zeros((4, 3))
    landmarks = np.array([[2.0, 0.0], [0.0, 1.0]])
    with pytest.raises(InvalidInputError, match=r"\[1, 0\].*>= 0.*-0\.3"):
        SENSOR.log_likelihood(particles, BAD, landmarks)
    # a valid observation still gives the Gaussian log-likelihood, by hand
    z = obs([[2.0, 0.0], [1.0, np.pi / 2]])
    np.testing.assert_allclose(SENSOR.log_likelihood(particles, z, landmarks), 0.0, atol=1e-12)


def test_inverse_refuses_negative_range() -> None:
    with pytest.raises(InvalidInputError, match=r"z \(range, bearing\)\[1, 0\].*>= 0.*-1"):
        RangeBearingModel.inverse([1.0, 2.0, 0.0], [[1.0, 0.0], [-1.0, 0.0]])
    with pytest.raises(InvalidInputError, match=r">= 0.*-1"):
        RangeBearingModel.inverse([1.0, 2.0, 0.0], [-1.0, 0.0])
    # zero range: the landmark is at the robot
    np.testing.assert_allclose(RangeBearingModel.inverse([1.0, 2.0, 0.3], [0.0, 1.0]), [1.0, 2.0])


def test_simulated_ranges_are_not_negative() -> None:
    # a landmark the robot drives over: noise of sigma 0.1 m on ranges below 0.3 m made
    # negative ranges, which the estimators now refuse
    sensor = RangeBearingModel(sigma_range=0.1)
    landmarks = np.array([[0.0, 0.0], [0.5, 0.0]])
    sim = simulate_landmark_world(
        MOTION,
        sensor,
        [0.0, 0.0, 0.0],
        loop_controls(20, 0.05, 0.0),
        landmarks,
        np.random.default_rng(1),
    )
    ranges = np.concatenate([o.z[:, 0] for o in sim.observations])
    assert ranges.size == 40 and ranges.min() >= 0.0
    slam = EKFSLAM(MOTION, sensor, np.zeros(3), 1e-6 * np.eye(3))
    for u, o in zip(sim.controls, sim.observations):
        slam.predict(u)
        slam.update(o)
    assert slam.num_landmarks == 2


def test_particle_log_likelihood_refuses_unknown_ids() -> None:
    # id -1 ("unknown" in LandmarkObservation) read the last landmark silently; 2 was a bare
    # IndexError
    particles = np.zeros((4, 3))
    landmarks = np.array([[2.0, 0.0], [0.0, 1.0]])
    for bad in (-1, 2):
        o = LandmarkObservation(ids=np.array([0, bad]), z=np.array([[2.0, 0.0], [1.0, 1.5]]))
        with pytest.raises(InvalidInputError, match=rf"landmark id {bad} is outside \[0, 2\)"):
            SENSOR.log_likelihood(particles, o, landmarks)
