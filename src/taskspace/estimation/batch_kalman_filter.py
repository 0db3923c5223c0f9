"""Kalman filter over ``N`` independent tracks at once (slides 6:10, 7:26).

All tracks share the model ``(F, H, Q, R)``; beliefs are stacked as ``x: (N, n)`` and
``P: (N, n, n)``. The equations are those of :mod:`taskspace.estimation.kalman_filter`, written
so that each is one BLAS call or a handful of elementwise numpy operations over all tracks:

* the Kronecker operators are scipy CSR matrices (single-threaded, sparse for structured
  models);
* beliefs are stored internally "structure of arrays": ``x`` as ``(n, N)`` and ``P`` as
  ``(n^2, N)``, so every matrix entry is one contiguous vector over tracks;
* ``F P F^T`` uses the row-major vectorization identity ``vec(F P F^T) = (F kron F) vec(P)``,
  so the whole stack is one ``(n^2, n^2) x (n^2, N)`` product;
* ``H P H^T`` and ``H P`` likewise use ``H kron H`` and ``H kron I``;
* ``S^-1`` is closed form for ``m = 1`` and ``m = 2`` (``[[d, -b], [-b, a]] / (a d - b^2)``),
  batched ``numpy.linalg.inv`` otherwise;
* ``P = P - K (P H^T)^T`` (short form, symmetrized) and ``x = x + K r``.
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import scipy.sparse as sp

from taskspace._validation import FloatArray, as_float_array, as_matrix
from taskspace.errors import (
    InvalidInputError,
    NotFiniteError,
    ShapeError,
    SolverError,
    TaskspaceError,
)
from taskspace.estimation._serialized import serialized
from taskspace.estimation.covariance import as_covariance

_CANCELLED = 1e-8
"""Posterior/prior variance ratio below which an update is redone in Joseph form."""
_LOST = 1e-24
"""Posterior/prior variance ratio below which even the Joseph form is refused."""


class BatchKalmanFilter:
    """Linear Kalman filter for ``N`` independent tracks sharing one model.

    Args:
        F: ``(n, n)`` state transition matrix.
        H: ``(m, n)`` measurement matrix.
        Q: ``(n, n)`` process noise covariance.
        R: ``(m, m)`` measurement noise covariance (positive definite).
        x0: ``(N, n)`` prior means.
        P0: ``(n, n)`` prior covariance shared by all tracks, or ``(N, n, n)`` per track
            (per-track covariances are checked for symmetry and finiteness, not eigenvalues).

    Thread safety: calls are serialized by the filter's lock; each of ``set_belief``,
    ``predict``, ``update``, ``step`` is atomic, so threads sharing one filter (a sensor
    callback updating while a timer predicts) lose no update; they do not run in parallel (use
    one filter per thread for that). Read the belief between calls, not during another thread's
    update.
    """

    def __init__(self, F: Any, H: Any, Q: Any, R: Any, x0: Any, P0: Any) -> None:
        self._lock = threading.RLock()
        self.F = as_matrix(F, (None, None), "F")
        n = self.F.shape[0]
        if self.F.shape[1] != n:
            raise InvalidInputError(f"F must be square, got shape {self.F.shape}")
        self.H = as_matrix(H, (None, n), "H")
        m = self.H.shape[0]
        self.Q = as_covariance(Q, n, "Q")
        self.R = as_covariance(R, m, "R", positive_definite=True)
        self.dim_x = n
        self.dim_z = m
        # Row-major vec identities: vec(A X B) = (A kron B^T) vec(X). Stored as CSR: the
        # Kronecker products are sparse for structured models (36 of 256 entries for the CV
        # model) and scipy's sparse-dense product is single-threaded, so it does not suffer
        # from BLAS thread contention on busy machines.
        with np.errstate(over="ignore", invalid="ignore"):
            FF, HH = np.kron(self.F, self.F), np.kron(self.H, self.H)
        for name, K in (("F", FF), ("H", HH)):
            if not np.isfinite(K).all():  # F = 1e200 I gave zeros with overflow warnings
                raise InvalidInputError(
                    f"{name} (x) {name} overflows: entries of {name} up to "
                    f"{float(np.max(np.abs(getattr(self, name)))):.3g} make {name} P {name}^T "
                    "overflow; rescale the states and measurements (units)"
                )
        self._FF = sp.csr_array(FF)
        self._HH = sp.csr_array(HH)
        self._HI = sp.csr_array(np.kron(self.H, np.eye(n)))
        self._Fs = sp.csr_array(self.F)
        self._Hs = sp.csr_array(self.H)
        self._Q_col = self.Q.reshape(-1, 1).copy()
        self._R_col = self.R.reshape(-1, 1).copy()
        self._x = np.empty((n, 0))
        self._P = np.empty((n * n, 0))
        self.set_belief(x0, P0)

    @property
    def num_tracks(self) -> int:
        """Number of tracks ``N``."""
        return int(self._x.shape[1])

    @property
    def x(self) -> FloatArray:
        """``(N, n)`` means (a read-only view of the internal storage)."""
        v = self._x.T
        v.flags.writeable = False
        return v

    @property
    def P(self) -> FloatArray:
        """``(N, n, n)`` covariances (a read-only view of the internal storage)."""
        n = self.dim_x
        v = self._P.reshape(n, n, -1).transpose(2, 0, 1)
        v.flags.writeable = False
        return v

    @serialized
    def set_belief(self, x: Any, P: Any) -> None:
        """Replace the beliefs by ``N(x_i, P_i)``: ``x (N, n)``, ``P (n, n)`` or ``(N, n, n)``."""
        n = self.dim_x
        xa = np.array(as_float_array(x, "x"))
        if xa.ndim != 2 or xa.shape[1] != n:
            raise ShapeError("x0", (-1, n), tuple(xa.shape))
        if not np.all(np.isfinite(xa)):
            bad = np.flatnonzero(~np.all(np.isfinite(xa), axis=1))
            raise NotFiniteError("x0", [int(i) for i in bad[:20]])
        N = xa.shape[0]
        Pa = as_float_array(P, "P")
        if Pa.ndim == 2:
            Pa = np.broadcast_to(as_covariance(Pa, n, "P0"), (N, n, n))
        elif Pa.shape != (N, n, n):
            raise ShapeError("P0", (N, n, n), tuple(Pa.shape))
        elif not np.all(np.isfinite(Pa)):
            bad = np.flatnonzero(~np.all(np.isfinite(Pa), axis=(1, 2)))
            raise NotFiniteError("P0", [int(i) for i in bad[:20]])
        elif np.max(np.abs(Pa - Pa.transpose(0, 2, 1)), initial=0.0) > 1e-8 * max(
            1.0, float(np.max(np.abs(Pa), initial=0.0))
        ):
            raise InvalidInputError("P0 must hold symmetric covariance matrices")
        self._x = np.ascontiguousarray(xa.T)
        self._P = np.ascontiguousarray(Pa.reshape(N, n * n).T)

    @serialized
    def predict(self) -> None:
        """Propagate all tracks: ``x_i = F x_i``, ``P_i = F P_i F^T + Q``.

        Raises:
            SolverError: a mean or covariance overflowed (the beliefs are left unchanged).
        """
        with np.errstate(over="ignore", invalid="ignore"):
            x = self._Fs @ self._x
            P = self._FF @ self._P
            P += self._Q_col
        _check_beliefs(x, P, "prediction")
        self._x, self._P = x, P

    @serialized
    def update(self, z: Any) -> FloatArray:
        """Condition every track ``i`` on its measurement ``z_i``.

        Args:
            z: ``(N, m)`` measurements.

        Returns:
            ``(N,)`` normalized innovation squared ``r_i^T S_i^-1 r_i``.

        Raises:
            ShapeError: if ``z`` is not ``(N, m)``.
            NotFiniteError: if ``z`` has NaN or inf entries (indices are track numbers).
            SolverError: if an innovation covariance is singular, or a mean or covariance
                overflowed (the beliefs are left unchanged).
        """
        N = self._x.shape[1]
        m = self.dim_z
        za = as_float_array(z, "z")
        if za.shape != (N, m):
            raise ShapeError("z", (N, m), tuple(za.shape))
        if not np.isfinite(za).all():
            bad = np.flatnonzero(~np.all(np.isfinite(za), axis=1))
            raise NotFiniteError("z", [int(i) for i in bad[:20]])
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            x, P, nis = self._update(za)
        _check_beliefs(x, P, "update")
        self._x, self._P = x, P
        return nis

    def _update(self, za: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        n = self.dim_x
        N = self._x.shape[1]
        m = self.dim_z
        HP = (self._HI @ self._P).reshape(m, n, N)  # rows of H P = columns of P H^T
        S = self._HH @ self._P
        S += self._R_col
        r = za.T - self._Hs @ self._x
        if m == 2:
            # S / s with s = max(S_00, S_11): a d overflowed for variances above 1e154 (det =
            # inf, so K = 0 and the measurement was ignored: F = 1e100 I kept x = F x).
            scale = np.maximum(S[0], S[3])  # > 0: R is positive definite
            a, b, c, d = S / scale
            det = a * d - b * c
            if not np.all(det > 0.0):
                raise SolverError(
                    "innovation covariance is not positive definite for tracks "
                    f"{np.flatnonzero(~(det > 0.0))[:20].tolist()}"
                )
            inv = 1.0 / (det * scale)
            # w = S^-1 r and K = P H^T S^-1 with the closed-form 2 x 2 inverse.
            r0, r1 = r
            w0 = (d * r0 - b * r1) * inv
            w1 = (a * r1 - c * r0) * inv
            nis = r0 * w0 + r1 * w1
            ph0, ph1 = HP
            K0 = ph0 * (d * inv) - ph1 * (c * inv)
            K1 = ph1 * (a * inv) - ph0 * (b * inv)
            x = self._x + ph0 * w0 + ph1 * w1
            P = self._P.reshape(n, n, N) - K0[:, None, :] * ph0[None, :, :]
            P -= K1[:, None, :] * ph1[None, :, :]
        else:
            S3 = S.reshape(m, m, N).transpose(2, 0, 1)
            if m == 1:
                s = S3[:, 0, 0]
                if not np.all(s > 0.0):
                    raise SolverError("innovation variance is not positive for some tracks")
                Sinv = (1.0 / s)[:, None, None]
            else:
                try:
                    Sinv = np.linalg.inv(S3)
                except np.linalg.LinAlgError as exc:
                    raise SolverError(f"innovation covariance is singular: {exc}") from exc
            w = np.einsum("nij,jn->in", Sinv, r)
            nis = np.einsum("in,in->n", r, w)
            K = np.einsum("kin,nkl->lin", HP, Sinv)  # (m, n, N): K[:, i, l]
            x = self._x + np.einsum("kin,kn->in", HP, w)
            P = self._P.reshape(n, n, N) - np.einsum("kin,kjn->ijn", K, HP)
        P = self._joseph_where_cancelled(P, (K0, K1) if m == 2 else K)
        P = 0.5 * (P + P.transpose(1, 0, 2))
        return x, P.reshape(n * n, N), np.asarray(nis)

    def _joseph_where_cancelled(
        self, P: FloatArray, K: FloatArray | tuple[FloatArray, FloatArray]
    ) -> FloatArray:
        """Redo in Joseph form the tracks whose short-form covariance lost its digits.

        ``P - K H P`` cancels when the measurement dominates the prior: F = 1e20 I with unit
        noises gave posterior variances 0 instead of ~R (the next updates then ignored the
        measurements). ``(I - K H) P (I - K H)^T + K R K^T`` keeps ``K R K^T``. Tracks with a
        posterior variance below :data:`_CANCELLED` times the prior one (or negative) are
        recomputed; ``K`` is ``(m, n, N)`` with ``K[l, i, t] = K_t[i, l]`` (or its rows).
        """
        n = self.dim_x
        N = P.shape[2]
        # diagonals as strided views of the (n^2, N) storage: no copies on the common path
        low = P.reshape(n * n, N)[:: n + 1] < _CANCELLED * self._P[:: n + 1]
        if not low.any():
            return P
        bad = np.flatnonzero(low.any(axis=0))
        prior = self._P.reshape(n, n, N)
        Kt = (np.stack(K) if isinstance(K, tuple) else K)[:, :, bad].transpose(2, 1, 0)
        IKH = np.eye(n) - Kt @ self.H
        Pp = prior[:, :, bad].transpose(2, 0, 1)
        Pj = IKH @ Pp @ IKH.transpose(0, 2, 1) + Kt @ self.R @ Kt.transpose(0, 2, 1)
        lost = (np.diagonal(Pj, axis1=1, axis2=2) < _LOST * np.diagonal(Pp, axis1=1, axis2=2)).any(
            axis=1
        )
        if lost.any():  # (I - K H) is only known to eps: its square to eps^2 of the prior
            raise SolverError(
                "the measurements are more than 1e12 times more precise than the predicted "
                f"variances of tracks {bad[lost][:20].tolist()}: the covariance update loses "
                "every digit (F = 1e150 I gave variances 1e268 instead of ~R); rescale the "
                "states and measurements (units) or lower the prior/process variances"
            )
        P[:, :, bad] = Pj.transpose(1, 2, 0)
        return P

    @serialized
    def step(self, z: Any) -> FloatArray:
        """Predict, then update with ``z: (N, m)``; returns the NIS of each track.

        A step that raises leaves the beliefs as they were before it.
        """
        x, P = self._x, self._P
        self.predict()
        try:
            return self.update(z)
        except TaskspaceError:
            self._x, self._P = x, P  # a failed step leaves the beliefs as they were
            raise


def _check_beliefs(x: FloatArray, P: FloatArray, step: str) -> None:
    """Raise :class:`SolverError` naming the tracks whose mean or covariance is not finite."""
    # Fast path: one reduction each; a finite total means finite entries (an overflowing
    # total of finite entries falls through to the exact test).
    if math.isfinite(float(np.add.reduce(x, axis=None))) and math.isfinite(
        float(np.add.reduce(P, axis=None))
    ):
        return
    bad = ~(np.isfinite(x).all(axis=0) & np.isfinite(P).all(axis=0))
    if bad.any():
        raise SolverError(
            f"the {step} gave a non-finite mean or covariance (overflow) for tracks "
            f"{np.flatnonzero(bad)[:20].tolist()}: the beliefs are left unchanged; rescale the "
            "states and measurements (units) or check the inputs"
        )
