"""Grasp synthesis for multi-finger hands: contact sets sampled on the surface, scored.

1. Sample sets of ``k`` points uniformly over the object's surface (one per finger), at least
   ``min_spacing`` apart, with point contacts with Coulomb friction along the inward normals.
2. Keep the sets in force closure and score them by the Ferrari-Canny epsilon (L1) of their
   linearized friction cones (one convex hull each), best first.

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from taskspace._validation import check_count
from taskspace.grasping.contact import (
    ContactType,
    GraspContact,
    check_edges,
    nonnegative,
)
from taskspace.grasping.epsilon import grasp_epsilon_batch
from taskspace.grasping.object_mesh import TriangleMesh

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class MultiFingerOptions:
    """Settings of :func:`sample_multifinger_grasps`.

    Attributes:
        fingers: contacts per grasp (>= 2; 3 or 4 for a hand).
        samples: contact sets sampled (each gives at most one candidate).
        mu: friction coefficient of the fingertips.
        edges: edges of each linearized friction cone.
        min_spacing: smallest distance between two contacts of a set [m].
    """

    fingers: int = 3
    samples: int = 200
    mu: float = 0.5
    edges: int = 8
    min_spacing: float = 0.02

    def __post_init__(self) -> None:
        object.__setattr__(self, "fingers", check_count(self.fingers, "fingers", minimum=2))
        object.__setattr__(self, "samples", check_count(self.samples, "samples", minimum=1))
        object.__setattr__(self, "mu", nonnegative(self.mu, "mu"))
        object.__setattr__(self, "edges", check_edges(self.edges))
        object.__setattr__(self, "min_spacing", nonnegative(self.min_spacing, "min_spacing"))


@dataclass(frozen=True)
class MultiFingerCandidates:
    """Contact sets in force closure in the object's frame, best first.

    Attributes:
        points: ``(N, k, 3)`` contact points [m].
        normals: ``(N, k, 3)`` inward unit normals.
        epsilon: Ferrari-Canny epsilon (L1) of each set (``> 0``) ``(N,)``.
        center: the point torques are taken about (the mesh's center of mass,
            :attr:`TriangleMesh.centroid`) [m].
        options: the sampling settings.
        sampled: how many sets were drawn (the rest were too close or not in closure).
    """

    points: FloatArray
    normals: FloatArray
    epsilon: FloatArray
    center: FloatArray
    options: MultiFingerOptions
    sampled: int

    def __len__(self) -> int:
        return len(self.epsilon)

    def contacts(self, i: int) -> list[GraspContact]:
        """The point contacts (with friction) of candidate ``i``."""
        return [
            GraspContact(p, n, type=ContactType.POINT_FRICTION, mu=self.options.mu)
            for p, n in zip(self.points[i], self.normals[i])
        ]


def sample_multifinger_grasps(
    mesh: TriangleMesh, rng: np.random.Generator, options: MultiFingerOptions | None = None
) -> MultiFingerCandidates:
    """Contact sets for a ``k``-finger hand on ``mesh``, in force closure, best epsilon first."""
    o = options or MultiFingerOptions()
    k = o.fingers
    points, outward, _ = mesh.sample_surface(o.samples * k, rng)
    points = points.reshape(o.samples, k, 3)
    normals = -outward.reshape(o.samples, k, 3)
    gaps = np.linalg.norm(points[:, :, None, :] - points[:, None, :, :], axis=-1)
    gaps[:, np.arange(k), np.arange(k)] = np.inf
    spaced = gaps.min(axis=(1, 2)) >= o.min_spacing
    center = mesh.centroid
    candidates = np.flatnonzero(spaced)
    scores = (
        grasp_epsilon_batch(
            points[candidates], normals[candidates], mu=o.mu, edges=o.edges, center=center
        )
        if len(candidates)
        else np.zeros(0)
    )
    idx = candidates[scores > 0.0]
    epsilon = scores[scores > 0.0]
    order = np.argsort(-epsilon, kind="stable")
    return MultiFingerCandidates(
        points[idx][order], normals[idx][order], epsilon[order], center, o, o.samples
    )
