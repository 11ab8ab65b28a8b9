"""The posterior Cramér–Rao bound along a track (Tichavský, Muravchik & Nehorai 1998; spec §8).

For the linear-Gaussian motion of :func:`core.dwna_model` and additive Gaussian sensor noise the
Fisher information of the state obeys (their eq. (21) with D¹¹ = FᵀQ⁻¹F, D¹² = −FᵀQ⁻¹,
D²² = Q⁻¹ + E[HᵀR⁻¹H])

    J_0     = J_prior + E[H_0ᵀ R⁻¹ H_0]
    J_{k+1} = (Q + F J_k⁻¹ Fᵀ)⁻¹ + E[H_{k+1}ᵀ R⁻¹ H_{k+1}],

with H_k = ∂h/∂X at the true state X_k (:class:`core.SensorModel`, i.e. the measurement model of
its :class:`core.Sensor`: :func:`core.field_jacobian` or :func:`core.magnetic_jacobian`)
and E over the true tracks. Given one track, E is that track (the usual "nominal track"
bound); given M sampled tracks (:func:`core.sample_tracks`), E is their mean.

The prediction is evaluated as ``(I + M Q)⁻¹ M`` with ``M = F⁻ᵀ J_k F⁻¹``: algebraically
``(Q + F J_k⁻¹ Fᵀ)⁻¹``, but valid when J_k or Q is singular (docs/tracking.md).

Where J_k is numerically singular (η_J below :data:`SINGULAR_TOL`, see :func:`pcrlb`), the bound
is +inf: not enough information yet, or a structurally unobservable geometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels.pcrlb import _recursion
from ..model import validation
from ..model.measurement import tracking_sensors
from .motion import dwna_model

__all__ = ["SINGULAR_TOL", "PcrlbResult", "linearisation_breaks", "pcrlb"]

#: J_k counts as singular when the smallest eigenvalue of its diagonally scaled form
#: D^-½ J D^-½ (1 on the diagonal, so scale-free) is below this.
SINGULAR_TOL = 1e-12


@dataclass(frozen=True)
class PcrlbResult:
    """Posterior CRLB at every step of a track.

    Attributes
    ----------
    information : ndarray, shape (steps, n, n)
        J_k, in 1 / (state unit × state unit).
    cov : ndarray, shape (steps, n, n)
        J_k⁻¹ (state units squared); +inf on the diagonal and NaN elsewhere where singular.
    position_std : ndarray, shape (steps,)
        sqrt(σx² + σy² + σz²) (m); +inf where J_k is singular.
    horizontal_std : ndarray, shape (steps,)
        sqrt(σx² + σy²) (m).
    std : ndarray, shape (steps, n)
        Bound on each state's standard deviation (m, m/s, A·m).
    observable : ndarray of bool, shape (steps,)
        J_k not singular.
    """

    information: np.ndarray
    cov: np.ndarray
    position_std: np.ndarray
    horizontal_std: np.ndarray
    std: np.ndarray
    observable: np.ndarray


def _tracks(track, n):
    arr = validation.as_array("track", track)
    if arr.ndim not in (2, 3) or arr.shape[-1] != n:
        raise ValueError(
            f"track must be true states of shape (steps, {n}), or (M, steps, {n}) for M sampled "
            f"tracks (the sensor's state size); got shape {arr.shape}"
        )
    validation.finite("track", arr)
    return arr if arr.ndim == 3 else arr[None]


def _matrix(name, value, shape):
    arr = validation.as_array(name, value)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}; got {arr.shape}")
    validation.finite(name, arr)
    return arr


def measurement_information(tracks, sensors):
    """E[Hᵀ R⁻¹ H] at every step: (M, steps, n) true states → (steps, n, n)."""
    H = sensors.jacobian(tracks) / sensors.noise_vector[:, None]  # R^-½ H: (M, steps, m, n)
    return np.einsum("nkri,nkrj->kij", H, H) / tracks.shape[0]


def _invert(J):
    """Covariances and the singular flag of a stack of information matrices (K, n, n)."""
    d = np.sqrt(np.clip(np.einsum("kii->ki", J), 0.0, None))  # (K, n)
    with np.errstate(divide="ignore"):
        s = np.where(d > 0.0, 1.0 / d, 0.0)
    Js = J * s[:, :, None] * s[:, None, :]
    ok = (d > 0.0).all(axis=1) & (np.linalg.eigvalsh(Js)[:, 0] > SINGULAR_TOL)
    cov = np.full(J.shape, np.nan)
    idx = np.arange(J.shape[1])
    cov[:, idx, idx] = np.inf
    if ok.any():
        cov[ok] = np.linalg.inv(Js[ok]) * s[ok][:, :, None] * s[ok][:, None, :]
    return cov, ok


def pcrlb(track, sensors, *, T=1.0, sigma_a=0.1, alpha=0.001, prior_cov=None, prior_info=None,
          sensor=None):
    """Posterior Cramér–Rao bound at every step of a track.

    Parameters
    ----------
    track : array_like, shape (steps, n) or (M, steps, n)
        True states ``[x, y, z, vx, vy, Ph, Pv]`` (m, m/s, A·m; n = 7) at every step, or
        ``[x, y, z, vx, vy, mx, my, mz]`` (n = 8) for a magnetic sensor kind: one nominal
        track (e.g. :func:`core.straight_track`) or M sampled ones (:func:`core.sample_tracks`),
        over which the measurement information is averaged.
    sensors : core.SensorModel or array_like (S, 3)
        Stations, axes (3 or 2) and the :class:`core.Sensor` (kind E, B, G, BG, noise per
        component, medium); or station positions (m) together with ``sensor``.
    T, sigma_a, alpha : float
        Sample interval (s), DWNA acceleration σ (m/s²), moment random walk ((A·m)² per step)
        of :func:`core.dwna_model`. ``sigma_a = alpha = 0``: a deterministic track.
    prior_cov : array_like, shape (n, n), or None
        Covariance of the prior at step 0 (state units squared); ``None`` (and no
        ``prior_info``) is a flat prior (J_prior = 0: no information but the measurements).
    prior_info : array_like, shape (n, n), or None
        The prior as an information matrix instead (1 / state units squared), symmetric
        positive *semi*-definite: zero rows are states with a flat prior (e.g. a filter bank that
        knows only the depth and Pv roughly). Not together with ``prior_cov``.
    sensor : core.Sensor or str, optional
        The measurement model (or a kind name) when ``sensors`` are station positions (3 axes
        per station); None there is the electric default.

    Returns
    -------
    PcrlbResult

    Raises
    ------
    ValueError
        Bad shapes or values, a target on a station, a prior that is not positive definite.

    Examples
    --------
    >>> import core
    >>> sensors = core.SensorModel([[0, -5, 20], [0, 5, 20]], axes=3)
    >>> track = core.straight_track([-60, -60, 0.5], 0.7, 2.0, 50)
    >>> b = core.pcrlb(track, sensors, prior_cov=None)
    >>> bool(b.observable[0]), bool(b.observable[-1]), b.position_std.shape
    (False, True, (50,))
    >>> mag = core.straight_track([-60, 15, 10], 0.0, 2.0, 50, moments=(2e3, -1e3, 3e3))
    >>> bg = core.pcrlb(mag, [[0, 0, 0]], sensor="BG")
    >>> bg.cov.shape, bool(bg.observable[-1])
    ((50, 8, 8), True)
    """
    sensors = tracking_sensors(sensors, sensor)
    n = sensors.n_states
    tracks = _tracks(track, n)
    F, Q = dwna_model(T, sigma_a, alpha, n_states=n)
    if prior_cov is not None and prior_info is not None:
        raise ValueError("give the prior as prior_cov or as prior_info, not both")
    if prior_info is not None:
        J = _matrix("prior_info", prior_info, (n, n))
        J = 0.5 * (J + J.T)
        if np.linalg.eigvalsh(J)[0] < -1e-12 * max(np.abs(J).max(), 1e-300):
            raise ValueError("prior_info must be symmetric positive semi-definite (1 / state units²)")
    elif prior_cov is None:
        J = np.zeros((n, n))
    else:
        P0 = _matrix("prior_cov", prior_cov, (n, n))
        P0 = 0.5 * (P0 + P0.T)
        try:
            np.linalg.cholesky(P0)
        except np.linalg.LinAlgError:
            raise ValueError("prior_cov must be symmetric positive definite (state units²)") from None
        J = np.linalg.inv(P0)
    info = measurement_information(tracks, sensors)  # (steps, n, n)
    Finv = np.linalg.inv(F)
    out = _recursion(Finv, np.ascontiguousarray(Finv.T), Q, J, info)
    cov, ok = _invert(out)
    var = np.einsum("kii->ki", cov)
    return PcrlbResult(
        information=out,
        cov=cov,
        position_std=np.sqrt(var[:, :3].sum(axis=1)),
        horizontal_std=np.sqrt(var[:, :2].sum(axis=1)),
        std=np.sqrt(var),
        observable=ok,
    )


def linearisation_breaks(crlb_m, range_m, limit=0.3):
    """Where a linearised bound stops predicting a tracker's error.

    A CRLB (or PCRLB) is the inverse of a *local* information: it describes errors small enough
    for the measurement to be linear over them. Far from the stations the range–strength
    direction (spec §4) is so weak that the bound grows to a sizeable fraction of the range,
    where the field is anything but linear — real estimators there run away along that
    direction or lock onto another solution, and a bound of tens of kilometres is not an error
    to quote. Flag such points instead.

    Parameters
    ----------
    crlb_m : array_like
        Bound on the position error (m), ≥ 0 or +inf (unobservable); NaN (on a station) gives
        False.
    range_m : array_like
        Distance from the target to the nearest station (or the array centre) (m), > 0;
        broadcasts against ``crlb_m``.
    limit : float
        Largest trusted ratio crlb / range, in (0, 1]; default 0.3 (the field changes by
        ~(1.3)³ ≈ 2.2× over such an error: far from linear).

    Returns
    -------
    ndarray of bool
        True where ``crlb_m > limit · range_m`` (including +inf bounds).

    Examples
    --------
    >>> import core
    >>> core.linearisation_breaks([1.0, 50.0, float("inf")], [100.0, 100.0, 100.0]).tolist()
    [False, True, True]
    """
    crlb = validation.as_array("crlb_m", crlb_m)
    rng = validation.as_array("range_m", range_m)
    if np.any(crlb < 0):
        raise ValueError("crlb_m must be ≥ 0 (m) or +inf; got a negative value")
    if np.any(~np.isfinite(rng)) or np.any(rng <= 0):
        raise ValueError("range_m must be finite and > 0 (m)")
    limit = validation.positive("limit", limit, "crlb / range")
    if limit > 1.0:
        raise ValueError(f"limit must be a number in (0, 1] (crlb / range); got {limit!r}")
    try:
        shape = np.broadcast_shapes(crlb.shape, rng.shape)
    except ValueError:
        raise ValueError(
            f"crlb_m {crlb.shape} and range_m {rng.shape} must broadcast against each other"
        ) from None
    with np.errstate(invalid="ignore"):
        return np.broadcast_to(crlb > limit * rng, shape).copy()
