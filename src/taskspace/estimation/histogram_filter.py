"""Bayes filter on a discrete state space: histogram / grid localization (slides 7:9-7:17).

The belief is a table ``p_t(x)`` over ``K`` cells (slide 6:5). One step of the Bayes filter
(slide 7:15):

* prediction ``p_hat_t(x') = sum_x P(x' | u, x) p_{t-1}(x)`` -- a matrix-vector product with the
  column-stochastic transition matrix ``T[x', x]`` (or, for motion by a shift with a noise kernel,
  a circular convolution);
* correction ``p_t(x) = c_t P(y_t | x) p_hat_t(x)``.

Prediction alone is dead reckoning (slide 7:17): the belief only spreads out.
The 1-D hallway with doors of slides 7:9-7:15 is :class:`HallwayWorld`.

Thread safety: :class:`HistogramFilter` serializes its calls with a lock (see there);
:class:`HallwayWorld` is an immutable value: :meth:`HallwayWorld.simulate` draws from the generator
it is given (one generator per thread).
"""

from __future__ import annotations

import enum
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_matrix, as_vector, check_int
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation._serialized import serialized

MAX_CELLS = 16_384
"""Largest ``num_cells`` of :func:`shift_transition_matrix` (a dense 2 GiB matrix)."""


def shift_transition_matrix(
    num_cells: int, shift: int, kernel: Any = (1.0,), *, cyclic: bool = True
) -> FloatArray:
    """Transition matrix of "move ``shift`` cells" with a centred noise kernel.

    ``T[x', x] = kernel[x' - x - shift + c]`` with ``c = len(kernel) // 2``. Non-cyclic worlds
    pile the mass that would leave the hallway onto its end cells.

    Args:
        num_cells: number of cells ``K``.
        shift: commanded motion [cells].
        kernel: odd-length non-negative weights of the motion error (normalized internally).
        cyclic: wrap around the ends.

    Returns:
        ``(K, K)`` column-stochastic matrix.
    """
    num_cells = check_int(num_cells, "num_cells", minimum=1)
    if num_cells > MAX_CELLS:  # a dense K x K matrix: 10**6 cells was a bare MemoryError
        raise InvalidInputError(
            f"num_cells must be at most {MAX_CELLS:,} (the transition matrix is dense "
            f"K x K), got {num_cells:,}"
        )
    shift = check_int(shift, "shift")  # 2.5 was a bare IndexError
    k = as_float_array(kernel, "kernel")
    if k.ndim != 1 or k.size % 2 == 0 or not np.isfinite(k).all() or (k < 0).any():
        raise InvalidInputError(
            f"kernel must be a 1-D array of odd length of finite non-negative weights, got {k}"
        )
    if not k.max() > 0:
        raise InvalidInputError("kernel weights sum to zero: the motion goes nowhere")
    # divided by the largest first: [1e308, 1e308, 1] summed to inf and gave a zero matrix
    # ([inf, 1, 1] NaN columns)
    k = k / k.max()
    k = k / k.sum()
    c = k.size // 2
    T = np.zeros((num_cells, num_cells))
    cols = np.arange(num_cells)
    for j, w in enumerate(k):
        dest = cols + shift + j - c
        dest = dest % num_cells if cyclic else np.clip(dest, 0, num_cells - 1)
        np.add.at(T, (dest, cols), w)
    return T


class HistogramStatus(enum.Enum):
    """Outcome of a histogram filter run."""

    SUCCESS = "success"
    INCONSISTENT = "inconsistent"


@dataclass(frozen=True)
class HistogramFilterResult:
    """History of a histogram filter run.

    Attributes:
        success: ``False`` if a measurement had zero probability under the prediction.
        status: outcome.
        beliefs: ``(T, K)`` posterior tables ``p_t``.
        predicted: ``(T, K)`` predictive tables ``p_hat_t``.
        evidence: ``(T,)`` normalizers ``P(y_t | y_0:t-1)``.
        time_s: wall time [s].
        message: diagnostic text.
    """

    success: bool
    status: HistogramStatus
    beliefs: FloatArray
    predicted: FloatArray
    evidence: FloatArray
    time_s: float
    message: str = ""


class HistogramFilter:
    """Discrete Bayes filter over ``K`` cells.

    Args:
        prior: ``(K,)`` non-negative prior (normalized internally).

    Thread safety: calls are serialized by the filter's lock; each of ``predict``, ``update``,
    ``run`` is atomic, so threads sharing one filter (a sensor callback updating while a timer
    predicts) lose no update; they do not run in parallel (use one filter per thread for that).
    Read the belief between calls, not during another thread's update.
    """

    def __init__(self, prior: Any) -> None:
        self._lock = threading.RLock()
        p = as_vector(prior, None, "prior")
        if (p < 0).any() or not p.max() > 0:
            raise InvalidInputError("prior must be non-negative with a positive sum")
        p = p / p.max()  # first: [1e308, 1e308] summed to inf, the belief was all zeros
        self.belief = p / p.sum()

    @property
    def num_cells(self) -> int:
        """Number of cells ``K``."""
        return int(self.belief.shape[0])

    @serialized
    def predict(self, transition: Any) -> None:
        """``p_hat(x') = sum_x T[x', x] p(x)`` with a ``(K, K)`` column-stochastic ``T``."""
        K = self.num_cells
        T = as_matrix(transition, (K, K), "transition")
        if (T < 0).any() or not np.allclose(T.sum(axis=0), 1.0, atol=1e-9):
            raise InvalidInputError("transition must be column-stochastic (columns sum to 1)")
        self.belief = T @ self.belief

    @serialized
    def update(self, likelihood: Any) -> float:
        """``p(x) = c P(y | x) p_hat(x)``; returns the evidence ``1 / c = sum_x P(y|x) p_hat(x)``.

        Raises:
            InvalidInputError: if the likelihood is negative or the measurement is impossible
                under the current belief (evidence zero).
        """
        lik = as_vector(likelihood, self.num_cells, "likelihood")
        if (lik < 0).any():
            raise InvalidInputError("likelihood must be non-negative")
        post = lik * self.belief
        ev = float(post.sum())
        if not ev > 0.0:
            raise InvalidInputError(
                "measurement has zero probability under the current belief (evidence 0)"
            )
        self.belief = post / ev
        return ev

    @serialized
    def run(
        self, transitions: Sequence[Any], likelihoods: Sequence[Any | None]
    ) -> HistogramFilterResult:
        """Predict with ``transitions[t]`` then update with ``likelihoods[t]`` (``None``: skip)."""
        if len(transitions) != len(likelihoods):
            raise InvalidInputError("transitions and likelihoods must have the same length")
        t0 = time.perf_counter()
        T = len(transitions)
        K = self.num_cells
        beliefs = np.empty((T, K))
        pred = np.empty((T, K))
        ev = np.ones(T)
        for t in range(T):
            self.predict(transitions[t])
            pred[t] = self.belief
            if likelihoods[t] is not None:
                ev[t] = self.update(likelihoods[t])
            beliefs[t] = self.belief
        return HistogramFilterResult(
            success=True,
            status=HistogramStatus.SUCCESS,
            beliefs=beliefs,
            predicted=pred,
            evidence=ev,
            time_s=time.perf_counter() - t0,
        )


@dataclass(frozen=True, kw_only=True)
class HallwayWorld:
    """1-D hallway with doors (slides 7:9-7:15).

    The robot moves along ``num_cells`` cells (cyclic) and a door detector reports ``True``
    with probability ``p_detect`` in front of a door and ``p_false_alarm`` elsewhere.

    Attributes:
        num_cells: number of cells.
        doors: indices of the cells in front of a door.
        p_detect: ``P(y = door | x at door)``.
        p_false_alarm: ``P(y = door | x not at door)``.
        motion_kernel: motion error weights for undershoot / exact / overshoot by one cell.
    """

    num_cells: int = 60
    doors: tuple[int, ...] = (8, 14, 38)
    p_detect: float = 0.8
    p_false_alarm: float = 0.1
    motion_kernel: tuple[float, ...] = (0.1, 0.8, 0.1)
    _door_mask: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if any(not 0 <= d < self.num_cells for d in self.doors):
            raise InvalidInputError(
                f"door cells must be in [0, {self.num_cells}), got {self.doors}"
            )
        mask = np.zeros(self.num_cells, dtype=bool)
        mask[list(self.doors)] = True
        object.__setattr__(self, "_door_mask", mask)

    def likelihood(self, saw_door: bool) -> FloatArray:
        """``P(y | x)`` for every cell."""
        p = np.where(self._door_mask, self.p_detect, self.p_false_alarm)
        return p if saw_door else 1.0 - p

    def transition(self, shift: int) -> FloatArray:
        """``P(x' | u = shift, x)`` as a ``(K, K)`` matrix."""
        return shift_transition_matrix(self.num_cells, shift, self.motion_kernel, cyclic=True)

    def simulate(
        self, start: int, shifts: Sequence[int], rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """True cells and door readings after each commanded shift.

        Returns:
            ``(T,)`` true cells and ``(T,)`` boolean door readings.
        """
        if not 0 <= start < self.num_cells:
            raise ShapeError("start", (self.num_cells,), (start,))
        k = np.asarray(self.motion_kernel) / np.sum(self.motion_kernel)
        c = k.size // 2
        x = int(start)
        cells, seen = [], []
        for s in shifts:
            x = (x + int(s) + int(rng.choice(k.size, p=k)) - c) % self.num_cells
            cells.append(x)
            p = self.p_detect if self._door_mask[x] else self.p_false_alarm
            seen.append(bool(rng.random() < p))
        return np.array(cells), np.array(seen)
