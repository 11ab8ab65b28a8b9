"""The Layout design tab's survey constraints (issue 49, spec §13): forbidden zones drawn on the
map, the stations the optimiser must leave where they are, a minimum spacing; and the survey
criteria and the N−1 error map offered beside the older ones (:data:`app.state.parts.CRITERIA`,
:data:`app.state.parts.ERROR_QUANTITIES` include these).

A part like the others (:mod:`app.state.parts` registers it): its inputs are declared here once,
so the link, the scenario file and the refusals derive from them. No Panel import.
"""

from __future__ import annotations

import math

import param

import core

from .part import Part

#: Most forbidden zones, and most vertices of one (a link stays short; a zone is drawn by hand).
MAX_ZONES, MAX_VERTICES = 8, 40

#: The survey criteria (core.CRITERIA keys), each label with its unit.
SURVEY_CRITERIA = {
    "Mean CRLB position error, A (m)": "mean_crlb",
    "Worst direction, E (log10 1/m²)": "worst_direction",
    "Worst-point CRLB position error (m)": "worst_crlb",
    "N−1 coverage: area under threshold with any one station lost (share)": "area_crlb_n1",
}
#: The error map of the worst single-station loss (core.station_loss), a choice of the design map.
N1_MAP = "Worst single-loss (N−1) 3-D position error (m)"
#: Its entry in app.state.parts.ERROR_QUANTITIES: the 3-D position error, of the loss map.
SURVEY_QUANTITIES = {N1_MAP: "position"}


def zone_problem(i, zone):
    """Why polygon ``zone`` (a list of [x, y], m) cannot be forbidden zone ``i`` (0-based; said
    1-based), or None."""
    name = f"Forbidden zone {i + 1}"
    if not isinstance(zone, (list, tuple)) or not all(
            isinstance(v, (list, tuple)) and len(v) == 2 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in v)
            for v in zone):
        return f"{name} must be a list of [x, y] vertices in m (finite numbers)"
    if len(zone) > MAX_VERTICES:
        return f"{name} has {len(zone)} vertices; at most {MAX_VERTICES}"
    try:
        core.LayoutConstraints(zones=[zone])
    except ValueError as exc:  # fewer than 3 vertices, crossing edges, zero area: core's words
        return f"{name}{str(exc).removeprefix('forbidden zone 0')}"
    return None


class Survey(Part):
    """Where the optimiser may put stations: the Layout design tab's constraints."""

    @classmethod
    def problem(cls, name, value):
        if name == "zones":
            if len(value) > MAX_ZONES:
                return f"At most {MAX_ZONES} forbidden zones; got {len(value)}"
            return next((p for p in (zone_problem(i, z) for i, z in enumerate(value)) if p), None)
        if name == "fixed_stations":
            bad = [v for v in value if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 8]
            if bad or len(set(value)) != len(value):
                return ("Fixed stations must be distinct station numbers 1 … 8 (rows of the table); "
                        f"got {str(value)[:40]}")
            return None
        return super().problem(name, value)

    zones = param.List([], item_type=list, label="Forbidden zones (x, y) (m)",
                       doc="Polygons where no optimised station may go, drawn on the design map: "
                           "each a list of [x, y] vertices, m (at least 3, edges not crossing).")
    fixed_stations = param.List([], item_type=int, label="Fixed stations",
                                doc="Station numbers (rows of the table, from 1) that already exist: "
                                    "the optimiser keeps them and moves only the others.")
    min_spacing = param.Number(0.0, softbounds=(0.0, 200.0), label="Minimum spacing (m)",
                               doc="Smallest 3-D distance between any two stations of an optimised "
                                   "layout, m (0: none).",
                               metadata=dict(hard=(0.0, 5000.0, "m")))


#: Its lists are checked by :meth:`Survey.problem` (its numbers by their declared limits).
Survey.also_checked = tuple(n for n in Survey.names() if isinstance(Survey.param[n], param.List))

__all__ = ["MAX_VERTICES", "MAX_ZONES", "N1_MAP", "SURVEY_CRITERIA", "SURVEY_QUANTITIES", "Survey",
           "zone_problem"]
