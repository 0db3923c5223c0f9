"""Every example runs headless: TASKSPACE_FAST=1 MPLBACKEND=Agg python EXAMPLE --save TMPDIR.

Rule for examples: each accepts ``--save DIR`` (figures, and for meshcat examples their HTML and
PNG outputs) and honors TASKSPACE_FAST=1; with --save or MPLBACKEND=Agg none opens a window or a
live viewer. Files starting with ``_`` are helpers and are not run.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted(
    p
    for p in (ROOT / "examples").rglob("*.py")
    if not p.name.startswith("_") and "__pycache__" not in p.parts
)
TIMEOUT = 300  # seconds per example


@pytest.mark.slow
@pytest.mark.parametrize(
    "script", EXAMPLES, ids=[p.relative_to(ROOT / "examples").as_posix() for p in EXAMPLES]
)
def test_example_runs_headless(script: Path, tmp_path: Path) -> None:
    env = dict(os.environ, TASKSPACE_FAST="1", MPLBACKEND="Agg")
    env.pop("DISPLAY", None)
    try:
        proc = subprocess.run(
            [sys.executable, str(script), "--save", str(tmp_path)],
            cwd=str(ROOT),
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
            stdin=subprocess.DEVNULL,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{script.name} did not finish within {TIMEOUT} s")
    assert proc.returncode == 0, (
        f"{script.name} exited with {proc.returncode}\n--- stdout ---\n{proc.stdout[-3000:]}"
        f"\n--- stderr ---\n{proc.stderr[-3000:]}"
    )


def test_examples_exist() -> None:
    assert any(p.name == "demo_main.py" for p in EXAMPLES)
