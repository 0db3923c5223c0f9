"""Import taskspace from this checkout inside a peer's virtual environment, with its kernels.

The peers' environments (``make bench-peers``) import taskspace from ``src/`` of the checkout.
Since the kernels are built by pip into ``build/<tag>/`` (an editable install maps them from
there), ``src/`` alone holds no compiled module: without the build directory on the
``taskspace._native`` path a peer would drive taskspace's Python collision checker (3x slower
per call) and the comparison would be unfair. The kernels load only when the peer's
Pinocchio/coal/eigenpy are the versions they were built against (their own check).
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def use_checkout() -> Path:
    """Put the checkout's ``src/`` and its built kernels on the path; returns the root.

    Prints to stderr when the kernels cannot be used (the peer then runs the Python paths).
    """
    sys.path.insert(0, str(ROOT / "src"))
    sys.path.insert(0, str(ROOT))
    import taskspace._native as native

    builds = sorted(
        ROOT.glob("build/*/install/platlib/taskspace/_native"),
        key=lambda p: p.stat().st_mtime,
        reverse=True,
    )
    native.__path__[:] = [*native.__path__, *(str(p) for p in builds)]
    reason = native.status()
    if reason:
        print(f"# taskspace kernels not in use in this peer: {reason}", file=sys.stderr)
    return ROOT
