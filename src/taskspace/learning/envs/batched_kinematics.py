"""Frame positions of many configurations of a serial chain at once (numpy, no loop per copy).

:class:`BatchedFramePosition` reads the chain from the root to one frame out of a Pinocchio
model (joint placements, joint axes, the frame's placement) and composes
``oMj = oMparent * jointPlacement * motion(q_j)`` for N configurations with array operations:
one pass over the chain's joints, each a few ``(N, 3, 3)`` products. Revolute and prismatic
joints (axis-aligned or not) are supported; other joints raise
:class:`~taskspace.errors.InvalidInputError`. The results are Pinocchio's forward kinematics
(checked against ``pin.framesForwardKinematics`` in the tests).

Thread safety: a :class:`BatchedFramePosition` is read-only after construction; its calls
allocate their own arrays and may run from several threads.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from taskspace.errors import InvalidInputError

_AXES = {"X": 0, "Y": 1, "Z": 2}


def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


class BatchedFramePosition:
    """World positions of one frame for batches of configurations.

    Args:
        model: the Pinocchio model.
        frame: the frame's name.

    Raises:
        InvalidInputError: unknown frame, or a joint on the chain that is neither revolute
            nor prismatic.
    """

    def __init__(self, model: Any, frame: str) -> None:
        if not model.existFrame(frame):
            names = ", ".join(f.name for f in model.frames)
            raise InvalidInputError(f"unknown frame {frame!r}; the model's frames: {names}")
        fr = model.frames[model.getFrameId(frame)]
        self.nq = int(model.nq)
        self._steps: list[tuple[str, int, np.ndarray, np.ndarray, np.ndarray, int]] = []
        for j in list(model.supports[fr.parentJoint])[1:]:
            jm = model.joints[j]
            name = jm.shortname()
            placement = model.jointPlacements[j]
            if name.startswith("JointModelR") and name[-1] in _AXES:  # RX, RY, RZ
                kind, k = "R", _AXES[name[-1]]
                axis = np.eye(3)[k]
            elif name.startswith("JointModelP") and name[-1] in _AXES:  # PX, PY, PZ
                kind, k = "P", _AXES[name[-1]]
                axis = np.eye(3)[k]
            elif name == "JointModelRevoluteUnaligned":
                kind, k, axis = "U", -1, np.asarray(jm.extract().axis, dtype=float).copy()
            elif name == "JointModelPrismaticUnaligned":
                kind, k, axis = "P", -1, np.asarray(jm.extract().axis, dtype=float).copy()
            else:
                raise InvalidInputError(
                    f"joint {model.names[j]!r} ({name}) on the chain to {frame!r} is not "
                    "supported; use revolute or prismatic joints (RX/RY/RZ/PX/PY/PZ/unaligned)"
                )
            self._steps.append(
                (
                    kind,
                    k,
                    axis,
                    np.asarray(placement.rotation).copy(),
                    np.asarray(placement.translation).copy(),
                    int(jm.idx_q),
                )
            )
        self._frame_translation = np.asarray(fr.placement.translation).copy()

    def __call__(self, configurations: np.ndarray) -> np.ndarray:
        """Positions (N x 3) [m] of the frame at the rows of ``configurations`` (N x nq)."""
        Q = np.asarray(configurations, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.nq:
            raise InvalidInputError(f"configurations must be N x {self.nq}, got {Q.shape}")
        n = Q.shape[0]
        # Rotations as (N, 3, 3) arrays; products with a constant 3 x 3 or 3-vector are one
        # (3N x 3) matrix product (a stacked matmul is much slower for small matrices).
        R: np.ndarray | None = None  # None: identity (the root)
        p = np.zeros((n, 3))
        for kind, k, axis, rot, trans, iq in self._steps:
            if R is None:
                p = p + trans
                A = np.empty((n, 3, 3))
                A[:] = rot
            else:
                flat = R.reshape(3 * n, 3)
                p = p + (flat @ trans).reshape(n, 3)
                A = (flat @ rot).reshape(n, 3, 3)
            q = Q[:, iq]
            if kind == "P":
                p = p + (A.reshape(3 * n, 3) @ axis).reshape(n, 3) * q[:, None]
                R = A
                continue
            c, s = np.cos(q)[:, None], np.sin(q)[:, None]
            if kind == "R":
                # Rotation about e_k mixes the two other columns (i, j) = (k+1, k+2) mod 3.
                i, jj = (k + 1) % 3, (k + 2) % 3
                ai, aj = A[:, :, i].copy(), A[:, :, jj].copy()
                A[:, :, i] = c * ai + s * aj
                A[:, :, jj] = c * aj - s * ai
                R = A
            else:  # Rodrigues: A (c I + s [a]x + (1 - c) a a^T)
                flat = A.reshape(3 * n, 3)
                Aa = (flat @ axis).reshape(n, 3)
                R = (
                    c[:, :, None] * A
                    + s[:, :, None] * (flat @ _skew(axis)).reshape(n, 3, 3)
                    + (1.0 - c)[:, :, None] * Aa[:, :, None] * axis[None, None, :]
                )
        if R is None:
            return p + self._frame_translation
        return p + (R.reshape(3 * n, 3) @ self._frame_translation).reshape(n, 3)
