"""read_g2o refuses several FIX lines instead of keeping the last (audit 31).

A g2o file may fix several vertices (one FIX line each); a PoseGraph holds one pose fixed,
and read_g2o silently kept the last FIX: "FIX 0 ... FIX 1" optimized with pose 0 free.
"""

from __future__ import annotations

import pytest

from taskspace.errors import InvalidInputError
from taskspace.estimation import read_g2o

HEAD = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"


def test_one_fix_line_is_read(tmp_path):
    path = tmp_path / "one.g2o"
    path.write_text(HEAD + "FIX 1\n")
    assert read_g2o(path).fixed == 1


def test_several_fix_lines_are_refused(tmp_path):
    path = tmp_path / "two.g2o"
    path.write_text(HEAD + "FIX 0\nFIX 1\n")
    with pytest.raises(InvalidInputError, match=r"two.g2o:5: .*FIX.*line 4"):
        read_g2o(path)
    path.write_text(HEAD + "FIX 1\nFIX 1\n")  # the same pose twice: harmless, accepted
    assert read_g2o(path).fixed == 1
