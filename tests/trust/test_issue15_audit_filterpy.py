"""Issue #15 item 8 checked against filterpy itself (audit of stop 23).

filterpy (a test dependency; else the benchmarks' peer environment ``.venv-peers/filterpy``)
runs the same scenarios in a child process and prints its beliefs as JSON; ours run
here and must agree to round-off. The scenarios use what a filterpy user writes:

* ``KalmanFilter``: scalar measurements in every form filterpy takes (float, 1-list, 0-d and
  ``(1, 1)`` arrays), ``update(None)`` (prediction only: filterpy's docstring "If z is None,
  nothing is computed"), a per-call scalar and matrix ``R``, a per-call ``H`` with a column
  ``z``, and ``Q_discrete_white_noise`` as the process noise;
* ``Q_discrete_white_noise(dim, dt, var, block_size, order_by_dim)`` for every dim filterpy
  knows (2, 3, 4), one and two blocks, both orders;
* ``ExtendedKalmanFilter``: a range-bearing update with a per-call measurement model and an
  angle residual, the bearing crossing +-pi;
* ``UnscentedKalmanFilter``: a unicycle whose heading (a state angle) and bearing (a measured
  angle) cross +-pi, with ``residual_x``, ``x_mean_fn``, ``residual_z``, ``z_mean_fn`` (ours:
  ``residual_x``, ``mean_x``, ``residual``, ``mean_z`` built by ``angle_residual`` and
  ``angle_mean``); Merwe sigma points with ours' default ``alpha=1, beta=2, kappa=0``.

The test is skipped when filterpy is absent from both.
"""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from taskspace.estimation import (
    ExtendedKalmanFilter,
    KalmanFilter,
    UnscentedKalmanFilter,
    angle_mean,
    angle_residual,
    discrete_white_noise,
)

ROOT = Path(__file__).resolve().parents[2]
if importlib.util.find_spec("filterpy") is not None:  # a test dependency (pyproject's test extra)
    PEER = Path(sys.executable)
else:  # or the benchmarks' peer environment (make bench-peers)
    PEER = ROOT / ".venv-peers" / "filterpy" / "bin" / "python"

pytestmark = pytest.mark.skipif(not PEER.exists(), reason=f"filterpy not installed ({PEER})")

DT = 0.1
LANDMARK = (5.0, 0.0)


def _scenario() -> dict[str, object]:
    rng = np.random.default_rng(7)
    forms = ["float", "list", "0d", "col"]
    kf_steps = []
    for k in range(40):
        z = 0.05 * k + float(rng.normal(0.0, 0.3))
        step: dict[str, object] = {"z": z, "form": forms[k % 4]}
        if k % 7 == 3:
            step["form"] = "none"
        elif k % 5 == 4:
            step["R"] = 1.0 if k % 10 == 4 else [[0.5]]
        elif k % 11 == 10:
            step["form"] = "H2"  # per-call H, column z of two entries
        kf_steps.append(step)
    # EKF: static position, range-bearing to the landmark from positions whose bearing
    # crosses +-pi (the robot passes the landmark's x on the far side).
    ekf_z = []
    for k in range(25):
        x, y = 7.0 - 0.1 * k, 0.02 * math.sin(k)
        b = math.atan2(LANDMARK[1] - y, LANDMARK[0] - x)
        r = math.hypot(LANDMARK[0] - x, LANDMARK[1] - y)
        ekf_z.append(
            [r + float(rng.normal(0, 0.05)), math.remainder(b + rng.normal(0, 0.02), 2 * math.pi)]
        )
    # UKF: unicycle (x, y, heading) turning at 1.3 rad/s for 6 s: the heading wraps.
    ukf_z = []
    x, y, th = 2.0, -1.0, 2.5
    for _ in range(60):
        x, y, th = (
            x + DT * math.cos(th),
            y + DT * math.sin(th),
            math.remainder(th + 1.3 * DT, 2 * math.pi),
        )
        b = math.atan2(LANDMARK[1] - y, LANDMARK[0] - x) - th
        r = math.hypot(LANDMARK[0] - x, LANDMARK[1] - y)
        ukf_z.append(
            [r + float(rng.normal(0, 0.05)), math.remainder(b + rng.normal(0, 0.02), 2 * math.pi)]
        )
    noise = [
        [dim, dt, var, block, order]
        for dim in (2, 3, 4)
        for dt, var in ((0.1, 0.5), (1.7, 3.0))
        for block in (1, 2)
        for order in (True, False)
    ]
    return {"kf": kf_steps, "ekf": ekf_z, "ukf": ukf_z, "noise": noise}


# The same models, written once as text: exec'd here and in the filterpy child.
MODELS = textwrap.dedent(
    """
    import math
    import numpy as np
    DT = 0.1
    LM = np.array([5.0, 0.0])

    def wrap(a):
        return (a + math.pi) % (2 * math.pi) - math.pi

    def hx_rb(x):  # range and bearing of the landmark from a position
        d = LM - x[:2]
        return np.array([math.hypot(d[0], d[1]), math.atan2(d[1], d[0])])

    def H_rb(x):
        d = LM - x[:2]
        q = d @ d
        r = math.sqrt(q)
        return np.array([[-d[0] / r, -d[1] / r], [d[1] / q, -d[0] / q]])

    def fx_uni(x, dt=DT):  # unicycle, speed 1 m/s, turn rate 1.3 rad/s
        return np.array([x[0] + dt * math.cos(x[2]), x[1] + dt * math.sin(x[2]),
                         wrap(x[2] + 1.3 * dt)])

    def hx_uni(x):  # range and bearing relative to the heading
        d = LM - x[:2]
        return np.array([math.hypot(d[0], d[1]), wrap(math.atan2(d[1], d[0]) - x[2])])
    """
)

FILTERPY_CHILD = MODELS + textwrap.dedent(
    """
    import json, sys
    from filterpy.common import Q_discrete_white_noise
    from filterpy.kalman import (ExtendedKalmanFilter, KalmanFilter, MerweScaledSigmaPoints,
                                 UnscentedKalmanFilter)
    S = json.loads(sys.stdin.read())
    out = {}
    kf = KalmanFilter(dim_x=2, dim_z=1)
    kf.F = np.array([[1.0, DT], [0.0, 1.0]])
    kf.H = np.array([[1.0, 0.0]])
    kf.Q = Q_discrete_white_noise(dim=2, dt=DT, var=0.5)
    kf.R = np.array([[0.09]])
    kf.x = np.zeros((2, 1))
    kf.P = np.eye(2) * 10.0
    rows = []
    for s in S["kf"]:
        kf.predict()
        z, form = s["z"], s["form"]
        R = s.get("R")
        R = np.array(R) if isinstance(R, list) else R
        if form == "none":
            kf.update(None)
        elif form == "H2":
            kf.update(np.array([[z], [0.0]]), R=np.diag([0.09, 0.2]), H=np.eye(2))
        else:
            zz = {"float": z, "list": [z], "0d": np.array(z), "col": np.array([[z]])}[form]
            kf.update(zz, R=R)
        rows.append(list(np.ravel(kf.x)) + list(np.ravel(kf.P)))
    out["kf"] = rows
    out["noise"] = [
        Q_discrete_white_noise(dim=d, dt=t, var=v, block_size=b, order_by_dim=o).tolist()
        for d, t, v, b, o in S["noise"]
    ]

    def resid_rb(a, b):
        y = np.asarray(a, float) - b
        y[1] = wrap(y[1])
        return y

    ekf = ExtendedKalmanFilter(dim_x=2, dim_z=2)
    ekf.x = np.array([6.5, 0.3])
    ekf.P = np.eye(2)
    ekf.F = np.eye(2)
    ekf.Q = np.eye(2) * 0.01
    ekf.R = np.diag([0.05**2, 0.02**2])
    rows = []
    for z in S["ekf"]:
        ekf.predict()
        ekf.update(np.array(z), H_rb, hx_rb, residual=resid_rb)
        rows.append(list(np.ravel(ekf.x)) + list(np.ravel(ekf.P)))
    out["ekf"] = rows

    def mean_ang(idx):
        def mean(points, weights):
            m = np.dot(weights, points)
            for i in idx:
                m[i] = math.atan2(np.dot(weights, np.sin(points[:, i])),
                                  np.dot(weights, np.cos(points[:, i])))
            return m
        return mean

    def resid_x(a, b):
        y = np.asarray(a, float) - b
        y[2] = wrap(y[2])
        return y

    pts = MerweScaledSigmaPoints(3, alpha=1.0, beta=2.0, kappa=0.0)
    ukf = UnscentedKalmanFilter(3, 2, DT, hx_uni, fx_uni, pts, x_mean_fn=mean_ang([2]),
                                z_mean_fn=mean_ang([1]), residual_x=resid_x,
                                residual_z=resid_rb)
    ukf.x = np.array([2.0, -1.0, 2.5])
    ukf.P = np.diag([0.1, 0.1, 0.05])
    ukf.Q = np.diag([1e-3, 1e-3, 1e-3])
    ukf.R = np.diag([0.05**2, 0.02**2])
    rows = []
    for z in S["ukf"]:
        ukf.predict()
        ukf.update(np.array(z))
        rows.append(list(np.ravel(ukf.x)) + list(np.ravel(ukf.P)))
    out["ukf"] = rows
    print(json.dumps(out))
    """
)


@pytest.fixture(scope="module")
def scenario_and_filterpy() -> tuple[dict[str, object], dict[str, list[list[float]]]]:
    scenario = _scenario()
    done = subprocess.run(
        [str(PEER), "-c", FILTERPY_CHILD],
        input=json.dumps(scenario),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    return scenario, json.loads(done.stdout.strip().splitlines()[-1])


_models: dict[str, object] = {}
exec(MODELS, _models)  # the same model text filterpy's child runs


def _ours_kf(steps: list[dict[str, object]]) -> np.ndarray:
    Q = discrete_white_noise(2, DT, 0.5)
    kf = KalmanFilter(
        [[1.0, DT], [0.0, 1.0]], [[1.0, 0.0]], Q, [[0.09]], [0.0, 0.0], np.eye(2) * 10.0
    )
    rows = []
    for s in steps:
        kf.predict()
        z, form = float(s["z"]), s["form"]  # type: ignore[arg-type]
        R = s.get("R")
        if form == "none":
            kf.update(None)
        elif form == "H2":
            kf.update(np.array([[z], [0.0]]), R=np.diag([0.09, 0.2]), H=np.eye(2))
        else:
            zz = {"float": z, "list": [z], "0d": np.array(z), "col": np.array([[z]])}[form]  # type: ignore[index]
            kf.update(zz, R=R)
        rows.append(list(np.ravel(kf.x)) + list(np.ravel(kf.P)))
    return np.array(rows)


def test_kalman_filter_measurement_forms_none_and_per_call_R_H_match_filterpy(
    scenario_and_filterpy: tuple[dict[str, object], dict[str, list[list[float]]]],
) -> None:
    scenario, theirs = scenario_and_filterpy
    ours = _ours_kf(scenario["kf"])  # type: ignore[arg-type]
    np.testing.assert_allclose(ours, np.array(theirs["kf"]), rtol=1e-11, atol=1e-12)


def test_discrete_white_noise_matches_filterpy(
    scenario_and_filterpy: tuple[dict[str, object], dict[str, list[list[float]]]],
) -> None:
    scenario, theirs = scenario_and_filterpy
    for (dim, dt, var, block, order), ref in zip(scenario["noise"], theirs["noise"], strict=True):  # type: ignore[call-overload]
        ours = discrete_white_noise(dim, dt, var, block_size=block, order_by_dim=order)
        np.testing.assert_allclose(
            ours, np.array(ref), rtol=1e-13, atol=0.0, err_msg=str((dim, dt, var, block, order))
        )


def test_ekf_bearing_update_with_a_per_call_model_matches_filterpy(
    scenario_and_filterpy: tuple[dict[str, object], dict[str, list[list[float]]]],
) -> None:
    scenario, theirs = scenario_and_filterpy
    hx, H = _models["hx_rb"], _models["H_rb"]
    # the filter's own h is a dummy: the per-call model of every update is the one used
    ekf = ExtendedKalmanFilter(
        lambda x, u=None: np.asarray(x, float),
        lambda x, u=None: np.eye(2),
        lambda x: np.zeros(2),
        lambda x: np.zeros((2, 2)),
        np.eye(2) * 0.01,
        np.diag([0.05**2, 0.02**2]),
        [6.5, 0.3],
        np.eye(2),
    )
    rows = []
    bearings = []
    for z in scenario["ekf"]:  # type: ignore[attr-defined]
        ekf.predict()
        ekf.update(z, h=hx, H_jacobian=H, residual=angle_residual(1))  # type: ignore[arg-type]
        rows.append(list(ekf.x) + list(np.ravel(ekf.P)))
        bearings.append(z[1])
    assert min(bearings) < -3.0 and max(bearings) > 3.0  # the bearing crossed +-pi
    np.testing.assert_allclose(np.array(rows), np.array(theirs["ekf"]), rtol=1e-10, atol=1e-12)


def test_ukf_with_angle_state_and_measurement_matches_filterpy(
    scenario_and_filterpy: tuple[dict[str, object], dict[str, list[list[float]]]],
) -> None:
    scenario, theirs = scenario_and_filterpy
    fx, hx = _models["fx_uni"], _models["hx_uni"]
    ukf = UnscentedKalmanFilter(
        lambda x, u=None: fx(x),  # type: ignore[operator]
        hx,  # type: ignore[arg-type]
        np.diag([1e-3, 1e-3, 1e-3]),
        np.diag([0.05**2, 0.02**2]),
        [2.0, -1.0, 2.5],
        np.diag([0.1, 0.1, 0.05]),
        residual=angle_residual(1),
        residual_x=angle_residual(2),
        mean_x=angle_mean(2),
        mean_z=angle_mean(1),
    )
    rows = []
    for z in scenario["ukf"]:  # type: ignore[attr-defined]
        ukf.predict()
        ukf.update(z)
        rows.append(list(ukf.x) + list(np.ravel(ukf.P)))
    rows_a = np.array(rows)
    theirs_a = np.array(theirs["ukf"])
    headings = rows_a[:, 2]
    assert np.any(np.abs(np.diff(headings)) > math.pi)  # the heading wrapped at least once
    # angles compared on the circle, everything else directly
    diff = rows_a - theirs_a
    diff[:, 2] = np.remainder(diff[:, 2] + math.pi, 2 * math.pi) - math.pi
    np.testing.assert_allclose(diff, 0.0, atol=1e-9)
