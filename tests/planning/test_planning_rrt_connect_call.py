"""The Python around the compiled RRT-Connect: validated options, the kernel's trees, time_s."""

from __future__ import annotations

import importlib
import time

import numpy as np
import pytest

from taskspace._native import planning_kernel, status
from taskspace.errors import InvalidInputError, UnknownNameError
from taskspace.planning.configuration_space import ConfigurationSpace, EdgeCheckOptions
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.scene_loader import motionbenchmaker_panda, motionbenchmaker_problems
from tests.planning._mbm import ROOT, SKIP_REASON

# the module (``taskspace.planning.rrt_connect`` is also the function's name in the package)
rrt_connect_module = importlib.import_module("taskspace.planning.rrt_connect")

pytestmark = [
    pytest.mark.skipif(planning_kernel() is None, reason=f"native kernel: {status()}"),
    pytest.mark.skipif(ROOT is None, reason=SKIP_REASON),
]

FAST = {"checker": "spheres_only", "validator": "spheres"}  # the benchmark's fast setting


@pytest.fixture(scope="module")
def problem():  # type: ignore[no-untyped-def]
    robot = motionbenchmaker_panda()
    req = motionbenchmaker_problems(ROOT, "bookshelf_small", [3])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    return space, np.asarray(req.start, dtype=float), np.asarray(req.goal, dtype=float)


def _trees_as_python(res, space, start, goal) -> None:  # type: ignore[no-untyped-def]
    """The trees as the Python planner gives them: (n, d) nodes, int64 parents, roots."""
    assert len(res.trees) == 2
    for tree, root in zip(res.trees, (start, goal), strict=True):
        assert tree.nodes.dtype == np.float64 and tree.nodes.ndim == 2
        assert tree.nodes.shape[1] == space.dim and tree.nodes.flags.c_contiguous
        assert tree.parents.dtype == np.int64 and tree.parents.shape == (tree.size,)
        np.testing.assert_array_equal(tree.nodes[0], root)
        assert tree.parents[0] == -1
        assert np.all(tree.parents < np.arange(tree.size))  # parents come first
    assert res.log["start_tree_nodes"] == res.trees[0].size
    assert res.log["goal_tree_nodes"] == res.trees[1].size


@pytest.mark.parametrize("options", [{}, FAST])
def test_one_node_trees_have_one_row(problem, options) -> None:  # type: ignore[no-untyped-def]
    """A plan solved by the straight line (or stopped at once) has trees of one node each.

    The kernel's one-row matrices were turned into 1-D arrays (shape (d,)): ``size`` was d.
    """
    space, start, _ = problem
    near = start + 0.01
    for goal, opts in (
        (near, RRTConnectOptions(**options)),
        (start + 0.3, RRTConnectOptions(max_iterations=0, time_limit_s=None, **options)),
    ):
        res = rrt_connect(space, start, goal, opts)
        python = rrt_connect(space, start, goal, RRTConnectOptions(native=False, **options))
        assert res.log["native"] == 1.0 and "native" not in python.log
        assert res.status is python.status and res.iterations == python.iterations == 0
        _trees_as_python(res, space, start, goal)
        for ours, reference in zip(res.trees, python.trees, strict=True):
            assert ours.nodes.shape == reference.nodes.shape == (1, space.dim)
            np.testing.assert_array_equal(ours.nodes, reference.nodes)
            np.testing.assert_array_equal(ours.parents, reference.parents)
            assert ours.parents.dtype == reference.parents.dtype


@pytest.mark.parametrize("options", [{}, FAST])
def test_trees_hold_the_path(problem, options) -> None:  # type: ignore[no-untyped-def]
    """The path is a root-to-node path of the start tree, then one of the goal tree reversed."""
    space, start, goal = problem
    res = rrt_connect(space, start, goal, RRTConnectOptions(seed=2, **options))
    assert res.success and res.iterations > 0
    _trees_as_python(res, space, start, goal)
    start_tree, goal_tree = res.trees
    assert start_tree.size > 1 or goal_tree.size > 1
    splits = []
    for k in range(1, len(res.path)):
        head, tail = res.path[:k], res.path[k:][::-1]
        i = np.flatnonzero((start_tree.nodes == head[-1]).all(axis=1))
        j = np.flatnonzero((goal_tree.nodes == tail[-1]).all(axis=1))
        if i.size and j.size:
            if np.array_equal(start_tree.path_to(int(i[0])), head) and np.array_equal(
                goal_tree.path_to(int(j[0])), tail
            ):
                splits.append(k)
    assert splits
    # the edges of the trees join parents to children (the Python Tree's own view)
    assert start_tree.edges().shape == (int((start_tree.parents >= 0).sum()), 2, space.dim)


def test_changed_options_are_validated_again(problem) -> None:  # type: ignore[no-untyped-def]
    """Options are validated once per object; a field changed behind the frozen dataclass
    (or set to an equal value of another type) is validated again at the next call."""
    space, start, goal = problem
    opts = RRTConnectOptions(seed=3, max_iterations=5, time_limit_s=None, **FAST)
    first = rrt_connect(space, start, goal, opts)
    assert first.iterations > 0  # not the straight line
    assert rrt_connect(space, start, goal, opts).iterations == first.iterations
    bad = (
        ("seed", True, InvalidInputError, "seed must be an integer >= 0"),
        ("seed", -1, InvalidInputError, "seed must be an integer >= 0"),
        ("max_iterations", 5.0, InvalidInputError, "max_iterations must be an integer"),
        ("step_size", -0.5, InvalidInputError, "step_size must be finite and > 0"),
        ("local_sampling", 1.5, InvalidInputError, r"local_sampling must be in \[0, 1\]"),
        ("fallback_iterations", True, InvalidInputError, "fallback_iterations must be an integer"),
        ("checker", "sphere", UnknownNameError, "spheres_only"),
        ("validator", "exact", UnknownNameError, "mesh"),
        ("coarse_resolution", 0.0, InvalidInputError, "coarse_resolution must be finite"),
        ("time_limit_s", float("nan"), InvalidInputError, "time_limit_s must be"),
    )
    for name, value, error, match in bad:
        good = getattr(opts, name)
        object.__setattr__(opts, name, value)
        with pytest.raises(error, match=match):
            rrt_connect(space, start, goal, opts)
        with pytest.raises(error, match=match):  # not cached as valid after the error
            rrt_connect(space, start, goal, opts)
        object.__setattr__(opts, name, good)
        again = rrt_connect(space, start, goal, opts)
        assert again.iterations == first.iterations
    # a valid change is used, not the settings validated before it
    object.__setattr__(opts, "max_iterations", 0)
    assert rrt_connect(space, start, goal, opts).iterations == 0


def test_equal_options_and_subclasses_are_validated(problem) -> None:  # type: ignore[no-untyped-def]
    space, start, goal = problem
    good = RRTConnectOptions(seed=3, max_iterations=5, time_limit_s=None)
    rrt_connect(space, start, goal, good)

    seeds = [3, -7]

    class Options(RRTConnectOptions):  # a subclass may compute its fields at each read
        def __getattribute__(self, name: str) -> object:
            if name == "seed":
                return seeds.pop(0) if len(seeds) > 1 else seeds[0]
            return super().__getattribute__(name)

    computed = Options(max_iterations=5, time_limit_s=None)
    rrt_connect(space, start, goal, computed)  # seed 3
    with pytest.raises(InvalidInputError, match="seed must be an integer >= 0, got -7"):
        rrt_connect(space, start, goal, computed)
    # many options objects
    for seed in range(192):
        opts = RRTConnectOptions(seed=seed, max_iterations=1, time_limit_s=None)
        assert rrt_connect(space, start, goal, opts).iterations <= 1


def test_time_s_counts_the_validation(problem, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """``time_s`` starts at the call's entry, before the options are validated."""
    space, start, goal = problem
    validate = rrt_connect_module._validate

    def slow(opts):  # type: ignore[no-untyped-def]
        time.sleep(0.02)
        return validate(opts)

    monkeypatch.setattr(rrt_connect_module, "_validate", slow)
    opts = RRTConnectOptions(seed=4, **FAST)  # a new object: validated at this call
    t0 = time.perf_counter()
    res = rrt_connect(space, start, goal, opts)
    wall = time.perf_counter() - t0
    assert res.success
    assert 0.02 <= res.time_s <= wall
    assert res.log["cost_times"] == [res.time_s]


def test_mesh_checker_ignores_the_validator() -> None:
    """``validator`` is ignored with ``checker="mesh"`` (documented): on a space whose kernel
    has no spheres yet, ``validator="spheres"`` plans as ``"mesh"`` does. The kernel refused
    it before ("the sphere checker needs set_spheres first") until a sphere plan had set
    the spheres on that checker's kernel."""
    robot = motionbenchmaker_panda()  # a new robot: its checker's kernel has no spheres
    req = motionbenchmaker_problems(ROOT, "bookshelf_small", [3])[0].apply(robot)
    space = ConfigurationSpace.from_robot(robot, edge=EdgeCheckOptions(resolution=0.03))
    got = rrt_connect(space, req.start, req.goal, RRTConnectOptions(seed=2, validator="spheres"))
    ref = rrt_connect(space, req.start, req.goal, RRTConnectOptions(seed=2))
    assert got.success and ref.success
    np.testing.assert_array_equal(got.path, ref.path)
    assert (got.iterations, got.collision_checks, got.edge_checks) == (
        ref.iterations,
        ref.collision_checks,
        ref.edge_checks,
    )
    assert got.log["validator"] == ref.log["validator"] == 0.0


def _same_plans(a, b) -> None:  # type: ignore[no-untyped-def]
    """Two results of the kernel's rrt_connect are the same plan (all but the phase times)."""
    assert a[0] == b[0] and a[2:5] == b[2:5] and a[7:9] == b[7:9]
    np.testing.assert_array_equal(a[1], b[1])
    for tree_a, tree_b in ((a[5], b[5]), (a[6], b[6])):
        np.testing.assert_array_equal(tree_a[0], tree_b[0])
        np.testing.assert_array_equal(tree_a[1], tree_b[1])
    timed = {key for key in a[9] if key.endswith("_us")}
    assert {k: v for k, v in a[9].items() if k not in timed} == {
        k: v for k, v in b[9].items() if k not in timed
    }


def test_fast_entry_converts_as_the_checked_function(problem) -> None:  # type: ignore[no-untyped-def]
    """The module's rrt_connect (converting the usual arguments itself) plans as the
    Boost.Python function does, and hands every other call to it: keywords, other number and
    array types, strided, byte-swapped and misaligned vectors, out-of-range integers."""
    space, start, goal = problem
    module = planning_kernel()
    kernel = space.checker.sphere_kernel()
    # (distinct values: two numbers swapped by the conversion would change the plan)
    args = [kernel, start, goal, space.lower, space.upper, 0.5, 0.03, 0.15, 0.45, 0.55, 0.75]
    args += [40, -1.0, 7, 2, 20, 1, None]  # iterations, no time limit, seed, checkers
    reference = module._rrt_connect_checked(*args)
    assert reference[2] > 0  # a plan with iterations, not the straight line
    _same_plans(module.rrt_connect(*args), reference)
    names = ["checker", "start", "goal", "lower", "upper", "alpha", "delta", "delta_c", "local"]
    names += ["sigma", "trapped", "max_iterations", "time_limit", "seed", "collision_checker"]
    names += ["fallback_iterations", "validator", "regions"]
    _same_plans(module.rrt_connect(**dict(zip(names, args, strict=True))), reference)
    wide = np.zeros((space.dim, 2))
    wide[:, 0] = start
    swapped = start.astype(">f8")
    raw = np.zeros(8 * space.dim + 1, dtype=np.uint8)[1:]
    misaligned = raw.view(np.float64)
    misaligned[:] = start
    assert not misaligned.flags.aligned
    for index, value in ((1, wide[:, 0]), (1, misaligned), (5, np.float64(0.5))):
        changed = list(args)  # (a strided view, a misaligned vector, a numpy float)
        changed[index] = value
        _same_plans(module.rrt_connect(*changed), reference)
    for index, value in (
        (1, swapped),  # (whatever eigenpy makes of it)
        (1, list(start)),
        (11, np.int64(40)),
        (11, 1 << 70),
        (13, np.uint64(7)),
        (13, -1),
        (13, 1 << 64),
        (14, True),
        (5, "0.5"),
    ):
        changed = list(args)
        changed[index] = value
        try:
            expected = module._rrt_connect_checked(*changed)
        except Exception as exc:  # (the checked function's error, whatever it is)
            with pytest.raises(type(exc)):
                module.rrt_connect(*changed)
        else:
            _same_plans(module.rrt_connect(*changed), expected)
