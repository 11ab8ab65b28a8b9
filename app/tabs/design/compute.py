"""The Layout design tab's numbers: CRLB maps and ellipses of a layout, the best spacing and the
optimised layout, over the x–y plane at the target depth.

Pure functions of a :class:`app.tabs.maps.compute.Snapshot`, as :func:`app.tabs.maps.compute.compute` is for the Maps
tab; :mod:`app.tabs.design.design` (the tab) asks for them through the shared cache
(:data:`app.kit.cache.SHARED`), and :mod:`app.tabs.track.track` draws its CRLB map as a :class:`Design`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import core

from app.kit.cache import KERNEL_LOCK
from app.state.scenario import CRITERIA, ScenarioValues, inputs
from app.tabs.maps.compute import Snapshot
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


@dataclass(frozen=True)
class Design:
    """CRLB maps of the custom layout over the x–y plane at the target depth."""

    plane: core.Plane
    stations: np.ndarray  # (S, 3), m
    errors: object  # core.CrlbErrors with (n, n) arrays


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
