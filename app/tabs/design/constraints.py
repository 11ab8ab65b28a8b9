"""The survey constraints of the Layout design tab's scenario (app/state/survey.py) as a
:class:`core.LayoutConstraints`, checked first in the page's own words: stations and zones are
numbered as the table and the map number them (from 1), where the core counts rows from 0.

Pure: no Panel, no Bokeh.
"""

from __future__ import annotations

import numpy as np

import core

from app.state.parts import inputs

#: The inputs the constraints read: the layout (the fixed stations are rows of it) and the
#: survey part's (the computations that use them add these to their keys).
CONSTRAINT_READS = ("stations", *inputs("survey"))


def fixed_rows(s):
    """The fixed stations' rows of the table (0-based) that exist, in order."""
    n = len(s.stations)  # numbers past the table's rows (stations deleted since) fix nothing
    return [i - 1 for i in sorted(s.fixed_stations) if i <= n]


def problems(s):
    """What the fixed stations break, in words naming the station and the zone (1-based): a fixed
    station inside a forbidden zone, two fixed stations closer than the minimum spacing."""
    rows = fixed_rows(s)
    fixed = np.array([s.stations[i] for i in rows], dtype=float).reshape(-1, 3)
    zones = core.LayoutConstraints(zones=s.zones)
    out = []
    for i, zone in zip(rows, zones.in_zone(fixed)):
        if zone >= 0:
            x, y, _ = s.stations[i]
            out.append(f"fixed station {i + 1} at ({x:g}, {y:g}) m lies inside forbidden zone {zone + 1}")
    for a in range(len(rows)):
        for b in range(a + 1, len(rows)):
            d = float(np.linalg.norm(fixed[a] - fixed[b]))
            if d < s.min_spacing:
                out.append(f"fixed stations {rows[a] + 1} and {rows[b] + 1} are {d:.3g} m apart, closer "
                           f"than the minimum spacing {s.min_spacing:g} m")
    return out


def layout_constraints(s):
    """core.LayoutConstraints of scenario values ``s``; ValueError naming the station or zone if
    the fixed stations already break them. None when there are no constraints."""
    found = problems(s)
    if found:
        raise ValueError("; ".join(found))
    rows = fixed_rows(s)
    if not rows and not s.zones and not s.min_spacing:
        return None
    return core.LayoutConstraints(fixed=[s.stations[i] for i in rows], zones=s.zones,
                                  min_spacing=s.min_spacing)


__all__ = ["CONSTRAINT_READS", "fixed_rows", "layout_constraints", "problems"]
