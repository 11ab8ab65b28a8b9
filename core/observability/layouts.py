"""Station layouts: N = 1 … :data:`MAX_STATIONS` stations in a line, triangle, square or free.

:func:`station_layout` gives their positions; :mod:`core.observability.design` scores them over a
surveillance region and searches for the best one.
"""

from __future__ import annotations

import numpy as np

from ..model import validation

__all__ = ["LAYOUTS", "MAX_STATIONS", "station_layout"]

#: Layout kinds accepted by :func:`station_layout`.
LAYOUTS = ("line", "triangle", "square", "free")
#: Largest number of stations a layout may have.
MAX_STATIONS = 8


def _n_stations(n_stations):
    return validation.integer("n_stations", n_stations, 1, MAX_STATIONS)


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
        pos = validation.as_array("positions", positions)
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
