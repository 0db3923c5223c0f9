"""Batched Panda reach env against gymnasium's SyncVectorEnv of the single env, and the
batched forward kinematics against Pinocchio."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pinocchio as pin
import pytest

from taskspace.errors import InvalidInputError, StaleModelError
from taskspace.learning.envs import PandaReachEnv, PandaReachVectorEnv
from taskspace.learning.envs.batched_kinematics import BatchedFramePosition
from taskspace.model.robot import Robot


@pytest.fixture(scope="module")
def panda() -> Robot:
    return Robot.load("panda")


def _pin_positions(model: pin.Model, frame: str, Q: np.ndarray) -> np.ndarray:
    data = model.createData()
    fid = model.getFrameId(frame)
    out = []
    for q in Q:
        pin.framesForwardKinematics(model, data, q)
        out.append(data.oMf[fid].translation.copy())
    return np.array(out)


@pytest.mark.parametrize(("name", "frame"), [("panda", "panda_hand_tcp"), ("cartpole", "tip")])
def test_batched_positions_are_pinocchio_fk(name: str, frame: str, panda: Robot) -> None:
    model = (panda if name == "panda" else Robot.load(name)).model
    Q = np.random.default_rng(0).uniform(-3, 3, (40, model.nq))
    ours = BatchedFramePosition(model, frame)(Q)
    assert ours == pytest.approx(_pin_positions(model, frame, Q), abs=1e-12)


def test_batched_positions_unaligned_joints() -> None:
    # A hand-built chain: unaligned revolute, unaligned prismatic, RX, with random placements.
    model = pin.Model()
    rng = np.random.default_rng(1)
    parent = 0
    for k, joint in enumerate(
        [
            pin.JointModelRevoluteUnaligned(*(rng.normal(size=3) / np.sqrt(3))),
            pin.JointModelPrismaticUnaligned(*(rng.normal(size=3) / np.sqrt(3))),
            pin.JointModelRX(),
        ]
    ):
        parent = model.addJoint(parent, joint, pin.SE3.Random(), f"j{k}")
    model.addFrame(pin.Frame("tip", parent, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    Q = rng.uniform(-3, 3, (30, model.nq))
    ours = BatchedFramePosition(model, "tip")(Q)
    assert ours == pytest.approx(_pin_positions(model, "tip", Q), abs=1e-12)
    with pytest.raises(InvalidInputError, match="unknown frame 'nope'"):
        BatchedFramePosition(model, "nope")


def _sync_state(vec: PandaReachVectorEnv, sync: gym.vector.SyncVectorEnv, k: int) -> None:
    env = sync.envs[k].unwrapped
    vec.q[k], vec.target[k] = env.q, env.target
    vec._tcp[k] = vec.tcp_position(env.q[None])[0]


def test_vector_env_matches_sync_vector_env_of_the_single_env(panda: Robot) -> None:
    n = 6
    vec = PandaReachVectorEnv(n, robot=panda, max_episode_steps=10_000)
    sync = gym.vector.SyncVectorEnv([lambda: PandaReachEnv(robot=panda)] * n)
    vec.reset(seed=0)
    sync.reset(seed=0)
    for k in range(n):
        _sync_state(vec, sync, k)
    rng = np.random.default_rng(2)
    # Copies 0-1 head for their targets (success), 2-3 for collisions, 4-5 move randomly.
    model, data = panda.model, panda.model.createData()
    fid = model.getFrameId("panda_hand_tcp")
    bad = panda.q_default.copy()
    bad[3] = panda.lower_limits[3] + 0.01
    bad[1] = 1.7  # elbow folded into the base
    events = {"success": 0, "collision": 0}
    prev_end = np.zeros(n, dtype=bool)
    for _ in range(60):
        act = rng.uniform(-1, 1, (n, 7))
        for k in range(n):
            q = sync.envs[k].unwrapped.q
            if k < 2:
                J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
                err = sync.envs[k].unwrapped.target - sync.envs[k].unwrapped.tcp()
                v = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(3), 2.0 * err)
                act[k] = np.clip(v / panda.velocity_limits, -1, 1)
            elif k < 4:
                act[k] = np.clip((bad - q) / (0.1 * panda.velocity_limits), -1, 1)
        act = act.astype(np.float32)
        o1, r1, te1, tr1, i1 = vec.step(act)
        o2, r2, te2, tr2, i2 = sync.step(act)
        assert not np.any(tr1) and not np.any(tr2)
        live = ~prev_end
        assert o1[live] == pytest.approx(o2[live], abs=1e-5)
        assert r1 == pytest.approx(r2, abs=1e-9)  # reset steps: 0 in both
        assert np.array_equal(te1, te2)
        for key in ("distance", "collision", "success"):
            assert np.allclose(i1[key][live], i2[key][live])
        events["success"] += int(np.sum(i1["success"][live]))
        events["collision"] += int(np.sum(i1["collision"][live]))
        # Reset copies (different random draws): a valid initial state; then take the
        # reference's state to keep comparing.
        for k in np.flatnonzero(prev_end):
            assert np.all(np.abs(vec.q[k] - panda.q_default) <= 0.1 + 1e-12)
            assert vec.checker.is_valid(vec.q[k])
            assert vec.observation_space.contains(o1)
            _sync_state(vec, sync, k)
        prev_end = te1 | tr1
    assert events["success"] >= 2 and events["collision"] >= 2


def test_make_vec_seeding_and_truncation(panda: Robot) -> None:
    def run(seed: int) -> np.ndarray:
        env = gym.make_vec(
            "taskspace/PandaReach-v0",
            num_envs=4,
            vectorization_mode="vector_entry_point",
            robot=panda,
            max_episode_steps=5,
        )
        assert isinstance(env.unwrapped, PandaReachVectorEnv)
        assert env.action_space.shape == (4, 7) and env.observation_space.shape == (4, 13)
        obs, info = env.reset(seed=seed)
        out = [obs]
        for step in range(6):
            obs, rew, _term, trunc, info = env.step(np.zeros((4, 7), dtype=np.float32))
            assert obs.dtype == np.float32 and env.observation_space.contains(obs)
            assert rew.shape == (4,) and info["distance"].shape == (4,)
            assert np.all(trunc) == (step == 4)
            out.append(obs)
        return np.array(out)

    a, b = run(3), run(3)
    assert np.array_equal(a, b) and not np.array_equal(a, run(4))
    # The step after truncation resets every copy: new targets.
    assert not np.array_equal(a[6][:, 10:], a[5][:, 10:])


def test_vector_env_follows_the_robot_version() -> None:
    robot = Robot.load("panda")
    vec = PandaReachVectorEnv(3, robot=robot)
    vec.reset(seed=0)
    upper = robot.upper_limits.copy()
    upper[0] = 0.05
    robot.set_limits(upper=upper)
    with pytest.raises(StaleModelError, match="call reset"):
        vec.step(np.zeros((3, 7), dtype=np.float32))
    vec.reset(seed=0)
    assert vec.single_observation_space.high[0] == pytest.approx(0.05)
    for _ in range(20):
        vec.step(np.tile(np.eye(7, dtype=np.float32)[0], (3, 1)))
    assert np.all(vec.q[:, 0] <= 0.05 + 1e-12)
