"""Shared scenario data of the IK tests."""

from __future__ import annotations

import numpy as np

DT = 0.005  # [s]


def benchmark_offset(k: int) -> np.ndarray:
    """Moving-target offset of the IK benchmark at step k [m]."""
    return np.array(
        [0.15 * np.sin(0.004 * k), 0.1 * (np.cos(0.004 * k) - 1.0), 0.1 * np.sin(0.002 * k)]
    )
