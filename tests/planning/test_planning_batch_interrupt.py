"""A large batch of the compiled collision checker can be interrupted (Ctrl-C) and shares the GIL.

The compiled kernel holds the GIL while it checks; one call with a million configurations
held it for seconds (SIGINT was handled only at the end, other threads starved). The checker
now calls it in chunks of ``KERNEL_CHUNK`` rows, with the same answers.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import numpy as np

from taskspace.planning.collision_checker import KERNEL_CHUNK, CollisionChecker
from tests.conftest import load_robot

CHILD = textwrap.dedent(
    """
    import sys, warnings
    import numpy as np
    warnings.simplefilter("ignore")
    from taskspace.model import Robot
    from taskspace.planning.collision_checker import CollisionChecker
    robot = Robot.load("panda", convex_collision=True)
    checker = CollisionChecker(robot)
    rng = np.random.default_rng(0)
    lo, hi = robot.lower_limits, robot.upper_limits
    qs = lo + (hi - lo) * rng.random((1_000_000, robot.nq))
    assert checker._query_kernel() is not None
    print("ready", flush=True)
    while True:
        checker._batch(qs, False)
    """
)


def test_chunked_batches_answer_like_one_kernel_call() -> None:
    robot = load_robot("panda", convex=True)
    checker = CollisionChecker(robot)
    kernel = checker._query_kernel()
    assert kernel is not None
    rng = np.random.default_rng(3)
    lo, hi = robot.lower_limits, robot.upper_limits
    qs = lo + (hi - lo) * rng.random((2 * KERNEL_CHUNK + 17, robot.nq))
    reference = np.asarray(kernel.collisions(qs), dtype=bool)
    assert 0 < reference.sum() < reference.size
    np.testing.assert_array_equal(checker._batch(qs, False), reference)
    # stop at the first collision, here in the second chunk
    free = qs[~reference][: KERNEL_CHUNK + 5]
    colliding = qs[reference][:3]
    rows = np.vstack([free, colliding, free[:4]])
    hits = checker._batch(rows, True)
    assert not hits[: free.shape[0]].any() and hits[free.shape[0] :].all()
    assert not checker._batch(free, True).any()


def test_sigint_stops_a_large_batch() -> None:
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        time.sleep(0.3)  # inside a batch of a million rows (seconds in one kernel call)
        sent = time.perf_counter()
        child.send_signal(signal.SIGINT)
        _, err = child.communicate(timeout=60)
        elapsed = time.perf_counter() - sent
    finally:
        child.kill()
    assert "KeyboardInterrupt" in err, err[-2000:]
    assert elapsed < 1.0, elapsed
