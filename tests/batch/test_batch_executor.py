"""The executor on serial and local-process backends: determinism, faults, resume, Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import _batch_tasks as T
import numpy as np
import pytest

from taskspace.batch import BatchError, BatchOptions, Executor, run_batch, task_rng
from taskspace.errors import InvalidInputError, UnknownNameError

HERE = Path(__file__).resolve().parent


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie (an orphan waiting for an init that may not
    reap it at once)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return False
    except OSError:  # no /proc: ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True
    return stat.rsplit(")", 1)[-1].split()[0] != "Z"


def _opts(backend: str, **kw: object) -> BatchOptions:
    return BatchOptions(backend=backend, progress=False, **kw)  # type: ignore[arg-type]


def test_values_depend_on_seed_and_index_only() -> None:
    items = list(range(23))
    reference = [
        (
            float(i)
            + np.random.default_rng(np.random.SeedSequence(11, spawn_key=(i,))).standard_normal(3)
        ).tolist()
        for i in items
    ]
    runs = [
        run_batch(T.noisy, items, options=_opts("serial", seed=11)),
        run_batch(T.noisy, items, options=_opts("processes", seed=11, workers=2)),
        run_batch(T.noisy, items, options=_opts("processes", seed=11, workers=1, chunk_size=5)),
        run_batch(T.noisy, items, options=_opts("processes", seed=11, workers=2, chunk_size=1)),
    ]
    for run in runs:
        assert run.success
        assert run.values == reference  # bit-identical, whatever the workers and chunks
    other_seed = run_batch(T.noisy, items, options=_opts("serial", seed=12)).values
    assert other_seed != reference


def test_task_rng_is_the_documented_seed_sequence() -> None:
    a = task_rng(3, 9).standard_normal(4)
    b = np.random.default_rng(np.random.SeedSequence(3, spawn_key=(9,))).standard_normal(4)
    assert np.array_equal(a, b)


def test_context_built_once_per_worker() -> None:
    result = run_batch(
        T.context_pid,
        range(40),
        context=T.make_context,
        options=_opts("processes", workers=2, chunk_size=2),
    )
    rows = result.values
    for pid, context_pid, serial in rows:
        assert pid == context_pid  # the context was built in the worker that used it
        assert serial == 1  # and only once there
    assert 1 <= len({r[0] for r in rows}) <= 2


def test_failing_task_is_reported_not_fatal() -> None:
    for backend in ("serial", "processes"):
        result = run_batch(T.fails_on_three, range(8), options=_opts(backend, workers=2))
        assert not result.success
        assert [r.index for r in result.failures] == [3]
        failure = result.failures[0]
        assert failure.item == 3
        assert "item 3 is bad" in failure.error and "ValueError" in failure.traceback
        others = [r.value for r in result.records if r.ok]
        assert others == [0, 2, 4, 8, 10, 12, 14]
        with pytest.raises(BatchError, match="1 of 8 tasks failed; first: task 3 with input 3"):
            _ = result.values


def test_killed_worker_loses_no_result(tmp_path: Path) -> None:
    items = [(i, str(tmp_path)) for i in range(12)]
    result = run_batch(T.dies_once, items, options=_opts("processes", workers=2, chunk_size=2))
    assert (tmp_path / "died-5").exists()  # the worker really was killed
    assert result.success
    assert result.values == [i + 100 for i in range(12)]
    assert result.records[5].attempts >= 2


def test_task_that_always_kills_its_worker_is_reported(tmp_path: Path) -> None:
    result = run_batch(
        T.always_dies, range(10), options=_opts("processes", workers=2, chunk_size=3, retries=1)
    )
    assert [r.index for r in result.failures] == [7]
    assert "worker died" in result.failures[0].error
    assert result.failures[0].item == 7
    assert [r.value for r in result.records if r.ok] == [0, 1, 2, 3, 4, 5, 6, 8, 9]


def test_resume_after_interruption(tmp_path: Path) -> None:
    path = tmp_path / "runs.jsonl"
    items = list(range(30))
    ex = Executor(_opts("processes", workers=2, chunk_size=3, seed=5))
    stream = ex.as_completed(T.noisy, items, results_file=path)
    first = [next(stream) for _ in range(7)]
    stream.close()  # as an interrupted campaign: the pool is stopped, the file kept
    lines = path.read_text().splitlines()
    assert json.loads(lines[0]) == {"header": {"tasks": 30, "seed": 5}}
    written = {json.loads(line)["index"] for line in lines[1:]}
    assert {r.index for r in first} <= written
    resumed = ex.map(T.noisy, items, results_file=path)
    assert resumed.n_resumed == len(written)
    fresh = run_batch(T.noisy, items, options=_opts("serial", seed=5))
    assert resumed.values == fresh.values
    # a third run does nothing but read the file
    again = ex.map(T.noisy, items, results_file=path)
    assert again.n_resumed == 30 and again.values == fresh.values
    with pytest.raises(BatchError, match="another run"):
        Executor(_opts("serial", seed=6)).map(T.noisy, items, results_file=path)


def test_cut_last_line_is_run_again(tmp_path: Path) -> None:
    path = tmp_path / "runs.jsonl"
    ex = Executor(_opts("serial"))
    ex.map(T.noisy, range(4), results_file=path)
    text = path.read_text()
    path.write_text(text[: len(text) - 10])  # the last record cut mid-line
    result = ex.map(T.noisy, range(4), results_file=path)
    assert result.n_resumed == 3
    assert result.values == run_batch(T.noisy, range(4), options=_opts("serial")).values


def test_bad_options_are_clear_errors() -> None:
    with pytest.raises(UnknownNameError, match="valid backends are: processes, ray, serial"):
        BatchOptions(backend="dask")  # type: ignore[arg-type]
    for kw in (
        {"workers": 0},
        {"chunk_size": 2.5},
        {"retries": -1},
        {"seed": -3},
        {"min_chunk_seconds": float("nan")},
    ):
        with pytest.raises(InvalidInputError):
            BatchOptions(**kw)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="fn must be callable"):
        run_batch(3, [1])  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="context must be a factory"):
        run_batch(T.noisy, [1], context=5)  # type: ignore[arg-type]


def test_real_robot_ik_dataset_same_on_every_backend() -> None:
    items = list(range(6))
    serial = run_batch(T.panda_ik, items, context=T.panda, options=_opts("serial", seed=2))
    procs = run_batch(
        T.panda_ik, items, context=T.panda, options=_opts("processes", seed=2, workers=2)
    )
    assert serial.success and procs.success
    assert procs.values == serial.values
    assert sum(v[0] for v in serial.values) >= 5  # solve_ik reaches (nearly) every pose


def test_ctrl_c_stops_cleanly_and_keeps_what_was_written(tmp_path: Path) -> None:
    path = tmp_path / "runs.jsonl"
    pids = tmp_path / "pids"
    pids.mkdir()
    script = textwrap.dedent(
        f"""
        import sys
        sys.path.insert(0, {str(HERE.parent.parent)!r})
        from taskspace.batch import BatchOptions, Executor
        sys.path.insert(0, {str(HERE)!r})
        import _batch_tasks as T
        ex = Executor(BatchOptions(backend="processes", workers=2, chunk_size=1, progress=False))
        try:
            items = [({str(pids)!r}, i) for i in range(2000)]
            ex.map(T.slow_marking_pid, items, results_file={str(path)!r})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(3)
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if path.exists() and len(path.read_text().splitlines()) > 5:
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 3 and "interrupted" in out
    rows = [json.loads(line) for line in path.read_text().splitlines()[1:]]
    assert len(rows) >= 5 and all(r["ok"] for r in rows)
    assert len(rows) < 2000
    # no worker process outlives the driver (the workers' own ids: with "forkserver" they are
    # not the driver's children, and an orphan's parent changes at once, so a look at the
    # driver's children could never fail)
    workers = {int(p.stem) for p in pids.glob("*.pid")}
    assert workers and proc.pid not in workers
    deadline = time.monotonic() + 60.0  # a hang bound
    while time.monotonic() < deadline and any(_alive(pid) for pid in workers):
        time.sleep(0.05)
    assert not any(_alive(pid) for pid in workers), "workers outlived the interrupted driver"


def test_executor_keeps_workers_and_contexts_between_runs(tmp_path: Path) -> None:
    with Executor(_opts("processes", workers=2, chunk_size=1)) as ex:
        # tasks that wait for each other start both workers (a process pool starts a worker
        # only when none is idle; 50 ms sleeps were not enough on a loaded CI machine, where
        # the first worker ran all four before the second had started)
        meeting = [(str(tmp_path), i) for i in range(4)]
        started = set(ex.map(T.meeting_pid, meeting, context=T.make_context).values)
        first = ex.map(T.context_pid, range(10), context=T.make_context).values
        second = ex.map(T.context_pid, range(10), context=T.make_context).values
    assert len(started) == 2
    assert {r[0] for r in first + second} <= started  # the same worker processes
    assert all(r[2] == 1 for r in first + second)  # each built its context once in all


def test_batch_inputs_that_cannot_work_are_refused_or_reported(tmp_path: Path) -> None:
    # before: workers=10**6 and retries=10**9 were accepted (a task that kills its worker
    # was retried 1e9 times), progress="yes" too; a lambda task on the processes backend, an
    # unpicklable task value and a results file that is a directory raised bare
    # AttributeError / IsADirectoryError
    from taskspace.batch import BatchOptions, Executor
    from taskspace.errors import InvalidInputError

    for kwargs in ({"workers": 10**6}, {"retries": 10**9}, {"progress": "yes"}, {"workers": True}):
        with pytest.raises(InvalidInputError, match=next(iter(kwargs))):
            BatchOptions(**kwargs)  # type: ignore[arg-type]
    options = BatchOptions(backend="processes", workers=2, chunk_size=1, progress=False)
    with Executor(options) as ex:
        with pytest.raises(InvalidInputError, match="picklable"):
            ex.map(lambda x, rng, ctx: x, [1, 2])
        result = ex.map(T.returns_a_lambda, [1, 2, 3])
        assert not any(r.ok for r in result.records)
        assert all("picklable" in r.error for r in result.records)
        with pytest.raises(InvalidInputError, match="results_file"):
            ex.map(T.returns_a_lambda, [1], results_file=tmp_path)


def test_automatic_chunks_ignore_the_context_build_time() -> None:
    # 1 ms tasks, a 0.3 s context: chunks should hold ~10 tasks (min_chunk_seconds=0.01),
    # capped at ceil(remaining / (4 * workers)) = 5; timing the context build with the
    # first task gave 1 (fails on the old code: assert 1 == 5).
    opts = BatchOptions(backend="processes", workers=2, progress=False)
    with Executor(opts) as ex:
        result = ex.map(T.millisecond, range(40), context=T.slow_context)
    assert result.values == list(range(40))
    assert 1 < result.chunk_size <= 5
