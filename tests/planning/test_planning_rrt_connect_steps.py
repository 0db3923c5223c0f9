"""The steps of rrt_connect around the compiled call: options, bounds, endpoints, kernels.

Each shortcut is compared with the full computation it stands for.
"""

from __future__ import annotations

import gc
import importlib
import itertools
import math
import weakref

import numpy as np
import pinocchio as pin
import pytest

from taskspace._native import planning_kernel, status
from taskspace.errors import TaskspaceError
from taskspace.planning.collision_checker import FunctionChecker
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.limits import limit_log
from taskspace.planning.rrt_connect import CHECKERS, RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from tests.planning._mbm import ROOT, SKIP_REASON

# the module (``taskspace.planning.rrt_connect`` is also the function's name in the package)
rrt_connect_module = importlib.import_module("taskspace.planning.rrt_connect")

# per field: valid and invalid values of the usual and of other types
VALUES = {
    "step_size": [0.5, 1e-3, 3, np.float64(0.2), 0.0, -0.0, -1.0, math.inf, math.nan, "a", None],
    "coarse_resolution": [None, 0.15, 2, 0.0, -0.1, math.inf, math.nan, np.float32(0.1)],
    "local_sampling": [0.0, 0.5, 1.0, 1, 0, True, -0.1, 1.5, math.nan, np.float64(0.3)],
    "local_sigma": [0.5, 1, 0.0, -1.0, math.inf, math.nan],
    "trapped_priority": [0.0, 0.75, 1.0, 1, -0.5, 2.0, math.nan],
    "max_iterations": [None, 0, 5, 1 << 70, -1, 5.0, True, np.int64(7), "5"],
    "time_limit_s": [None, 0.0, -0.0, 1.0, 2, math.inf, -1.0, math.nan, True, np.float64(0.5)],
    "seed": [0, 3, 1 << 70, -1, True, 2.0, np.int64(4), None],
    "checker": ["mesh", "spheres", "spheres_only", "clearance", "sphere", 1, None],
    "validator": ["mesh", "spheres", "exact", 0],
    "fallback_iterations": [None, 0, 200, 1 << 70, -1, True, 5.0, np.int32(3)],
}


class _Str(str):
    """A str subclass (not the usual type)."""


def _outcome(function, opts):  # type: ignore[no-untyped-def]
    try:
        settings = function(opts)
    except (TaskspaceError, TypeError) as exc:
        return ("error", type(exc), str(exc))
    # the values, their types and the signs of the zeros
    return ("ok", tuple(settings), tuple(map(type, settings)), tuple(map(_sign, settings)))


def _sign(x: object) -> float:
    return math.copysign(1.0, x) if type(x) is float else 0.0


def _options_cases():  # type: ignore[no-untyped-def]
    yield RRTConnectOptions()
    for name, values in VALUES.items():  # each field alone
        for value in values:
            yield RRTConnectOptions(**{name: value})
    rng = np.random.default_rng(0)
    names = list(VALUES)
    for _ in range(400):  # several fields at once
        fields = {}
        for name in rng.choice(names, size=3, replace=False):
            values = VALUES[str(name)]
            fields[str(name)] = values[int(rng.integers(len(values)))]
        yield RRTConnectOptions(**fields)
    yield RRTConnectOptions(checker=_Str("spheres"))
    yield RRTConnectOptions(max_iterations=None, time_limit_s=None)
    yield RRTConnectOptions(max_iterations=None, time_limit_s=math.inf)


def test_usual_settings_are_the_checked_settings() -> None:
    """The shortcut for usual options gives what the checks one by one give (values, types,
    errors and their messages), for valid and invalid values of many types."""
    shortcut = 0
    for opts in _options_cases():
        expected = _outcome(rrt_connect_module._checked_settings, opts)
        assert _outcome(rrt_connect_module._validate, opts) == expected, opts
        usual = rrt_connect_module._usual_settings(opts)
        if usual is not None:
            shortcut += 1
            assert expected[0] == "ok", opts  # never valid where the checks refuse
            assert _outcome(lambda _, u=usual: u, opts) == expected, opts
    assert shortcut > 50  # the usual options take the shortcut
    assert rrt_connect_module._usual_settings(RRTConnectOptions()) is not None
    assert rrt_connect_module._usual_settings(RRTConnectOptions(checker=_Str("mesh"))) is None


def _box_space(lower: np.ndarray, upper: np.ndarray) -> ConfigurationSpace:
    return ConfigurationSpace(lower, upper, FunctionChecker(lambda q: True))


def test_bounds_diameter_follows_writable_bounds() -> None:
    """The diameter is kept only for read-only bounds: bounds the caller can still write
    (its own arrays, taken without a copy) are measured at every call."""
    lower, upper = np.zeros(3), np.ones(3)
    space = _box_space(lower, upper)
    assert space.lower is lower  # the caller's arrays: writable
    lo, hi, diameter = space.bounds_diameter()
    assert lo is lower and hi is upper and diameter == math.dist([1, 1, 1], [0, 0, 0])
    upper[:] = 4.0
    assert space.bounds_diameter()[2] == math.dist([4, 4, 4], [0, 0, 0])
    # read-only bounds: kept, and the same value as measuring again
    lower.flags.writeable = False
    upper.flags.writeable = False
    kept = space.bounds_diameter()
    assert space.bounds_diameter() is kept
    assert kept[2] == math.dist(upper.tolist(), lower.tolist())


def test_endpoint_vector_shortcut() -> None:
    """A contiguous float64 vector of size d is returned as is; everything else as before."""
    space = _box_space(-np.ones(4), np.ones(4))
    q = np.array([0.1, 0.2, 0.3, 0.4])
    assert space.endpoint_vector(q, "start") is q
    wide = np.arange(8.0) / 10.0
    strided = space.endpoint_vector(wide[::2], "start")  # a view with strides (16,)
    assert strided.flags.c_contiguous and strided.tolist() == wide[::2].tolist()
    for other in (q.astype(np.float32), q.astype(">f8"), q.tolist(), q.reshape(1, 4)[0]):
        out = space.endpoint_vector(other, "goal")
        assert out.dtype == np.float64 and out.shape == (4,) and out.flags.c_contiguous
        np.testing.assert_array_equal(out, np.asarray(other, dtype=np.float64))
    for bad in (np.zeros(3), np.zeros((4, 1)), np.array([0.0, math.nan, 0.0, 0.0])):
        with pytest.raises(TaskspaceError):
            space.endpoint_vector(bad.tolist() if bad.ndim == 1 and bad.size == 4 else bad, "q")


@pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}")
@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
def test_kernels_follow_the_world() -> None:
    """native_kernel / sphere_kernel return the kept kernel until the world changes; the new
    world's kernel has its spheres, and plans on it see the new obstacles."""
    robot = motionbenchmaker_panda()
    problems = motionbenchmaker_problems(ROOT, "bookshelf_small", [1, 2])
    req = problems[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    checker = space.checker
    kernel = checker.sphere_kernel()
    assert kernel.has_spheres and checker.native_kernel() is kernel
    assert checker.sphere_kernel() is kernel
    opts = RRTConnectOptions(seed=1, checker="spheres_only", validator="spheres")
    assert rrt_connect(space, req.start, req.goal, opts).success
    old = weakref.ref(kernel)
    del kernel
    other = problems[1].apply(robot)  # a new world: new kernels
    fresh = checker.native_kernel()
    gc.collect()
    assert old() is None  # the old world's kernel is not kept alive
    assert not fresh.has_spheres
    assert checker.sphere_kernel() is fresh and fresh.has_spheres
    res = rrt_connect(space, other.start, other.goal, opts)
    assert res.success
    model, geom = robot._model, robot._collision_model  # Pinocchio's check, this world

    def collides(q: np.ndarray) -> bool:
        return bool(
            pin.computeCollisions(model, model.createData(), geom, geom.createData(), q, True)
        )

    for a, b in itertools.pairwise(res.path):  # dense checks along the path
        for t in np.linspace(0.0, 1.0, 12):
            assert not collides(a + t * (b - a))


@pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}")
@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
def test_native_log_has_limit_log_fields() -> None:
    """The compiled plan's log holds limit_log's fields (values, types, place in the log)."""
    robot = motionbenchmaker_panda()
    req = motionbenchmaker_problems(ROOT, "bookshelf_small", [3])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    stopped = set()
    for fields in ({}, {"max_iterations": 1, "time_limit_s": None}, {"time_limit_s": 0.0}):
        res = rrt_connect(space, req.start, req.goal, RRTConnectOptions(seed=2, **fields))
        expected = limit_log(res.status, res.path_length, res.time_s)
        got = {key: res.log[key] for key in expected}
        assert got == expected
        assert [type(v) for v in got["costs"] + got["cost_times"]] == [float] * (2 * res.success)
        keys = list(res.log)
        assert keys[keys.index("path_certified") + 1 : keys.index("kernel_run_us")] == list(
            expected
        )
        stopped.add(res.log["stopped_by"])
    assert stopped == {"first solution", "iterations", "time"}


@pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}")
@pytest.mark.skipif(ROOT is None, reason=SKIP_REASON)
def test_native_log_is_a_new_dict_of_the_keys() -> None:
    """The kernel makes the log (a copy of one dict of its keys): the keys of
    ``_NATIVE_LOG_KEYS`` in order, floats but limit_log's fields, a new dict per plan (one
    plan's log changed does not change the next one's)."""
    module = planning_kernel()
    assert module.RRT_CONNECT_LOG_KEYS == rrt_connect_module._NATIVE_LOG_KEYS
    robot = motionbenchmaker_panda()
    req = motionbenchmaker_problems(ROOT, "bookshelf_small", [3])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    limit_keys = ("stopped_by", "costs", "cost_times")
    logs = []
    for checker, validator in (("mesh", "mesh"), ("spheres_only", "spheres")):
        opts = RRTConnectOptions(seed=2, checker=checker, validator=validator)
        for _ in range(2):
            res = rrt_connect(space, req.start, req.goal, opts)
            assert res.success
            assert tuple(res.log) == rrt_connect_module._NATIVE_LOG_KEYS
            assert all(type(v) is float for k, v in res.log.items() if k not in limit_keys)
            assert res.log["start_tree_nodes"] == res.trees[0].size
            assert res.log["native"] == 1.0 and res.log["checker"] == float(CHECKERS.index(checker))
            logs.append(res.log)
            res.log["native"] = -1.0  # the caller's dict: the next plan's is another
            res.log["costs"].append(0.0)
    assert len({id(log) for log in logs}) == len(logs)
    assert all(len(log["costs"]) == 2 for log in logs)
