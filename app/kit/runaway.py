"""Where a CRLB map stops predicting a tracker's error (issue 18), as the Maps, Layout design and
Track tabs all compute and mark it: a bound over RUNAWAY_LIMIT × the range to the nearest
station, marked with white dots."""

from __future__ import annotations

import numpy as np

import core

#: Largest CRLB / range at which a linearised bound still predicts a tracker's error
#: (:func:`core.linearisation_breaks`, issue 18): beyond it the maps hatch the point.
RUNAWAY_LIMIT = 0.3
DOT = 3  # pixels of the map grid per side of a runaway dot (one every 2 DOT, in both directions)


def nearest_range(points, stations):
    """Distance (m) from each of ``points`` (..., 3) to the nearest of ``stations`` (S, 3), S ≥ 1:
    shape (...)."""
    points = np.asarray(points, dtype=float)
    out = np.full(points.shape[:-1], np.inf)
    for st in np.asarray(stations, dtype=float).reshape(-1, 3):
        out = np.minimum(out, np.linalg.norm(points - st, axis=-1))
    return out


def plane_points(plane):
    """The (x, y, z) of every point of ``plane`` (m): shape (n, n, 3), rows its second axis."""
    uu, vv = np.meshgrid(*plane.axes)
    fixed = np.full_like(uu, plane.fixed)
    return np.stack((uu, fixed, vv) if plane.kind == "xz" else (uu, vv, fixed), axis=-1)


def runaway(plane, stations, crlb, observable):
    """Observable points of a CRLB map (m, (n, n)) whose bound exceeds RUNAWAY_LIMIT × the range
    to the nearest station: there the linearised bound stops predicting a tracker's error."""
    if len(stations) == 0:
        return np.zeros(np.shape(crlb), dtype=bool)
    rng = np.maximum(nearest_range(plane_points(plane), stations), 1e-9)  # on a station the CRLB is NaN: False
    return observable & np.isfinite(crlb) & core.linearisation_breaks(crlb, rng, limit=RUNAWAY_LIMIT)


def runaway_dots(shape):
    """Where the white dots of the runaway marks are, on a map grid of ``shape`` (bool): squares
    of DOT × DOT points on a 2 DOT grid, a pattern no stripe of the unobservable veil resembles
    (the Maps, Layout design and Track tabs all mark runaway points with it)."""
    i, j = np.indices(shape)
    return ((i // DOT) % 2 == 0) & ((j // DOT) % 2 == 0)
