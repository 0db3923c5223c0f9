"""Shared fixtures: robots are loaded once per test session."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import settings

from taskspace.model import Robot

os.environ.setdefault("MPLBACKEND", "Agg")

# Ctrl-C as in a terminal, however pytest was started. A command started in the background
# by a shell without job control (`make test > log &` in a script, `nohup ... &`) inherits
# SIGINT *ignored*; Python then installs no KeyboardInterrupt handler, and neither do the
# xdist workers nor the subprocesses that the tests start. Six Ctrl-C tests (a snapshot, a
# batch run, a compiled plan, a planning batch, a simulation, a rollout) then failed: "DID
# NOT RAISE KeyboardInterrupt" after 50 snapshots (~100-150 s under load), subprocesses that
# never stop (30 or 60 s timeouts). Python's own handler again; the subprocesses get the
# default action (an exec resets a handled signal, while an ignored one stays ignored).
if (
    threading.current_thread() is threading.main_thread()
    and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
):
    signal.signal(signal.SIGINT, signal.default_int_handler)

# Property tests draw the same examples on every run: CI must not depend on luck.
settings.register_profile("taskspace", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("taskspace")

_CACHE: dict[tuple[str, bool], Robot] = {}


def load_robot(name: str, convex: bool = False) -> Robot:
    """Load a registry robot once per session (tests must not add obstacles to it)."""
    key = (name, convex)
    if key not in _CACHE:
        _CACHE[key] = Robot.load(name, convex_collision=convex)
    return _CACHE[key]


def xdist_groups(item: pytest.Item) -> set[str]:
    """The ``--dist loadgroup`` groups of a test: its ``xdist_group`` marks, else its module's.

    A test that uses a module-scoped fixture (a robot loaded, a walk or a scene computed once
    for the module) is put in its module's group, so that the whole module runs on one worker
    and the fixture is built once, not once per worker that gets some of its tests.
    """
    groups = {
        str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
        for mark in item.iter_markers("xdist_group")
    }
    if groups:
        return groups
    info = getattr(item, "_fixtureinfo", None)
    for name in info.names_closure if info is not None else ():
        defs = info.name2fixturedefs.get(name)
        if defs and defs[-1].scope in ("module", "class"):
            return {f"module_{item.path.stem}"}
    return set()


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """``--dist loadgroup``: give each grouped test (:func:`xdist_groups`) its ``@<group>``.

    pytest-xdist (3.8) tells its scheduler a test's group by appending ``@<group>`` to the node
    id it reports, but it writes ``item._nodeid``, which pytest 9.2 no longer reads (node ids
    are ``item._id``, a structured ``NodeId``): the groups were silently ignored, so the Ray
    tests ran on both workers at once and a worker could wait in the docs build's lock while
    the other built it (pytest-xdist issue 1386). The suffix is added here, in the same way,
    when xdist did not add it.

    xdist schedules the groups first (more tests first), then the other tests in the order of
    ``items``: the tests marked ``slow`` are put before the quick ones, so that the last tests
    of the run are short and both workers end at about the same time.
    """
    if not getattr(config.option, "loadgroup", False):  # set in xdist workers
        return
    grouped = [(item, xdist_groups(item)) for item in items]
    grouped.sort(key=lambda pair: not (pair[1] or pair[0].get_closest_marker("slow")))
    items[:] = [item for item, _ in grouped]
    for item, groups in grouped:
        suffix = "@" + "_".join(sorted(groups))
        if not groups or item.nodeid.endswith(suffix):
            continue
        new = item.nodeid + suffix
        if hasattr(item, "_id"):  # pytest >= 9.2
            item._id = type(item._id).parse(new)
        else:
            item._nodeid = new


@pytest.fixture(scope="session")
def robot_loader() -> Callable[..., Robot]:
    return load_robot


@pytest.fixture(scope="session")
def panda() -> Robot:
    return load_robot("panda")


@pytest.fixture(scope="session")
def talos() -> Robot:
    return load_robot("talos")


@pytest.fixture(scope="session")
def g1() -> Robot:
    return load_robot("g1")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
