"""MeshcatRender (taskspace.viz.env_viewer): the meshcat scene follows the environment."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("meshcat")

from taskspace.errors import InvalidInputError
from taskspace.learning.envs import CartPoleEnv, PandaReachEnv, PendulumEnv
from taskspace.model.robot import Robot
from taskspace.viz import Viewer
from taskspace.viz.env_viewer import MeshcatRender


@pytest.mark.parametrize("make", [PendulumEnv, CartPoleEnv])
def test_viewer_follows_the_configuration(make) -> None:  # type: ignore[no-untyped-def]
    env = make()
    viewer = Viewer(env.robot)
    wrapped = MeshcatRender(env, "human", viewer=viewer)
    wrapped.reset(seed=0)
    for _ in range(5):
        wrapped.step(wrapped.action_space.sample())
        assert viewer.q == pytest.approx(np.asarray(env.q))
    # The robot's geometry nodes sit where Pinocchio puts them for that configuration.
    model, data = env.robot.model, env.robot.model.createData()
    gmodel = env.robot.visual_model
    gdata = gmodel.createData()
    pin.forwardKinematics(model, data, np.asarray(env.q))
    pin.updateGeometryPlacements(model, data, gmodel, gdata)
    tree = viewer.recorder
    for k, node in enumerate(viewer._geom_paths):
        shown = _recorded_transform(tree, node)
        assert shown == pytest.approx(gdata.oMg[k].homogeneous, abs=1e-9)
    assert wrapped.render() is None


def _recorded_transform(recorder, node: str) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The last set_transform recorded for ``/meshcat/<node>`` (meshcat: column-major)."""
    import umsgpack

    packed = recorder._root.find(["meshcat", *node.split("/")]).transform
    return np.asarray(umsgpack.unpackb(packed)["matrix"], dtype=float).reshape(4, 4).T


def test_errors() -> None:
    env = PendulumEnv()
    viewer = Viewer(env.robot)
    with pytest.raises(InvalidInputError, match="render_mode 'ansi'"):
        MeshcatRender(env, "ansi", viewer=viewer)
    with pytest.raises(InvalidInputError, match="no 'robot' and 'q'"):
        MeshcatRender(gym.make("CartPole-v1"), "human", viewer=viewer)


@pytest.mark.slow
def test_panda_target_marker() -> None:
    panda = Robot.load("panda")
    env = PandaReachEnv(robot=panda)
    viewer = Viewer(panda)
    wrapped = MeshcatRender(env, "human", viewer=viewer)
    wrapped.reset(seed=0)
    target = _recorded_transform(viewer.recorder, viewer._marker("target"))
    assert target[:3, 3] == pytest.approx(env.target, abs=1e-6)
    wrapped.step(np.zeros(7, dtype=np.float32))
    assert viewer.q == pytest.approx(env.q)


@pytest.mark.slow
@pytest.mark.snapshot
@pytest.mark.xdist_group("browser")
def test_rgb_array_is_a_snapshot_of_the_robot() -> None:
    env = MeshcatRender(PendulumEnv(), "rgb_array", size=(160, 120))
    env.reset(seed=0)
    base = env.unwrapped
    images = []
    for angle in (0.0, np.pi / 2):
        base.state = np.array([angle, 0.0])
        env.step(np.zeros(1, dtype=np.float32))  # shows the state after the step
        image = env.render()
        assert isinstance(image, np.ndarray)
        assert image.shape == (120, 160, 3) and image.dtype == np.uint8
        images.append(image.astype(int))
    # The pendulum moved: the pictures differ, and each shows more than a blank background.
    assert np.abs(images[0] - images[1]).sum(axis=2).astype(bool).mean() > 0.005
    for image in images:
        assert image.std() > 5
    env.close()
