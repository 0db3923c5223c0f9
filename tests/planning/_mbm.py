"""Where the tests find the MotionBenchMaker Panda problems (taskspace does not ship them).

``$TASKSPACE_MOTIONBENCHMAKER_DIR``, else ``shared/benchmarks/motionbenchmaker_panda`` beside
the checkout (the project's layout; ``make`` passes the same). Tests that need the files are
skipped when neither exists.
"""

from __future__ import annotations

from pathlib import Path

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
