"""The best N-station layout of a kind for a region criterion (:func:`optimise_layout`): the
spacing of a centred line, triangle or square, or free station positions."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from ..model import validation
from .crlb import _pair
from .criteria import _criterion
from .layouts import LAYOUTS, _n_stations, station_layout
from .problem import check_problem
from .spacing import _d_grid, _refine
from . import search
from .constraints import feasibility

__all__ = ["LayoutResult", "optimise_layout"]


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
    fixed : int
        The first ``fixed`` rows of ``stations`` are the problem's fixed stations (unmoved).
    """

    stations: np.ndarray
    value: float
    kind: str
    d: float | None
    nfev: int
    at_bound: tuple = ()
    fixed: int = 0


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
    d = _d_grid(d_range, n_curve)
    best_d, best_v, _, _, nfev = _refine(
        lambda v: objective(_centred_layout(kind, n, v, h, box)), d, client, _LAYOUT_XATOL)
    tol = 2.0 * _LAYOUT_XATOL  # Brent stops within ~⅔ xatol of a minimiser on a bound
    at_bound = (("d_min",) if best_d - d[0] <= tol else ()) + (("d_max",) if d[-1] - best_d <= tol else ())
    return best_d, best_v, nfev, at_bound if n > 1 else ()  # one station: d plays no part


def optimise_layout(kind, n_stations, problem, *, d_range=None, n_curve=25, x0=None,
                    bounds=None, maxfev=400, client=None):
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
    problem : core.LayoutProblem
        Region, target, measurement, criterion, station depth h and constraints.
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
    >>> problem = core.LayoutProblem(region)
    >>> r = core.optimise_layout("triangle", 3, problem, d_range=(5, 300), n_curve=5)
    >>> r.stations.shape
    (3, 3)
    """
    if kind not in LAYOUTS:
        raise ValueError(f"layout kind must be one of {list(LAYOUTS)}; got {kind!r}")
    n = _n_stations(n_stations)
    validation.integer("maxfev", maxfev, 1)
    problem = check_problem(problem)
    states, sensor, threshold, h, T = problem.prepared()
    region = problem.region
    (xlo, xhi), (ylo, yhi) = _default_bounds(region) if bounds is None else (
        _pair("bounds[0]", bounds[0]), _pair("bounds[1]", bounds[1]))
    if not (xlo < xhi and ylo < yhi):
        raise ValueError(f"bounds must be ((xmin, xmax), (ymin, ymax)) with min < max; got {bounds!r}")
    box = np.array([[xlo, xhi], [ylo, yhi]])

    cons = problem.constraints
    cand = None if cons is None else feasibility(cons, n, h, box, sensor.sea)  # said at once

    def value(st):
        return _criterion(states, st, problem.criterion, threshold, problem.steps, T,
                          problem.known, sensor).value

    if kind != "free":
        if d_range is None:
            fit = _largest_spacing(kind, n, box)
            d_range = (min(2.0, 0.5 * fit), fit)
        unbounded = np.array([[-np.inf, np.inf]] * 2)  # the scaled layout's box is d_range's
        scorer = None if cons is None else search.Scorer(value, cons, unbounded, sensor.sea)
        d, best, nfev, at_bound = _optimise_spacing(kind, n, h, box, d_range, n_curve,
                                                    value if cons is None else scorer.score, client)
        st = _centred_layout(kind, n, d, h, box)
        if cons is not None:
            if best <= search.INFEASIBLE:
                raise ValueError(f"no spacing d in {tuple(map(float, d_range))} m puts a centred "
                                 f"{kind} of {n} stations where the constraints allow")
            st, best = np.vstack([cons.fixed, st]), value(np.vstack([cons.fixed, st]))
        return LayoutResult(st, best, kind, d, nfev, at_bound, 0 if cons is None else len(cons.fixed))
    if cons is not None:
        with search.serial():
            st, best, nfev = _constrained_free(value, cons, n, h, box, cand, sensor.sea, x0, maxfev)
        return LayoutResult(st, best, kind, None, nfev, _touching(st[len(cons.fixed):], box),
                            len(cons.fixed))
    nfev = 0
    if x0 is None:
        start = optimise_layout("square", n, problem, d_range=d_range, n_curve=n_curve,
                                bounds=((xlo, xhi), (ylo, yhi)), client=client)
        xy, nfev = start.stations[:, :2], start.nfev
    else:
        xy = _x0(x0, n)
    xy = np.clip(xy, [xlo, ylo], [xhi, yhi])

    def objective(p):
        return -value(np.column_stack([p.reshape(n, 2), np.full(n, h)]))

    res = optimize.minimize(objective, xy.ravel(), method="Powell",
                            bounds=[(xlo, xhi), (ylo, yhi)] * n,
                            options={"maxfev": int(maxfev), "xtol": 1e-2, "ftol": 1e-6})
    p = res.x if res.fun <= objective(xy.ravel()) else xy.ravel()
    st = np.column_stack([p.reshape(n, 2), np.full(n, h)])
    return LayoutResult(st, float(-objective(p)), kind, None, int(nfev + res.nfev + 2),
                        _touching(st, box))


def _x0(x0, n):
    xy = validation.as_array("x0", x0)
    if xy.shape != (n, 2) or not np.all(np.isfinite(xy)):
        raise ValueError(f"x0 must be a finite (N, 2) = ({n}, 2) array of (x, y) in m; "
                         f"got shape {xy.shape}")
    return xy


def _touching(st, box):
    """The box sides that a station lies on (within _BOX_TOUCH of the box width)."""
    (xlo, xhi), (ylo, yhi) = box
    near = _BOX_TOUCH * np.diff(box, axis=1)[:, 0]
    return tuple(name for name, hit in (
        ("x_min", np.any(st[:, 0] - xlo <= near[0])), ("x_max", np.any(xhi - st[:, 0] <= near[0])),
        ("y_min", np.any(st[:, 1] - ylo <= near[1])), ("y_max", np.any(yhi - st[:, 1] <= near[1]))) if hit)


def _constrained_free(value, cons, n, h, box, cand, sea, x0, maxfev):
    """The constrained free search (:mod:`.search`); returns (all stations, value, nfev)."""
    scorer = search.Scorer(value, cons, box, sea)
    if x0 is not None:
        new = np.column_stack([_x0(x0, n), np.full(n, h)])
        if not scorer.feasible(new):
            raise ValueError("x0 breaks the constraints: " + "; ".join(
                cons.violations(np.vstack([cons.fixed, new]), sea) or ["a station is outside the box"]))
    else:
        coarse = search.grid(box, h, cons, sea, search.EXCHANGE_GRID)
        new, _ = search.exchange(scorer, coarse, n, h)
        if new is None:  # the coarse grid has no room: the feasibility check's finer one has
            new, _ = search.exchange(scorer, cand, n, h)
    new, best = search.polish(scorer, new, maxfev)
    st = np.vstack([cons.fixed, new])
    broken = cons.violations(st, sea)
    if broken:  # cannot happen: every step keeps the feasible layout it starts from
        raise RuntimeError("the constrained search broke its constraints: " + "; ".join(broken))
    return st, value(st), scorer.nfev + 1
