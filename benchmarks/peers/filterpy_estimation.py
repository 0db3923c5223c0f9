"""filterpy peer for the estimation suite (runs in .venv-peers/filterpy).

Prints one JSON line with per-call timings (microseconds) of
* ``kf_step``: ``KalmanFilter.predict(); update(z)`` on the 4-state constant-velocity model;
* ``batch_sweep``: one predict+update of ``tracks`` independent ``KalmanFilter`` objects in a loop;
* ``systematic_resample`` of ``filterpy.monte_carlo`` at N = 1,000 and 100,000.
Usage: ``python filterpy_estimation.py [--quick]``.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
from filterpy.kalman import KalmanFilter
from filterpy.monte_carlo import systematic_resample

DT = 0.1
Q_ACC = 0.5


def cv_model() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    eye = np.eye(2)
    F = np.block([[eye, DT * eye], [np.zeros((2, 2)), eye]])
    Q = Q_ACC * np.block([[DT**3 / 3 * eye, DT**2 / 2 * eye], [DT**2 / 2 * eye, DT * eye]])
    H = np.hstack([eye, np.zeros((2, 2))])
    R = np.array([[0.1, 0.02], [0.02, 0.2]])
    return F, Q, H, R


def make_kf(x0: np.ndarray) -> KalmanFilter:
    F, Q, H, R = cv_model()
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.F, kf.Q, kf.H, kf.R = F, Q, H, R
    kf.x = x0.copy()
    kf.P = np.eye(4)
    return kf


def stats(samples: list[float]) -> dict[str, float]:
    a = np.asarray(samples) * 1e6
    return {
        "median_us": float(np.median(a)),
        "p95_us": float(np.percentile(a, 95)),
        "p99_us": float(np.percentile(a, 99)),
        "mean_us": float(np.mean(a)),
        "n": int(a.size),
    }


def time_calls(fn, warmup: int, repeat: int) -> dict[str, float]:  # type: ignore[no-untyped-def]
    for _ in range(warmup):
        fn()
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return stats(out)


def main() -> None:
    quick = "--quick" in sys.argv
    rng = np.random.default_rng(0)
    kf = make_kf(np.zeros(4))
    zs = rng.normal(size=(4096, 2))
    it = iter(range(10**9))

    def kf_step() -> None:
        kf.predict()
        kf.update(zs[next(it) % 4096])

    result: dict[str, object] = {"peer": "filterpy"}
    result["kf_step"] = time_calls(kf_step, 200, 2000 if quick else 20000)

    tracks = 1000 if quick else 10000
    filters = [make_kf(x) for x in rng.normal(size=(tracks, 4))]
    z = rng.normal(size=(tracks, 2))

    def sweep() -> None:
        for f, zi in zip(filters, z):
            f.predict()
            f.update(zi)

    result["batch_sweep"] = time_calls(sweep, 1, 3 if quick else 5)
    result["batch_tracks"] = tracks

    for n in (1000, 100000):
        w = rng.random(n)
        w /= w.sum()
        result[f"systematic_resample_{n}"] = time_calls(
            lambda w=w: systematic_resample(w), 5, 50 if quick else 200
        )
    print(json.dumps(result))


if __name__ == "__main__":
    main()
