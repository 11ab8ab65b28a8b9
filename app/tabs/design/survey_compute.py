"""The Layout design tab's survey numbers (issue 49): the worst single-station loss map of the
custom layout (core.station_loss) and the stations-count curve (core.station_count_curve).

Pure functions of a :class:`app.tabs.maps.compute.Snapshot`, cached in the shared cache as the
tab's other computations (:mod:`app.tabs.design.compute`); no Panel, no Bokeh.
"""

from __future__ import annotations

import dataclasses

import numpy as np

import core

from app.kit.cache import KERNEL_LOCK
from app.kit.views import Design
from app.state.scenario import CRITERIA, MAX_STATIONS
from app.state.snapshot import Snapshot
from app.state.survey import N1_MAP
from .compute import ERROR_MAP_READS, LAYOUT_READS, _fisher_options, design, xy_region
from .constraints import layout_constraints

#: :func:`loss_design`: the custom layout's map, and the threshold its coverage counts against.
LOSS_READS = (*ERROR_MAP_READS, "threshold")
#: :func:`count_curve`: the optimised layout's problem at every N (its N is the curve's axis).
COUNT_READS = tuple(n for n in LAYOUT_READS if n != "n_stations")
#: The count curve's region resolution (each N is an optimisation on it: coarse, as the
#: optimiser's own 31² is for one N).
COUNT_RESOLUTION = 21


@dataclasses.dataclass(frozen=True)
class LossDesign(Design):
    """A :class:`Design` whose errors' ``position`` is the worst single-loss error (m), with the
    coverage left without each station and the N−1 coverage (core.StationLoss)."""

    loss: object = None  # core.StationLoss


def loss_design(snapshot: Snapshot) -> LossDesign:
    """The custom layout's map with its position error replaced by the worst single-station loss
    (core.station_loss on the design map's grid; the other errors are the whole layout's)."""
    s = snapshot.scenario()
    whole = design(snapshot)
    plane = xy_region(s, int(s.resolution))
    with KERNEL_LOCK:
        problem = core.LayoutProblem(plane, velocity=s.velocity(), moments=s.moments(),
                                     threshold=s.threshold, **_fisher_options(s))
        loss = core.station_loss(whole.stations, problem)
    # where a loss leaves a point unobservable its error is +inf (drawn white, as NaN is)
    errors = dataclasses.replace(whole.errors, position=loss.worst)
    return LossDesign(plane=plane, stations=whole.stations, errors=errors, loss=loss)


def error_map_of(quantity):
    """The computation behind the design map for error map ``quantity`` (its label)."""
    return loss_design if quantity == N1_MAP else design


def coverage_text(loss):
    """A line on a loss map: the coverage left without each station (1-based), the N−1 coverage."""
    left = ", ".join(f"{k + 1}: {c:.0%}" for k, c in enumerate(loss.coverage_left))
    return (f"**Coverage left** (error ≤ {loss.threshold:g} m) without station {left}. "
            f"Whichever one is lost: {loss.coverage_n1:.0%} (N−1 coverage).")


@dataclasses.dataclass(frozen=True)
class Count:
    """The stations-count curve of the scenario's problem (core.StationCount) and its criterion."""

    curve: object  # core.StationCount
    criterion: str  # core key
    label: str  # the page's label, with its unit


def count_curve(snapshot: Snapshot) -> Count:
    """core.station_count_curve for N = fixed + 1 … MAX_STATIONS of the chosen layout kind and
    criterion, with the scenario's constraints (fixed stations counted in N)."""
    s = snapshot.scenario()
    key = CRITERIA[s.criterion]
    with KERNEL_LOCK:
        problem = core.LayoutProblem(xy_region(s, COUNT_RESOLUTION), h=s.h, velocity=s.velocity(),
                                     moments=s.moments(), criterion=key, threshold=s.threshold,
                                     constraints=layout_constraints(s), **_fisher_options(s))
        curve = core.station_count_curve(problem, kind=s.layout_kind, n_max=MAX_STATIONS)
    return Count(curve=curve, criterion=key, label=s.criterion)


def count_rows(count):
    """The curve as rows (N, value), finite values only (an unobservable N is −inf)."""
    c = count.curve
    return [(int(n), float(v)) for n, v in zip(c.n, c.value) if np.isfinite(v)]


__all__ = ["COUNT_READS", "COUNT_RESOLUTION", "LOSS_READS", "Count", "LossDesign", "count_curve",
           "count_rows", "coverage_text", "error_map_of", "loss_design"]
