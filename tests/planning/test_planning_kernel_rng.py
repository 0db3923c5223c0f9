"""The compiled planner's random stream against a reference written from the published algorithms.

xoshiro256++ and splitmix64 (Blackman and Vigna, "Scrambled linear pseudorandom number
generators", ACM TOMS 2021; the authors' reference C code), the 53-bit unit draw, Lemire's
bounded integers with rejection ("Fast random integer generation in an interval", ACM TOMACS
2019) and Marsaglia's polar method, in plain Python integers and floats; then the moments and
frequencies a planner relies on (uniform targets, uniform node picks, standard normal steps).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from taskspace._native import planning_kernel

MASK = (1 << 64) - 1

kernel = planning_kernel()
pytestmark = pytest.mark.skipif(
    kernel is None or not hasattr(kernel, "plan_rng_draws"), reason="compiled kernel missing"
)


def _rotl(x: int, k: int) -> int:
    return ((x << k) | (x >> (64 - k))) & MASK


class Reference:
    """xoshiro256++ seeded by four splitmix64 steps."""

    def __init__(self, seed: int) -> None:
        self.s = []
        for _ in range(4):
            seed = (seed + 0x9E3779B97F4A7C15) & MASK
            z = seed
            z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
            z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
            self.s.append(z ^ (z >> 31))
        self.spare: float | None = None

    def next(self) -> int:
        s = self.s
        result = (_rotl((s[0] + s[3]) & MASK, 23) + s[0]) & MASK
        t = (s[1] << 17) & MASK
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = _rotl(s[3], 45)
        return result

    def unit(self) -> float:
        return (self.next() >> 11) * 2.0**-53

    def below(self, n: int) -> int:
        m = self.next() * n
        low = m & MASK
        if low < n:
            floor = (1 << 64) % n
            while low < floor:
                m = self.next() * n
                low = m & MASK
        return m >> 64

    def normal(self) -> float:
        if self.spare is not None:
            value, self.spare = self.spare, None
            return value
        while True:
            u = 2.0 * self.unit() - 1.0
            v = 2.0 * self.unit() - 1.0
            r2 = u * u + v * v
            if 0.0 < r2 < 1.0:
                break
        f = math.sqrt(-2.0 * math.log(r2) / r2)
        self.spare = v * f
        return u * f


def test_splitmix64_seeding_matches_its_published_first_output() -> None:
    # splitmix64 from state 0: first output 0xE220A8397B1DCDAF (the authors' reference code)
    assert Reference(0).s[0] == 0xE220A8397B1DCDAF


@pytest.mark.parametrize("seed", [0, 1, 12345, (1 << 64) - 1])
@pytest.mark.parametrize("bound", [1, 7, 1000, (1 << 31) - 1])
def test_the_kernel_stream_is_the_reference_stream(seed: int, bound: int) -> None:
    raw, unit, below, normal = kernel.plan_rng_draws(seed, 200, bound)
    ref = [Reference(seed) for _ in range(4)]
    assert raw == [ref[0].next() for _ in range(200)]
    assert unit == [ref[1].unit() for _ in range(200)]
    assert below == [ref[2].below(bound) for _ in range(200)]
    np.testing.assert_allclose(normal, [ref[3].normal() for _ in range(200)], rtol=1e-15, atol=0)


def test_the_draws_have_the_moments_and_frequencies_a_planner_needs() -> None:
    n = 200_000
    _, unit, below, normal = kernel.plan_rng_draws(7, n, 10)
    u = np.asarray(unit)
    assert u.min() >= 0.0 and u.max() < 1.0
    assert abs(u.mean() - 0.5) < 5 * math.sqrt(1 / 12 / n)
    assert abs(u.var() - 1 / 12) < 0.002
    counts = np.bincount(np.asarray(below), minlength=10)
    assert counts.size == 10
    chi2 = float(((counts - n / 10) ** 2 / (n / 10)).sum())
    assert chi2 < 33.7  # chi-square with 9 degrees of freedom: P(> 33.7) = 1e-4
    z = np.asarray(normal)
    assert abs(z.mean()) < 5 / math.sqrt(n)
    assert abs(z.var() - 1.0) < 0.02
    # tails of a standard normal: P(|z| > 2) = 0.0455
    assert abs(np.mean(np.abs(z) > 2.0) - 0.0455) < 0.003


def test_bad_arguments_are_refused() -> None:
    from taskspace.errors import InvalidInputError

    with pytest.raises(InvalidInputError):
        kernel.plan_rng_draws(1, -1, 3)
    with pytest.raises(InvalidInputError):
        kernel.plan_rng_draws(1, 3, 0)
