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
