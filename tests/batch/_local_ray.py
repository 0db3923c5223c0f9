"""A local Ray runtime for the Ray tests (``local_ray`` in conftest.py, and the restart test)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
STARTED: set[str] = set()  # GCS addresses of the runtimes start_local_ray started


def start_local_ray() -> None:
    """Start a local Ray runtime of 2 CPUs whose workers can import the task module by name.

    The folder of ``_batch_tasks`` goes through the environment the runtime inherits, as
    ``taskspace.batch.ray_backend.connect`` does for the driver's path: the two workers Ray
    starts with the runtime then serve the actors (a ``runtime_env`` would make Ray start two
    more processes for them).
    """
    ray = pytest.importorskip("ray")
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    before = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = f"{HERE}{os.pathsep}{before or ''}"
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    finally:
        if before is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = before
    STARTED.add(ray.get_runtime_context().gcs_address)
