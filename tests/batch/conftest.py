"""The local Ray runtime shared by the Ray test files of this folder (one xdist group).

The tests that only need some local runtime (the ``local_ray`` fixture) share one for the
session: starting one costs a few seconds of CPU (Ray's daemons and worker processes). The
tests that start, stop or restart a runtime or a cluster themselves do so; the shared runtime
is started again for the next test that needs it. Those tests run after the sharing ones
(:func:`pytest_collection_modifyitems`), so that the runtime is started once per session when
no test restarts it.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from _local_ray import STARTED, start_local_ray


@pytest.fixture(scope="session")
def _ray_session() -> Iterator[Any]:
    """The ``ray`` module; the runtime still running at the end of the session is stopped."""
    ray = pytest.importorskip("ray")
    yield ray
    if ray.is_initialized():
        ray.shutdown()


@pytest.fixture
def local_ray(_ray_session: Any) -> None:
    """A local runtime started by :func:`start_local_ray`: the session's, or a new one.

    A new one when the last was stopped, or when this process is connected to another
    runtime (one started otherwise, a cluster).
    """
    ray = _ray_session
    if ray.is_initialized() and ray.get_runtime_context().gcs_address not in STARTED:
        ray.shutdown()
    if not ray.is_initialized():
        start_local_ray()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The Ray tests that share the runtime first, in their order, then the others."""
    ray_tests = [
        i
        for i, item in enumerate(items)
        if any(m.args[:1] == ("ray",) for m in item.iter_markers("xdist_group"))
    ]
    shared = [i for i in ray_tests if "local_ray" in getattr(items[i], "fixturenames", ())]
    own = [i for i in ray_tests if i not in shared]
    reordered = [items[i] for i in shared + own]
    for i, item in zip(ray_tests, reordered):
        items[i] = item
