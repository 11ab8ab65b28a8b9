"""Sensor-layout design: how good a station layout is for a surveillance region, and the best one.

- :func:`layout_criterion` — a layout's region criterion (:data:`CRITERIA`: mean or worst
  D-optimal measure, or the area whose CRLB position error is below a threshold).
- :func:`spacing_curve`, :func:`best_spacing` — the criterion against a scaled layout's
  spacing d, and the best d.
- :func:`optimise_layout` — the best N-station layout of a kind (its spacing, or free positions).

These build on :mod:`.crlb` (CRLB covariance, error ellipses and their maps) and :mod:`.layouts`
(:func:`station_layout`), whose public names are re-exported here: ``core.observability.design``
still offers the whole design API.

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
from ..model import sensors, validation
from .crlb import (
    CrlbErrors,
    _pair,
    _plane_states,
    crlb_covariance,
    crlb_maps,
    horizontal_error_ellipse,
    magnetic_plane_states,  # noqa: F401  (re-exported: importable from here before the split)
)
from .fisher import DEFAULT_STEPS, fisher_measures
from .gamma import RANK_RTOL, _gamma
from .grids import Plane
from .layouts import LAYOUTS, MAX_STATIONS, _n_stations, station_layout

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

#: Region criteria: name -> (label, unit). Larger is better for every one of them.
CRITERIA = {
    "mean_dopt": ("mean D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "worst_dopt": ("worst (minimum) D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "area_crlb": ("fraction of the region with CRLB position error < threshold", "dimensionless"),
}


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


def _criterion(states, stations, criterion, threshold, steps, T, known, sensor):
    """Criterion over (P, n_states) region states of ``sensor``; points on a station are left
    out."""
    states = states[sensor.clear(states, stations, steps, T)]
    if states.shape[0] == 0:
        raise ValueError("every point of the region lies on a station; nothing to evaluate")
    m = fisher_measures(states, stations, steps=steps, T=T, known=known, sensor=sensor)
    frac = float(np.mean(m.observable))
    if criterion == "area_crlb":
        return CriterionResult(float(np.mean(m.position_std < threshold)), frac)
    d_opt = m.d_optimal.copy()
    bad = np.flatnonzero(~m.observable)
    if bad.size:  # the D-optimal floor of the module notes (R^-½ Γ of a magnetic kind: noise 1)
        _, noise = sensor.kernel_rows()
        g = _gamma(states[bad], stations, T, sensor, steps, known)
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
    return _criterion(_region_states(region, velocity, moments, sensor),
                      validation.stations(stations), criterion, threshold, steps,
                      validation.positive("T", T, "s"), known, sensor)


def _scaled_layout_objective(region, kind, n_stations, h, velocity, moments, criterion,
                             threshold, noise, steps, T, sigma, model, sea, known, sensor=None):
    """Validate once; return f(d) -> criterion value for a scaled layout."""
    if kind not in ("line", "triangle", "square"):
        raise ValueError(f"a spaced layout kind must be 'line', 'triangle' or 'square'; got {kind!r}")
    n_stations = _n_stations(n_stations)
    threshold = _check_criterion(criterion, threshold)
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    states = _region_states(region, velocity, moments, sensor)
    station_layout(kind, n_stations, d=1.0, h=h)  # validates h

    def value(d):
        return _criterion(states, station_layout(kind, n_stations, d=d, h=h), criterion,
                          threshold, steps, T, known, sensor).value
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
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    common = {"h": h, "velocity": velocity, "moments": moments, "criterion": criterion,
              "threshold": threshold, "steps": steps, "T": T, "known": known,
              "sensor": sensor}
    n = _n_stations(n_stations)
    if isinstance(maxfev, bool) or not isinstance(maxfev, (int, np.integer)) or maxfev < 1:
        raise ValueError(f"maxfev must be an integer ≥ 1; got {maxfev!r}")
    states = _region_states(region, velocity, moments, sensor)
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
            return _criterion(states, st, criterion, threshold, steps, T, known, sensor).value

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
        return -_criterion(states, st, criterion, threshold, steps, T, known, sensor).value

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
