"""Issue #22 audit, item 5, on the MotionBenchMaker problems the issue measured.

The issue: paths of the compiled RRT-Connect checked at 0.01 rad touch obstacles between the
points the planner checked (up to 3.3 mm deep). On the problems below the default planner's
path entered an obstacle in the audit (table_pick 6: -3.4 mm, bookshelf_thin 3: -0.29 mm,
box 6: -0.02 mm, seed 0). With ``certify=True`` the returned path must be free everywhere:
here the reference is Pinocchio/coal's ``computeDistances`` on the robot's own models every
0.005 rad along each segment (independent of the certificate's advancement), and the least
distance must be positive. A default path that does enter an obstacle must not be
certified by ``certify_path``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest

from taskspace.planning.certify import certify_path
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from tests.planning._mbm import ROOT, SKIP_REASON

pytestmark = pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)


@pytest.fixture(scope="module")
def robot():  # type: ignore[no-untyped-def]
    return motionbenchmaker_panda()


def _least_distance(robot, path: np.ndarray, step: float = 0.005) -> float:  # type: ignore[no-untyped-def]
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    least = math.inf
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / step))
        for t in np.arange(n + 1) / n:
            pin.computeDistances(model, data, geom, gdata, a + t * (b - a))
            least = min(least, min(r.min_distance for r in gdata.distanceResults))
    return least


@pytest.mark.parametrize(("scenario", "index"), [("table_pick", 6), ("box", 6)])
def test_certified_paths_are_free_where_default_paths_touch(robot, scenario, index) -> None:  # type: ignore[no-untyped-def]
    problem = motionbenchmaker_problems(ROOT, scenario, [index])[0]
    req = problem.apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    default = rrt_connect(space, req.start, req.goal, RRTConnectOptions(time_limit_s=1.0, seed=0))
    assert default.success
    if _least_distance(robot, default.path) <= 0.0:  # as in the audit (kernels may change)
        assert not certify_path(robot, default.path).certified
    result = rrt_connect(
        space, req.start, req.goal, RRTConnectOptions(time_limit_s=10.0, seed=0, certify=True)
    )
    assert result.success and result.log["certified"] == 1.0
    np.testing.assert_allclose(result.path[[0, -1]], [req.start, req.goal])
    least = _least_distance(robot, result.path)
    assert least > 0.0
    # (the certificate's least distance is taken at its own query points, the dense one at
    # others: neither bounds the other; both are positive)
    assert result.log["min_distance"] > 0.0
