"""The Layout design tab's numbers: CRLB maps and ellipses of a layout, the best spacing and the
optimised layout, over the x–y plane at the target depth.

Pure functions of a :class:`app.state.snapshot.Snapshot`, as :func:`app.tabs.maps.compute.compute` is for the
Maps tab; :mod:`app.tabs.design.design` (the tab) asks for them through the shared cache
(:data:`app.kit.cache.SHARED`), and :mod:`app.tabs.track.track` draws its CRLB map as a :class:`app.kit.views.Design`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import core

from app.kit.cache import KERNEL_LOCK
from app.kit.views import Design
from app.state.scenario import CRITERIA, ScenarioValues, inputs
from app.state.snapshot import Snapshot
from .constraints import CONSTRAINT_READS, layout_constraints

#: Spacings d (m) scanned for the best-spacing curve, and the resolution of its region.
SPACING_RANGE, SPACING_POINTS, REGION_RESOLUTION = (2.0, 200.0), 25, 41

# What each computation reads (its key in the cache; tests/test_tab_keys.py checks each against
# what it reads). All of them: the target (its sources, motion and depth), the sea and the sensor.
_TARGET_SEEN = inputs("target", "medium", "sensor")
#: :func:`design` (the error map) and :func:`error_at` (the ellipse, and the readout under it):
#: the custom stations over the x–y region at the target depth.
ERROR_MAP_READS = (*_TARGET_SEEN, "stations", "extent", "resolution")
#: :func:`best_spacing`: dual stations at depth h, the criterion.
SPACING_READS = (*_TARGET_SEEN, "h", "extent", "resolution", "criterion", "threshold")
#: :func:`optimised_layout`: N stations at depth h in a shape, the criterion.
LAYOUT_READS = (*_TARGET_SEEN, "h", "extent", "criterion", "threshold", "layout_kind", "n_stations",
                *CONSTRAINT_READS)


def _fisher_options(s: ScenarioValues):
    return s.core_options(None, measure=False)


def xy_region(s: ScenarioValues, n):
    """The x–y plane at the target depth (for the design tab, whatever the map plane)."""
    return core.Plane("xy", (-s.extent, s.extent), (-s.extent, s.extent), s.z, n)


#: Decimals of a station's coordinates in the table (its "0.0" format) and of a drawn one (m).
DECIMALS = 1
#: A drawn row within this of an old station (m) is that station, untouched: half the table's step.
TOUCHED = 0.5 * 10 ** -DECIMALS


def drawn_stations(data, old, h):
    """The custom layout after a PointDraw edit: ``data`` (columns x, y; any z is ignored) against
    the ``old`` layout (S, 3), m.

    The browser's z column is not trusted: the point-draw tool fills a new point's z with a
    placeholder, and kept the placeholder (0, the surface) for earlier clicked stations when the
    next one was added. So a depth comes from the layout itself: a row at an old station's (x, y)
    keeps that station's depth; a moved station keeps the depth of the old station it replaces;
    a station added by a click (a row beyond the old ones) sits at the station depth ``h``."""
    # a dragged or clicked position to the table's 0.1 m: the browser's float noise
    # (206.999985918) went into the link while the table showed 207.0 (issue 46 defect 9)
    rows = [(round(float(x), DECIMALS), round(float(y), DECIMALS)) for x, y in zip(data["x"], data["y"])]
    unused = list(range(len(old)))
    depth = [None] * len(rows)
    for i, (x, y) in enumerate(rows):  # unchanged stations, matched by position, kept exactly
        j = next((j for j in unused if abs(old[j][0] - x) <= TOUCHED and abs(old[j][1] - y) <= TOUCHED), None)
        if j is not None:
            rows[i], depth[i] = (float(old[j][0]), float(old[j][1])), float(old[j][2])
            unused.remove(j)
    for i in range(len(rows)):
        if depth[i] is None:  # dragged (an old station is left over for it) or added (at the end)
            depth[i] = float(old[unused.pop(0)][2]) if i < len(old) and unused else float(h)
    return [[x, y, z] for (x, y), z in zip(rows, depth)]


#: What a bound of core.LayoutResult.at_bound means, for the result line.
BOUNDS = {"d_min": "the smallest spacing scanned", "d_max": "the largest spacing that fits in the region",
          "x_min": "the region's edge x = −extent", "x_max": "the region's edge x = +extent",
          "y_min": "the region's edge y = −extent", "y_max": "the region's edge y = +extent"}


def design(snapshot: Snapshot) -> Design:
    s = snapshot.scenario()
    stations = np.array(s.stations, dtype=float)
    plane = xy_region(s, int(s.resolution))
    with KERNEL_LOCK:
        errors = core.crlb_maps(plane, stations, velocity=s.velocity(), moments=s.moments(),
                                **_fisher_options(s))
    return Design(plane=plane, stations=stations, errors=errors)


def error_at(snapshot: Snapshot, x, y):
    """CRLB errors (core.CrlbErrors of scalars) of a target at (x, y, z) for the custom layout."""
    s = snapshot.scenario()
    state = [x, y, s.z, *s.velocity(), *s.moments()]
    try:
        return core.horizontal_error_ellipse(state, np.array(s.stations, dtype=float),
                                             **_fisher_options(s))
    except ValueError:  # the click landed on a station
        return None


@dataclass(frozen=True)
class Spacing:
    """The best dual-station spacing over the x–y region, and the maps to compare."""

    result: object  # core.SpacingResult
    criterion: str
    label: str
    best: Design
    paper: Design  # d = 15 m, the paper's Fig. 5


def best_spacing(snapshot: Snapshot) -> Spacing:
    s = snapshot.scenario()
    key = CRITERIA[s.criterion]
    region = xy_region(s, REGION_RESOLUTION)
    common = dict(velocity=s.velocity(), moments=s.moments(), **_fisher_options(s))
    with KERNEL_LOCK:
        problem = core.LayoutProblem(region, h=s.h, criterion=key, threshold=s.threshold, **common)
        result = core.best_spacing(problem, d_range=SPACING_RANGE, n_curve=SPACING_POINTS)

    def at(d):
        stations = core.dual_station(s.h, d)
        plane = xy_region(s, min(int(s.resolution), 150))
        with KERNEL_LOCK:
            return Design(plane, stations, core.crlb_maps(plane, stations, **common))

    return Spacing(result=result, criterion=key, label=core.CRITERIA[key][0], best=at(result.d),
                   paper=at(15.0))


def optimised_layout(snapshot: Snapshot):
    """core.optimise_layout for the chosen shape and N new stations over the x–y region, beside
    the fixed ones and clear of the zones (app/tabs/design/constraints.py): a core.LayoutResult."""
    s = snapshot.scenario()
    with KERNEL_LOCK:
        problem = core.LayoutProblem(xy_region(s, 31), h=s.h, velocity=s.velocity(),
                                     moments=s.moments(), criterion=CRITERIA[s.criterion],
                                     threshold=s.threshold, constraints=layout_constraints(s),
                                     **_fisher_options(s))
        return core.optimise_layout(s.layout_kind, int(s.n_stations), problem)  # fits the region


__all__ = ["ERROR_MAP_READS", "LAYOUT_READS", "REGION_RESOLUTION", "SPACING_POINTS", "SPACING_RANGE",
           "SPACING_READS", "Design", "Spacing",
           "best_spacing", "design", "error_at", "optimised_layout", "xy_region"]
