"""A large batch of the compiled collision checker can be interrupted (Ctrl-C) and shares the GIL.

The compiled kernel holds the GIL while it checks; one call with a million configurations
held it for seconds (SIGINT was handled only at the end, other threads starved). The checker
now calls it in chunks of ``KERNEL_CHUNK`` rows, with the same answers.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from taskspace.planning.collision_checker import KERNEL_CHUNK, CollisionChecker
from tests.conftest import load_robot

CHILD = textwrap.dedent(
    """
    import json, sys, time, traceback, warnings
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
    try:
        while True:
            checker._batch(qs, False)
    except KeyboardInterrupt as exc:
        frames = [frame.name for frame in traceback.extract_tb(exc.__traceback__)]
        print(json.dumps({"cpu": time.process_time(), "in_batch": "_batch" in frames}))
    """
)


def _cpu_seconds(pid: int) -> float:
    """The CPU time (user + system, all threads) that process ``pid`` has spent so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


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


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc/<pid>/stat")
def test_sigint_stops_a_large_batch() -> None:
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        # Inside the batches of a million rows once the child has spent 0.1 s of CPU time in
        # them (a fixed wall delay may pass on a loaded machine before the first one starts).
        ready, deadline = _cpu_seconds(child.pid), time.monotonic() + 60.0
        while _cpu_seconds(child.pid) < ready + 0.1 and time.monotonic() < deadline:
            time.sleep(0.01)
        sent = _cpu_seconds(child.pid)
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=60)
    finally:
        child.kill()
    assert "Traceback" not in err, err[-2000:]
    run = json.loads(out.strip().splitlines()[-1])
    assert run["in_batch"], run  # the KeyboardInterrupt came out of a batch
    # The CPU time the child spent between the signal and the KeyboardInterrupt: one kernel
    # call for the whole batch goes on checking for a second or more, a chunk of KERNEL_CHUNK
    # rows takes milliseconds. (The wall time from the signal to the child's exit, asserted
    # < 1 s before, was 2.0-3.7 s in 4 of 5 runs with five busy loops on the child's core: a
    # loaded machine that does not schedule the child adds wall time, not CPU time.)
    assert run["cpu"] - sent < 0.3, (run, sent)
