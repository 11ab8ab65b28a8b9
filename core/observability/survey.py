"""Survey questions beyond one layout (spec §13): what the loss of any one station does
(:func:`station_loss`) and how many stations are enough (:func:`station_count_curve`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import validation
from .layouts import LAYOUTS, MAX_STATIONS
from .loss import StationLoss, loss_maps
from .optimiser import optimise_layout
from .problem import check_problem

__all__ = ["StationCount", "StationLoss", "station_count_curve", "station_loss"]


def station_loss(stations, problem):
    """The CRLB over the problem's region when any one station is lost.

    Parameters
    ----------
    stations : array_like, shape (S, 3)
        Station positions (m), S ≥ 1 (the fixed ones included: any station may fail).
    problem : core.LayoutProblem
        Region (its grid is the maps' grid), target, measurement and the coverage threshold T
        (m); its criterion and constraints play no part.

    Returns
    -------
    core.StationLoss
        The worst single-loss map (m), the station behind it, the map without each station (m),
        the coverage left without each station and the N−1 coverage (fractions).

    Notes
    -----
    F = Σ_s F_s with independent stations; each F_s is computed once per point and the loss of
    station k is Σ_{s≠k} F_s (:mod:`core.observability.loss`), so the S maps cost about one
    (docs/performance.md). With one station, every loss leaves nothing: +inf everywhere.

    Examples
    --------
    >>> import core
    >>> problem = core.LayoutProblem(core.Plane("xy", (-300, 300), (-300, 300), 120.0, 9))
    >>> loss = core.station_loss(core.station_layout("square", 4, d=150), problem)
    >>> loss.per_station.shape, loss.coverage_left.shape
    ((4, 9, 9), (4,))
    """
    problem = check_problem(problem)
    states, sensor, threshold, _, T = problem.prepared()
    stations = validation.stations(stations)
    sensor.check_column(states[:0], stations)
    clear = sensor.clear(states, stations, problem.steps, T)
    return loss_maps(states, clear, stations, problem.region.n, threshold, problem.steps, T,
                     problem.known, sensor)


@dataclass(frozen=True)
class StationCount:
    """Result of :func:`station_count_curve`.

    Attributes
    ----------
    n : ndarray of int, shape (K,)
        Total station counts N (fixed stations counted).
    value : ndarray, shape (K,)
        Best criterion found with N stations (the problem's criterion and unit).
    layouts : tuple of core.LayoutResult
        The layout behind each value.
    knee : int or None
        The first N after which one more station adds less than ``share`` of the curve's whole
        gain (value[-1] − value[0]); None when no N qualifies (every step pays, or K < 2).
    share : float
        That share.
    """

    n: np.ndarray
    value: np.ndarray
    layouts: tuple
    knee: int | None
    share: float


def station_count_curve(problem, *, kind="free", n_max=MAX_STATIONS, share=0.05, **options):
    """The best criterion for N = 1 … n_max stations, and the knee where adding one stops paying.

    Parameters
    ----------
    problem : core.LayoutProblem
        The problem; its fixed stations (constraints) are counted in N, so the curve starts at
        N = fixed + 1.
    kind : {"free", "line", "triangle", "square"}
        The new stations' layout (:func:`core.optimise_layout`).
    n_max : int
        Largest total N, ≤ :data:`core.MAX_STATIONS`.
    share : float
        Knee rule: the first N where value(N + 1) − value(N) < share · (value(n_max) − value(first)),
        0 < share < 1.
    **options
        Passed to :func:`core.optimise_layout` at every N (``d_range``, ``n_curve``, ``maxfev``,
        ``bounds``, ``client``).

    Returns
    -------
    core.StationCount
        Each point is :func:`core.optimise_layout` with N − fixed new stations, as if called
        on its own.

    Examples
    --------
    >>> import core
    >>> problem = core.LayoutProblem(core.Plane("xy", (-300, 300), (-300, 300), 120.0, 7))
    >>> c = core.station_count_curve(problem, kind="square", n_max=3, n_curve=4)
    >>> c.n.tolist()
    [1, 2, 3]
    """
    problem = check_problem(problem)
    if kind not in LAYOUTS:
        raise ValueError(f"layout kind must be one of {list(LAYOUTS)}; got {kind!r}")
    n_max = validation.integer("n_max", n_max, 1, MAX_STATIONS)
    share = float(share) if np.isscalar(share) else np.nan
    if not 0.0 < share < 1.0:
        raise ValueError(f"share must be a number in (0, 1); got {share!r}")
    n_fixed = 0 if problem.constraints is None else problem.constraints.fixed.shape[0]
    if n_fixed >= n_max:
        raise ValueError(f"{n_fixed} fixed stations leave no new one within n_max = {n_max}")
    n = np.arange(n_fixed + 1, n_max + 1)
    layouts = tuple(optimise_layout(kind, int(k - n_fixed), problem, **options) for k in n)
    value = np.array([r.value for r in layouts])
    return StationCount(n, value, layouts, _knee(n, value, share), share)


def _knee(n, value, share):
    gain = value[-1] - value[0]
    if n.size < 2 or not np.isfinite(gain) or gain <= 0:
        return None
    steps = np.diff(value) < share * gain
    return int(n[np.argmax(steps)]) if np.any(steps) else None
