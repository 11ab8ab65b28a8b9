"""The Cramér–Rao bound of a layout in metres: covariance, error ellipses and their maps.

Built on the all-rows Fisher information of :mod:`core.observability.fisher`
(F = ΓᵀΓ / noise², every component of every station over ``steps`` instants, spec §3):

- :func:`crlb_covariance` — the full Cramér–Rao covariance F⁻¹, from a QR factorisation of the
  column-scaled Γ (backward stable; forming ΓᵀΓ would square its condition number).
- :func:`horizontal_error_ellipse` and :func:`crlb_maps` — the 1-σ horizontal position error
  ellipse (m, degrees), depth error σz (m), speed error σ|v| (m/s) per point or over a plane
  (:class:`CrlbErrors`).

Where Γ is structurally rank-deficient the CRLB is +inf (orientation NaN); the region criteria
of :mod:`core.observability.design` say how they count such points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import sensors, validation
from .fisher import DEFAULT_STEPS, fisher_measures
from .gamma import _gamma
from .grids import Plane

__all__ = [
    "CrlbErrors",
    "crlb_covariance",
    "crlb_maps",
    "horizontal_error_ellipse",
]

#: Γ entries per chunk of :func:`crlb_maps` (bounds memory at ~32 MB per array).
_CHUNK_ENTRIES = 1 << 22


def _covariance_flat(states, stations, observable, steps, T, known, sensor):
    """Full CRLB covariance of (P, n_states) valid states, (P, n_states, n_states).

    Known states get zero rows and columns (they are known exactly). Where ``observable`` is
    False the unknown block is NaN off the diagonal and +inf on it.
    """
    free = sensor.free_columns(known)
    npts, n, n_x = states.shape[0], free.size, sensor.n_states
    cov = np.zeros((npts, n_x, n_x))
    block = np.full((npts, n, n), np.nan)
    block[:, np.arange(n), np.arange(n)] = np.inf
    idx = np.flatnonzero(observable)
    if idx.size:
        _, noise = sensor.kernel_rows()  # the noise the whitened Γ leaves (electric: all of it)
        g = _gamma(states[idx], stations, T, sensor, steps, known)
        norms = np.linalg.norm(g, axis=-2)  # (p, n): column norms, (V/m) per state unit
        # 1. Γ_s = Γ / ‖Γ_j‖ = Q R; (Γ_sᵀΓ_s)⁻¹ = R⁻¹ R⁻ᵀ. The flag guarantees R is invertible.
        r = np.linalg.qr(g / norms[:, None, :], mode="r")  # (p, n, n)
        rinv = np.linalg.solve(r, np.broadcast_to(np.eye(n), r.shape))
        inv_s = rinv @ np.swapaxes(rinv, -1, -2)
        # 2. Undo the column scaling and apply R = noise² I: Cov = noise² D⁻¹ (Γ_sᵀΓ_s)⁻¹ D⁻¹.
        block[idx] = noise**2 * inv_s / (norms[:, :, None] * norms[:, None, :])
    cov[:, free[:, None], free[None, :]] = block
    return cov


def crlb_covariance(states, stations, *, noise=None, steps=DEFAULT_STEPS, T=1.0,
                    sigma=None, model=None, sea=None, known=(), sensor=None):
    """Full Cramér–Rao covariance F⁻¹ of the 7 states.

    Parameters
    ----------
    states, stations, noise, steps, T, known, sensor
        As for :func:`core.fisher_measures` (``sensor``: the measurement model with its medium,
        whose magnetic kinds take 8 states and noise in nT, nT/m).
    sigma, model, sea
        Deprecated (a DeprecationWarning): the electric medium beside ``sensor=``; pass
        ``sensor=core.Sensor("E", noise, sigma, sea, model)``, which they build.

    Returns
    -------
    cov : ndarray, shape (..., 7, 7) (8 × 8 for magnetic kinds)
        Covariance in state units (m², m²/s, …, (A·m)²), always 7 × 7 in the state order of
        :data:`core.STATE_NAMES`. Rows and columns of ``known`` states are 0. Where the point
        is unobservable (the flag of :func:`core.fisher_measures`) the unknown block has +inf on
        its diagonal and NaN elsewhere.
    observable : ndarray of bool, shape (...)

    Raises
    ------
    ValueError
        As :func:`core.fisher_measures` (bad shapes, non-finite values, target on a station …).

    Examples
    --------
    >>> import numpy as np, core
    >>> cov, ok = core.crlb_covariance([30, 40, 120, 2, 2, 100, 20], core.dual_station(100, 15))
    >>> cov.shape, bool(ok)
    ((7, 7), True)
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    m = fisher_measures(states, stations, steps=steps, T=T, known=known,
                        sensor=sensor)  # validates everything, flags observability
    flat, lead = sensor.states(states)
    cov = _covariance_flat(flat, validation.stations(stations), m.observable.reshape(-1), steps,
                           T, known, sensor)
    return cov.reshape(lead + (sensor.n_states,) * 2), m.observable


@dataclass(frozen=True)
class CrlbErrors:
    """1-σ Cramér–Rao errors; every array has the points' shape (or the plane's (n, n)).

    Attributes
    ----------
    semi_major, semi_minor : ndarray
        Semi-axes (m) of the 1-σ horizontal position error ellipse, the (x, y) block of the
        covariance. +inf where unobservable.
    orientation : ndarray
        Direction of the semi-major axis (degrees from +x towards +y, in (−90, 90]). NaN where
        unobservable; 0 for a circle.
    sigma_z : ndarray
        Depth error σz (m).
    sigma_speed : ndarray
        Error of the speed |v| = sqrt(vx² + vy²) (m/s), by the gradient (vx, vy)/|v| through the
        (vx, vy) covariance block.
    position : ndarray
        sqrt(σx² + σy² + σz²) (m), as :attr:`core.FisherMeasures.position_std`.
    observable : ndarray of bool
        False where unobservable and (for maps) on stations.

    Notes
    -----
    Maps from :func:`crlb_maps` hold NaN on stations (within ``ON_STATION``).
    """

    semi_major: np.ndarray
    semi_minor: np.ndarray
    orientation: np.ndarray
    sigma_z: np.ndarray
    sigma_speed: np.ndarray
    position: np.ndarray
    observable: np.ndarray


def _errors_from_cov(states, cov, observable):
    """CrlbErrors fields (flat) from (P, 7) states, (P, 7, 7) covariance, (P,) flag."""
    cxx, cyy, cxy = cov[:, 0, 0], cov[:, 1, 1], cov[:, 0, 1]
    with np.errstate(invalid="ignore"):
        half_gap = np.hypot(0.5 * (cxx - cyy), cxy)
        mid = 0.5 * (cxx + cyy)
        semi_major = np.sqrt(mid + half_gap)
        semi_minor = np.sqrt(np.maximum(mid - half_gap, 0.0))  # round-off may give −0
        orient = 0.5 * np.degrees(np.arctan2(2.0 * cxy, cxx - cyy))  # (−90, 90]
        grad = states[:, 3:5] / np.hypot(states[:, 3], states[:, 4])[:, None]  # ∂|v|/∂(vx, vy)
        var_speed = np.einsum("pi,pij,pj->p", grad, cov[:, 3:5, 3:5], grad)
        sigma_speed = np.sqrt(np.maximum(var_speed, 0.0))
        position = np.sqrt(cxx + cyy + cov[:, 2, 2])
        sigma_z = np.sqrt(cov[:, 2, 2])
    bad = ~observable
    for arr in (semi_major, semi_minor, sigma_z, sigma_speed, position):
        arr[bad] = np.inf
    orient[bad] = np.nan
    return {"semi_major": semi_major, "semi_minor": semi_minor, "orientation": orient,
            "sigma_z": sigma_z, "sigma_speed": sigma_speed, "position": position,
            "observable": observable.copy()}


def horizontal_error_ellipse(states, stations, *, noise=None, steps=DEFAULT_STEPS,
                             T=1.0, sigma=None, model=None, sea=None, known=(), sensor=None):
    """1-σ horizontal position error ellipse, depth and speed errors from the CRLB.

    Parameters
    ----------
    states, stations, noise, steps, T, sigma, model, sea, known, sensor
        As for :func:`crlb_covariance`. A known state has zero error.

    Returns
    -------
    CrlbErrors
        Arrays of shape (...): ellipse semi-axes (m) and orientation (degrees), σz (m),
        σ|v| (m/s), 3-D position error (m). +inf (orientation NaN) where unobservable.

    Notes
    -----
    The ellipse {p : pᵀ C⁻¹ p = 1} of the 2 × 2 block C = Cov[(x, y)]: semi-axes are the square
    roots of C's eigenvalues, λ = (cxx + cyy)/2 ± sqrt(((cxx − cyy)/2)² + cxy²), and the major
    axis is at ½·atan2(2 cxy, cxx − cyy).

    Examples
    --------
    >>> import core
    >>> e = core.horizontal_error_ellipse([30, 40, 120, 2, 2, 100, 20], core.dual_station(100, 15))
    >>> bool(e.semi_major >= e.semi_minor > 0)
    True
    >>> bool(core.horizontal_error_ellipse([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]]).semi_major
    ...      == float("inf"))
    True
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    cov, observable = crlb_covariance(states, stations, steps=steps, T=T, known=known,
                                      sensor=sensor)
    flat, lead = sensor.states(states)
    n = sensor.n_states
    fields = _errors_from_cov(flat, cov.reshape(-1, n, n), observable.reshape(-1))
    return CrlbErrors(**{k: v.reshape(lead) for k, v in fields.items()})


def _plane_states(plane, velocity, moments, sensor=None, rows=slice(None)):
    """Target states (rows · n, n_states) on a plane's grid: velocity (vx, vy) and the kind's
    moments everywhere (validated as the kind's states: a speed > 0 for the electric kind)."""
    if not isinstance(plane, Plane):  # ValueError for all bad input, as core does
        raise ValueError(
            f"plane must be a core.Plane; got {type(plane).__name__}")
    sensor = sensors.sensor_model(sensor)
    vel = _pair("velocity", velocity)
    n_moments = sensor.n_states - 5
    mom = np.asarray(moments, dtype=np.float64) if np.ndim(moments) == 1 else None
    if mom is None or mom.shape != (n_moments,) or not np.all(np.isfinite(mom)):
        names = ", ".join(sensor.state_names[5:])
        raise ValueError(f"moments of sensor kind {sensor.kind!r} must be ({names}), finite; "
                         f"got {moments!r}")
    sensor.states(np.concatenate([[0.0, 0.0, 0.0], vel, mom]))  # the kind's checks (speed > 0)
    out = plane.states(vel, mom, rows)  # the grid of any state size (compiled grid_states)
    return out.reshape(-1, out.shape[-1])


def _pair(name, value):
    arr = np.asarray(value, dtype=np.float64) if np.ndim(value) == 1 else None
    if arr is None or arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a pair of finite numbers; got {value!r}")
    return arr


def crlb_maps(plane, stations, *, velocity, moments, noise=None, steps=DEFAULT_STEPS,
              T=1.0, sigma=None, model=None, sea=None, known=(), sensor=None):
    """CRLB errors (ellipse, depth, speed, position) over a :class:`core.Plane`.

    Parameters
    ----------
    plane, stations, velocity, moments
        As for :func:`core.evaluate_map`.
    noise, steps, T, sigma, model, sea, known, sensor
        As for :func:`crlb_covariance`.

    Returns
    -------
    CrlbErrors
        Arrays of shape (n, n), rows along the plane's second axis (y or z), columns x, as in
        :class:`core.MapResult`. NaN within ``ON_STATION`` of a station, +inf where
        unobservable.

    Examples
    --------
    >>> import core
    >>> plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 11)
    >>> e = core.crlb_maps(plane, core.dual_station(100, 15), velocity=(2, 2), moments=(100, 20))
    >>> e.semi_major.shape
    (11, 11)
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    states = _plane_states(plane, velocity, moments, sensor)
    stations = validation.stations(stations)
    ok = np.flatnonzero(sensor.clear(states, stations, steps, T))
    out = {k: np.full(states.shape[0], np.nan) for k in
           ("semi_major", "semi_minor", "orientation", "sigma_z", "sigma_speed", "position")}
    out["observable"] = np.zeros(states.shape[0], dtype=bool)
    rows = sensor.n_components * stations.shape[0] * validation.steps(steps, 1)
    chunk = max(1, _CHUNK_ENTRIES // (rows * sensor.n_states))
    for c0 in range(0, ok.size, chunk):
        idx = ok[c0:c0 + chunk]
        e = horizontal_error_ellipse(states[idx], stations, steps=steps, T=T, known=known,
                                     sensor=sensor)
        for k, arr in out.items():
            arr[idx] = getattr(e, k)
    n = plane.n
    return CrlbErrors(**{k: v.reshape(n, n) for k, v in out.items()})
