"""Shared fixtures: robots are loaded once per test session."""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import settings

from taskspace.model import Robot

os.environ.setdefault("MPLBACKEND", "Agg")

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


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """``--dist loadgroup``: give each ``xdist_group`` test its ``@<group>`` suffix.

    pytest-xdist (3.8) tells its scheduler a test's group by appending ``@<group>`` to the node
    id it reports, but it writes ``item._nodeid``, which pytest 9.2 no longer reads (node ids
    are ``item._id``, a structured ``NodeId``): the groups were silently ignored, so the Ray
    tests ran on both workers at once and a worker could wait in the docs build's lock while
    the other built it (pytest-xdist issue 1386). The suffix is added here, in the same way,
    when xdist did not add it.
    """
    if not getattr(config.option, "loadgroup", False):  # set in xdist workers
        return
    for item in items:
        groups = {
            str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
            for mark in item.iter_markers("xdist_group")
        }
        suffix = "@" + "_".join(sorted(groups))
        if not groups or item.nodeid.endswith(suffix):
            continue
        if hasattr(item, "_id"):  # pytest >= 9.2
            item._id = type(item._id).parse(item.nodeid + suffix)
        else:
            item._nodeid = item.nodeid + suffix


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
