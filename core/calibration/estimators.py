"""Estimating K and Bp from readings at known attitudes: batch least squares and seed 004's
linear Kalman filter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.validation import integer
from .model import design_rows
from .observability import CAL_RANK_RTOL
from .validation import (
    _array,
    _attitudes,
    _min_attitudes,
    _readings,
    _square4,
    checked_be,
    checked_noise,
)


@dataclass(frozen=True)
class LsqResult:
    """Batch least-squares calibration (:func:`lsq_calibrate`).

    Attributes
    ----------
    K : ndarray, shape (..., 3, 3)
        Induced-interference matrix (dimensionless).
    Bp : ndarray, shape (..., 3)
        Permanent-interference vector (nT).
    rank : int
        Rank of Γ (12 when the manoeuvre determines everything; otherwise K and Bp are the
        minimum-norm solution in column-scaled coordinates, one of many).
    residual_rms_nt : ndarray, shape (...)
        RMS of B − (K A Be + Bp) over all readings (nT).
    """

    K: np.ndarray
    Bp: np.ndarray
    rank: int
    residual_rms_nt: np.ndarray


def lsq_calibrate(B, attitudes, be, *, convention="seed004"):
    """Batch least-squares K and Bp from readings at known attitudes.

    Parameters
    ----------
    B : array_like, shape (..., N, 3)
        Readings (nT).
    attitudes, be, convention
        As for :func:`ship_field`; N ≥ 4, the leading axes of B and attitudes must match.

    Returns
    -------
    LsqResult

    Examples
    --------
    >>> import numpy as np, core
    >>> att = core.heading_manoeuvre(roll_deg=10, pitch_deg=5, n_attitudes=8)
    >>> B = core.ship_field(np.eye(3), [100, 200, 300], att, [34000, 2000, 35000])
    >>> np.round(core.lsq_calibrate(B, att, [34000, 2000, 35000]).Bp, 6).tolist()
    [100.0, 200.0, 300.0]
    """
    att = _attitudes(attitudes)
    _min_attitudes(att)
    B = _readings(B, att)
    C = design_rows(att, be, convention=convention)  # (..., N, 4)
    lead = np.broadcast_shapes(C.shape[:-2], B.shape[:-2])
    C = np.broadcast_to(C, lead + C.shape[-2:])
    B = np.broadcast_to(B, lead + B.shape[-2:])
    scale = np.linalg.norm(C, axis=-2, keepdims=True)  # (..., 1, 4)
    U, s, Vt = np.linalg.svd(C / scale, full_matrices=False)
    keep = s > CAL_RANK_RTOL * s[..., :1]
    sinv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    X = np.swapaxes(Vt, -1, -2) @ (sinv[..., :, None] * (np.swapaxes(U, -1, -2) @ B))  # (..., 4, 3)
    X = X / np.swapaxes(scale, -1, -2)
    res = B - C @ X
    rank = 3 * int(np.min(np.sum(keep, axis=-1)))
    return LsqResult(np.swapaxes(X[..., :3, :], -1, -2), X[..., 3, :], rank,
                     np.sqrt(np.mean(res ** 2, axis=(-2, -1))))


@dataclass(frozen=True)
class KalmanResult:
    """Seed 004's Kalman filter run (:func:`kalman_calibrate`).

    Attributes
    ----------
    history : ndarray, shape (..., M + 1, 4, 3)
        Seed 004's state x(n) = [K Bp]ᵀ for n = 0…M (x(0) the initial value).
    P_diag : ndarray, shape (..., M + 1, 4)
        Diagonal of P(n) (K entries dimensionless², Bp in nT²), shared by the three axes.
    """

    history: np.ndarray
    P_diag: np.ndarray

    @property
    def K_history(self):
        """ndarray, shape (..., M + 1, 3, 3): K after each iteration (dimensionless)."""
        return np.swapaxes(self.history[..., :3, :], -1, -2)

    @property
    def Bp_history(self):
        """ndarray, shape (..., M + 1, 3): Bp after each iteration (nT)."""
        return self.history[..., 3, :]

    @property
    def K(self):
        """ndarray, shape (..., 3, 3): the final K."""
        return self.K_history[..., -1, :, :]

    @property
    def Bp(self):
        """ndarray, shape (..., 3): the final Bp (nT)."""
        return self.Bp_history[..., -1, :]

    @property
    def coefficients(self):
        """ndarray, shape (..., M + 1, 12): the history in the order of :data:`COEFFICIENTS`."""
        lead = self.history.shape[:-2]
        return np.concatenate([self.K_history.reshape(lead + (9,)), self.Bp_history], axis=-1)


#: Default prior of :func:`kalman_calibrate`: x(0) = 0 as seed 004 suggests ("with little prior
#: information take x(0) = 0"), with standard deviations of 1 for each K entry and 3000 nT for
#: each Bp entry (the size of the values seed 004 reports) in P(0).
DEFAULT_P0_DIAG = (1.0, 1.0, 1.0, 3000.0 ** 2)
#: Most filter steps one call runs: one pass over the largest log accepted (MAX_CSV_ROWS);
#: ~20 µs each in this Python loop (~20 s at the limit on this machine) and 128 bytes of history
#: each (128 MB). Reusing the data adds no information with Q = 0 (docs/calibration.md).
MAX_KALMAN_ITERATIONS = 1_000_000
#: Steps the CLI's default runs at most: 50 passes over a short log (seed 004's 12 readings:
#: 600), fewer over a long one, never less than one pass (:func:`default_iterations`).
KALMAN_STEP_BUDGET = 60_000


def default_iterations(n_readings):
    """Filter steps for a log of ``n_readings``: 50 passes, cut to whole passes within
    :data:`KALMAN_STEP_BUDGET` steps, at least one pass (cost bounded by max(N, budget)).

    Examples
    --------
    >>> from core.calibration import default_iterations
    >>> default_iterations(12), default_iterations(5000), default_iterations(1_000_000)
    (600, 60000, 1000000)
    """
    n = integer("n_readings", n_readings, 1)
    return n * max(1, min(50, KALMAN_STEP_BUDGET // n))


def kalman_calibrate(B, attitudes, be, *, sigma_nt, iterations=None, x0=None, P0=None, Q=None,
                     convention="seed004"):
    """Seed 004's linear Kalman filter for the state x = [K Bp]ᵀ (4 × 3).

    Parameters
    ----------
    B : array_like, shape (..., N, 3)
        Readings (nT).
    attitudes, be, convention
        As for :func:`ship_field`.
    sigma_nt : float
        Observation noise standard deviation σ (nT), > 0 (seed 004's σ²).
    iterations : int, optional
        Number of filter steps M, 1 ≤ M ≤ :data:`MAX_KALMAN_ITERATIONS`; the N readings are
        reused cyclically when M > N (seed 004's "extension" of its 12 readings). Default N
        (one pass). Cost: time and memory linear in M.
    x0 : array_like, shape (4, 3), optional
        Initial state (seed 004: zero, the default).
    P0 : array_like, shape (4,) or (4, 4), optional
        Initial P(0) (diagonal or full; K part dimensionless², Bp part nT²); default
        :data:`DEFAULT_P0_DIAG`.
    Q : array_like, shape (4,) or (4, 4) or float, optional
        Random-walk process noise per step (same units as P); default 0 (constant coefficients).

    Returns
    -------
    KalmanResult

    Notes
    -----
    Seed 004's steps (§2.1) for n = 1…M with C(n) = [Beᵀ Aᵀ(n), 1], y(n) = B(n)ᵀ:
    R = P(n−1) + Q; m = R Cᵀ / (C R Cᵀ + σ²); x(n) = (E − m C) x(n−1) + m y(n);
    P(n) = (E − m C) R. (The printed gain lacks the inverse of C R Cᵀ + σ², a scalar here.)
    P is updated in the Joseph form (E − m C) R (E − m C)ᵀ + σ² m mᵀ, algebraically the same and
    more robust in float64. Still, a covariance-form filter subtracts nearly equal numbers when
    P(0) exceeds the final P by more than ~1e12 (e.g. P(0) = 1e12 for every entry): the
    estimate then reaches the least-squares value only slowly. Scale P(0) to the coefficients
    (K ~ 1, Bp ~ |Be|) rather than making it uniformly enormous.
    """
    att = _attitudes(attitudes)
    B = _readings(B, att)
    be = checked_be(be)
    sigma2 = checked_noise("sigma_nt", sigma_nt) ** 2
    N = att.shape[-2]
    M = integer("iterations", N if iterations is None else iterations, 1, MAX_KALMAN_ITERATIONS,
               " (filter steps)")
    P = _square4("P0", DEFAULT_P0_DIAG if P0 is None else P0, allow_zero=False)
    Qm = _square4("Q", 0.0 if Q is None else Q, allow_zero=True)
    x = np.zeros((4, 3)) if x0 is None else _array("x0", x0, "shape (4, 3): [K Bp]ᵀ")
    if x.shape != (4, 3):
        raise ValueError(f"x0 must have shape (4, 3) ([K Bp]ᵀ); got {x.shape}")
    C = design_rows(att, be, convention=convention)  # (..., N, 4)
    lead = np.broadcast_shapes(C.shape[:-2], B.shape[:-2])
    C = np.broadcast_to(C, lead + C.shape[-2:])
    B = np.broadcast_to(B, lead + B.shape[-2:])
    x = np.broadcast_to(x, lead + (4, 3)).copy()
    P = np.broadcast_to(P, lead + (4, 4)).copy()
    hist = np.empty(lead + (M + 1, 4, 3))
    pdiag = np.empty(lead + (M + 1, 4))
    hist[..., 0, :, :] = x
    pdiag[..., 0, :] = np.diagonal(P, axis1=-2, axis2=-1)
    if lead == ():
        _kalman_one(C, B, x, P, Qm, sigma2, hist, pdiag)
        return KalmanResult(hist, pdiag)
    E = np.eye(4)
    for n in range(1, M + 1):
        c = C[..., (n - 1) % N, :]  # (..., 4)
        y = B[..., (n - 1) % N, :]  # (..., 3)
        R = P + Qm
        Rc = (R @ c[..., :, None])[..., 0]  # R Cᵀ (..., 4)
        m = Rc / ((c * Rc).sum(axis=-1) + sigma2)[..., None]  # gain (..., 4)
        innov = y - (c[..., None, :] @ x)[..., 0, :]  # y − C x (..., 3)
        x = x + m[..., :, None] * innov[..., None, :]
        IKC = E - m[..., :, None] * c[..., None, :]
        P = IKC @ R @ np.swapaxes(IKC, -1, -2) + sigma2 * m[..., :, None] * m[..., None, :]
        P = 0.5 * (P + np.swapaxes(P, -1, -2))
        hist[..., n, :, :] = x
        pdiag[..., n, :] = np.diagonal(P, axis1=-2, axis2=-1)
    return KalmanResult(hist, pdiag)


def _kalman_one(C, B, x, P, Qm, sigma2, hist, pdiag):
    """The loop of :func:`kalman_calibrate` for one log (no leading axes), the same steps on
    1-D and 2-D arrays: half the numpy calls of the broadcasting loop (~11 µs a step instead of
    ~21 µs; the filter is the CLI's longest step at N = 1e6). Fills hist[1:] and pdiag[1:]."""
    N = C.shape[0]
    E = np.eye(4)
    outer, dot = np.multiply.outer, np.dot
    no_q = not Qm.any()  # R = P + 0 is P: skip the addition
    for n in range(1, hist.shape[0]):
        c, y = C[(n - 1) % N], B[(n - 1) % N]  # (4,), (3,)
        R = P if no_q else P + Qm
        Rc = dot(R, c)  # R Cᵀ
        m = Rc / (dot(c, Rc) + sigma2)  # gain (4,)
        x = x + outer(m, y - dot(c, x))  # (4, 3)
        IKC = E - outer(m, c)
        P = dot(dot(IKC, R), IKC.T) + sigma2 * outer(m, m)  # Joseph form
        P = 0.5 * (P + P.T)
        hist[n] = x
        pdiag[n] = P.diagonal()


def convergence_iteration(history, tol):
    """First iteration after which every coefficient stays within ``tol`` of its final value.

    Parameters
    ----------
    history : array_like, shape (..., M + 1, 12)
        Estimates after each iteration (e.g. :attr:`KalmanResult.coefficients`).
    tol : array_like, shape (12,) or float
        Tolerance per coefficient (coefficient units), > 0, e.g. the CRLB standard deviations;
        +inf ignores a coefficient (an undetermined one's CRLB).

    Returns
    -------
    ndarray of int, shape (...)
        0 if x(0) is already within tolerance, M if only the last estimate is.
    """
    h = _array("history", history, "shape (..., M + 1, 12)")
    try:
        t = np.asarray(tol, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be numbers > 0 (coefficient units); got {tol!r}") from None
    if h.ndim < 2 or h.shape[-1] != 12:
        raise ValueError(f"history must have shape (..., M + 1, 12); got {h.shape}")
    if not (t > 0).all():  # also refuses NaN
        raise ValueError("tol must be > 0 (coefficient units; +inf ignores a coefficient)")
    ok = np.all(np.abs(h - h[..., -1:, :]) <= t, axis=-1)  # (..., M + 1)
    # the last iteration that is not within tolerance, plus one
    bad_rev = np.argmax(~ok[..., ::-1], axis=-1)  # position from the end of the last bad one
    any_bad = (~ok).any(axis=-1)
    return np.where(any_bad, ok.shape[-1] - bad_rev, 0)


