"""Extended Kalman filters on the core's measurement model: EKF and PUEKF (seed 001 §2.3).

Every function works on a *stack* of N independent filters (leading axis N: Monte-Carlo runs ×
bank hypotheses), so one time step is one :func:`core.field_jacobian` call on an (N, 7) array
and a few batched 7 × 7 / m × m products and solves.

Progressive update (PUEKF, seed 001 eq. (16)): the update at step k is split into N_pu
sub-updates, each relinearised at the current estimate and each with the noise covariance
N_pu · R (N_pu measurements of covariance N_pu R carry the information of one of covariance R).
With N_pu = 1 it is the EKF. Covariances are updated in Joseph form,
``P ← (I − K H) P (I − K H)ᵀ + K R' Kᵀ``, which keeps them symmetric positive definite over many
sub-updates.

Linearisation points are *guarded*: the depth is clipped into the water column of a layered
sea, the speed is kept ≥ :data:`MIN_SPEED` (the moment's heading needs one) and the estimate is
kept :data:`MIN_STATION_DISTANCE` from every station. The measurement is then linearised at the
guarded point x_g: ``h(x) ≈ h(x_g) + H (x − x_g)``. A filter whose state or covariance becomes
non-finite is *dead*: it is frozen, and its log-likelihood is −inf.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from .measurement import SensorModel

__all__ = ["MIN_SPEED", "MIN_STATION_DISTANCE", "FilterRun", "ekf_predict", "ekf_update",
           "run_filters"]

#: Smallest speed (m/s) at which a filter linearises the measurement (the heading needs one).
MIN_SPEED = 1e-3
#: Smallest distance (m) from a station at which a filter linearises the measurement.
MIN_STATION_DISTANCE = 1e-3
_LOG_2PI = np.log(2.0 * np.pi)


@nb.njit(cache=True, nogil=True)
def _predict_kernel(P, F, Q, out):
    """out[f] = F P[f] Fᵀ + Q for (N, 7, 7) P."""
    FP = np.empty((7, 7))
    for f in range(P.shape[0]):
        for i in range(7):
            for j in range(7):
                acc = 0.0
                for q in range(7):
                    acc += F[i, q] * P[f, q, j]
                FP[i, j] = acc
        for i in range(7):
            for j in range(i + 1):
                acc = Q[i, j]
                for q in range(7):
                    acc += FP[i, q] * F[j, q]
                out[f, i, j] = acc
                out[f, j, i] = acc


@nb.njit(cache=True, nogil=True)
def _nees_kernel(P, err, out):
    """out[f] = err[f]ᵀ P[f]⁻¹ err[f] by Cholesky; NaN where P[f] is not positive definite."""
    L = np.empty((7, 7))
    z = np.empty(7)
    for f in range(P.shape[0]):
        if _cholesky(P[f], L):
            _cholesky_solve(L, err[f], z)
            acc = 0.0
            for i in range(7):
                acc += err[f, i] * z[i]
            out[f] = acc
        else:
            out[f] = np.nan


def ekf_predict(x, P, F, Q):
    """Time update of N filters: ``x ← F x``, ``P ← F P Fᵀ + Q``.

    Parameters
    ----------
    x : ndarray, shape (N, 7)
    P : ndarray, shape (N, 7, 7)
    F, Q : ndarray, shape (7, 7)
        From :func:`core.dwna_model`.

    Returns
    -------
    x, P : ndarray, shapes (N, 7), (N, 7, 7)
    """
    P = np.ascontiguousarray(P, dtype=float)
    out = np.empty_like(P)
    _predict_kernel(P, np.ascontiguousarray(F, dtype=float), np.ascontiguousarray(Q, dtype=float), out)
    return np.asarray(x, dtype=float) @ F.T, out


def _guard(x, sensors):
    """Linearisation points: finite, in the water column, moving, off the stations."""
    g = np.where(np.isfinite(x), x, 0.0)
    lo, hi = sensors.depth_range
    g[:, 2] = np.clip(g[:, 2], lo, hi)
    speed = np.hypot(g[:, 3], g[:, 4])
    slow = speed < MIN_SPEED
    if slow.any():  # keep the heading where there is one, else point along +x
        moving = slow & (speed > 0.0)
        g[moving, 3:5] *= (MIN_SPEED / speed[moving])[:, None]
        g[slow & (speed == 0.0), 3] = MIN_SPEED
    off = g[:, None, :3] - sensors.stations[None]  # (N, S, 3)
    dist = np.linalg.norm(off, axis=-1)
    near = dist < MIN_STATION_DISTANCE
    if near.any():  # step away from the station horizontally
        n, s = np.nonzero(near)
        g[n, 0] = sensors.stations[s, 0] + MIN_STATION_DISTANCE
    return g


@nb.njit(cache=True, nogil=True)
def _cholesky_solve(L, b, z):
    """Solve (L Lᵀ) z = b into z (m,), L lower triangular (m, m); b is not changed."""
    m = b.shape[0]
    for i in range(m):
        z[i] = b[i]
    for i in range(m):  # L w = b
        acc = z[i]
        for j in range(i):
            acc -= L[i, j] * z[j]
        z[i] = acc / L[i, i]
    for i in range(m - 1, -1, -1):  # Lᵀ z = w
        acc = z[i]
        for j in range(i + 1, m):
            acc -= L[j, i] * z[j]
        z[i] = acc / L[i, i]


@nb.njit(cache=True, nogil=True)
def _cholesky(S, L):
    """Lower Cholesky factor of S (m, m) into L; False if S is not positive definite."""
    m = S.shape[0]
    for i in range(m):
        for j in range(i + 1):
            acc = S[i, j]
            for q in range(j):
                acc -= L[i, q] * L[j, q]
            if i == j:
                if not acc > 0.0:  # also catches NaN
                    return False
                L[i, i] = np.sqrt(acc)
            else:
                L[i, j] = acc / L[j, j]
        for j in range(i + 1, m):
            L[i, j] = 0.0
    return True


@nb.njit(cache=True, nogil=True)
def _update_kernel(x, P, nu, H, r_update, r_like, want_like, like):
    """One (sub-)update of N filters in place: x (N, 7), P (N, 7, 7), innovation nu (N, m),
    H (N, m, 7), noise variance r_update per axis; with want_like, also the Gaussian
    log-likelihood of nu under H P Hᵀ + r_like I into like (N,). A filter whose S is not
    positive definite gets NaN (it is then dead)."""
    n, m = nu.shape
    PHt = np.empty((7, m))
    S = np.empty((m, m))
    L = np.empty((m, m))
    K = np.empty((7, m))
    A = np.empty((7, 7))
    AP = np.empty((7, 7))
    z = np.empty(m)
    for f in range(n):
        for i in range(7):  # P Hᵀ (7, m)
            for r in range(m):
                acc = 0.0
                for j in range(7):
                    acc += P[f, i, j] * H[f, r, j]
                PHt[i, r] = acc
        for r in range(m):  # H P Hᵀ (m, m), symmetric
            for c in range(r + 1):
                acc = 0.0
                for j in range(7):
                    acc += H[f, r, j] * PHt[j, c]
                S[r, c] = acc
                S[c, r] = acc
        if want_like:
            for r in range(m):
                S[r, r] += r_like
            if _cholesky(S, L):
                _cholesky_solve(L, nu[f], z)
                quad = 0.0
                logdet = 0.0
                for r in range(m):
                    quad += nu[f, r] * z[r]
                    logdet += 2.0 * np.log(L[r, r])
                like[f] = -0.5 * (quad + logdet + m * _LOG_2PI)
            else:
                like[f] = np.nan
            for r in range(m):
                S[r, r] += r_update - r_like
        else:
            for r in range(m):
                S[r, r] += r_update
        if not _cholesky(S, L):
            x[f, :] = np.nan
            continue
        for i in range(7):  # K = P Hᵀ S⁻¹, row by row: S K[i]ᵀ = (P Hᵀ)[i]ᵀ
            _cholesky_solve(L, PHt[i], K[i])
        for i in range(7):
            acc = 0.0
            for r in range(m):
                acc += K[i, r] * nu[f, r]
            x[f, i] += acc
        for i in range(7):  # A = I − K H
            for j in range(7):
                acc = 1.0 if i == j else 0.0
                for r in range(m):
                    acc -= K[i, r] * H[f, r, j]
                A[i, j] = acc
        for i in range(7):  # A P
            for j in range(7):
                acc = 0.0
                for q in range(7):
                    acc += A[i, q] * P[f, q, j]
                AP[i, j] = acc
        for i in range(7):  # Joseph form: A P Aᵀ + r K Kᵀ, symmetric
            for j in range(i + 1):
                acc = 0.0
                for q in range(7):
                    acc += AP[i, q] * A[j, q]
                kk = 0.0
                for r in range(m):
                    kk += K[i, r] * K[j, r]
                acc += r_update * kk
                P[f, i, j] = acc
                P[f, j, i] = acc


def ekf_update(x, P, y, sensors, *, n_pu=1):
    """Measurement update of N filters, progressive (PUEKF) with ``n_pu`` sub-updates.

    Parameters
    ----------
    x : ndarray, shape (N, 7)
        Predicted states.
    P : ndarray, shape (N, 7, 7)
        Predicted covariances.
    y : ndarray, shape (N, m)
        Measurements (V/m), in the order of :class:`core.SensorModel`.
    sensors : core.SensorModel
    n_pu : int
        Number of progressive sub-updates N_pu ≥ 1 (1 = EKF).

    Returns
    -------
    x, P : ndarray, shapes (N, 7), (N, 7, 7)
        Updated states and covariances (new arrays; NaN for a filter whose innovation
        covariance was not positive definite).
    loglik : ndarray, shape (N,)
        log N(y; h(x̂), H P Hᵀ + R) of the *predicted* measurement, the increment of the bank's
        accumulated log-likelihood (seed 001 eqs. (8)–(9)).

    Notes
    -----
    The Kalman algebra runs in a compiled kernel (Cholesky of S per filter); measurement values
    and Jacobians come from :meth:`core.SensorModel.h_and_jacobian`, i.e. the core's field.
    """
    x = np.array(x, dtype=float)
    P = np.array(P, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    r = sensors.noise**2
    like = np.empty(x.shape[0])
    for i in range(n_pu):
        g = _guard(x, sensors)
        h, H = sensors.h_and_jacobian(g)  # (N, m), (N, m, 7)
        nu = y - h - np.einsum("nri,ni->nr", H, x - g)  # innovation, linearised at the guard
        _update_kernel(x, P, np.ascontiguousarray(nu), np.ascontiguousarray(H), n_pu * r, r,
                       i == 0, like)
    return x, P, like


@dataclass(frozen=True)
class FilterRun:
    """Output of :func:`run_filters` for N filters over K steps.

    Attributes
    ----------
    x : ndarray, shape (N, K, 7)
        Posterior estimates at every step.
    position_var : ndarray, shape (N, K)
        Trace of the position block of the posterior covariance (m²).
    loglik : ndarray, shape (N, K)
        Accumulated log-likelihood of the measurements up to each step; −inf once dead.
    nees : ndarray, shape (N, K), or None
        Normalised estimation error squared (x̂ − x)ᵀ P⁻¹ (x̂ − x) over the 7 states, when the
        true states were given; NaN once dead.
    alive : ndarray of bool, shape (N,)
        False for filters that became non-finite.
    """

    x: np.ndarray
    position_var: np.ndarray
    loglik: np.ndarray
    nees: np.ndarray | None
    alive: np.ndarray


def run_filters(x0, P0, ys, sensors, F, Q, *, n_pu=1, truth=None, progress=None):
    """Run N independent (PU)EKFs over K steps of their own measurements.

    At step 0 each filter updates its prior (x0, P0) with ys[:, 0]; from step 1 on it predicts
    and updates.

    Parameters
    ----------
    x0 : array_like, shape (N, 7)
        Prior means at step 0.
    P0 : array_like, shape (N, 7, 7) or (7, 7)
        Prior covariances.
    ys : array_like, shape (N, K, m)
        Measurements of every filter at every step (V/m).
    sensors : core.SensorModel
    F, Q : array_like, shape (7, 7)
        From :func:`core.dwna_model`.
    n_pu : int
        Progressive sub-updates (1 = EKF).
    truth : array_like, shape (N, K, 7), optional
        True states, for the NEES.
    progress : callable, optional
        Called with 1 after every step (e.g. ``tqdm.update``).

    Returns
    -------
    FilterRun
    """
    if not isinstance(sensors, SensorModel):
        raise ValueError(f"sensors must be a core.SensorModel; got {type(sensors).__name__}")
    x = np.array(x0, dtype=float)
    ys = np.asarray(ys, dtype=float)
    if x.ndim != 2 or x.shape[1] != 7:
        raise ValueError(f"x0 must have shape (N, 7); got {x.shape}")
    n = x.shape[0]
    if ys.ndim != 3 or ys.shape[0] != n or ys.shape[2] != sensors.n_meas:
        raise ValueError(
            f"ys must have shape (N, K, m) = ({n}, K, {sensors.n_meas}) for these sensors; got {ys.shape}"
        )
    if not np.all(np.isfinite(ys)):
        raise ValueError("ys must be finite (V/m)")
    P = np.broadcast_to(np.asarray(P0, dtype=float), (n, 7, 7)).copy()
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(P)):
        raise ValueError("x0 and P0 must be finite")
    if isinstance(n_pu, bool) or not isinstance(n_pu, (int, np.integer)) or n_pu < 1:
        raise ValueError(f"n_pu must be an integer ≥ 1 (progressive sub-updates); got {n_pu!r}")
    F, Q = np.asarray(F, float), np.asarray(Q, float)
    if truth is not None:
        truth = np.asarray(truth, dtype=float)
        if truth.shape != (n, ys.shape[1], 7):
            raise ValueError(f"truth must have shape {(n, ys.shape[1], 7)}; got {truth.shape}")
    k_steps = ys.shape[1]
    xs = np.empty((n, k_steps, 7))
    pos_var = np.empty((n, k_steps))
    ll = np.empty((n, k_steps))
    nees = np.empty((n, k_steps)) if truth is not None else None
    alive = np.ones(n, dtype=bool)
    total = np.zeros(n)
    for k in range(k_steps):
        xp, Pp = (x, P) if k == 0 else ekf_predict(x, P, F, Q)
        with np.errstate(all="ignore"):  # a diverging filter may overflow; it is marked dead
            xu, Pu, inc = ekf_update(xp, Pp, ys[:, k], sensors, n_pu=int(n_pu))
        ok = alive & np.isfinite(xu).all(axis=1) & np.isfinite(Pu).all(axis=(1, 2)) & np.isfinite(inc)
        alive &= ok
        x = np.where(ok[:, None], xu, x)
        P = np.where(ok[:, None, None], Pu, P)
        total = np.where(ok, total + np.where(ok, inc, 0.0), -np.inf)
        xs[:, k], ll[:, k] = x, total
        pos_var[:, k] = np.einsum("nii->n", P[:, :3, :3])
        if nees is not None:
            _nees_kernel(P, x - truth[:, k], nees[:, k])
            nees[~alive, k] = np.nan
        if progress is not None:
            progress(1)
    return FilterRun(x=xs, position_var=pos_var, loglik=ll, nees=nees, alive=alive)
