"""Extended Kalman filters on the core's measurement model: EKF and PUEKF (seed 001 §2.3).

Every function works on a *stack* of N independent filters (leading axis N: Monte-Carlo runs ×
bank hypotheses), so one time step is one measurement call (:meth:`core.Sensor.measure`) on an
(N, n) array and a few batched n × n / m × m products and solves.

The filters are generic over the measurement model: h(X) and ∂h/∂X come from the sensors'
:class:`core.Sensor` (any kind: electric E with n = 7 states, magnetic B, G, BG with n = 8), the
noise of each component from its ``noise_vector`` (R diagonal, B in nT and G in nT/m side by
side); the compiled Kalman algebra reads n and m from the arrays.

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
from ..model.measurement import tracking_sensors
from ..model.validation import integer

__all__ = ["MIN_SPEED", "MIN_STATION_DISTANCE", "FilterRun", "ekf_predict", "ekf_update",
           "run_filters"]


def ekf_predict(x, P, F, Q):
    """Time update of N filters: ``x ← F x``, ``P ← F P Fᵀ + Q``.

    Parameters
    ----------
    x : ndarray, shape (N, n)
    P : ndarray, shape (N, n, n)
    F, Q : ndarray, shape (n, n)
        From :func:`core.dwna_model`.

    Returns
    -------
    x, P : ndarray, shapes (N, n), (N, n, n)
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


def ekf_update(x, P, y, sensors, *, n_pu=1, sensor=None):
    """Measurement update of N filters, progressive (PUEKF) with ``n_pu`` sub-updates.

    Parameters
    ----------
    x : ndarray, shape (N, n)
        Predicted states (n = 7 electric, 8 magnetic).
    P : ndarray, shape (N, n, n)
        Predicted covariances.
    y : ndarray, shape (N, m)
        Measurements (V/m, nT, nT/m), in the order of :class:`core.SensorModel`.
    sensors : core.SensorModel or array_like (S, 3)
        The sensors, or station positions together with ``sensor``.
    n_pu : int
        Number of progressive sub-updates N_pu ≥ 1 (1 = EKF).
    sensor : core.Sensor or str, optional
        The measurement model when ``sensors`` are station positions (3 axes per station).

    Returns
    -------
    x, P : ndarray, shapes (N, n), (N, n, n)
        Updated states and covariances (new arrays; NaN for a filter whose innovation
        covariance was not positive definite).
    loglik : ndarray, shape (N,)
        log N(y; h(x̂), H P Hᵀ + R) of the *predicted* measurement, the increment of the bank's
        accumulated log-likelihood (seed 001 eqs. (8)–(9)).

    Notes
    -----
    The Kalman algebra runs in a compiled kernel (Cholesky of S per filter); measurement values
    and Jacobians come from :meth:`core.SensorModel.h_and_jacobian`, i.e. the sensor's
    measurement model. R = diag(noise_vector²) is passed as a scale (the first component's
    variance) times per-component weights, so that equal noise (every electric sensor) runs
    the arithmetic of a scalar R = σ² I.
    """
    sensors = tracking_sensors(sensors, sensor)
    x = np.array(x, dtype=float)
    P = np.array(P, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    var = sensors.noise_vector**2
    r = float(var[0])
    weight = np.ascontiguousarray(var / r)
    like = np.empty(x.shape[0])
    for i in range(n_pu):
        g = _guard(x, sensors)
        h, H = sensors.h_and_jacobian(g)  # (N, m), (N, m, n)
        nu = y - h - np.einsum("nri,ni->nr", H, x - g)  # innovation, linearised at the guard
        _update_kernel(x, P, np.ascontiguousarray(nu), np.ascontiguousarray(H), n_pu * r, r,
                       weight, i == 0, like)
    return x, P, like


@dataclass(frozen=True)
class FilterRun:
    """Output of :func:`run_filters` for N filters over K steps.

    Attributes
    ----------
    x : ndarray, shape (N, K, n)
        Posterior estimates at every step (n = 7 electric, 8 magnetic).
    position_var : ndarray, shape (N, K)
        Trace of the position block of the posterior covariance (m²).
    loglik : ndarray, shape (N, K)
        Accumulated log-likelihood of the measurements up to each step; −inf once dead.
    nees : ndarray, shape (N, K), or None
        Normalised estimation error squared (x̂ − x)ᵀ P⁻¹ (x̂ − x) over the n states (its mean
        is n for a consistent filter), when the true states were given; NaN once dead.
    alive : ndarray of bool, shape (N,)
        False for filters that became non-finite.
    """

    x: np.ndarray
    position_var: np.ndarray
    loglik: np.ndarray
    nees: np.ndarray | None
    alive: np.ndarray


def run_filters(x0, P0, ys, sensors, F, Q, *, n_pu=1, truth=None, progress=None, sensor=None):
    """Run N independent (PU)EKFs over K steps of their own measurements.

    At step 0 each filter updates its prior (x0, P0) with ys[:, 0]; from step 1 on it predicts
    and updates.

    Parameters
    ----------
    x0 : array_like, shape (N, n)
        Prior means at step 0; n = the sensor's state size (7 electric, 8 magnetic).
    P0 : array_like, shape (N, n, n) or (n, n)
        Prior covariances.
    ys : array_like, shape (N, K, m)
        Measurements of every filter at every step (V/m, nT, nT/m).
    sensors, n_pu, sensor
        As for :func:`ekf_update`.
    F, Q : array_like, shape (n, n)
        From :func:`core.dwna_model` (``n_states=n``).
    truth : array_like, shape (N, K, n), optional
        True states, for the NEES.
    progress : callable, optional
        Called with 1 after every step (e.g. ``tqdm.update``).

    Returns
    -------
    FilterRun

    Examples
    --------
    A magnetometer + gradiometer (``"BG"``) at one station, 8 states:

    >>> import numpy as np, core
    >>> F, Q = core.dwna_model(1.0, 0.01, 1.0, n_states=8)
    >>> truth = core.straight_track([-20, 10, 5], 0.0, 2.0, 20, moments=(2e3, -1e3, 3e3))
    >>> sensors = core.SensorModel([[0, 0, 0]], sensor=core.Sensor("BG", noise=(0.01, 0.01)))
    >>> ys = sensors.h(truth)[None]  # noise-free here
    >>> P0 = np.diag([2.0, 2.0, 1.0, 0.3, 0.3, 300.0, 300.0, 300.0]) ** 2
    >>> run = core.run_filters(truth[None, 0] + 0.5, P0, ys, sensors, F, Q)
    >>> run.x.shape, bool(np.abs(run.x[0, -1, :3] - truth[-1, :3]).max() < 0.1)
    ((1, 20, 8), True)
    """
    sensors = tracking_sensors(sensors, sensor)
    n_x = sensors.n_states
    x = np.array(x0, dtype=float)
    ys = np.asarray(ys, dtype=float)
    if x.ndim != 2 or x.shape[1] != n_x:
        raise ValueError(f"x0 must have shape (N, {n_x}) (the state size of sensor kind "
                         f"{sensors.kind!r}); got {x.shape}")
    n = x.shape[0]
    if ys.ndim != 3 or ys.shape[0] != n or ys.shape[2] != sensors.n_meas:
        raise ValueError(
            f"ys must have shape (N, K, m) = ({n}, K, {sensors.n_meas}) for these sensors; got {ys.shape}"
        )
    if not np.all(np.isfinite(ys)):
        raise ValueError("ys must be finite (V/m, nT, nT/m)")
    try:
        P = np.broadcast_to(np.asarray(P0, dtype=float), (n, n_x, n_x)).copy()
    except ValueError:
        raise ValueError(f"P0 must have shape ({n_x}, {n_x}) or (N, {n_x}, {n_x}); got "
                         f"{np.shape(P0)}") from None
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(P)):
        raise ValueError("x0 and P0 must be finite")
    integer("n_pu", n_pu, 1, what=" (progressive sub-updates)")
    F, Q = np.asarray(F, float), np.asarray(Q, float)
    if F.shape != (n_x, n_x) or Q.shape != (n_x, n_x):
        raise ValueError(f"F and Q must be {n_x} × {n_x} (core.dwna_model(..., n_states={n_x})); "
                         f"got {F.shape} and {Q.shape}")
    if truth is not None:
        truth = np.asarray(truth, dtype=float)
        if truth.shape != (n, ys.shape[1], n_x):
            raise ValueError(f"truth must have shape {(n, ys.shape[1], n_x)}; got {truth.shape}")
    k_steps = ys.shape[1]
    xs = np.empty((n, k_steps, n_x))
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
