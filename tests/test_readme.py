"""The README's quick example runs as printed (the README must stay true)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_quick_example_runs_and_reaches_its_target() -> None:
    text = README.read_text()
    start = text.index("## Quick example")
    code = text[text.index("```python\n", start) + len("```python\n") :]
    code = code[: code.index("```")]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, str(README), "exec"), {"__name__": "readme"})
    status, error = out.getvalue().splitlines()[0].split()
    assert status == "IKStatus.SOLVED"
    assert float(error) < 0.02  # m: the tcp reached the target shifted by 0.3 m
    assert out.getvalue().splitlines()[1] == "True"


def test_batch_example_runs_as_a_script(tmp_path: Path) -> None:
    """The batch section's example, saved as a script and run (workers re-import it)."""
    import subprocess
    import sys

    text = README.read_text()
    start = text.index("## Batch work")
    code = text[text.index("```python\n", start) + len("```python\n") :]
    code = code[: code.index("```")]
    script = tmp_path / "batch_example.py"
    script.write_text(code)
    proc = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("BatchStatus.COMPLETE")
    assert float(lines[0].split()[1]) == round(
        9
        + __import__("numpy")
        .random.default_rng(__import__("numpy").random.SeedSequence(0, spawn_key=(3,)))
        .normal(),
        6,
    )
    assert lines[1].endswith("of the poses reached") and int(lines[1].split("%")[0]) >= 95
    assert (tmp_path / "squares.jsonl").exists()
