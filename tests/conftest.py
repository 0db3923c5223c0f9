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
