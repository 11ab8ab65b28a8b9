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

import numpy as np

from ..kernels.filters import (
    MIN_SPEED,
    MIN_STATION_DISTANCE,
    _nees_kernel,
    _predict_kernel,
    _update_kernel,
)
from ..model.measurement import SensorModel

__all__ = ["MIN_SPEED", "MIN_STATION_DISTANCE", "FilterRun", "ekf_predict", "ekf_update",
           "run_filters"]


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
