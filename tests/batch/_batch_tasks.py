"""Task functions for the batch tests (module-level so that every backend can pickle them)."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path
from typing import Any

import numpy as np


def noisy(item: Any, rng: np.random.Generator, context: Any) -> list[float]:
    """A value that depends on the input and on the task's generator only."""
    return (float(item) + rng.standard_normal(3)).tolist()


def context_pid(item: Any, rng: np.random.Generator, context: Any) -> list[int]:
    """Which worker ran the task and which context object it saw."""
    return [os.getpid(), context["pid"], context["serial"]]


_SERIAL = [0]


def make_context() -> dict[str, int]:
    """A context that records the process that built it and how many it built there."""
    _SERIAL[0] += 1
    return {"pid": os.getpid(), "serial": _SERIAL[0]}


def fails_on_three(item: Any, rng: np.random.Generator, context: Any) -> int:
    if item == 3:
        raise ValueError(f"item {item} is bad")
    return int(item) * 2


def dies_once(item: Any, rng: np.random.Generator, context: Any) -> int:
    """Kill the worker (SIGKILL) the first time item 5 runs; marker file in item's folder."""
    value, folder = item
    marker = Path(folder) / f"died-{value}"
    if value == 5 and not marker.exists():
        marker.write_text("x")
        os.kill(os.getpid(), signal.SIGKILL)
    return int(value) + 100


def always_dies(item: Any, rng: np.random.Generator, context: Any) -> int:
    if item == 7:
        os.kill(os.getpid(), signal.SIGKILL)
    return int(item)


def slow(item: Any, rng: np.random.Generator, context: Any) -> int:
    time.sleep(0.05)
    return int(item)


def slow_marking_pid(item: Any, rng: np.random.Generator, context: Any) -> int:
    """``slow`` on item (folder, i), leaving a file named after the worker's process id."""
    folder, i = item
    (Path(folder) / f"{os.getpid()}.pid").touch()
    time.sleep(0.05)
    return int(i)


def panda() -> Any:
    from taskspace.model import Robot

    return Robot.load("panda")


def panda_ik(item: Any, rng: np.random.Generator, context: Any) -> list[float]:
    """Solve IK for the tcp pose of a random configuration, from a random start."""
    import pinocchio as pin

    from taskspace import features as F
    from taskspace.ik import SolveIKOptions, solve_ik
    from taskspace.tasks import Task

    robot = context
    q_goal = robot.random_configuration(rng)
    target = robot.state(q_goal).frame_placement(robot.frame_id("panda_hand_tcp"))
    task = Task(F.FramePose(robot, "panda_hand_tcp"))
    task.set_target(pin.SE3(target))
    options = SolveIKOptions(restarts=5)
    result = solve_ik(robot, [task], q0=robot.random_configuration(rng), options=options, rng=rng)
    return [float(result.success), *np.asarray(result.q).tolist()]


def returns_a_lambda(item: Any, rng: np.random.Generator, context: Any) -> Any:
    """A value the worker cannot send back (not picklable)."""
    return lambda: item


def slow_context() -> str:
    """A context that takes 0.3 s to build (a robot model or a scene loading)."""
    time.sleep(0.3)
    return "ready"


def millisecond(item: Any, rng: np.random.Generator, context: Any) -> int:
    """A task of about 1 ms."""
    time.sleep(0.001)
    return int(item)


def slow_pid(item: Any, rng: np.random.Generator, context: Any) -> int:
    """The worker's process id, after 50 ms."""
    time.sleep(0.05)
    return os.getpid()


def meeting_pid(item: Any, rng: np.random.Generator, context: Any) -> int:
    """The worker's process id, once two workers have each started a task (item: folder, index).

    Each task writes its process id into the folder and waits (at most 60 s) until two
    different ids are there, so two tasks of a two-worker pool run on two processes even
    when the second worker starts slowly on a loaded machine.
    """
    folder, index = Path(item[0]), item[1]
    (folder / f"{index}.pid").write_text(str(os.getpid()))
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        pids = {p.read_text() for p in folder.glob("*.pid")}
        if len(pids - {""}) >= 2:
            break
        time.sleep(0.005)
    return os.getpid()


def dies_first_in_a_worker(driver_pid: int, folder: str) -> str:
    """A context factory that SIGKILLs the first worker process building it (marker file)."""
    marker = Path(folder) / "context-died"
    if os.getpid() != driver_pid and not marker.exists():
        marker.write_text("x")
        os.kill(os.getpid(), signal.SIGKILL)
    return "ready"
