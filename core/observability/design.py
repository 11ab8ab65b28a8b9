"""Sensor-layout design: CRLB error ellipses in metres, N-station layouts, the best spacing.

Everything here builds on the all-rows Fisher information of :mod:`core.observability.fisher`
(F = ΓᵀΓ / noise², every component of every station over ``steps`` instants, spec §3):

- :func:`crlb_covariance` — the full Cramér–Rao covariance F⁻¹, from a QR factorisation of the
  column-scaled Γ (backward stable; forming ΓᵀΓ would square its condition number).
- :func:`horizontal_error_ellipse` and :func:`crlb_maps` — the 1-σ horizontal position error
  ellipse (m, degrees), depth error σz (m), speed error σ|v| (m/s) per point or over a plane.
- :func:`station_layout` — "line", "triangle", "square" and "free" layouts of N = 1..8 stations.
- :func:`layout_criterion`, :func:`spacing_curve`, :func:`best_spacing`,
  :func:`optimise_layout` — how good a layout is for a surveillance region, and the best one.

Unobservable points
-------------------
Where Γ is structurally rank-deficient (:func:`core.observable_rank` < n, the flag of
:func:`core.fisher_measures`), F is singular: the CRLB is +inf and the D-optimal measure −inf.
Region criteria cannot average −inf, so :func:`layout_criterion` counts such a point at its
**D-optimal floor**, the value it would have at the largest η a rank-deficient Γ_s can have,
η_max = RANK_RTOL·√(e·n) (σ_min ≤ RANK_RTOL·σ_max, σ_max ≤ √n, and Π of the other n − 1
singular values ≤ √e, all for unit columns):

    floor = log10(η_max) + Σ_j log10 ‖Γ_j‖ − n·log10(noise),

the largest D-optimal value that float64 round-off could fake at that point (D-opt =
log10 η + Σ log10‖Γ_j‖ − n log10 noise where observable). The criterion stays finite and the
floor grows with the column norms, so an optimiser sees a slope; an observable point may lie
below it (η measures volume, not rank), so :attr:`CriterionResult.observable_fraction` says how
much of the region is truly observable. For ``"area_crlb"`` an unobservable point simply
fails the threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from .. import dask_backend
from ..model import magnetic, sensors, validation
from .fisher import DEFAULT_STEPS, fisher_measures, magnetic_fisher
from .gamma import RANK_RTOL, gamma
from .grids import Plane

__all__ = [
    "CRITERIA",
    "LAYOUTS",
    "MAX_STATIONS",
    "CriterionResult",
    "CrlbErrors",
    "LayoutResult",
    "SpacingResult",
    "best_spacing",
    "crlb_covariance",
    "crlb_maps",
    "horizontal_error_ellipse",
    "layout_criterion",
    "optimise_layout",
    "spacing_curve",
    "station_layout",
]

#: Layout kinds accepted by :func:`station_layout`.
LAYOUTS = ("line", "triangle", "square", "free")
#: Largest number of stations a layout may have.
MAX_STATIONS = 8
#: Region criteria: name -> (label, unit). Larger is better for every one of them.
CRITERIA = {
    "mean_dopt": ("mean D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "worst_dopt": ("worst (minimum) D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "area_crlb": ("fraction of the region with CRLB position error < threshold", "dimensionless"),
}
#: Γ entries per chunk of :func:`crlb_maps` (bounds memory at ~32 MB per array).
_CHUNK_ENTRIES = 1 << 22


# --------------------------------------------------------------------------------------------
# CRLB covariance and the errors derived from it
# --------------------------------------------------------------------------------------------

def _covariance_flat(states, stations, observable, noise, steps, T, sigma, model, sea, known):
    """Full 7 × 7 CRLB covariance of (P, 7) valid states, (P, 7, 7).

    Known states get zero rows and columns (they are known exactly). Where ``observable`` is
    False the unknown block is NaN off the diagonal and +inf on it.
    """
    free = validation.free_columns(known)
    npts, n = states.shape[0], free.size
    cov = np.zeros((npts, sensors.ELECTRIC_STATES, sensors.ELECTRIC_STATES))
    block = np.full((npts, n, n), np.nan)
    block[:, np.arange(n), np.arange(n)] = np.inf
    idx = np.flatnonzero(observable)
    if idx.size:
        g = gamma(states[idx], stations, T=T, sigma=sigma, model=model, sea=sea, steps=steps,
                  known=known)
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
                    sigma=4.0, model="exact", sea=None, known=(), sensor=None):
    """Full Cramér–Rao covariance F⁻¹ of the 7 states.

    Parameters
    ----------
    states : array_like, shape (..., 7)
        ``[x, y, z, vx, vy, Ph, Pv]`` in m, m/s, A·m (speed > 0).
    stations : array_like, shape (S, 3)
        Station positions (m).
    noise : float
        Sensor noise standard deviation (V/m) on every field component, > 0.
    steps : int
        Number of instants N ≥ 1 (all rows of all stations).
    T, sigma, model, sea, known, sensor
        As for :func:`core.gamma` (``sea``: whole space or a :class:`core.Sea`; ``sensor``: the
        measurement model, whose magnetic kinds take 8 states and noise in nT, nT/m).

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
    if sensor.magnetic:
        m, block, lead = magnetic_fisher(states, stations, sensor, T, steps, known)
        free = sensor.free_columns(known)
        n = sensor.n_states
        cov = np.zeros((block.shape[0], n, n))
        cov[:, free[:, None], free[None, :]] = block
        return cov.reshape(lead + (n, n)), m.observable.reshape(lead)
    sigma, model, sea, noise = sensor.sigma, sensor.model, sensor.sea, sensor.noise_vector[0]
    m = fisher_measures(states, stations, noise=noise, steps=steps, T=T, sigma=sigma,
                        model=model, sea=sea, known=known)  # validates everything, flags observability
    flat, lead = validation.states(states)
    cov = _covariance_flat(flat, validation.stations(stations), m.observable.reshape(-1),
                           float(noise), steps, T, sigma, model, sea, known)
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
                             T=1.0, sigma=4.0, model="exact", sea=None, known=(), sensor=None):
    """1-σ horizontal position error ellipse, depth and speed errors from the CRLB.

    Parameters
    ----------
    states : array_like, shape (..., 7)
        ``[x, y, z, vx, vy, Ph, Pv]`` in m, m/s, A·m (speed > 0).
    stations : array_like, shape (S, 3)
        Station positions (m).
    noise, steps, T, sigma, model, sea, known, sensor
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
    flat, lead = (magnetic.states if sensor.magnetic else validation.states)(states)
    n = sensor.n_states
    fields = _errors_from_cov(flat, cov.reshape(-1, n, n), observable.reshape(-1))
    return CrlbErrors(**{k: v.reshape(lead) for k, v in fields.items()})


def _plane_states(plane, velocity, moments, sensor=None):
    if not isinstance(plane, Plane):  # ValueError for all bad input, as core does
        raise ValueError(
            f"plane must be a core.Plane; got {type(plane).__name__}")
    if sensor is not None and sensor.magnetic:
        return magnetic_plane_states(plane, velocity, moments)
    template, _ = validation.states([0.0, 0.0, 0.0, *_pair("velocity", velocity),
                                     *_pair("moments", moments)])  # checks speed > 0
    return plane.states(template[0, 3:5], template[0, 5:]).reshape(-1, template.shape[-1])


def magnetic_plane_states(plane, velocity, moments, rows=slice(None)):
    """Magnetic target states (rows · n, 8) on a plane's grid: velocity (vx, vy) m/s and moment
    (mx, my, mz) A·m² everywhere."""
    vel = _pair("velocity", velocity)
    mom = np.asarray(moments, dtype=np.float64) if np.ndim(moments) == 1 else None
    if mom is None or mom.shape != (3,) or not np.all(np.isfinite(mom)):
        raise ValueError(f"moments of a magnetic kind must be (mx, my, mz) in A·m², finite; got {moments!r}")
    out = plane.states(vel, mom, rows)  # the grid of any state size (compiled grid_states)
    return out.reshape(-1, out.shape[-1])


def magnetic_clear(states, stations, sensor, steps, T):
    """(P,) True where a magnetic target (P, 8) stays clear of every station at every instant
    of Γ: farther than ON_STATION, and than a gradiometer's baseline (its magnetometers sit
    ±L/2 about the station)."""
    near = validation.ON_STATION
    if sensor.kind in ("G", "BG"):
        near = max(near, magnetic.baseline_value(sensor.baseline))
    T = validation.positive("T", T, "s")
    clear = np.ones(states.shape[0], dtype=bool)
    for i in range(validation.steps(steps, 1)):
        moved = states[:, :3].copy()
        moved[:, :2] += i * T * states[:, 3:5]
        clear &= np.min(validation.station_distances(moved, stations), axis=1) >= near
    return clear


def _pair(name, value):
    arr = np.asarray(value, dtype=np.float64) if np.ndim(value) == 1 else None
    if arr is None or arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a pair of finite numbers; got {value!r}")
    return arr


def _off_station(states, stations):
    return np.min(validation.station_distances(states, stations), axis=1) >= validation.ON_STATION


def crlb_maps(plane, stations, *, velocity, moments, noise=None, steps=DEFAULT_STEPS,
              T=1.0, sigma=4.0, model="exact", sea=None, known=(), sensor=None):
    """CRLB errors (ellipse, depth, speed, position) over a :class:`core.Plane`.

    Parameters
    ----------
    plane : core.Plane
    stations : array_like, shape (S, 3)
        Station positions (m).
    velocity : (vx, vy)
        Target velocity (m/s), speed > 0.
    moments : (Ph, Pv) or (mx, my, mz)
        Dipole moments: (Ph, Pv) A·m for the electric kind, the moment vector A·m² for magnetic.
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
    if sensor.magnetic:
        ok = np.flatnonzero(magnetic_clear(states, stations, sensor, steps, T))
    else:
        ok = np.flatnonzero(_off_station(states, stations))
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


# --------------------------------------------------------------------------------------------
# Layouts
# --------------------------------------------------------------------------------------------

def _n_stations(n_stations):
    if isinstance(n_stations, bool) or not isinstance(n_stations, (int, np.integer)) or not (
        1 <= n_stations <= MAX_STATIONS
    ):
        raise ValueError(f"n_stations must be an integer in [1, {MAX_STATIONS}]; got {n_stations!r}")
    return int(n_stations)


def station_layout(kind, n_stations=2, *, d=15.0, h=100.0, positions=None):
    """Positions of N stations at depth h in one of the :data:`LAYOUTS`.

    Parameters
    ----------
    kind : {"line", "triangle", "square", "free"}
        - ``"line"``: station i at (i·d, 0, h), i = 0 … N−1; station 1 at the origin as in the
          paper, so ``"line"`` with N = 2 is :func:`core.dual_station`.
        - ``"triangle"``: a triangular lattice of side d filled row by row (rows of
          ⌈√N⌉ stations, each row shifted by d/2 and √3·d/2 in y): N = 3 is the equilateral
          triangle (0,0), (d,0), (d/2, √3 d/2).
        - ``"square"``: a square lattice of side d filled row by row (rows of ⌈√N⌉ stations):
          N = 4 is the square of side d with a corner at the origin.
        - ``"free"``: the given ``positions``.
    n_stations : int
        N, 1 … :data:`MAX_STATIONS`. For ``"free"`` it must match ``positions`` (or be None).
    d : float
        Spacing (m), > 0; ignored for ``"free"``.
    h : float
        Station depth (m), on the same axis as the target's z; ignored for ``"free"`` with
        (S, 3) positions.
    positions : array_like, shape (S, 2) or (S, 3), optional
        ``"free"`` only: (x, y) at depth h, or (x, y, z) (m).

    Returns
    -------
    ndarray, shape (N, 3)
        Station positions (m).

    Examples
    --------
    >>> import core
    >>> core.station_layout("line", 3, d=10, h=100).tolist()
    [[0.0, 0.0, 100.0], [10.0, 0.0, 100.0], [20.0, 0.0, 100.0]]
    >>> core.station_layout("square", 4, d=5, h=50)[:, :2].tolist()
    [[0.0, 0.0], [5.0, 0.0], [0.0, 5.0], [5.0, 5.0]]
    """
    if kind not in LAYOUTS:
        raise ValueError(f"layout kind must be one of {list(LAYOUTS)}; got {kind!r}")
    h = float(h) if np.isscalar(h) and np.isfinite(h) else None
    if h is None:
        raise ValueError("station depth h must be a finite number (m)")
    if kind == "free":
        if positions is None:
            raise ValueError("layout 'free' needs positions: an (S, 2) or (S, 3) array in m")
        pos = validation._array("positions", positions)
        if pos.ndim != 2 or pos.shape[1] not in (2, 3):
            raise ValueError(f"positions must have shape (S, 2) or (S, 3) in m; got shape {pos.shape}")
        if pos.shape[1] == 2:
            pos = np.column_stack([pos, np.full(pos.shape[0], h)])
        if n_stations is not None and _n_stations(n_stations) != pos.shape[0]:
            raise ValueError(f"n_stations={n_stations} does not match {pos.shape[0]} positions")
        _n_stations(pos.shape[0])
        return validation.stations(pos)
    n = _n_stations(n_stations)
    d = validation.positive("d", d, "m")
    if kind == "line":
        return np.column_stack([d * np.arange(n), np.zeros(n), np.full(n, h)])
    cols = int(np.ceil(np.sqrt(n)))
    i = np.arange(n)
    row, col = i // cols, i % cols
    if kind == "square":
        x, y = d * col, d * row
    else:  # triangle: alternate rows shifted by half a side
        x, y = d * (col + 0.5 * (row % 2)), d * (np.sqrt(3.0) / 2.0) * row
    return np.column_stack([x.astype(float), y.astype(float), np.full(n, h)])


# --------------------------------------------------------------------------------------------
# Region criteria and optimisation
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class CriterionResult:
    """A layout's criterion over a region.

    Attributes
    ----------
    value : float
        The criterion (see :data:`CRITERIA`); larger is better.
    observable_fraction : float
        Fraction of the region's (off-station) points that are observable.
    """

    value: float
    observable_fraction: float


def _check_criterion(criterion, threshold):
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {sorted(CRITERIA)}; got {criterion!r}")
    return validation.positive("threshold", threshold, "m")


def _region_states(region, velocity, moments, sensor=None):
    if not isinstance(region, Plane):
        raise ValueError(
            "region must be a core.Plane (an x–y rectangle at a target depth, or an x–z band of "
            f"depths); got {type(region).__name__}"
        )
    return _plane_states(region, velocity, moments, sensor)


def _magnetic_criterion(states, stations, criterion, threshold, steps, T, known, sensor):
    """:func:`_criterion` of a magnetic kind: the Fisher measures of the whitened Γ."""
    states = states[magnetic_clear(states, stations, sensor, steps, T)]
    if states.shape[0] == 0:
        raise ValueError("every point of the region lies on a station; nothing to evaluate")
    m, _, _ = magnetic_fisher(states, stations, sensor, T, steps, known)
    frac = float(np.mean(m.observable))
    if criterion == "area_crlb":
        return CriterionResult(float(np.mean(m.position_std < threshold)), frac)
    d_opt = m.d_optimal.copy()
    bad = np.flatnonzero(~m.observable)
    if bad.size:  # the D-optimal floor of the module notes, on the whitened Γ (noise 1)
        g = sensors.magnetic_gamma(states[bad], stations, sensor, T=T, steps=steps, known=known,
                                   whiten=True)
        with np.errstate(divide="ignore"):
            log_norms = np.sum(np.log10(np.linalg.norm(g, axis=-2)), axis=-1)
        n = g.shape[-1]
        d_opt[bad] = np.log10(RANK_RTOL * np.sqrt(np.e * n)) + log_norms
    value = np.mean(d_opt) if criterion == "mean_dopt" else np.min(d_opt)
    return CriterionResult(float(value), frac)


def _criterion(states, stations, criterion, threshold, noise, steps, T, sigma, model, sea, known,
               sensor=None):
    """Criterion over (P, 7) region states; on-station points are left out. A magnetic
    ``sensor`` (its (P, 8) states) goes to :func:`_magnetic_criterion`."""
    if sensor is not None and sensor.magnetic:
        return _magnetic_criterion(states, stations, criterion, threshold, steps, T, known, sensor)
    states = states[_off_station(states, stations)]
    if states.shape[0] == 0:
        raise ValueError("every point of the region lies on a station; nothing to evaluate")
    m = fisher_measures(states, stations, noise=noise, steps=steps, T=T, sigma=sigma,
                        model=model, sea=sea, known=known)
    frac = float(np.mean(m.observable))
    if criterion == "area_crlb":
        return CriterionResult(float(np.mean(m.position_std < threshold)), frac)
    d_opt = m.d_optimal.copy()
    bad = np.flatnonzero(~m.observable)
    if bad.size:  # the D-optimal floor of the module notes
        g = gamma(states[bad], stations, T=T, sigma=sigma, model=model, sea=sea, steps=steps,
                  known=known)
        with np.errstate(divide="ignore"):
            log_norms = np.sum(np.log10(np.linalg.norm(g, axis=-2)), axis=-1)
        n = g.shape[-1]
        d_opt[bad] = np.log10(RANK_RTOL * np.sqrt(np.e * n)) + log_norms - n * np.log10(noise)
    value = np.mean(d_opt) if criterion == "mean_dopt" else np.min(d_opt)
    return CriterionResult(float(value), frac)


def layout_criterion(stations, region, *, velocity=(2.0, 2.0), moments=(100.0, 20.0),
                     criterion="mean_dopt", threshold=10.0, noise=None,
                     steps=DEFAULT_STEPS, T=1.0, sigma=4.0, model="exact", sea=None, known=(),
                     sensor=None):
    """How well a station layout covers a surveillance region.

    Parameters
    ----------
    stations : array_like, shape (S, 3)
        Station positions (m).
    region : core.Plane
        ``"xy"``: rectangle of target positions at depth ``fixed`` (m); ``"xz"``: x–z band of
        depths at y = ``fixed``.
    velocity : (vx, vy)
        Target velocity (m/s), the same at every region point.
    moments : (Ph, Pv) or (mx, my, mz)
        Dipole moments: (Ph, Pv) A·m electric, the moment vector A·m² for magnetic kinds.
    criterion : {"mean_dopt", "worst_dopt", "area_crlb"}
        ``"mean_dopt"``: mean D-optimal measure over the region's points; ``"worst_dopt"``: its
        minimum; ``"area_crlb"``: fraction of the points whose CRLB position error
        sqrt(σx² + σy² + σz²) is below ``threshold``. Unobservable points count at their
        D-optimal floor (module notes) or as failing the threshold.
    threshold : float
        Position error threshold (m) for ``"area_crlb"``, > 0.
    noise, steps, T, sigma, model, sea, known, sensor
        As for :func:`crlb_covariance`.

    Returns
    -------
    CriterionResult
        Points within ``ON_STATION`` of a station are left out.

    Examples
    --------
    >>> import core
    >>> region = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 11)
    >>> one = core.layout_criterion(core.single_station(100), region)
    >>> two = core.layout_criterion(core.dual_station(100, 15), region)
    >>> one.observable_fraction, two.observable_fraction, two.value > one.value
    (0.0, 1.0, True)
    """
    threshold = _check_criterion(criterion, threshold)
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    if sensor.magnetic:
        return _magnetic_criterion(_region_states(region, velocity, moments, sensor),
                                   validation.stations(stations), criterion, threshold, steps,
                                   validation.positive("T", T, "s"), known, sensor)
    noise = sensor.noise_vector[0]
    return _criterion(_region_states(region, velocity, moments), validation.stations(stations),
                      criterion, threshold, noise, steps, T, sensor.sigma, sensor.model,
                      sensor.sea, known)


def _sensor_args(sensor, sigma, model, sea, noise):
    """The optimisers' measurement model: (noise, sigma, model, sea, magnetic Sensor or None)
    from ``sensor=`` or the old keywords (electric: the keywords of :func:`_criterion`)."""
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    if sensor.magnetic:
        return None, 4.0, "exact", None, sensor
    return sensor.noise_vector[0], sensor.sigma, sensor.model, sensor.sea, None


def _scaled_layout_objective(region, kind, n_stations, h, velocity, moments, criterion,
                             threshold, noise, steps, T, sigma, model, sea, known, sensor=None):
    """Validate once; return f(d) -> criterion value for a scaled layout."""
    if kind not in ("line", "triangle", "square"):
        raise ValueError(f"a spaced layout kind must be 'line', 'triangle' or 'square'; got {kind!r}")
    n_stations = _n_stations(n_stations)
    threshold = _check_criterion(criterion, threshold)
    noise, sigma, model, sea, mag = _sensor_args(sensor, sigma, model, sea, noise)
    states = _region_states(region, velocity, moments, mag)
    station_layout(kind, n_stations, d=1.0, h=h)  # validates h

    def value(d):
        return _criterion(states, station_layout(kind, n_stations, d=d, h=h), criterion,
                          threshold, noise, steps, T, sigma, model, sea, known, mag).value
    return value


def _d_values(d_values):
    d = validation._array("d_values", d_values)
    if d.ndim != 1 or d.size < 1 or not np.all(np.isfinite(d)) or np.any(d <= 0):
        raise ValueError(f"d_values must be a 1-D array of finite spacings > 0 (m); got {d_values!r}")
    return d


def _map(f, values, client):
    """``[f(v) for v in values]`` as an array: here, or on a Dask cluster (core.dask_backend)."""
    if client is None:
        return np.array([f(v) for v in values])
    return np.array(dask_backend.map_ordered(dask_backend.check_client(client), f, values))


def spacing_curve(d_values, region, *, kind="line", n_stations=2, h=100.0, velocity=(2.0, 2.0),
                  moments=(100.0, 20.0), criterion="mean_dopt", threshold=10.0,
                  noise=None, steps=DEFAULT_STEPS, T=1.0, sigma=4.0, model="exact",
                  sea=None, known=(), client=None, sensor=None):
    """Criterion against station spacing d (default: the paper's dual, a 2-station line).

    Parameters
    ----------
    d_values : array_like, shape (K,)
        Spacings (m), > 0.
    region : core.Plane
        Surveillance region (see :func:`layout_criterion`).
    kind : {"line", "triangle", "square"}
        Layout scaled by d (see :func:`station_layout`).
    n_stations : int
        N, 1 … :data:`MAX_STATIONS`.
    h : float
        Station depth (m).
    velocity, moments, criterion, threshold, noise, steps, T, sigma, model, sea, known, sensor
        As for :func:`layout_criterion`.
    client : distributed.Client, optional
        Evaluate the K spacings as tasks on this Dask cluster (see :mod:`core.dask_backend`);
        the values are the same as without it.

    Returns
    -------
    ndarray, shape (K,)
        Criterion at each d (larger is better).

    Examples
    --------
    >>> import core
    >>> region = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 11)
    >>> core.spacing_curve([10, 50], region).shape
    (2,)
    """
    d = _d_values(d_values)
    f = _scaled_layout_objective(region, kind, n_stations, h, velocity, moments, criterion,
                                 threshold, noise, steps, T, sigma, model, sea, known, sensor)
    return _map(f, d, client)


@dataclass(frozen=True)
class SpacingResult:
    """Result of :func:`best_spacing`.

    Attributes
    ----------
    d : float
        Best spacing (m).
    value : float
        Criterion at ``d``.
    d_values, curve : ndarray, shape (K,)
        The coarse curve the bracket was taken from.
    at_bound : bool
        The best grid point is an end of ``d_values``: the optimum may lie outside the range.
    nfev : int
        Criterion evaluations, curve included.
    """

    d: float
    value: float
    d_values: np.ndarray
    curve: np.ndarray
    at_bound: bool
    nfev: int


def best_spacing(region, *, d_values=None, d_range=(2.0, 200.0), n_curve=25, xatol=0.05,
                 kind="line", n_stations=2, h=100.0, velocity=(2.0, 2.0), moments=(100.0, 20.0),
                 criterion="mean_dopt", threshold=10.0, noise=None,
                 steps=DEFAULT_STEPS, T=1.0, sigma=4.0, model="exact", sea=None, known=(),
                 client=None, sensor=None):
    """Spacing d that maximises a region criterion.

    Parameters
    ----------
    region : core.Plane
        Surveillance region (see :func:`layout_criterion`).
    d_values : array_like, shape (K,), optional
        Coarse spacings (m) for the bracketing curve; default ``n_curve`` points evenly spaced
        over ``d_range``.
    d_range : (float, float)
        (min, max) spacing (m), 0 < min < max, when ``d_values`` is not given.
    n_curve : int
        Points of the default coarse curve, ≥ 3.
    xatol : float
        Absolute tolerance on d (m) of the bounded Brent search, > 0.
    kind, n_stations, h, velocity, moments, criterion, threshold, noise, steps, T, sigma, \
model, sea, known
        As for :func:`spacing_curve`.
    client : distributed.Client, optional
        Evaluate the coarse curve on this Dask cluster (:func:`spacing_curve`); the Brent
        refinement is sequential and runs here. The result is the same as without it.

    Returns
    -------
    SpacingResult

    Notes
    -----
    1. Evaluate the criterion on the coarse curve and take its best point d_i.
    2. Refine with ``scipy.optimize.minimize_scalar(method="bounded")`` on the bracket
       [d_{i−1}, d_{i+1}] (clipped to the curve's ends), minimising −criterion.
    3. Keep the better of the refined and the grid point (Brent on a multimodal stretch may
       stop at a worse local optimum).

    ``"area_crlb"`` is piecewise constant in d (a count of grid points), so the refinement only
    moves within a plateau; the coarse curve decides.

    Examples
    --------
    >>> import core
    >>> region = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 11)
    >>> r = core.best_spacing(region, d_range=(5, 300), n_curve=7)
    >>> bool(r.d_values[0] <= r.d <= r.d_values[-1])
    True
    """
    if d_values is None:
        lo, hi = (validation.positive("d_range", v, "m") for v in _pair("d_range", d_range))
        if not lo < hi:
            raise ValueError(f"d_range must be (min, max) with 0 < min < max (m); got {d_range!r}")
        if isinstance(n_curve, bool) or not isinstance(n_curve, (int, np.integer)) or n_curve < 3:
            raise ValueError(f"n_curve must be an integer ≥ 3; got {n_curve!r}")
        d = np.linspace(lo, hi, int(n_curve))
    else:
        d = np.unique(_d_values(d_values))
        if d.size < 3:
            raise ValueError(f"d_values must hold at least 3 distinct spacings; got {d_values!r}")
    xatol = validation.positive("xatol", xatol, "m")
    f = _scaled_layout_objective(region, kind, n_stations, h, velocity, moments, criterion,
                                 threshold, noise, steps, T, sigma, model, sea, known, sensor)
    curve = _map(f, d, client)
    i = int(np.argmax(curve))
    lo, hi = d[max(i - 1, 0)], d[min(i + 1, d.size - 1)]
    res = optimize.minimize_scalar(lambda v: -f(v), bounds=(lo, hi), method="bounded",
                                   options={"xatol": xatol})
    best_d, best_v = (float(res.x), float(-res.fun)) if -res.fun >= curve[i] else (d[i], curve[i])
    return SpacingResult(d=float(best_d), value=float(best_v), d_values=d, curve=curve,
                         at_bound=i in (0, d.size - 1), nfev=int(d.size + res.nfev))


@dataclass(frozen=True)
class LayoutResult:
    """Result of :func:`optimise_layout`.

    Attributes
    ----------
    stations : ndarray, shape (N, 3)
        Optimised station positions (m). Scaled kinds are centred on the region (the stations'
        mean (x, y) is the centre of the region's horizontal box).
    value : float
        Criterion of that layout.
    kind : str
    d : float or None
        Spacing (m) for the scaled kinds; None for ``"free"``.
    nfev : int
        Criterion evaluations.
    at_bound : tuple of str
        The bounds the optimum lies on, empty when it is interior: ``"d_min"`` or ``"d_max"``
        (the ends of ``d_range``) for the scaled kinds; for ``"free"`` the sides of the box that
        a station touches, from ``"x_min"``, ``"x_max"``, ``"y_min"``, ``"y_max"``. A bound
        that is hit means the optimum may lie beyond it.
    """

    stations: np.ndarray
    value: float
    kind: str
    d: float | None
    nfev: int
    at_bound: tuple = ()


def _default_bounds(region):
    """Horizontal box for free station positions: the region's x–y extent (x–z band: x range,
    and y within half the x width of the band's y)."""
    if region.kind == "xy":
        return tuple(map(float, region.u)), tuple(map(float, region.v))
    half = 0.5 * (region.u[1] - region.u[0])
    return tuple(map(float, region.u)), (region.fixed - half, region.fixed + half)


#: Tolerance (m) of the bounded Brent search over d in :func:`optimise_layout`.
_LAYOUT_XATOL = 0.05
#: A free station within this fraction of the box width of a side counts as on it.
_BOX_TOUCH = 1e-3


def _centred_layout(kind, n, d, h, box):
    """``station_layout(kind, n, d=d, h=h)`` shifted so that its mean (x, y) is the box centre."""
    st = station_layout(kind, n, d=d, h=h)
    st[:, :2] += np.mean(box, axis=1) - st[:, :2].mean(axis=0)
    return st


def _largest_spacing(kind, n, box):
    """Largest d at which the centred ``kind`` layout of n stations fits in the box (m)."""
    unit = station_layout(kind, n, d=1.0)[:, :2]
    extent = unit.max(axis=0) - unit.min(axis=0)
    width = np.diff(box, axis=1)[:, 0]
    fits = [w / e for w, e in zip(width, extent) if e > 0]
    return float(min(fits)) if fits else float(width.max())  # one station: d plays no part


def _optimise_spacing(kind, n, h, box, d_range, n_curve, objective, client=None):
    """Best d of the centred layout: coarse curve over d_range, then bounded Brent on the
    bracket of its best point (as :func:`best_spacing`). Returns (d, value, nfev, at_bound)."""
    lo, hi = d_range
    if isinstance(n_curve, bool) or not isinstance(n_curve, (int, np.integer)) or n_curve < 3:
        raise ValueError(f"n_curve must be an integer ≥ 3; got {n_curve!r}")
    d = np.linspace(lo, hi, int(n_curve))
    f = lambda v: objective(_centred_layout(kind, n, v, h, box))
    curve = _map(f, d, client)  # the coarse curve: here, or on a Dask cluster
    i = int(np.argmax(curve))
    res = optimize.minimize_scalar(lambda v: -f(v), bounds=(d[max(i - 1, 0)], d[min(i + 1, d.size - 1)]),
                                   method="bounded", options={"xatol": _LAYOUT_XATOL})
    best_d, best_v = (float(res.x), float(-res.fun)) if -res.fun >= curve[i] else (d[i], curve[i])
    tol = 2.0 * _LAYOUT_XATOL  # Brent stops within ~⅔ xatol of a minimiser on a bound
    at_bound = (("d_min",) if best_d - lo <= tol else ()) + (("d_max",) if hi - best_d <= tol else ())
    if n == 1:
        at_bound = ()  # one station: d plays no part
    return float(best_d), float(best_v), int(d.size + res.nfev), at_bound


def optimise_layout(kind, n_stations, region, *, h=100.0, velocity=(2.0, 2.0),
                    moments=(100.0, 20.0), criterion="mean_dopt", threshold=10.0,
                    noise=None, steps=DEFAULT_STEPS, T=1.0, sigma=4.0, model="exact",
                    sea=None, known=(), d_range=None, n_curve=25, x0=None, bounds=None,
                    maxfev=400, client=None, sensor=None):
    """Optimise an N-station layout for a region criterion.

    Parameters
    ----------
    kind : {"line", "triangle", "square", "free"}
        Scaled kinds optimise their one spacing d, the layout centred on the region (its mean
        station (x, y) at the centre of the region's horizontal box), as :func:`best_spacing`
        does (a coarse curve of ``n_curve`` points over ``d_range``, then bounded Brent).
        ``"free"`` optimises the (x, y) of all N stations at depth h with
        ``scipy.optimize.minimize(method="Powell")`` within ``bounds`` (derivative-free, so it
        copes with the piecewise-constant ``"area_crlb"``).
    n_stations : int
        N, 1 … :data:`MAX_STATIONS`.
    region : core.Plane
        Surveillance region.
    h, velocity, moments, criterion, threshold, noise, steps, T, sigma, model, sea, known, sensor
        As for :func:`spacing_curve`.
    d_range : (float, float), optional
        (min, max) spacing (m) of the scaled kinds, 0 < min < max, and of the default start of
        ``"free"``. Default: from min(2 m, d_fit / 2) to d_fit, the largest spacing at which the
        centred layout still fits in the box (``bounds``' default).
    n_curve : int
        Points of the coarse curve over ``d_range``, ≥ 3.
    x0 : array_like, shape (N, 2), optional
        ``"free"``: starting (x, y) (m). Default: the best centred ``"square"`` lattice (so the
        free result is never worse than it), clipped into ``bounds``.
    bounds : ((xmin, xmax), (ymin, ymax)), optional
        Box for every station (m): ``"free"`` keeps the stations in it; it sets the scaled
        kinds' centre and default ``d_range``. Default: the region's horizontal extent (for an
        x–z band, y within half the band's x width of its y).
    maxfev : int
        ``"free"``: budget of criterion evaluations for Powell, ≥ 1.
    client : distributed.Client, optional
        Evaluate the coarse spacing curves on this Dask cluster (see :func:`best_spacing`);
        Powell's steps are sequential and run here. The result is the same as without it.

    Returns
    -------
    LayoutResult
        ``at_bound`` names the bounds the optimum lies on (``d_min``/``d_max``, or the box sides
        for ``"free"``; a station within 1e-3 of the box width of a side is on it).

    Examples
    --------
    >>> import core
    >>> region = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 9)
    >>> r = core.optimise_layout("triangle", 3, region, d_range=(5, 300), n_curve=5)
    >>> r.stations.shape
    (3, 3)
    """
    if kind not in LAYOUTS:
        raise ValueError(f"layout kind must be one of {list(LAYOUTS)}; got {kind!r}")
    the_sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    noise, sigma, model, sea, mag = _sensor_args(the_sensor, 4.0, "exact", None, None)
    common = {"h": h, "velocity": velocity, "moments": moments, "criterion": criterion,
              "threshold": threshold, "steps": steps, "T": T, "known": known,
              "sensor": the_sensor}
    n = _n_stations(n_stations)
    if isinstance(maxfev, bool) or not isinstance(maxfev, (int, np.integer)) or maxfev < 1:
        raise ValueError(f"maxfev must be an integer ≥ 1; got {maxfev!r}")
    states = _region_states(region, velocity, moments, mag)
    (xlo, xhi), (ylo, yhi) = _default_bounds(region) if bounds is None else (
        _pair("bounds[0]", bounds[0]), _pair("bounds[1]", bounds[1]))
    if not (xlo < xhi and ylo < yhi):
        raise ValueError(f"bounds must be ((xmin, xmax), (ymin, ymax)) with min < max; got {bounds!r}")
    box = np.array([[xlo, xhi], [ylo, yhi]])
    if kind != "free":
        if d_range is None:
            fit = _largest_spacing(kind, n, box)
            d_range = (min(2.0, 0.5 * fit), fit)
        lo, hi = (validation.positive("d_range", v, "m") for v in _pair("d_range", d_range))
        if not lo < hi:
            raise ValueError(f"d_range must be (min, max) with 0 < min < max (m); got {d_range!r}")
        threshold = _check_criterion(criterion, threshold)
        h = station_layout("line", 1, h=h)[0, 2]  # validates h

        def objective(st):
            return _criterion(states, st, criterion, threshold, noise, steps, T, sigma, model,
                              sea, known, mag).value

        d, value, nfev, at_bound = _optimise_spacing(kind, n, h, box, (lo, hi), n_curve, objective,
                                                    client)
        return LayoutResult(_centred_layout(kind, n, d, h, box), value, kind, d, nfev, at_bound)
    nfev = 0
    if x0 is None:
        start = optimise_layout("square", n, region, d_range=d_range, n_curve=n_curve,
                                bounds=((xlo, xhi), (ylo, yhi)), client=client, **common)
        xy, nfev = start.stations[:, :2], start.nfev
    else:
        xy = validation._array("x0", x0)
        if xy.shape != (n, 2) or not np.all(np.isfinite(xy)):
            raise ValueError(f"x0 must be a finite (N, 2) = ({n}, 2) array of (x, y) in m; "
                             f"got shape {xy.shape}")
    xy = np.clip(xy, [xlo, ylo], [xhi, yhi])
    threshold = _check_criterion(criterion, threshold)
    station_layout("line", 1, h=h)  # validates h

    def objective(p):
        st = np.column_stack([p.reshape(n, 2), np.full(n, float(h))])
        return -_criterion(states, st, criterion, threshold, noise, steps, T, sigma, model,
                           sea, known, mag).value

    res = optimize.minimize(objective, xy.ravel(), method="Powell",
                            bounds=[(xlo, xhi), (ylo, yhi)] * n,
                            options={"maxfev": int(maxfev), "xtol": 1e-2, "ftol": 1e-6})
    p = res.x if res.fun <= objective(xy.ravel()) else xy.ravel()
    value = -objective(p)
    st = np.column_stack([p.reshape(n, 2), np.full(n, float(h))])
    near = _BOX_TOUCH * np.diff(box, axis=1)[:, 0]
    at_bound = tuple(name for name, hit in (
        ("x_min", np.any(st[:, 0] - xlo <= near[0])), ("x_max", np.any(xhi - st[:, 0] <= near[0])),
        ("y_min", np.any(st[:, 1] - ylo <= near[1])), ("y_max", np.any(yhi - st[:, 1] <= near[1]))) if hit)
    return LayoutResult(st, float(value), kind, None, int(nfev + res.nfev + 2), at_bound)
