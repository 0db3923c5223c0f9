"""How a Ray failure is reported in a task's record (no Ray runtime needed)."""

from __future__ import annotations

from taskspace.batch.ray_backend import _MAX_REASON, _reason


def test_the_cause_after_the_first_line_is_kept() -> None:
    # The shape of a RayTaskError wrapping a RaySystemError: the cause is on later lines.
    exc = RuntimeError(
        "\x1b[36mray::run_chunk()\x1b[39m (pid=10288, ip=192.0.2.2)\n"
        '  File "worker.py", line 3, in run_chunk\n'
        "ray.exceptions.RaySystemError: System error: No module named '_batch_tasks'\n"
    )
    reason = _reason(exc)
    assert reason.startswith("RuntimeError: ray::run_chunk() (pid=10288")
    assert "No module named '_batch_tasks'" in reason
    assert "\x1b" not in reason and "\n" not in reason


def test_a_long_error_is_capped_and_keeps_its_end() -> None:
    exc = RuntimeError("head\n" + "x" * 10_000 + "\nthe real cause")
    reason = _reason(exc)
    assert len(reason) <= _MAX_REASON + 10
    assert reason.startswith("RuntimeError: head") and reason.endswith("the real cause")
