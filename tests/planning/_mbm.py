"""Where the tests find the MotionBenchMaker Panda problems (taskspace does not ship them).

``$TASKSPACE_MOTIONBENCHMAKER_DIR``, else ``shared/benchmarks/motionbenchmaker_panda`` beside
the checkout (the project's layout; ``make`` passes the same). Tests that need the files are
skipped when neither exists.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from taskspace.errors import ModelLoadError
from taskspace.planning.scene_loader import motionbenchmaker_dir

BESIDE_CHECKOUT = (
    Path(__file__).resolve().parents[2].parent / "shared" / "benchmarks" / "motionbenchmaker_panda"
)


def mbm_root() -> Path | None:
    """The directory of the problems, or ``None`` when they are not on this machine."""
    try:
        return motionbenchmaker_dir()
    except ModelLoadError:
        return BESIDE_CHECKOUT if BESIDE_CHECKOUT.is_dir() else None


ROOT = mbm_root()
SKIP_REASON = "MotionBenchMaker files not present (set TASKSPACE_MOTIONBENCHMAKER_DIR)"


def reference_free(robot: Any, path: np.ndarray, resolution: float) -> np.ndarray:
    """Pinocchio's computeCollisions (narrow phase on every pair) at the points k / n of every
    edge, n = ceil(|edge| / resolution): True where free."""
    model, geom = robot.model, robot.collision_model
    data, gdata = model.createData(), geom.createData()
    out = []
    for a, b in zip(path[:-1], path[1:]):  # noqa: RUF007
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / resolution - 1e-12)))
        for t in np.arange(n + 1) / n:
            out.append(not pin.computeCollisions(model, data, geom, gdata, a + t * (b - a), True))
    return np.asarray(out)
