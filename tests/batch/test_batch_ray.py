"""The Ray backend on a real local Ray runtime and on a `ray start --head` cluster."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _batch_tasks as T
import pytest

from taskspace.batch import BatchOptions, run_batch

ray = pytest.importorskip("ray")
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
HERE = Path(__file__).resolve().parent


def _pythonpath() -> str:
    return f"{HERE}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"


def _ray(**kw: object) -> BatchOptions:
    return BatchOptions(backend="ray", progress=False, workers=2, **kw)  # type: ignore[arg-type]


def test_ray_gives_the_serial_values(local_ray: None) -> None:
    items = list(range(25))
    serial = run_batch(T.noisy, items, options=BatchOptions(backend="serial", progress=False))
    for chunk_size in (None, 1, 4):
        result = run_batch(T.noisy, items, options=_ray(chunk_size=chunk_size))
        assert result.success and result.backend == "ray"
        assert result.values == serial.values


def test_ray_context_once_per_worker(local_ray: None) -> None:
    rows = run_batch(T.context_pid, range(30), context=T.make_context, options=_ray(chunk_size=2))
    for pid, context_pid, serial in rows.values:
        assert pid == context_pid and serial == 1


def test_ray_reports_failures_and_survives_killed_workers(local_ray: None, tmp_path: Path) -> None:
    failed = run_batch(T.fails_on_three, range(6), options=_ray())
    assert [r.index for r in failed.failures] == [3]
    assert "item 3 is bad" in failed.failures[0].error
    items = [(i, str(tmp_path)) for i in range(10)]
    survived = run_batch(T.dies_once, items, options=_ray(chunk_size=2))
    assert (tmp_path / "died-5").exists()
    assert survived.values == [i + 100 for i in range(10)]
    poisoned = run_batch(T.always_dies, range(9), options=_ray(chunk_size=3, retries=1))
    assert [r.index for r in poisoned.failures] == [7]
    assert "worker died" in poisoned.failures[0].error


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("", 0))
        return int(sock.getsockname()[1])


def test_ray_cluster_by_address(monkeypatch: pytest.MonkeyPatch) -> None:
    """`ray start --head` in a subprocess, then a run connected to that cluster's address.

    The address is the one `ray start` records in its temp dir: with ``"auto"`` Ray picks any
    cluster it finds on the machine when the record is elsewhere (here the local runtime of the
    tests above may still be shutting down), which made this test fail now and then. The
    cluster is started with ``--block`` and stopped by terminating that process, so no other
    Ray cluster on the machine is touched (``ray stop`` would stop them all); it gets a free
    port, as another cluster may hold Ray's default one. Ray turns token authentication on for
    a ``ray start`` when a token file exists but never for a driver given an explicit address:
    both sides get the same ``RAY_AUTH_MODE``.
    """
    ray_cli = shutil.which("ray", path=str(Path(sys.executable).parent))
    if ray_cli is None:
        pytest.skip("the ray command is not installed next to this Python")
    if ray.is_initialized():
        ray.shutdown()
    # Keep this process's mode (a local ray.init above set "token"): actors created after a
    # reconnection with another mode die at once (Ray 2.60).
    monkeypatch.setenv("RAY_AUTH_MODE", os.environ.get("RAY_AUTH_MODE", "disabled"))
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0", "PYTHONPATH": _pythonpath()}
    temp_dir = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # Ray's socket paths must be short
    address_file = Path(temp_dir) / "ray_current_cluster"
    head = subprocess.Popen(
        [
            ray_cli,
            "start",
            "--head",
            "--block",
            f"--port={_free_port()}",
            "--num-cpus=2",
            "--include-dashboard=false",
            f"--temp-dir={temp_dir}",
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 180
        while not address_file.exists() or not address_file.read_text().strip():
            if head.poll() is not None:
                pytest.fail(f"ray start exited with {head.returncode}: {head.stderr.read()}")
            assert time.monotonic() < deadline, "ray start did not record its address in 180 s"
            time.sleep(0.2)
        address = address_file.read_text().strip()
        result = run_batch(T.noisy, range(12), options=_ray(ray_address=address))
        serial = run_batch(
            T.noisy, range(12), options=BatchOptions(backend="serial", progress=False)
        )
        assert result.values == serial.values
        assert ray.get_runtime_context().gcs_address == address  # really that cluster
    finally:
        ray.shutdown()
        head.terminate()
        try:
            head.wait(timeout=120)
        except subprocess.TimeoutExpired:
            head.kill()
            head.wait()
        shutil.rmtree(temp_dir, ignore_errors=True)
