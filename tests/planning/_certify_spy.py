"""A spy on taskspace.planning.certify.certify_path for the certified-retry tests."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from taskspace.planning import certify as certify_module


def spy_certificates(monkeypatch: pytest.MonkeyPatch) -> list[tuple[np.ndarray, Any]]:
    """Record every path that certify_planned certifies, with its certificate."""
    seen: list[tuple[np.ndarray, Any]] = []
    real = certify_module.certify_path

    def spy(robot: Any, path: Any, **kwargs: Any) -> Any:
        cert = real(robot, path, **kwargs)
        seen.append((np.array(path, dtype=float), cert))
        return cert

    monkeypatch.setattr(certify_module, "certify_path", spy)
    return seen
