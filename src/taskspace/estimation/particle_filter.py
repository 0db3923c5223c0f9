"""Particle filter / Monte Carlo localization (slides 6:11-6:13, 7:21-7:25).

The belief is a weighted particle set ``q(x) = sum_i w_i delta(x - x_i)``. One step of the
Bayes filter ``p_t(x_t) ~ P(y_t | x_t) int P(x_t | u_{t-1}, x_{t-1}) p_{t-1}(x_{t-1})`` is

1. resample to unit-weight particles (here only when the effective sample size
   ``N_eff = 1 / sum w_i^2`` falls below ``ess_threshold * N``),
2. sample the motion model ``x_t^i ~ P(x_t | u_{t-1}, x_{t-1}^i)`` (:meth:`ParticleFilter.predict`),
3. weight by the observation model ``w_t^i ~ P(y_t | x_t^i)`` (:meth:`ParticleFilter.update`).

Against particle depletion (slide 7:25) a fraction of the particles can be drawn from an
observation-driven proposal ``x ~ P(y_t | x)`` (sensor resetting; with ``adaptive_mixture``
the fraction follows the augmented-MCL rule ``max(0, 1 - w_fast / w_slow)`` of Thrun et al.).
All operations are vectorized over particles; the callables receive the whole ``(N, d)`` array.

Thread safety: :class:`ParticleFilter` serializes its calls with a lock (see there);
:class:`ParticleFilterOptions` is immutable.
"""

from __future__ import annotations

import enum
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from taskspace._validation import FloatArray, as_float_array, as_scalar, check_finite
from taskspace.errors import InvalidInputError, ShapeError
from taskspace.estimation._inputs import call_model
from taskspace.estimation._serialized import serialized
from taskspace.estimation.angles import _indices
from taskspace.estimation.resampling import get_resampler

logger = logging.getLogger(__name__)

MotionSampler = Callable[[FloatArray, Any, np.random.Generator], FloatArray]
LogLikelihood = Callable[[FloatArray, Any], FloatArray]
ObservationSampler = Callable[[Any, int, np.random.Generator], FloatArray]


@dataclass(frozen=True, kw_only=True)
class ParticleFilterOptions:
    """Settings of :class:`ParticleFilter`.

    Attributes:
        resampling: ``"systematic"``, ``"stratified"``, ``"residual"`` or ``"multinomial"``.
        ess_threshold: resample when ``N_eff < ess_threshold * N`` (1.0: every step).
        mixture_fraction: fraction of particles replaced after resampling by draws from the
            observation proposal (needs ``observation_sampler``).
        adaptive_mixture: use the augmented-MCL fraction ``max(0, 1 - w_fast / w_slow)``
            (capped by ``mixture_fraction``) instead of the fixed fraction. ``w_slow`` and
            ``w_fast`` average the measurement likelihood ``sum_i w_i P(z | x_i)`` of the
            predicted particles (Thrun's mean of ``P(z | x_i)`` when the weights are uniform),
            kept as logarithms: a constant added to every log-likelihood leaves the fraction
            unchanged.
        alpha_slow: decay rate of the long-term average likelihood ``w_slow``, in ``(0, 1]``.
        alpha_fast: decay rate of the short-term average likelihood ``w_fast``, in ``(0, 1]``.
        angular_dims: state indices that are angles [rad] (circular mean in :meth:`estimate`);
            an index or a sequence of distinct indices (negative ones count from the end).
    """

    resampling: str = "systematic"
    ess_threshold: float = 0.5
    mixture_fraction: float = 0.0
    adaptive_mixture: bool = False
    alpha_slow: float = 0.001
    alpha_fast: float = 0.1
    angular_dims: tuple[int, ...] = ()


def _log_blend(log_w: float, log_new: float, alpha: float) -> float:
    """``log((1 - alpha) w + alpha w_new)`` from ``log w`` and ``log w_new``."""
    if alpha >= 1.0:
        return log_new
    return float(np.logaddexp(math.log1p(-alpha) + log_w, math.log(alpha) + log_new))


class PFStatus(enum.Enum):
    """Outcome of a particle filter run."""

    SUCCESS = "success"
    DEGENERATE = "degenerate"


@dataclass(frozen=True)
class ParticleFilterResult:
    """History of a particle filter run.

    Attributes:
        success: ``False`` if all weights collapsed to zero at some step.
        status: outcome.
        means: ``(T, d)`` weighted means after each update.
        covs: ``(T, d, d)`` weighted covariances.
        ess: ``(T,)`` effective sample size after each update (before resampling).
        num_resamples: number of resampling steps.
        num_injected: total number of particles drawn from the observation proposal.
        time_s: wall time [s].
        message: diagnostic text.
    """

    success: bool
    status: PFStatus
    means: FloatArray
    covs: FloatArray
    ess: FloatArray
    num_resamples: int
    num_injected: int
    time_s: float
    message: str = ""


class ParticleFilter:
    """Sampling-importance-resampling particle filter (slide 7:22).

    Args:
        particles: ``(N, d)`` initial particles (samples of the prior).
        motion_sampler: ``f(particles, u, rng) -> (N, d)`` samples of ``P(x_t | u, x_{t-1})``.
        log_likelihood: ``g(particles, z) -> (N,)`` values of ``log P(z | x)``.
        rng: random generator (all randomness of the filter).
        observation_sampler: optional ``h(z, n, rng) -> (n, d)`` draws from a proposal
            proportional to ``P(z | x)`` (the mixture proposal of slide 7:25).
        options: settings.

    User functions: an exception other than a ``TaskspaceError`` raised by one of them is
    re-raised as :class:`~taskspace.errors.CallbackError` naming it (the original is its
    ``__cause__``); what they return is checked (shape, finiteness) before it is used; the
    belief is left unchanged when a step fails.

    Thread safety: calls are serialized by the filter's lock; each of ``predict``, ``update``,
    ``resample``, ``run`` is atomic, so threads sharing one filter (a sensor callback updating
    while a timer predicts) lose no update; they do not run in parallel (use one filter per
    thread for that). Read the belief between calls, not during another thread's update.
    """

    def __init__(
        self,
        particles: Any,
        motion_sampler: MotionSampler,
        log_likelihood: LogLikelihood,
        rng: np.random.Generator,
        *,
        observation_sampler: ObservationSampler | None = None,
        options: ParticleFilterOptions | None = None,
    ) -> None:
        self._lock = threading.RLock()
        self.options = options or ParticleFilterOptions()
        o = self.options
        self._resample = get_resampler(o.resampling)
        if not 0.0 <= as_scalar(o.ess_threshold, "ess_threshold") <= 1.0:
            raise InvalidInputError(f"ess_threshold must be in [0, 1], got {o.ess_threshold}")
        if not 0.0 <= as_scalar(o.mixture_fraction, "mixture_fraction") < 1.0:
            raise InvalidInputError(f"mixture_fraction must be in [0, 1), got {o.mixture_fraction}")
        for label in ("alpha_slow", "alpha_fast"):  # -1, NaN, 5 made the mixture meaningless
            rate = getattr(o, label)
            if not 0.0 < as_scalar(rate, label) <= 1.0:
                raise InvalidInputError(f"{label} must be in (0, 1], got {rate!r}")
        if o.mixture_fraction > 0.0 and observation_sampler is None:
            raise InvalidInputError("mixture_fraction > 0 needs an observation_sampler")
        for label, fn in (
            ("motion_sampler", motion_sampler),
            ("log_likelihood", log_likelihood),
            ("observation_sampler", observation_sampler),
        ):
            if fn is not None and not callable(fn):
                raise InvalidInputError(f"{label} must be a function, got {type(fn).__name__}")
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy Generator (np.random.default_rng(seed)), got "
                f"{type(rng).__name__}"
            )
        p = np.array(as_float_array(particles, "particles"), dtype=np.float64)
        if p.ndim == 1:
            p = p[:, None]
        if p.ndim != 2 or p.shape[0] < 1:
            raise ShapeError("particles", (-1, -1), tuple(p.shape))
        check_finite(p, "particles")
        # checked here: out of range it was a bare IndexError in estimate(), after the run
        dims = _indices(o.angular_dims, "angular_dims")
        wrong = [i for i in dims if not -p.shape[1] <= i < p.shape[1]]
        if wrong:
            raise InvalidInputError(
                f"angular_dims {wrong} are not indices of the {p.shape[1]}-D state"
            )
        normalized = [i % p.shape[1] for i in dims]
        if len(set(normalized)) != len(normalized):
            raise InvalidInputError(f"angular_dims has repeated indices: {dims}")
        self._angular_dims = tuple(normalized)
        self.particles = p
        self.log_weights = np.full(p.shape[0], -np.log(p.shape[0]))
        self.motion_sampler = motion_sampler
        self.log_likelihood = log_likelihood
        self.observation_sampler = observation_sampler
        self.rng = rng
        # log w_slow, log w_fast (None until the first likelihood): w = exp(-800) underflowed
        # to 0, the averages stayed 0 and the adaptive mixture never injected a particle
        self._log_w_slow: float | None = None
        self._log_w_fast: float | None = None
        self.num_resamples = 0
        self.num_injected = 0

    @property
    def num_particles(self) -> int:
        """Number of particles ``N``."""
        return int(self.particles.shape[0])

    @property
    def weights(self) -> FloatArray:
        """Normalized weights ``w_i``."""
        w = np.exp(self.log_weights - self.log_weights.max())
        return w / w.sum()

    def effective_sample_size(self) -> float:
        """``N_eff = 1 / sum w_i^2``."""
        w = self.weights
        return float(1.0 / np.dot(w, w))

    @serialized
    def predict(self, u: Any) -> None:
        """Move every particle with a sample of the motion model ``P(x_t | u, x_{t-1})``."""
        new = as_float_array(
            call_model(self.motion_sampler, "motion_sampler", self.particles, u, self.rng),
            "motion_sampler output",
        )
        if new.shape != self.particles.shape:
            raise ShapeError("motion_sampler output", self.particles.shape, tuple(new.shape))
        check_finite(new, "motion_sampler output")
        self.particles = new

    @serialized
    def update(self, z: Any) -> float:
        """Reweight by ``P(z | x_i)``, then resample if ``N_eff < ess_threshold * N``.

        Args:
            z: measurement passed to ``log_likelihood`` (and ``observation_sampler``).

        Returns:
            The effective sample size before resampling.

        Raises:
            InvalidInputError: if the likelihood has the wrong shape or is NaN / +inf.
        """
        ll = as_float_array(
            call_model(self.log_likelihood, "log_likelihood", self.particles, z),
            "log_likelihood output",
        )
        N = self.num_particles
        if ll.shape != (N,):
            raise ShapeError("log_likelihood output", (N,), tuple(ll.shape))
        if np.isnan(ll).any() or np.isposinf(ll).any():
            raise InvalidInputError("log_likelihood returned NaN or +inf")
        lw = self.log_weights + ll
        mx = float(lw.max())
        # log sum_i w_i P(z | x_i): the likelihood of z given the predicted particles
        log_w_avg = mx + math.log(float(np.sum(np.exp(lw - mx)))) if np.isfinite(mx) else -math.inf
        if not np.isfinite(mx):
            # Every particle is impossible: keep the predictive set (uniform weights).
            logger.warning("all particle weights are zero; resetting to uniform weights")
            lw = np.full(N, -np.log(N))
            mx = float(lw.max())
        lw = lw - (mx + np.log(np.sum(np.exp(lw - mx))))
        self.log_weights = lw
        w = np.exp(lw)
        ess = float(1.0 / np.dot(w, w))
        o = self.options
        if o.adaptive_mixture:
            if self._log_w_slow is None or self._log_w_fast is None:
                if math.isfinite(log_w_avg):
                    self._log_w_slow = self._log_w_fast = log_w_avg
            else:  # w += alpha (w_avg - w), in logarithms
                self._log_w_slow = _log_blend(self._log_w_slow, log_w_avg, o.alpha_slow)
                self._log_w_fast = _log_blend(self._log_w_fast, log_w_avg, o.alpha_fast)
        if ess < o.ess_threshold * N or o.ess_threshold >= 1.0:
            self.resample(z)
        return ess

    @serialized
    def resample(self, z: Any | None = None) -> None:
        """Draw ``N`` unit-weight particles, then inject observation-proposal particles."""
        N = self.num_particles
        idx = self._resample(np.exp(self.log_weights), self.rng)
        self.particles = self.particles[idx]
        self.log_weights = np.full(N, -np.log(N))
        self.num_resamples += 1
        o = self.options
        if o.mixture_fraction > 0.0 and z is not None and self.observation_sampler is not None:
            frac = o.mixture_fraction
            if o.adaptive_mixture and self._log_w_slow is not None and self._log_w_fast is not None:
                ratio = math.exp(min(self._log_w_fast - self._log_w_slow, 0.0))
                frac = min(frac, 1.0 - ratio)
            k = int(self.rng.binomial(N, frac)) if frac > 0.0 else 0
            if k > 0:
                new = as_float_array(
                    call_model(self.observation_sampler, "observation_sampler", z, k, self.rng),
                    "observation_sampler output",
                )
                if new.shape != (k, self.particles.shape[1]):
                    raise ShapeError(
                        "observation_sampler output", (k, self.particles.shape[1]), new.shape
                    )
                check_finite(new, "observation_sampler output")
                slots = self.rng.choice(N, size=k, replace=False)
                self.particles[slots] = new
                self.num_injected += k

    @serialized
    def estimate(self) -> tuple[FloatArray, FloatArray]:
        """Weighted mean ``sum w_i x_i`` (circular for ``angular_dims``) and covariance."""
        w = self.weights
        p = self.particles
        mean = w @ p
        diff = p - mean
        for d in self._angular_dims:
            mean[d] = np.arctan2(w @ np.sin(p[:, d]), w @ np.cos(p[:, d]))
            diff[:, d] = np.angle(np.exp(1j * (p[:, d] - mean[d])))
        cov = (diff * w[:, None]).T @ diff
        return mean, cov

    @serialized
    def run(
        self, controls: Sequence[Any], measurements: Sequence[Any | None]
    ) -> ParticleFilterResult:
        """Filter a sequence: predict with ``controls[k]``, update with ``measurements[k]``.

        Updates are skipped for ``None`` measurements; the estimate is recorded each step.

        Returns:
            The :class:`ParticleFilterResult`.
        """
        if len(controls) != len(measurements):
            raise InvalidInputError(
                f"controls and measurements must have the same length, got {len(controls)} "
                f"and {len(measurements)}"
            )
        t0 = time.perf_counter()
        T = len(controls)
        d = self.particles.shape[1]
        means = np.empty((T, d))
        covs = np.empty((T, d, d))
        ess = np.full(T, float(self.num_particles))
        for k in range(T):
            self.predict(controls[k])
            if measurements[k] is not None:
                ess[k] = self.update(measurements[k])
            means[k], covs[k] = self.estimate()
        ok = bool(np.isfinite(means).all())
        return ParticleFilterResult(
            success=ok,
            status=PFStatus.SUCCESS if ok else PFStatus.DEGENERATE,
            means=means,
            covs=covs,
            ess=ess,
            num_resamples=self.num_resamples,
            num_injected=self.num_injected,
            time_s=time.perf_counter() - t0,
            message="" if ok else "non-finite particle estimate",
        )
