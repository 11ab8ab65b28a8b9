"""The Layout design tab: a custom layout's Cramér–Rao errors, the best spacing, optimised layouts."""

from __future__ import annotations

from functools import partial

import holoviews as hv
import panel as pn
from bokeh.models.widgets.tables import NumberFormatter

from app.kit import offloop, views
from app.kit.alerts import alert, refusal
from app.kit.inputs import number_input
from app.kit.runaway import RUNAWAY_LIMIT, nearest_range
from app.kit.shown import ALWAYS
from app.kit.tab import Tab
from app.state.scenario import MAX_STATIONS, Design
from app.state.survey import Survey
from app.state.snapshot import Snapshot
from . import compute as design_compute, live as design_live, survey
from .compute import DECIMALS, ERROR_MAP_READS, LAYOUT_READS, SPACING_READS, drawn_stations

#: What redraws the Layout design map's layers (:func:`design_tab`).
Refresh = hv.streams.Stream.define("Refresh")

DESIGN_HELP = """
**Layout design.** Click on the map to add a station (up to 8; it sits at the station depth h),
drag one to move it, select it and press Backspace to delete it; or edit the table (z is a depth,
positive down). The map is the Cramér–Rao bound (1σ) on the 3-D position, horizontal, depth or
speed error of a target at depth z, with the sensor noise and N instants of the Advanced section —
the numbers an analyst reports — on a log colour scale. White dots: the 3-D bound exceeds {limit:.0%}
of the range to the nearest station, where a linearised bound no longer predicts a tracker's error
(far-field runaway; read it as "not trackable from here"). The red ellipse is the horizontal error
ellipse of a target at the point set under the table (*Error ellipse at x, y*). *Find best spacing* scans the dual layout's spacing d over this region and refines the
optimum with scipy; *Optimise N-station layout* does the same for a line, triangle or square of
N stations (or free positions, ~10 s) and makes it the custom layout.
""".format(limit=RUNAWAY_LIMIT)

#: The title of the Layout design map.
DESIGN_TITLE = "Custom layout: Cramér–Rao error"
#: The station table's columns.
COLUMNS = ["x (m)", "y (m)", "z (m)"]
#: Inputs of this tab whose refusal is shown here, next to their inputs.
OWN = ("stations", *Design.names(), *Survey.names())


#: What a bound of core.LayoutResult.at_bound means, for the result line.
BOUNDS = {"d_min": "the smallest spacing scanned", "d_max": "the largest spacing that fits in the region",
          "x_min": "the region's edge x = −extent", "x_max": "the region's edge x = +extent",
          "y_min": "the region's edge y = −extent", "y_max": "the region's edge y = +extent"}


def optimise_text(result, criterion):
    """One line on an optimised layout (core.LayoutResult): its size, criterion, and a bound hit."""
    size = f"spacing d = {result.d:.1f} m, " if result.d is not None else ""
    text = (f"**Optimised {result.kind}** of {len(result.stations)} stations, centred on the region: "
            f"{size}{criterion} = {result.value:.4g}.")
    if result.at_bound:
        text += (" The optimum lies on " + " and ".join(BOUNDS[b] for b in result.at_bound) +
                 ": a better layout may lie beyond it (widen the region, *extent*).")
    return text


#: Under the "Find best spacing" button until it has a result.
SPACING_HINT = "Press *Find best spacing* (about a second)."


def spacing_text(sp):
    """The line under the button on a best spacing (design_compute.Spacing): d, criterion, a
    bound hit, and where its plots are."""
    r = sp.result
    edge = (" — at the edge of the scanned range: a better spacing may lie beyond it"
            if r.at_bound else "")
    return (f"**Best spacing: d = {r.d:.1f} m** ({sp.label} = {r.value:.4g}){edge}. Its curve and "
            "the error maps of this layout and the paper's (d = 15 m, one colour scale) are shown "
            "beside or below.")


def _map(scenario, cache, snap, redraw, follow, loss_line):
    """The error map with its station layer (a click adds a station, a drag moves one), the
    forbidden zones (app/tabs/design/survey.py) and the ellipse, redrawn by the stream ``redraw``:
    (the pane, its Task). ``loss_line``: the pane saying the N−1 map's coverage."""
    st = scenario.stations  # the Stations part
    points = hv.DynamicMap(lambda **_: views.station_layer(st.stations, editable=True).opts(hooks=[follow.hook]),
                           streams=[redraw])
    # One more than allowed: a 9th click reaches the Scenario, which refuses it ("at most 8
    # stations") and restores the layout (with num_objects=8 the tool deleted the oldest silently)
    draw = hv.streams.PointDraw(source=points, num_objects=MAX_STATIONS + 1, empty_value=st.h)

    def drawn(data):
        if data is None or not len(data.get("x", [])):
            return
        # the preview hidden and the exact map of the layout drawn in one message (this runs on
        # the event loop, outside a callback of the document: Bokeh models change in a hold)
        with pn.io.hold():
            follow.dropped()
            st.stations = drawn_stations(data, st.stations, st.h)

    draw.add_subscriber(drawn)

    def error_layer(**_):  # the layout's map, or its worst single-loss map (app/tabs/design/survey.py)
        d = survey.error_design(cache, scenario)
        loss_line.object = survey.loss_text(d)
        return views.error_map(d, DESIGN_TITLE, scenario.design.error_quantity)

    errors = hv.DynamicMap(error_layer, streams=[redraw])
    zones, _zone_streams = survey.zone_layer(scenario, Refresh())

    # The ellipse's point is an input of its own (a click on the map adds a station: it cannot
    # also move the ellipse)
    def ellipse(**_):
        x, y = scenario.design.ellipse_x, scenario.design.ellipse_y
        return views.error_ellipse(design_compute.error_at(snap(), x, y), x, y,
                                   scenario.region.extent)[0]

    map_pane = pn.pane.HoloViews(errors * zones * points * hv.DynamicMap(ellipse, streams=[redraw]))
    # Shown again after a change made while hidden: the map computed off the event loop, a
    # spinner over it meanwhile, then redrawn (from the shared cache) on the loop
    return map_pane, offloop.Task("design-map", busy=[map_pane])


def _readout_of(key):
    """The ellipse's text at (x, y) of ``key`` (snapshot, x, y)."""
    snapshot, x, y = key
    s = snapshot.scenario()
    rng = float(nearest_range([x, y, s.z], s.stations)) if len(s.stations) else None
    column = float(s.sea_depth) if s.sea_model == "layered" else None
    return views.error_ellipse(design_compute.error_at(snapshot, x, y), x, y, s.extent, rng,
                               column)[1]


def _readout(scenario, shown, snap):
    """The readout under the table, by a Task, which shows the latest change's text only
    (computed per change on Panel's threads, an older, slower computation ending last left an
    older preset's numbers on the page). The first one here and now: the tab is built when it
    is first shown (app.page.first_visit), and the readout is in its first frame (arriving
    later, it pushed what is under it ~85 px down, out of view at 1280 × 800)."""
    readout_task = offloop.Task("design-readout")

    def now():
        return snap(), scenario.design.ellipse_x, scenario.design.ellipse_y

    def refresh(*_):
        with readout_task.lock:
            key = now()
            readout_task.start(key, partial(_readout_of, key), partial(setattr, readout, "object"))

    readout = pn.pane.Markdown(_readout_of(now()), sizing_mode="stretch_width", css_classes=["w-ellipse-text"])
    scenario.watch_inputs(shown(refresh), ERROR_MAP_READS)
    scenario.design.param.watch(shown(refresh), ["ellipse_x", "ellipse_y"])
    return readout


def _frame(scenario):  # x, y, z and the survey's fixed column
    return survey.frame(scenario.stations.stations, scenario.survey.fixed_stations, COLUMNS)


def _station_table(scenario, shown):
    """The custom layout as an editable table, in step with the Stations part both ways."""
    st = scenario.stations
    table = pn.widgets.Tabulator(
        _frame(scenario), show_index=False, sizing_mode="stretch_width", height=260,
        css_classes=["w-station-table"],
        formatters={**{c: NumberFormatter(format=f"0.{'0' * DECIMALS}") for c in COLUMNS},
                    survey.FIXED: {"type": "tickCross"}})
    showing = [False]  # the table's value is being set from the layout: not an edit

    def show_layout(*_):
        showing[0] = True
        try:
            table.value = _frame(scenario)  # a new frame: Panel sends it even amid an edit's sync
        finally:
            showing[0] = False

    def edited(event):
        # On the table's value, not on_edit: Panel may run an edit's on_edit callbacks before
        # the edited data reaches ``value`` (the z = −5 edit was read as no change, then carried
        # into the next edit, which was refused with it: y = 130 was lost; issue 40 defect 4).
        if showing[0]:
            return
        wanted = event.new[COLUMNS].astype(float).values.tolist()
        fixed = survey.fixed_of(event.new)
        if fixed != scenario.survey.fixed_stations:
            scenario.survey.fixed_stations = fixed
        if wanted == st.stations:
            return
        st.stations = wanted
        if st.stations != wanted:
            # refused (the Scenario restored the layout and said why, next to the table): the
            # table shows the kept layout at once (it kept the refused cell, silently)
            show_layout()

    st.param.watch(shown(show_layout), ["stations"])
    scenario.survey.param.watch(shown(show_layout), ["fixed_stations"])
    table.param.watch(edited, ["value"])
    return table


def _spacing_views(cache, snapshot):
    """(the line under the button, the curve and the best and paper layouts' maps)."""
    sp = cache.get(snapshot, design_compute.best_spacing)
    clim = views.common_clim(sp.best, sp.paper)  # one scale: the comparison must not mislead
    best = views.error_map(sp.best, f"Best: d = {sp.result.d:.1f} m", clim=clim, size=260)
    paper = views.error_map(sp.paper, "Paper: d = 15 m", clim=clim, size=260)
    return spacing_text(sp), (views.spacing_plot(sp), best * views.station_layer(sp.best.stations),
                              paper * views.station_layer(sp.paper.stations))


def _spacing(scenario, cache):
    """The best spacing's button, its line and its plots: (run, said, found). The optimisers take
    ~1 s (best spacing) to ~10 s (free layouts): off the event loop (app.kit.offloop), a spinner
    over what they will change meanwhile. The result is said right under the button, where the
    user is looking (the hint there gives way to it); its curve and maps follow (at 1280 px they
    wrap below the fold: the line says where they are)."""
    run = pn.widgets.Button(name="Find best spacing", button_type="primary")
    said = pn.pane.Markdown(SPACING_HINT, sizing_mode="stretch_width", css_classes=["w-spacing-result"])
    found = pn.Column(sizing_mode="stretch_width", css_classes=["w-spacing-plots"])
    spacing_task = offloop.Task("design", busy=[said, found, run])

    def spacing_shown(result):
        text, plots = result
        said.object = text
        found[:] = [pn.FlexBox(*[pn.pane.HoloViews(p) for p in plots], sizing_mode="stretch_width")]

    def spacing_failed(exc):
        said.object = ""
        found[:] = [pn.pane.HTML(alert(f"Best spacing not found: {type(exc).__name__}: {exc}", "danger"),
                                 sizing_mode="stretch_width")]

    def spacing(event):
        snapshot = Snapshot.of(scenario, SPACING_READS)
        spacing_task.start(snapshot, partial(_spacing_views, cache, snapshot), spacing_shown, spacing_failed)

    run.on_click(spacing)
    return run, said, found


def _optimise(scenario, cache):
    """The optimiser's button and its outcome line: (button, outcome)."""
    optimise = pn.widgets.Button(name="Optimise N-station layout → custom layout", button_type="primary")
    outcome = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["w-optimise-result"])
    optimise_task = offloop.Task("design", busy=[optimise, outcome])

    def optimised(result, criterion, kept):
        scenario.stations.stations = [[float(v) for v in station] for station in result.stations]
        scenario.survey.fixed_stations = survey.rows_of(scenario.stations.stations, kept)  # still ticked
        outcome.object = optimise_text(result, criterion)

    def optimise_failed(exc):
        outcome.object = f"**Not optimised**: {type(exc).__name__}: {exc}"

    def optimise_clicked(event):
        snapshot, criterion = Snapshot.of(scenario, LAYOUT_READS), scenario.design.criterion
        optimise_task.start(None, partial(cache.get, snapshot, design_compute.optimised_layout),
                            partial(optimised, criterion=criterion, kept=survey.fixed_of_scenario(scenario)),
                            optimise_failed)

    optimise.on_click(optimise_clicked)
    return optimise, outcome


def _criteria(scenario, widgets):
    return pn.Column(
        pn.Param(scenario.design, parameters=["criterion"], show_name=False, widgets=widgets,
                 sizing_mode="stretch_width"),
        survey.criterion_unit(scenario),
        number_input(scenario.design, "threshold", css_classes=["w-threshold"]),
        pn.Param(scenario.design, parameters=["layout_kind"], show_name=False, widgets=widgets,
                 sizing_mode="stretch_width"),
        number_input(scenario.design, "n_stations", css_classes=["w-n_stations"]),
        survey.survey_inputs(scenario),
        sizing_mode="stretch_width", margin=0)


def design_tab(scenario, cache, widgets, shown=ALWAYS):
    """Custom layouts in metres of error, and the best dual-station spacing. ``widgets``: the
    widget spec of pn.Param (the sidebar's); ``shown``: the tab's :class:`app.kit.shown.WhenShown`
    (hidden, the tab computes nothing: its map, table and readout follow the scenario when it is
    shown again, a spinner over the map meanwhile)."""
    snap = lambda: Snapshot.of(scenario, ERROR_MAP_READS)  # what the error map and the ellipse read
    # The map's three layers are redrawn by one stream, which the scenario's changes trigger
    # through ``shown`` (streams on the scenario's parameters recomputed the map, on the thread
    # of the change, on a hidden tab too: a preset clicked on the Maps tab waited for it)
    redraw = Refresh()
    # The map follows a dragged station: previews until the drop (app/tabs/design/live.py), drawn
    # into layers the station layer's hook adds to the figure
    follow = design_live.StationDrag(scenario, lambda: scenario.design.error_quantity, pn.state.curdoc)
    loss_line = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["w-loss-text"])
    map_pane, map_task = _map(scenario, cache, snap, redraw, follow, loss_line)
    readout = _readout(scenario, shown, snap)
    table = _station_table(scenario, shown)

    def redraw_now(*_):
        redraw.event()

    def redraw_later():
        snapshot = snap()
        map_task.start(None, partial(cache.get, snapshot, design_compute.design),
                       lambda _: redraw.event())

    # the map after the table: a change shows its layout at once, before the map (a layered
    # sea's takes seconds) is computed
    scenario.watch_inputs(shown(redraw_now, redraw_later), ERROR_MAP_READS)
    scenario.design.param.watch(shown(redraw_now, redraw_later), ["error_quantity", "ellipse_x", "ellipse_y"])
    message = refusal(scenario, OWN, "w-design-message")
    run, said, found = _spacing(scenario, cache)
    optimise, outcome = _optimise(scenario, cache)
    tab = pn.Column(
        pn.pane.Markdown(DESIGN_HELP, sizing_mode="stretch_width"),
        pn.FlexBox(map_pane,
                   pn.Column(pn.Param(scenario.design, parameters=["error_quantity"], show_name=False, widgets=widgets),
                             message, table,
                             number_input(scenario.design, "ellipse_x", css_classes=["w-ellipse_x"]),
                             number_input(scenario.design, "ellipse_y", css_classes=["w-ellipse_y"]),
                             readout, loss_line,
                             width=380),
                   sizing_mode="stretch_width"),
        pn.FlexBox(pn.Column(pn.pane.Markdown(survey.ZONES_HELP, sizing_mode="stretch_width"),
                             _criteria(scenario, widgets), run, said, optimise, outcome,
                             survey.count_section(scenario, cache), width=360), found,
                   sizing_mode="stretch_width"),
        sizing_mode="stretch_width",
    )
    tab.follow = follow  # the drag's previews (tests, the benchmark)
    return tab


#: The Layout design tab, as the page mounts it (app.kit.tab).
TAB = Tab("design", "Layout design", reads=ERROR_MAP_READS, banner=True, waits=True,
          view=lambda m: design_tab(m.scenario, m.cache, m.widgets, m.shown))
