"""The Layout design tab's survey controls and views (issue 49): forbidden zones drawn, moved
and deleted on the design map, the "fixed" column of the station table, the criterion's unit,
the N−1 map's coverage line and the stations-count curve.

The zones are drawn with Bokeh's polygon draw and edit tools through HoloViews' ``PolyDraw`` and
``PolyEdit`` streams (public API): what the tools leave in the page is read back as a list of
polygons and set on the scenario's ``zones``, which refuses a bad one (fewer than 3 vertices,
crossing edges: app/state/survey.py) with a message naming it and keeps the last good zones (the
optimiser uses those). The layer is not redrawn on a refusal: a zone being drawn has fewer than
3 vertices until its last corner is set, and a redraw wiped it.
"""

from __future__ import annotations

from functools import partial

import holoviews as hv
import pandas as pd
import panel as pn

import core

from app.kit import offloop
from app.kit.alerts import alert
from app.kit.inputs import number_input
from app.state.scenario import CRITERIA
from app.state.snapshot import Snapshot
from app.state.survey import MAX_ZONES, N1_MAP
from . import survey_compute
from .compute import ERROR_MAP_READS
from .survey_compute import COUNT_READS, LOSS_READS

#: Decimals of a drawn vertex (m), as the station table's.
DECIMALS = 1
#: The station table's fixed column.
FIXED = "fixed"
#: Under the zones' tools on the page.
ZONES_HELP = ("**Forbidden zones**: pick the polygon tool in the map's toolbar, press and hold to "
              "start a zone, click its corners, press and hold to close it; drag a zone to move "
              "it; select one and press Backspace to delete it; the vertex tool edits corners "
              "(press and hold a zone to show them). "
              "The optimiser puts no new station in a zone. Tick *fixed* in the table for "
              "stations that already exist: the optimiser keeps them and places N new ones.")


# -- the zones ------------------------------------------------------------------------------------

def drawn_zones(data):
    """The polygons a PolyDraw/PolyEdit stream's ``data`` ({"xs": [...], "ys": [...]}) holds, as
    the scenario's zones: lists of [x, y] (m, to the table's 0.1 m), the closing vertex a
    drawing tool may repeat dropped."""
    zones = []
    for xs, ys in zip(data.get("xs", []), data.get("ys", [])):
        zone = [[round(float(x), DECIMALS), round(float(y), DECIMALS)] for x, y in zip(xs, ys)]
        if len(zone) > 1 and zone[0] == zone[-1]:
            zone = zone[:-1]
        zones.append(zone)
    return zones


def zone_element(zones):
    """The zones as hv.Polygons (x, y in m), red: where no station may go."""
    dims = [hv.Dimension("x", unit="m"), hv.Dimension("y", unit="m")]
    paths = [{"x": [v[0] for v in z], "y": [v[1] for v in z]} for z in zones]
    return hv.Polygons(paths, kdims=dims).opts(fill_color="#c0392b", fill_alpha=0.25, line_color="#c0392b",
                                               line_width=2)


def zone_layer(scenario, redraw):
    """The zones' layer of the design map (a DynamicMap on ``redraw``, an hv stream) with its draw
    and edit streams, wired to the scenario's ``zones`` (module docstring)."""
    sv = scenario.survey
    layer = hv.DynamicMap(lambda **_: zone_element(sv.zones), streams=[redraw])
    draw = hv.streams.PolyDraw(source=layer, drag=True, num_objects=MAX_ZONES + 1, show_vertices=True,
                               vertex_style={"size": 8, "fill_color": "white", "line_color": "#c0392b"})
    edit = hv.streams.PolyEdit(source=layer, vertex_style={"size": 8, "fill_color": "#c0392b"}, shared=True)

    drawing = [False]  # the zones are being set from the map: the layer already shows them

    def drawn(data):
        if data is None:
            return
        zones = drawn_zones(data)
        if zones != sv.zones:
            # a refused zone (said next to the table) leaves the scenario's last good zones;
            # the layer is not redrawn with them: a zone being drawn has fewer than 3 vertices
            # until its last corner, and a redraw wiped it from under the hand
            drawing[0] = True
            try:
                sv.zones = zones
            finally:
                drawing[0] = False

    # a link, a scenario file, a preset: the layer shows the scenario's zones
    sv.param.watch(lambda _e: None if drawing[0] else redraw.event(), ["zones"])

    draw.add_subscriber(drawn)
    edit.add_subscriber(drawn)
    return layer, (draw, edit)


# -- the table's fixed column -------------------------------------------------------------------

def frame(stations, fixed, columns):
    """The station table: x, y, z (m) and whether each station is fixed (numbers from 1)."""
    df = pd.DataFrame(stations, columns=columns, dtype=float)
    df[FIXED] = [i + 1 in fixed for i in range(len(stations))]
    return df


def fixed_of(df):
    """The fixed stations' numbers (from 1) the table's fixed column ticks."""
    if FIXED not in df:
        return []
    return [i + 1 for i, v in enumerate(df[FIXED].tolist()) if bool(v)]


def fixed_of_scenario(scenario):
    """The fixed stations' positions (m) in the scenario's layout."""
    stations = scenario.stations.stations
    return [list(stations[i - 1]) for i in scenario.survey.fixed_stations if i <= len(stations)]


def rows_of(stations, kept):
    """The numbers (from 1) of the rows of ``stations`` that are the ``kept`` positions: the
    fixed stations in an optimised layout (which puts them where it puts them)."""
    return [i + 1 for i, row in enumerate(stations) if [float(v) for v in row] in
            [[float(v) for v in k] for k in kept]]


# -- the criterion and the N−1 map ----------------------------------------------------------------

def unit_text(label):
    """The criterion's line under its selector: what it is, and its unit."""
    what, unit = core.CRITERIA[CRITERIA[label]]
    return f"<small>Criterion: {what}; unit: **{unit}**. Larger is better (errors are negated).</small>"


def criterion_unit(scenario):
    """A pane under the criterion selector saying its meaning and unit, following it."""
    pane = pn.pane.Markdown(unit_text(scenario.design.criterion), sizing_mode="stretch_width",
                            css_classes=["w-criterion-unit"])
    scenario.design.param.watch(lambda e: setattr(pane, "object", unit_text(e.new)), ["criterion"])
    return pane


def error_design(cache, scenario):
    """The design map's data for the chosen error map: the N−1 loss map or the layout's own."""
    quantity = scenario.design.error_quantity
    reads = LOSS_READS if quantity == N1_MAP else ERROR_MAP_READS
    return cache.get(Snapshot.of(scenario, reads), survey_compute.error_map_of(quantity))


def loss_text(design):
    """The line under the map: the coverage left per station when the N−1 map is shown."""
    loss = getattr(design, "loss", None)
    return survey_compute.coverage_text(loss) if loss is not None else ""


# -- the stations-count curve -------------------------------------------------------------------

def count_plot(count):
    """The best criterion against the number of stations N (fixed ones counted), the knee marked;
    hover gives N and the value."""
    rows = survey_compute.count_rows(count)
    unit = core.CRITERIA[count.criterion][1]
    n = hv.Dimension("N", label="Stations N (fixed counted)")
    v = hv.Dimension("value", label=count.label.rsplit(" (", 1)[0], unit=unit)
    curve = hv.Curve(rows, kdims=[n], vdims=[v]).opts(color="#1f77b4", line_width=2)
    dots = hv.Scatter(rows, kdims=[n], vdims=[v]).opts(size=8, tools=["hover"], color="#1f77b4")
    plot = curve * dots
    knee = count.curve.knee
    if knee is not None:
        at = [(k, val) for k, val in rows if k == knee]
        plot = plot * hv.VLine(knee).opts(color="#c0392b", line_dash="dashed") * hv.Scatter(
            at, kdims=[n], vdims=[v], label=f"knee: N = {knee}").opts(size=14, marker="diamond",
                                                                         color="#c0392b", tools=["hover"])
    return plot.opts(title="Best criterion against the number of stations", width=420, height=300,
                     show_grid=True, legend_position="bottom_right")


def count_text(count):
    knee = count.curve.knee
    said = (f"one more station after **N = {knee}** adds less than {count.curve.share:.0%} of the "
            "whole gain" if knee is not None else "every added station still pays (no knee)")
    return f"**Stations needed** ({count.label}): {said}."


def count_section(scenario, cache):
    """The button that computes the stations-count curve (off the event loop) and its plot."""
    button = pn.widgets.Button(name="Stations needed: curve for N = 1 … 8", button_type="default",
                               css_classes=["w-count-button"])
    said = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["w-count-result"])
    plot = pn.Column(sizing_mode="stretch_width", css_classes=["w-count-plot"])
    task = offloop.Task("design-count", busy=[button, said, plot])

    def shown(count):
        said.object, plot[:] = count_text(count), [pn.pane.HoloViews(count_plot(count))]

    def failed(exc):
        said.object, plot[:] = "", [pn.pane.HTML(alert(f"Not counted: {exc}", "danger"),
                                                 sizing_mode="stretch_width")]

    def clicked(_):
        snapshot = Snapshot.of(scenario, COUNT_READS)
        task.start(snapshot, partial(cache.get, snapshot, survey_compute.count_curve), shown, failed)

    button.on_click(clicked)
    return pn.Column(button, said, plot, sizing_mode="stretch_width", margin=0)


def survey_inputs(scenario):
    """The survey inputs shown under the optimiser's: the minimum spacing."""
    return number_input(scenario.survey, "min_spacing", css_classes=["w-min_spacing"])


__all__ = ["FIXED", "ZONES_HELP", "count_plot", "count_section", "count_text", "criterion_unit",
           "drawn_zones", "error_design", "fixed_of", "fixed_of_scenario", "frame", "rows_of", "loss_text", "survey_inputs",
           "unit_text", "zone_element", "zone_layer"]
