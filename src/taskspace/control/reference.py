"""Joint-space reference trajectories ``t -> (q_ref, q'_ref, q''_ref)`` (slide 5:30).

Thread safety: :class:`ReferencePoint` is immutable and the references keep only the data given at
construction, so they may be called from several threads as long as nobody modifies their
arrays, nor those of the points they return (a :class:`ConstantReference` returns its own ``q``
and zero arrays).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import (
    FloatArray,
    as_float_array,
    as_matrix,
    as_scalar,
    as_vector,
    check_int,
    check_positive,
)
from taskspace.errors import InvalidInputError


@dataclass(frozen=True)
class ReferencePoint:
    """Reference position, velocity and acceleration at one time.

    Attributes:
        q: position (n,) [rad, m].
        v: velocity (n,) [rad/s, m/s].
        a: acceleration (n,) [rad/s^2, m/s^2].
    """

    q: FloatArray
    v: FloatArray
    a: FloatArray


JointReference = Callable[[float], ReferencePoint]
"""A reference trajectory: ``reference(t)`` returns the :class:`ReferencePoint` at ``t`` [s]."""


class ConstantReference:
    """Hold ``q*`` with zero velocity and acceleration (set-point regulation).

    Args:
        q: the held position (n,) [rad, m].
        velocity_size: size of the (zero) velocity and acceleration; ``None``: ``q``'s size.
            A robot with continuous joints (``(cos, sin)`` per joint) or a floating base has
            ``nv < nq``: give ``robot.nv``.
    """

    def __init__(self, q: Any, velocity_size: int | None = None) -> None:
        self.q = as_vector(q, None, "reference q")
        n = (
            self.q.size
            if velocity_size is None
            else check_int(velocity_size, "velocity_size", minimum=0)
        )
        self._zero = np.zeros(n)

    def __call__(self, t: float) -> ReferencePoint:
        """The constant reference."""
        return ReferencePoint(self.q, self._zero, self._zero)


class SinusoidalReference:
    """``q_ref(t) = center + amplitude sin(2 pi f t + phase)`` per joint, with exact derivatives.

    Args:
        center: mean position (n,) [rad].
        amplitude: amplitude, scalar or (n,) [rad].
        frequency: frequency, scalar or (n,) [Hz] (>= 0).
        phase: phase, scalar or (n,) [rad].
    """

    def __init__(self, center: Any, amplitude: Any, frequency: Any, phase: Any = 0.0) -> None:
        self.center = as_vector(center, None, "center")
        n = self.center.size
        # as_float_array: text / complex values gave a bare ValueError / TypeError
        self.amplitude = as_vector(
            np.broadcast_to(as_float_array(amplitude, "amplitude"), n), n, "amplitude"
        )
        freq = as_vector(np.broadcast_to(as_float_array(frequency, "frequency"), n), n, "frequency")
        if np.any(freq < 0):
            raise InvalidInputError(f"frequency must be >= 0 [Hz], got {frequency!r}")
        self.omega = 2.0 * math.pi * freq
        self.phase = as_vector(np.broadcast_to(as_float_array(phase, "phase"), n), n, "phase")
        with np.errstate(over="ignore", invalid="ignore"):
            peak = np.abs(self.amplitude) * self.omega**2  # was: overflow warnings, inf
        if not np.isfinite(peak).all():
            raise InvalidInputError(
                "amplitude * (2 pi frequency)^2 overflows (the reference acceleration): "
                f"frequency {frequency!r} Hz, amplitude {amplitude!r}"
            )

    def __call__(self, t: float) -> ReferencePoint:
        """Reference at time ``t`` [s] (finite; NaN gave a NaN reference)."""
        if t.__class__ is not float or not math.isfinite(t):  # fast path: finite floats
            t = as_scalar(t, "t")
        arg = self.omega * t + self.phase
        s, c = np.sin(arg), np.cos(arg)
        return ReferencePoint(
            self.center + self.amplitude * s,
            self.amplitude * self.omega * c,
            -self.amplitude * self.omega**2 * s,
        )


class SampledReference:
    """A reference given by samples ``q_0..q_K`` every ``tau`` seconds (slide 5:30).

    Velocities and accelerations come from finite differences,
    ``q''_k = (q_{k-1} + q_{k+1} - 2 q_k) / tau^2`` (slide 5:30; 0 at the first and the last
    sample, which have one neighbour) and ``q'_k = (q_{k+1} - q_{k-1}) / (2 tau)`` (one-sided
    at the ends); between samples all three are interpolated linearly; after the last sample
    the reference holds ``q_K`` at rest.

    Args:
        samples: (K+1, n) positions [rad, m], K >= 2.
        tau: sample spacing [s] (> 0).
    """

    def __init__(self, samples: Any, tau: float) -> None:
        q = as_matrix(samples, (None, None), "samples")
        if q.shape[0] < 3:
            raise InvalidInputError(f"samples needs at least 3 rows, got {q.shape[0]}")
        self.tau = check_positive(tau, "tau (sample spacing [s])")
        self.q = q
        v = np.empty_like(q)
        v[1:-1] = (q[2:] - q[:-2]) / (2.0 * self.tau)
        v[0] = (q[1] - q[0]) / self.tau
        v[-1] = (q[-1] - q[-2]) / self.tau
        a = np.zeros_like(q)
        a[1:-1] = (q[:-2] + q[2:] - 2.0 * q[1:-1]) / self.tau / self.tau  # tau**2 overflowed
        self.v = v
        self.a = a
        self.duration = self.tau * (q.shape[0] - 1)

    def __call__(self, t: float) -> ReferencePoint:
        """Reference at time ``t`` [s] (finite; NaN raised a bare ValueError)."""
        if t.__class__ is not float or not math.isfinite(t):
            t = as_scalar(t, "t")
        if t >= self.duration:
            zero = np.zeros(self.q.shape[1])
            return ReferencePoint(self.q[-1].copy(), zero, zero)
        s = max(t, 0.0) / self.tau
        k = int(s)
        w = s - k
        return ReferencePoint(
            (1 - w) * self.q[k] + w * self.q[k + 1],
            (1 - w) * self.v[k] + w * self.v[k + 1],
            (1 - w) * self.a[k] + w * self.a[k + 1],
        )


def as_reference(reference: Any, size: int, velocity_size: int | None = None) -> JointReference:
    """Accept a callable reference or a fixed target vector (held as :class:`ConstantReference`).

    Args:
        reference: ``reference(t) -> ReferencePoint``, or a target vector of ``size`` entries.
        size: size of the target (the robot's ``nq``).
        velocity_size: size of the target's zero velocity and acceleration (the robot's
            ``nv``); ``None``: ``size``.
    """
    if callable(reference):
        return reference  # type: ignore[no-any-return]
    try:
        return ConstantReference(as_vector(reference, size, "reference"), velocity_size)
    except InvalidInputError as exc:
        raise InvalidInputError(
            f"reference must be callable as reference(t) -> ReferencePoint or a target vector "
            f"of size {size}: {exc}"
        ) from exc
