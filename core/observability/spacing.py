"""A scaled layout's criterion against its spacing d (:func:`spacing_curve`) and the best d
(:func:`best_spacing`); the criteria are :mod:`.criteria`'s."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from .. import dask_backend
from ..model import validation
from .crlb import _pair
from .criteria import _criterion
from .layouts import _n_stations, station_layout
from .problem import check_problem

__all__ = ["SpacingResult", "best_spacing", "spacing_curve"]


def _scaled_layout_objective(problem, kind, n_stations):
    """Validate once; return f(d) -> criterion value for a scaled layout of the problem."""
    if kind not in ("line", "triangle", "square"):
        raise ValueError(f"a spaced layout kind must be 'line', 'triangle' or 'square'; got {kind!r}")
    n_stations = _n_stations(n_stations)
    p = check_problem(problem)
    states, sensor, threshold, h, T = p.prepared()

    def value(d):
        return _criterion(states, station_layout(kind, n_stations, d=d, h=h), p.criterion,
                          threshold, p.steps, T, p.known, sensor).value
    return value


def _d_values(d_values):
    d = validation.as_array("d_values", d_values)
    if d.ndim != 1 or d.size < 1 or not np.all(np.isfinite(d)) or np.any(d <= 0):
        raise ValueError(f"d_values must be a 1-D array of finite spacings > 0 (m); got {d_values!r}")
    return d


def _map(f, values, client):
    """``[f(v) for v in values]`` as an array: here, or on a Dask cluster (core.dask_backend)."""
    if client is None:
        return np.array([f(v) for v in values])
    return np.array(dask_backend.map_ordered(dask_backend.check_client(client), f, values))


def _d_grid(d_range, n_curve):
    """The coarse curve's spacings: ``n_curve`` (≥ 3) points evenly over ``d_range`` (min, max),
    0 < min < max (m)."""
    lo, hi = (validation.positive("d_range", v, "m") for v in _pair("d_range", d_range))
    if not lo < hi:
        raise ValueError(f"d_range must be (min, max) with 0 < min < max (m); got {d_range!r}")
    return np.linspace(lo, hi, validation.integer("n_curve", n_curve, 3))


def _refine(f, d, client, xatol):
    """The coarse curve f(d), then bounded Brent on the bracket of its best point (clipped to the
    curve's ends), keeping the better of the two (:func:`best_spacing`'s notes). Returns (best d,
    its value, the curve, the best grid index, evaluations)."""
    curve = _map(f, d, client)
    i = int(np.argmax(curve))
    res = optimize.minimize_scalar(lambda v: -f(v), method="bounded", options={"xatol": xatol},
                                   bounds=(d[max(i - 1, 0)], d[min(i + 1, d.size - 1)]))
    best_d, best_v = (float(res.x), float(-res.fun)) if -res.fun >= curve[i] else (d[i], curve[i])
    return float(best_d), float(best_v), curve, i, int(d.size + res.nfev)


def spacing_curve(d_values, problem, *, kind="line", n_stations=2, client=None):
    """Criterion against station spacing d (default: the paper's dual, a 2-station line).

    Parameters
    ----------
    d_values : array_like, shape (K,)
        Spacings (m), > 0.
    problem : core.LayoutProblem
        Region, target, measurement, criterion and station depth h (its constraints play no
        part: a scaled layout has no free station).
    kind : {"line", "triangle", "square"}
        Layout scaled by d (see :func:`station_layout`).
    n_stations : int
        N, 1 … :data:`MAX_STATIONS`.
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
    >>> core.spacing_curve([10, 50], core.LayoutProblem(region)).shape
    (2,)
    """
    d = _d_values(d_values)
    return _map(_scaled_layout_objective(problem, kind, n_stations), d, client)


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


def best_spacing(problem, *, kind="line", n_stations=2, d_values=None, d_range=(2.0, 200.0),
                 n_curve=25, xatol=0.05, client=None):
    """Spacing d that maximises a region criterion.

    Parameters
    ----------
    problem : core.LayoutProblem
        As for :func:`spacing_curve`.
    kind, n_stations
        As for :func:`spacing_curve`.
    d_values : array_like, shape (K,), optional
        Coarse spacings (m) for the bracketing curve; default ``n_curve`` points evenly spaced
        over ``d_range``.
    d_range : (float, float)
        (min, max) spacing (m), 0 < min < max, when ``d_values`` is not given.
    n_curve : int
        Points of the default coarse curve, ≥ 3.
    xatol : float
        Absolute tolerance on d (m) of the bounded Brent search, > 0.
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
    >>> r = core.best_spacing(core.LayoutProblem(region), d_range=(5, 300), n_curve=7)
    >>> bool(r.d_values[0] <= r.d <= r.d_values[-1])
    True
    """
    if d_values is None:
        d = _d_grid(d_range, n_curve)
    else:
        d = np.unique(_d_values(d_values))
        if d.size < 3:
            raise ValueError(f"d_values must hold at least 3 distinct spacings; got {d_values!r}")
    xatol = validation.positive("xatol", xatol, "m")
    f = _scaled_layout_objective(problem, kind, n_stations)
    best_d, best_v, curve, i, nfev = _refine(f, d, client, xatol)
    return SpacingResult(d=best_d, value=best_v, d_values=d, curve=curve,
                         at_bound=i in (0, d.size - 1), nfev=nfev)
