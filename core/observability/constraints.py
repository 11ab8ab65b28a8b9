"""Constraints of a survey layout (:class:`LayoutConstraints`, spec §13): stations that already
exist, forbidden zones in x–y, an allowed depth band, a minimum spacing and the station budget
(:data:`core.MAX_STATIONS`).

Every check here is geometry only (no field is evaluated), so an infeasible set is said at once,
in words that name the station or the zone, before any search starts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import validation
from .layouts import MAX_STATIONS

__all__ = ["LayoutConstraints"]

#: Candidate points per side of the box on which "room for a free station" is judged.
ROOM_GRID = 41


@dataclass(frozen=True)
class LayoutConstraints:
    """Where stations may go (spec §13).

    Parameters
    ----------
    fixed : array_like, shape (F, 3), optional
        Stations that already exist (m); they are counted in every criterion and never moved.
    zones : sequence of array_like, each shape (K, 2), K ≥ 3
        Forbidden zones: simple (not self-intersecting) polygons of x–y vertices (m). No
        station may lie inside or on the edge of one.
    depth_band : (float, float) or "seabed" or ("seabed", float) or None
        Allowed station depths (m, z down): ``(z_min, z_max)``; ``"seabed"`` on the seabed of
        the problem's layered sea (z = D); ``("seabed", height)`` within ``height`` m above it,
        D − height ≤ z ≤ D. None: any depth.
    min_spacing : float
        Minimum horizontal-and-vertical (3-D) distance between any two stations (m), ≥ 0.

    Examples
    --------
    >>> import core
    >>> c = core.LayoutConstraints(fixed=[[0, 0, 100]], zones=[[(50, 50), (90, 50), (70, 90)]],
    ...                            min_spacing=20.0)
    >>> c.allowed([[70, 60, 100], [10, 0, 100], [-80, 0, 100]]).tolist()
    [False, False, True]
    """

    fixed: object = ()
    zones: tuple = ()
    depth_band: object = None
    min_spacing: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "fixed", _fixed(self.fixed))
        object.__setattr__(self, "zones", tuple(_polygon(i, z) for i, z in enumerate(self.zones)))
        object.__setattr__(self, "min_spacing", _non_negative("min_spacing", self.min_spacing))
        _band_spec(self.depth_band)

    def band(self, sea=None):
        """The depth band (z_min, z_max) in m, resolved against ``sea`` (a core.Sea) for the
        ``"seabed"`` forms; (-inf, inf) when there is none."""
        spec = _band_spec(self.depth_band)
        if spec is None:
            return (-np.inf, np.inf)
        if spec[0] == "seabed":
            if sea is None:
                raise ValueError("depth_band 'seabed' needs a layered sea: give the problem a "
                                 "sensor with sea=core.Sea(depth, seabed_sigma)")
            return (float(sea.depth) - spec[1], float(sea.depth))
        return spec

    def in_zone(self, xy):
        """(P,) index of the first forbidden zone that holds each x–y point (inside or on its
        edge), −1 for none."""
        xy = np.atleast_2d(np.asarray(xy, dtype=np.float64))[:, :2]
        out = np.full(xy.shape[0], -1)
        for i in range(len(self.zones) - 1, -1, -1):
            out[_inside(self.zones[i], xy)] = i
        return out

    def allowed(self, points, sea=None):
        """(P,) True where a station at each (x, y, z) point (m) is outside every zone, in the
        depth band and at least ``min_spacing`` from every fixed station."""
        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        lo, hi = self.band(sea)
        ok = (self.in_zone(p) < 0) & (p[:, 2] >= lo) & (p[:, 2] <= hi)
        if self.fixed.shape[0] and self.min_spacing > 0:
            ok &= distances(p, self.fixed).min(axis=1) >= self.min_spacing
        return ok

    def violations(self, stations, sea=None):
        """Every constraint a layout (fixed stations first, then the new ones) breaks, in
        words; an empty list for a layout that meets them all."""
        st = np.atleast_2d(np.asarray(stations, dtype=np.float64))
        out = []
        nf = self.fixed.shape[0]
        if st.shape[0] < nf or not np.array_equal(st[:nf], self.fixed):
            out.append("the fixed stations were moved")
        lo, hi = self.band(sea)
        for i, (zone, z) in enumerate(zip(self.in_zone(st), st[:, 2])):
            if zone >= 0:
                out.append(f"station {i} at ({st[i, 0]:g}, {st[i, 1]:g}) m lies in forbidden "
                           f"zone {zone}")
            if not lo <= z <= hi:
                out.append(f"station {i} at depth {z:g} m is outside the depth band "
                           f"[{lo:g}, {hi:g}] m")
        d = distances(st, st) + np.diag(np.full(st.shape[0], np.inf))
        for i, j in zip(*np.nonzero(np.triu(d < self.min_spacing, 1))):
            out.append(f"stations {i} and {j} are {d[i, j]:.3g} m apart, closer than the "
                       f"minimum spacing {self.min_spacing:g} m")
        if st.shape[0] > MAX_STATIONS:
            out.append(f"{st.shape[0]} stations; at most MAX_STATIONS = {MAX_STATIONS}")
        return out


def _fixed(fixed):
    arr = np.asarray(fixed, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 3))
    return validation.stations(arr)


def _non_negative(name, value):
    v = float(value) if np.isscalar(value) and np.isreal(value) else np.nan
    if not np.isfinite(v) or v < 0:
        raise ValueError(f"{name} must be a finite number ≥ 0 (m); got {value!r}")
    return v


def _band_spec(band):
    """The depth band as None, ("seabed", height) or (z_min, z_max); ValueError otherwise."""
    if band is None:
        return None
    if isinstance(band, str):
        band = (band, 0.0)
    if len(band) == 2 and isinstance(band[0], str):
        if band[0] != "seabed":
            raise ValueError(f"depth_band must be (z_min, z_max), 'seabed' or ('seabed', height); "
                             f"got {band!r}")
        return ("seabed", _non_negative("depth_band height above the seabed", band[1]))
    arr = np.asarray(band, dtype=np.float64) if np.ndim(band) == 1 else None
    if arr is None or arr.shape != (2,) or not np.all(np.isfinite(arr)) or arr[0] > arr[1]:
        raise ValueError(f"depth_band must be (z_min, z_max) in m with z_min ≤ z_max, 'seabed' "
                         f"or ('seabed', height); got {band!r}")
    return (float(arr[0]), float(arr[1]))


def _polygon(i, zone):
    """Polygon i as a (K, 2) array: finite, K ≥ 3, simple (no two edges cross)."""
    p = np.asarray(zone, dtype=np.float64) if np.ndim(zone) == 2 else None
    if p is None or p.shape[1:] != (2,):
        raise ValueError(f"forbidden zone {i} must be a (K, 2) array of x–y vertices in m; "
                         f"got {zone!r}")
    if p.shape[0] < 3:
        raise ValueError(f"forbidden zone {i} has {p.shape[0]} vertices; a polygon needs at "
                         "least 3")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"forbidden zone {i} has a non-finite vertex")
    k = p.shape[0]
    for a in range(k):
        for b in range(a + 1, k):
            if b == a + 1 or (a == 0 and b == k - 1):
                continue  # neighbouring edges share a vertex
            if _cross(p[a], p[(a + 1) % k], p[b], p[(b + 1) % k]):
                raise ValueError(f"forbidden zone {i} is self-intersecting: its edges {a} and "
                                 f"{b} cross; give a simple polygon")
    if abs(_area(p)) == 0.0:
        raise ValueError(f"forbidden zone {i} has zero area")
    return p


def _area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _orient(a, b, c):
    return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def _cross(a, b, c, d):
    """Whether segments ab and cd intersect (touching counts)."""
    o1, o2, o3, o4 = _orient(a, b, c), _orient(a, b, d), _orient(c, d, a), _orient(c, d, b)
    if o1 != o2 and o3 != o4:
        return True

    def on(p, q, r):  # r on segment pq, given collinear
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[1], q[1])
    return any(o == 0 and on(*s) for o, s in ((o1, (a, b, c)), (o2, (a, b, d)),
                                               (o3, (c, d, a)), (o4, (c, d, b))))


def _inside(poly, xy):
    """(P,) True where x–y points lie inside the polygon or on its edge (even–odd rule)."""
    x, y = xy[:, 0][:, None], xy[:, 1][:, None]
    x1, y1 = poly[:, 0], poly[:, 1]
    x2, y2 = np.roll(x1, -1), np.roll(y1, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        crosses = ((y1 > y) != (y2 > y)) & (x < (x2 - x1) * (y - y1) / (y2 - y1) + x1)
        # on an edge: within a round-off width of the segment
        ex, ey = x2 - x1, y2 - y1
        t = np.clip(((x - x1) * ex + (y - y1) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        gap = np.hypot(x - (x1 + t * ex), y - (y1 + t * ey))
    scale = 1e-9 * max(1.0, float(np.abs(poly).max()))
    return (np.count_nonzero(crosses, axis=1) % 2 == 1) | np.any(gap <= scale, axis=1)


def distances(a, b):
    return np.linalg.norm(a[:, None, :3] - b[None, :, :3], axis=-1)


def feasibility(constraints, n_new, h, box, sea=None):
    """ValueError, in words naming the station or zone, if the constraints cannot hold for
    ``n_new`` new stations at depth h (m) in the x–y ``box`` ((xmin, xmax), (ymin, ymax));
    else the (G, 3) candidate points (m) where a new station may go (a ROOM_GRID² grid of the
    box, allowed points only)."""
    c = constraints
    nf = c.fixed.shape[0]
    if nf + n_new > MAX_STATIONS:
        raise ValueError(f"{nf} fixed + {n_new} new = {nf + n_new} stations; at most "
                         f"MAX_STATIONS = {MAX_STATIONS}")
    lo, hi = c.band(sea)
    for i, (zone, z) in enumerate(zip(c.in_zone(c.fixed), c.fixed[:, 2])):
        if zone >= 0:
            raise ValueError(f"fixed station {i} at ({c.fixed[i, 0]:g}, {c.fixed[i, 1]:g}) m lies "
                             f"inside forbidden zone {zone}")
        if not lo <= z <= hi:
            raise ValueError(f"fixed station {i} at depth {z:g} m is outside the allowed depth "
                             f"band [{lo:g}, {hi:g}] m")
    d = distances(c.fixed, c.fixed) + np.diag(np.full(nf, np.inf))
    if nf > 1 and d.min() < c.min_spacing:
        i, j = np.unravel_index(np.argmin(d), d.shape)
        raise ValueError(f"fixed stations {min(i, j)} and {max(i, j)} are {d[i, j]:.3g} m apart: "
                         f"they already break the minimum spacing {c.min_spacing:g} m")
    if n_new and not lo <= h <= hi:
        raise ValueError(f"the new stations' depth h = {h:g} m is outside the allowed depth band "
                         f"[{lo:g}, {hi:g}] m")
    (xlo, xhi), (ylo, yhi) = box
    gx, gy = np.meshgrid(np.linspace(xlo, xhi, ROOM_GRID), np.linspace(ylo, yhi, ROOM_GRID))
    cand = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, h)])
    cand = cand[c.allowed(cand, sea)]
    room = _pack(cand, n_new, c.min_spacing)
    if room < n_new:
        raise ValueError(f"the constraints leave room for {room} of the {n_new} new stations: "
                         f"in the box x {xlo:g}…{xhi:g} m, y {ylo:g}…{yhi:g} m, outside the "
                         f"{len(c.zones)} forbidden zones and {c.min_spacing:g} m from the "
                         f"{nf} fixed stations and each other (judged on a {ROOM_GRID}² grid)")
    return cand


def _pack(cand, n, spacing):
    """How many of n stations fit greedily on the candidate points, ≥ spacing apart."""
    placed = []
    left = cand
    while len(placed) < n and left.shape[0]:
        placed.append(left[0])
        left = left[np.linalg.norm(left - left[0], axis=1) >= max(spacing, 1e-12)]
    return len(placed)
