"""Timing helpers and the result row shared by every benchmark suite.

A suite is a module in ``benchmarks/suites/`` exposing ``SUITE: str`` and
``def run(quick: bool) -> list[Row]``. Scenes (what is measured) are built by functions separate
from timing. Peer libraries run in their own virtual environments
(``.venv-peers/<peer>/bin/python``) through :func:`run_peer`, which returns the JSON the peer
script printed, or ``None`` when that environment is not installed (``make bench-peers``).
"""

from __future__ import annotations

import json
import os
import subprocess
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

# The MotionBenchMaker problems are not shipped with taskspace: the project keeps them in
# shared/ beside the checkout, unless TASKSPACE_MOTIONBENCHMAKER_DIR says otherwise.
_MOTIONBENCHMAKER = ROOT.parent / "shared" / "benchmarks" / "motionbenchmaker_panda"
if _MOTIONBENCHMAKER.is_dir():
    os.environ.setdefault("TASKSPACE_MOTIONBENCHMAKER_DIR", str(_MOTIONBENCHMAKER))
PEERS_DIR = ROOT / ".venv-peers"


@dataclass
class Timing:
    """Per-call timing statistics in microseconds."""

    median_us: float
    p95_us: float
    p99_us: float
    mean_us: float
    n: int

    @staticmethod
    def from_samples(samples_s: Any) -> Timing:
        """Build from an array of per-call durations in seconds."""
        a = np.asarray(samples_s, dtype=float) * 1e6
        return Timing(
            median_us=float(np.median(a)),
            p95_us=float(np.percentile(a, 95)),
            p99_us=float(np.percentile(a, 99)),
            mean_us=float(np.mean(a)),
            n=int(a.size),
        )


@dataclass
class Row:
    """One line of the benchmark table.

    Attributes:
        suite: suite name.
        scene: scene name.
        method: what was measured (``"taskspace"``, ``"pink"``, ``"raw pinocchio"``...).
        timing: per-call timing, or ``None`` when the method could not run.
        extra: other measured quantities (success rate, failed steps, errors...).
        ratio_to: name of the method this row is compared with (for the ratio column).
        note: free text (why a peer is missing...).
    """

    suite: str
    scene: str
    method: str
    timing: Timing | None
    extra: dict[str, Any] = field(default_factory=dict)
    ratio_to: str | None = None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain-dict form for JSON."""
        return asdict(self)


def measure(fn: Callable[[], Any], *, warmup: int = 20, repeat: int = 200) -> Timing:
    """Time ``fn()`` call by call after ``warmup`` untimed calls."""
    for _ in range(warmup):
        fn()
    samples = np.empty(repeat)
    clock = time.perf_counter
    for i in range(repeat):
        t0 = clock()
        fn()
        samples[i] = clock() - t0
    return Timing.from_samples(samples)


def measure_interleaved(
    fns: list[Callable[[], Any]], *, warmup: int = 50, rounds: int = 200, block: int = 20
) -> list[Timing]:
    """Time several functions in alternating blocks so that they see the same machine load.

    Each round times ``block`` consecutive calls of every function in turn; a sample is the
    per-call mean of one block. Use it for ratios between methods measured in one process.
    """
    for fn in fns:
        for _ in range(warmup):
            fn()
    clock = time.perf_counter
    samples = np.empty((len(fns), rounds))
    for r in range(rounds):
        for i, fn in enumerate(fns):
            t0 = clock()
            for _ in range(block):
                fn()
            samples[i, r] = (clock() - t0) / block
    return [Timing.from_samples(s) for s in samples]


def peer_python(peer: str) -> Path | None:
    """Python interpreter of a peer's virtual environment, or ``None`` if not installed."""
    exe = PEERS_DIR / peer / "bin" / "python"
    return exe if exe.exists() else None


def run_peer(peer: str, script: str, args: list[str] | None = None, timeout: float = 1800) -> Any:
    """Run ``benchmarks/peers/<script>`` in the peer's environment and parse its JSON output.

    Returns ``None`` when the peer environment is missing. Raises ``RuntimeError`` with the
    peer's stderr when the script fails.
    """
    exe = peer_python(peer)
    if exe is None:
        return None
    cmd = [str(exe), str(ROOT / "benchmarks" / "peers" / script), *(args or [])]
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    if proc.returncode != 0:
        raise RuntimeError(f"peer script {script} failed:\n{proc.stderr[-4000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])
